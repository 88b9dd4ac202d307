//! Texture nodes: Image Texture over the scene's textures, and every procedural texture
//! through `crate::procedural` (already exact to Cycles).

use crate::material::texture::{Texture, Wrap};
use crate::procedural::{Procedural, SocketValue};
use glam::{Vec2, Vec3};
use std::sync::Arc;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Interpolation {
    Linear,
    Closest,
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

impl Image {
    pub fn lookup(&self, v: Vec3) -> [f32; 3] {
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
        self.texture.lookup_with(uv, self.wrap, self.wrap)
    }

    pub fn eval(&self, i: &[Vec3], o: &mut [Vec3]) {
        let c = self.lookup(i[0]);
        o[0] = Vec3::from(c);
        // Environment Texture has no Alpha output: only Image Texture's second slot exists.
        if let Some(alpha) = o.get_mut(1) {
            *alpha = Vec3::new(1.0, 0.0, 0.0);
        }
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
        };
        assert_eq!(img.lookup(Vec3::new(0.49, 0.5, 0.0))[0], 1.0);
        assert_eq!(img.lookup(Vec3::new(0.51, 0.5, 0.0))[0], 3.0);
        let lin = Image { interpolation: Interpolation::Linear, ..img };
        assert!((lin.lookup(Vec3::new(0.5, 0.5, 0.0))[0] - 2.0).abs() < 1e-6);
    }
}
