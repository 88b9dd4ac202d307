//! Texture nodes: Image Texture over the scene's textures, and every procedural texture
//! through `crate::procedural` (already exact to Cycles).

use crate::material::texture::{Filter, Texture, Wrap};
use crate::procedural::{Procedural, SocketValue};
use glam::{Vec2, Vec3};
use std::sync::Arc;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Interpolation {
    Linear,
    Closest,
    /// Cubic B-spline (Blender's Cubic and Smart: Cycles' CPU kernel filters both so).
    Cubic,
}

/// Image Texture: Vector → Color, Alpha (the flat projection).
#[derive(Clone, Debug)]
pub struct Image {
    pub texture: Arc<Texture>,
    pub wrap: Wrap,
    /// MIRROR: reflect the coordinate at every tile edge, then extend.
    pub mirror: bool,
    pub interpolation: Interpolation,
    /// Environment Texture: the vector is a direction, looked up equirectangularly.
    pub equirectangular: bool,
    /// The texture holds associated (premultiplied) colour and the Alpha output is
    /// read: the Color output is divided by the filtered alpha, before the sRGB decode
    /// for byte textures (Cycles' `NODE_IMAGE_ALPHA_UNASSOCIATE`, svm_image_texture in
    /// intern/cycles/kernel/svm/image.h).
    pub unassociate: bool,
}

/// Cycles' mirror extension: the coordinate folded into 0..1 by reflection.
fn mirror(t: f32) -> f32 {
    let f = t.rem_euclid(2.0);
    if f > 1.0 {
        2.0 - f
    } else {
        f
    }
}

/// Cycles' `color_srgb_to_linear` (intern/cycles/util/color.h).
fn srgb_to_linear(c: f32) -> f32 {
    if c < 0.04045 {
        if c < 0.0 {
            0.0
        } else {
            c / 12.92
        }
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

impl Image {
    pub fn lookup(&self, v: Vec3) -> [f32; 3] {
        self.texture.lookup_with(self.uv(v), self.wrap, self.wrap, self.filter())
    }

    fn filter(&self) -> Filter {
        if self.interpolation == Interpolation::Cubic {
            Filter::Cubic
        } else {
            Filter::Bilinear
        }
    }

    /// The texture coordinates of the lookup at vector `v` (projection, mirror, closest).
    fn uv(&self, v: Vec3) -> Vec2 {
        let mut uv = if self.equirectangular {
            // Cycles direction_to_equirectangular
            let u = -v.y.atan2(v.x) / std::f32::consts::TAU + 0.5;
            let w = v.z.atan2(v.x.hypot(v.y)) / std::f32::consts::PI + 0.5;
            Vec2::new(u, w)
        } else {
            Vec2::new(v.x, v.y)
        };
        if self.mirror {
            uv = Vec2::new(mirror(uv.x), mirror(uv.y));
        }
        if self.interpolation == Interpolation::Closest {
            // The centre of the texel the point falls in, so bilinear returns that texel.
            let (w, h) = (self.texture.width as f32, self.texture.height as f32);
            uv = Vec2::new(((uv.x * w).floor() + 0.5) / w, 1.0 - (((1.0 - uv.y) * h).floor() + 0.5) / h);
        }
        uv
    }

    /// Color and Alpha at vector `v`.
    pub fn lookup_rgba(&self, v: Vec3) -> (Vec3, f32) {
        let uv = self.uv(v);
        let t = &self.texture;
        if self.unassociate {
            let [r, g, b, a] = t.lookup_encoded_with(uv, self.wrap, self.wrap, self.filter());
            let mut c = Vec3::new(r, g, b);
            if a != 1.0 && a != 0.0 {
                c /= a;
            }
            if t.is_srgb8() {
                c = Vec3::new(srgb_to_linear(c.x), srgb_to_linear(c.y), srgb_to_linear(c.z));
            }
            return (c, a);
        }
        let c = Vec3::from(self.lookup(v));
        // Alpha is 1 everywhere unless the image has some, or CLIP fades it at the edge.
        let a = if t.has_alpha() || self.wrap == Wrap::Clip {
            t.lookup_alpha_with(uv, self.wrap, self.wrap, self.filter())
        } else {
            1.0
        };
        (c, a)
    }

    pub fn eval(&self, i: &[Vec3], o: &mut [Vec3]) {
        // Environment Texture has no Alpha output: only Image Texture's second slot exists.
        if o.len() < 2 {
            o[0] = Vec3::from(self.lookup(i[0]));
            return;
        }
        let (c, a) = self.lookup_rgba(i[0]);
        o[0] = c;
        o[1] = Vec3::new(a, 0.0, 0.0);
    }
}

/// A procedural texture node: the node's struct with its constant inputs set, plus
/// where each socket goes (`slots[k]` for input socket k).
#[derive(Clone, Debug)]
pub struct ProceduralNode {
    pub node: Procedural,
    pub slots: Vec<ProceduralSlot>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ProceduralSlot {
    Vector,
    W,
    /// Index in `Procedural::input_names`, and whether it is a colour.
    Input(usize, bool),
}

impl ProceduralNode {
    pub fn eval(&self, i: &[Vec3], o: &mut [Vec3]) {
        let mut node = self.node;
        let (mut vector, mut w) = (Vec3::ZERO, 0.0);
        for (k, slot) in self.slots.iter().enumerate() {
            match *slot {
                ProceduralSlot::Vector => vector = i[k],
                ProceduralSlot::W => w = i[k].x,
                ProceduralSlot::Input(j, true) => node.set_input(j, SocketValue::Vector(i[k])),
                ProceduralSlot::Input(j, false) => node.set_input(j, SocketValue::Float(i[k].x)),
            }
        }
        for (k, v) in node.evaluate(vector, w).as_slice().iter().enumerate() {
            o[k] = match *v {
                SocketValue::Float(f) => Vec3::new(f, 0.0, 0.0),
                SocketValue::Vector(v) => v,
            };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mirror_folds_and_closest_picks_one_texel() {
        assert!((mirror(1.25) - 0.75).abs() < 1e-6 && (mirror(-0.25) - 0.25).abs() < 1e-6);
        let t = Texture::from_linear("t", 2, 1, 3, &[1.0, 0.0, 0.0, 3.0, 0.0, 0.0], Wrap::Repeat).unwrap();
        let img = Image {
            texture: Arc::new(t),
            wrap: Wrap::Repeat,
            mirror: false,
            interpolation: Interpolation::Closest,
            equirectangular: false,
            unassociate: false,
        };
        assert_eq!(img.lookup(Vec3::new(0.49, 0.5, 0.0))[0], 1.0);
        assert_eq!(img.lookup(Vec3::new(0.51, 0.5, 0.0))[0], 3.0);
        let lin = Image { interpolation: Interpolation::Linear, ..img };
        assert!((lin.lookup(Vec3::new(0.5, 0.5, 0.0))[0] - 2.0).abs() < 1e-6);
    }

    #[test]
    fn alpha_output_and_unassociation() {
        // 2×1 associated linear RGBA: straight red 1 at alpha 0.25 and red 0.5 at alpha 1.
        let px = [0.25, 0.0, 0.0, 0.25, 0.5, 0.0, 0.0, 1.0];
        let t = Arc::new(Texture::from_linear("t", 2, 1, 4, &px, Wrap::Extend).unwrap());
        let img = Image {
            texture: t,
            wrap: Wrap::Extend,
            mirror: false,
            interpolation: Interpolation::Linear,
            equirectangular: false,
            unassociate: false,
        };
        let mut o = [Vec3::ZERO; 2];
        img.eval(&[Vec3::new(0.25, 0.5, 0.0)], &mut o);
        assert_eq!((o[0].x, o[1].x), (0.25, 0.25));
        // Un-associated: the texel's straight colour; between texels, the filtered
        // associated colour over the filtered alpha (0.375 / 0.625).
        let un = Image { unassociate: true, ..img };
        un.eval(&[Vec3::new(0.25, 0.5, 0.0)], &mut o);
        assert_eq!((o[0].x, o[1].x), (1.0, 0.25));
        un.eval(&[Vec3::new(0.5, 0.5, 0.0)], &mut o);
        assert!((o[0].x - 0.6).abs() < 1e-6 && (o[1].x - 0.625).abs() < 1e-6, "{o:?}");
        // sRGB bytes: divided while encoded, then decoded (straight 0.5 encoded → 0.214).
        let b = Arc::new(Texture::from_srgb8("b", 1, 1, 4, &[64, 0, 0, 128], Wrap::Repeat).unwrap());
        let ub = Image { texture: b, ..un };
        ub.eval(&[Vec3::new(0.5, 0.5, 0.0)], &mut o);
        let straight = (64.0f32 / 255.0) / (128.0 / 255.0);
        assert!((o[0].x - srgb_to_linear(straight)).abs() < 1e-6 && (o[1].x - 128.0 / 255.0).abs() < 1e-7);
    }
}
