//! Image textures kept as RGB in memory (docs/design.md#rgb-data, deferred conversion): no per-texel
//! spectra are ever stored. A lookup returns linear RGB; the caller converts it to a
//! spectrum with the render's uplift (eq. 10) at the hit.
//!
//! Storage is either linear `f32` RGB (12 bytes per texel) or 8-bit sRGB-encoded RGB
//! (3 bytes per texel, decoded through a 256-entry table on lookup). An alpha channel in
//! the input is kept as a separate plane (f32 or byte, as the colour) only when some
//! texel's alpha differs from 1 (model only what a scene requires); without a plane
//! every texel's alpha is 1. Alpha is linear (never sRGB-encoded).
//!
//! Conventions (Blender's): the pixel buffer is row-major with the *top* row first (as
//! numpy, Pillow and OpenEXR give images), texture coordinate `v = 0` is the bottom edge,
//! texel centres sit at `((i + ½)/w, (j + ½)/h)`, and lookups are bilinear.

use crate::scene::{BufferView, TextureDesc, TextureEncoding};
use crate::{Error, Result};
use glam::Vec2;
use serde::{Deserialize, Serialize};

/// What a lookup outside [0,1]² returns (Blender's Image Texture extension modes).
/// How a lookup filters texels: bilinearly, or with Cycles' cubic B-spline (Blender's
/// Cubic and Smart interpolation on the CPU, `interp_cubic` in kernel/device/cpu/image.h).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Filter {
    Bilinear,
    Cubic,
}

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "SCREAMING_SNAKE_CASE")]
pub enum Wrap {
    /// Tile the image.
    #[default]
    Repeat,
    /// Black outside the image (texels beyond the edge count as black when filtering).
    Clip,
    /// Repeat the edge texels.
    Extend,
}

/// How the texels are stored.
#[derive(Clone, Debug)]
pub enum TexelData {
    /// Linear RGB, 3 floats per texel.
    Linear(Vec<f32>),
    /// sRGB-encoded RGB, 3 bytes per texel.
    Srgb8(Vec<u8>),
}

/// The alpha plane of a texture, one value per texel.
#[derive(Clone, Debug)]
pub enum AlphaData {
    Linear(Vec<f32>),
    /// Bytes, alpha = byte / 255.
    Byte(Vec<u8>),
}

/// An RGB image texture, with an alpha plane when the image has a non-trivial alpha.
#[derive(Clone, Debug)]
pub struct Texture {
    pub name: String,
    pub width: u32,
    pub height: u32,
    pub wrap: Wrap,
    data: TexelData,
    alpha: Option<AlphaData>,
}

/// The sRGB transfer function, decoded for every byte value.
fn srgb_table() -> &'static [f32; 256] {
    static T: std::sync::OnceLock<[f32; 256]> = std::sync::OnceLock::new();
    T.get_or_init(|| {
        std::array::from_fn(|i| {
            let c = i as f64 / 255.0;
            let l = if c <= 0.04045 { c / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) };
            l as f32
        })
    })
}

/// Decodes one sRGB-encoded byte to linear.
pub fn srgb_decode(byte: u8) -> f32 {
    srgb_table()[byte as usize]
}

fn check_shape(name: &str, width: u32, height: u32, channels: u32, len: usize) -> Result<usize> {
    if width == 0 || height == 0 {
        return Err(Error::object("texture", name, format!("size {width}×{height} must be at least 1×1")));
    }
    if !(channels == 3 || channels == 4) {
        return Err(Error::object("texture", name, format!("{channels} channels: expected 3 (RGB) or 4 (RGBA)")));
    }
    let texels = width as usize * height as usize;
    let expected =
        texels.checked_mul(channels as usize).ok_or_else(|| Error::object("texture", name, "size overflows"))?;
    if len != expected {
        return Err(Error::object(
            "texture",
            name,
            format!("buffer holds {len} values, expected {width}×{height}×{channels} = {expected}"),
        ));
    }
    Ok(texels)
}

#[inline]
fn lerp(a: f32, b: f32, t: f32) -> f32 {
    // Exact when a == b (a constant image filters to exactly its value).
    a + (b - a) * t
}

impl Texture {
    /// Builds texture `index` of a scene description from its numbered buffer.
    pub fn from_desc(d: &TextureDesc, buffers: &[BufferView]) -> Result<Self> {
        let name = d.name.as_str();
        match (d.encoding, buffers.get(d.buffer)) {
            (TextureEncoding::Linear, Some(BufferView::F32(v))) => {
                Self::from_linear(name, d.width, d.height, d.channels, v, d.wrap)
            }
            (TextureEncoding::Srgb, Some(BufferView::U8(v))) => {
                Self::from_srgb8(name, d.width, d.height, d.channels, v, d.wrap)
            }
            (TextureEncoding::Linear, Some(_)) => Err(Error::object(
                "texture",
                name,
                format!("encoding 'linear' needs float32 pixels but buffer {} holds another type", d.buffer),
            )),
            (TextureEncoding::Srgb, Some(_)) => Err(Error::object(
                "texture",
                name,
                format!("encoding 'srgb' needs uint8 pixels but buffer {} holds another type", d.buffer),
            )),
            (_, None) => Err(Error::object("texture", name, format!("buffer {} does not exist", d.buffer))),
        }
    }

    /// A texture from linear float pixels (`channels` = 3 or 4, top row first).
    /// Non-finite texels are an error naming the texture and the texel.
    pub fn from_linear(name: &str, width: u32, height: u32, channels: u32, pixels: &[f32], wrap: Wrap) -> Result<Self> {
        let texels = check_shape(name, width, height, channels, pixels.len())?;
        let mut data = Vec::with_capacity(texels * 3);
        for (k, px) in pixels.chunks_exact(channels as usize).enumerate() {
            if let Some(v) = px.iter().find(|v| !v.is_finite()) {
                let (x, y) = (k % width as usize, k / width as usize);
                return Err(Error::object("texture", name, format!("texel ({x}, {y}) has the non-finite value {v}")));
            }
            data.extend_from_slice(&px[..3]);
        }
        let alpha = (channels == 4 && pixels.chunks_exact(4).any(|px| px[3] != 1.0))
            .then(|| AlphaData::Linear(pixels.chunks_exact(4).map(|px| px[3]).collect()));
        Ok(Self { name: name.into(), width, height, wrap, data: TexelData::Linear(data), alpha })
    }

    /// A texture from 8-bit sRGB-encoded pixels (`channels` = 3 or 4, top row first).
    pub fn from_srgb8(name: &str, width: u32, height: u32, channels: u32, pixels: &[u8], wrap: Wrap) -> Result<Self> {
        let texels = check_shape(name, width, height, channels, pixels.len())?;
        let data = if channels == 3 {
            pixels.to_vec()
        } else {
            let mut d = Vec::with_capacity(texels * 3);
            for px in pixels.chunks_exact(4) {
                d.extend_from_slice(&px[..3]);
            }
            d
        };
        let alpha = (channels == 4 && pixels.chunks_exact(4).any(|px| px[3] != 255))
            .then(|| AlphaData::Byte(pixels.chunks_exact(4).map(|px| px[3]).collect()));
        Ok(Self { name: name.into(), width, height, wrap, data: TexelData::Srgb8(data), alpha })
    }

    /// Bytes of texel storage held (the raw RGB size, plus the alpha plane if any).
    pub fn bytes(&self) -> usize {
        let rgb = match &self.data {
            TexelData::Linear(v) => v.len() * std::mem::size_of::<f32>(),
            TexelData::Srgb8(v) => v.len(),
        };
        rgb + match &self.alpha {
            None => 0,
            Some(AlphaData::Linear(v)) => v.len() * std::mem::size_of::<f32>(),
            Some(AlphaData::Byte(v)) => v.len(),
        }
    }

    /// Whether the texture holds an alpha plane (some texel's alpha is not 1).
    pub fn has_alpha(&self) -> bool {
        self.alpha.is_some()
    }

    /// Whether the colour is stored as sRGB-encoded bytes.
    pub fn is_srgb8(&self) -> bool {
        matches!(self.data, TexelData::Srgb8(_))
    }

    /// Alpha of the texel at column `x`, row `y` (1 without an alpha plane).
    #[inline]
    pub fn texel_alpha(&self, x: usize, y: usize) -> f32 {
        let k = y * self.width as usize + x;
        match &self.alpha {
            None => 1.0,
            Some(AlphaData::Linear(v)) => v[k],
            Some(AlphaData::Byte(v)) => f32::from(v[k]) / 255.0,
        }
    }

    /// The stored colour of a texel as it is encoded (sRGB bytes / 255, or linear floats).
    #[inline]
    fn texel_encoded(&self, x: usize, y: usize) -> [f32; 3] {
        let k = 3 * (y * self.width as usize + x);
        match &self.data {
            TexelData::Linear(v) => [v[k], v[k + 1], v[k + 2]],
            TexelData::Srgb8(v) => [0, 1, 2].map(|c| f32::from(v[k + c]) / 255.0),
        }
    }

    /// Linear RGB of the texel at column `x`, row `y` (row 0 = top), inside the image.
    #[inline]
    pub fn texel(&self, x: usize, y: usize) -> [f32; 3] {
        let k = 3 * (y * self.width as usize + x);
        match &self.data {
            TexelData::Linear(v) => [v[k], v[k + 1], v[k + 2]],
            TexelData::Srgb8(v) => {
                let t = srgb_table();
                [t[v[k] as usize], t[v[k + 1] as usize], t[v[k + 2] as usize]]
            }
        }
    }

    /// Along one axis of `n` texels: the two texel indices a bilinear lookup at `t`
    /// blends (None = outside the image under CLIP: black) and the weight of the second.
    #[inline]
    fn axis(t: f32, n: u32, wrap: Wrap) -> (Option<usize>, Option<usize>, f32) {
        let nf = n as f32;
        let x = t * nf - 0.5;
        let x0 = x.floor();
        let f = x - x0;
        let last = n as i64 - 1;
        match wrap {
            Wrap::Repeat => {
                // Float modulo (no integer division); the clamp absorbs rounding.
                let i = ((x0 - (x0 / nf).floor() * nf) as i64).clamp(0, last);
                let j = if i == last { 0 } else { i + 1 };
                (Some(i as usize), Some(j as usize), f)
            }
            Wrap::Extend => {
                let i = (x0.clamp(-1.0, nf) as i64).clamp(0, last);
                let j = ((x0.clamp(-1.0, nf) as i64) + 1).clamp(0, last);
                (Some(i as usize), Some(j as usize), f)
            }
            Wrap::Clip => {
                let i = x0.clamp(-2.0, nf + 1.0) as i64;
                let inside = |k: i64| (0..=last).contains(&k).then_some(k as usize);
                (inside(i), inside(i + 1), f)
            }
        }
    }

    /// Bilinearly filtered linear RGB at texture coordinates `uv` with this texture's
    /// wrap mode in both directions.
    #[inline]
    pub fn lookup(&self, uv: Vec2) -> [f32; 3] {
        self.lookup_with(uv, self.wrap, self.wrap, Filter::Bilinear)
    }

    /// Linear RGB filtered by `filter`, with explicit wrap modes along u and v.
    pub fn lookup_with(&self, uv: Vec2, wrap_u: Wrap, wrap_v: Wrap, filter: Filter) -> [f32; 3] {
        self.filtered(uv, wrap_u, wrap_v, filter, |x, y| self.texel(x, y))
    }

    /// Alpha, with the same wrap modes and weights as the colour (outside the image under
    /// CLIP alpha is 0, so a texture without an alpha plane gives its coverage).
    pub fn lookup_alpha_with(&self, uv: Vec2, wrap_u: Wrap, wrap_v: Wrap, filter: Filter) -> f32 {
        self.filtered(uv, wrap_u, wrap_v, filter, |x, y| [self.texel_alpha(x, y)])[0]
    }

    /// Colour in its stored encoding (sRGB-encoded values for byte textures, as Cycles
    /// filters 8-bit sRGB images before decoding them) and alpha.
    pub fn lookup_encoded_with(&self, uv: Vec2, wrap_u: Wrap, wrap_v: Wrap, filter: Filter) -> [f32; 4] {
        self.filtered(uv, wrap_u, wrap_v, filter, |x, y| {
            let [r, g, b] = self.texel_encoded(x, y);
            [r, g, b, self.texel_alpha(x, y)]
        })
    }

    #[inline]
    fn filtered<const N: usize>(
        &self,
        uv: Vec2,
        wrap_u: Wrap,
        wrap_v: Wrap,
        filter: Filter,
        texel: impl Fn(usize, usize) -> [f32; N],
    ) -> [f32; N] {
        if !(uv.x.is_finite() && uv.y.is_finite()) {
            return [0.0; N]; // a non-finite coordinate reads black
        }
        match filter {
            Filter::Bilinear => self.bilinear(uv, wrap_u, wrap_v, texel),
            Filter::Cubic => self.bicubic(uv, wrap_u, wrap_v, texel),
        }
    }

    /// Along one axis of `n` texels: the four texels a cubic lookup at `t` weighs (None
    /// = outside the image under CLIP: black) and their B-spline weights
    /// (SET_CUBIC_SPLINE_WEIGHTS, centred by the same −0.5 texel as the bilinear filter).
    #[inline]
    fn cubic_axis(t: f32, n: u32, wrap: Wrap) -> ([Option<usize>; 4], [f32; 4]) {
        let x = t * n as f32 - 0.5;
        let x0 = x.floor();
        let f = x - x0;
        let w = [
            (((-1.0 / 6.0) * f + 0.5) * f - 0.5) * f + 1.0 / 6.0,
            ((0.5 * f - 1.0) * f) * f + 2.0 / 3.0,
            ((-0.5 * f + 0.5) * f + 0.5) * f + 1.0 / 6.0,
            (1.0 / 6.0) * f * f * f,
        ];
        let n = n as i64;
        // Repeat wraps any coordinate; the others only need it near the image.
        let i = if wrap == Wrap::Repeat { (x0 as i64).rem_euclid(n) } else { x0.clamp(-4.0, n as f32 + 4.0) as i64 };
        let taps = std::array::from_fn(|k| {
            let j = i - 1 + k as i64;
            match wrap {
                Wrap::Repeat => Some(j.rem_euclid(n) as usize),
                Wrap::Extend => Some(j.clamp(0, n - 1) as usize),
                Wrap::Clip => (0..n).contains(&j).then_some(j as usize),
            }
        });
        (taps, w)
    }

    /// Bicubic filter of `texel` values (0 outside the image under CLIP) at a finite `uv`.
    fn bicubic<const N: usize>(
        &self,
        uv: Vec2,
        wrap_u: Wrap,
        wrap_v: Wrap,
        texel: impl Fn(usize, usize) -> [f32; N],
    ) -> [f32; N] {
        let (xs, wx) = Self::cubic_axis(uv.x, self.width, wrap_u);
        let (ys, wy) = Self::cubic_axis(1.0 - uv.y, self.height, wrap_v);
        let mut out = [0.0; N];
        for (yi, wy) in ys.iter().zip(wy) {
            for (xi, wx) in xs.iter().zip(wx) {
                if let (Some(a), Some(b)) = (xi, yi) {
                    let t = texel(*a, *b);
                    for c in 0..N {
                        out[c] += wx * wy * t[c];
                    }
                }
            }
        }
        out
    }

    /// Bilinear filter of `texel` values (0 outside the image under CLIP) at a finite `uv`.
    #[inline]
    fn bilinear<const N: usize>(
        &self,
        uv: Vec2,
        wrap_u: Wrap,
        wrap_v: Wrap,
        texel: impl Fn(usize, usize) -> [f32; N],
    ) -> [f32; N] {
        // Texel centres at integers; rows count from the top (v = 1).
        let (x0, x1, fx) = Self::axis(uv.x, self.width, wrap_u);
        let (y0, y1, fy) = Self::axis(1.0 - uv.y, self.height, wrap_v);
        let (xs, ys) = ([x0, x1], [y0, y1]);
        let at = |xi: Option<usize>, yi: Option<usize>| match (xi, yi) {
            (Some(a), Some(b)) => texel(a, b),
            _ => [0.0; N],
        };
        let (c00, c10, c01, c11) = (at(xs[0], ys[0]), at(xs[1], ys[0]), at(xs[0], ys[1]), at(xs[1], ys[1]));
        std::array::from_fn(|c| lerp(lerp(c00[c], c10[c], fx), lerp(c01[c], c11[c], fx), fy))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bilinear_hits_texel_centres_and_midpoints() {
        // 2×1 image: left texel red 1, right texel red 3.
        let t = Texture::from_linear("t", 2, 1, 3, &[1.0, 0.0, 0.0, 3.0, 0.0, 0.0], Wrap::Extend).unwrap();
        assert_eq!(t.lookup(Vec2::new(0.25, 0.5))[0], 1.0);
        assert_eq!(t.lookup(Vec2::new(0.75, 0.5))[0], 3.0);
        assert!((t.lookup(Vec2::new(0.5, 0.5))[0] - 2.0).abs() < 1e-6);
        // Extend: beyond the edge stays at the edge texel.
        assert_eq!(t.lookup(Vec2::new(-3.0, 0.5))[0], 1.0);
        // Repeat: u = 0 is halfway between the last and the first texel.
        let r = Texture { wrap: Wrap::Repeat, ..t.clone() };
        assert!((r.lookup(Vec2::new(0.0, 0.5))[0] - 2.0).abs() < 1e-6);
        assert!((r.lookup(Vec2::new(1.25, 0.5))[0] - 1.0).abs() < 1e-6);
        // Clip: black outside, half-faded at the edge.
        let c = Texture { wrap: Wrap::Clip, ..t };
        assert_eq!(c.lookup(Vec2::new(-1.0, 0.5)), [0.0; 3]);
        assert!((c.lookup(Vec2::new(0.0, 0.5))[0] - 0.5).abs() < 1e-6);
    }

    /// The cubic B-spline filter reproduces linear data exactly (its weights sum to 1
    /// and have mean offset 0) and at a texel centre gives (c₋₁ + 4c₀ + c₁)/6.
    #[test]
    fn bicubic_is_the_cubic_b_spline() {
        let row: Vec<f32> = (0..8).flat_map(|i| [i as f32, 0.0, 0.0]).collect();
        let t = Texture::from_linear("t", 8, 1, 3, &row, Wrap::Extend).unwrap();
        for &u in &[0.3f32, 0.41, 0.5, 0.62] {
            let linear = u * 8.0 - 0.5; // the texel index at u
            assert!(
                (t.lookup_with(Vec2::new(u, 0.5), Wrap::Extend, Wrap::Extend, Filter::Cubic)[0] - linear).abs() < 1e-5
            );
        }
        let spiky: Vec<f32> = (0..8).flat_map(|i| [if i == 4 { 6.0 } else { 0.0 }, 0.0, 0.0]).collect();
        let s = Texture::from_linear("s", 8, 1, 3, &spiky, Wrap::Repeat).unwrap();
        let at = |i: f32| s.lookup_with(Vec2::new((i + 0.5) / 8.0, 0.5), Wrap::Repeat, Wrap::Repeat, Filter::Cubic)[0];
        assert!((at(4.0) - 4.0).abs() < 1e-5 && (at(3.0) - 1.0).abs() < 1e-5 && at(6.0).abs() < 1e-6);
        // Repeat wraps the taps; Clip reads black beyond the edge.
        assert!((at(4.0 + 8.0) - 4.0).abs() < 1e-4);
        let c = s.lookup_with(Vec2::new(-0.5 / 8.0, 0.5), Wrap::Clip, Wrap::Clip, Filter::Cubic)[0];
        assert_eq!(c, 0.0);
    }

    #[test]
    fn top_row_is_v_one() {
        // 1×2: top texel 1, bottom texel 0.
        let t = Texture::from_linear("t", 1, 2, 3, &[1.0, 1.0, 1.0, 0.0, 0.0, 0.0], Wrap::Extend).unwrap();
        assert_eq!(t.lookup(Vec2::new(0.5, 0.75))[1], 1.0);
        assert_eq!(t.lookup(Vec2::new(0.5, 0.25))[1], 0.0);
    }

    #[test]
    fn srgb_bytes_decode_and_alpha_is_kept_apart() {
        let t = Texture::from_srgb8("s", 1, 1, 4, &[255, 128, 0, 7], Wrap::Repeat).unwrap();
        assert_eq!(t.bytes(), 4);
        assert!(
            (t.lookup_alpha_with(Vec2::new(0.3, 0.9), Wrap::Repeat, Wrap::Repeat, Filter::Bilinear) - 7.0 / 255.0)
                .abs()
                < 1e-7
        );
        // An opaque alpha channel stores no plane.
        let o = Texture::from_srgb8("o", 1, 1, 4, &[255, 128, 0, 255], Wrap::Repeat).unwrap();
        assert!(!o.has_alpha() && o.bytes() == 3);
        let c = t.lookup(Vec2::new(0.3, 0.9));
        assert_eq!(c[0], 1.0);
        assert!((c[1] - 0.215_860_5).abs() < 1e-6, "{}", c[1]);
        assert_eq!(c[2], 0.0);
    }

    #[test]
    fn alpha_filters_like_the_colour() {
        // 2×1 RGBA: alpha 0.2 and 0.6; same weights, wraps and CLIP fade as the colour.
        let px = [1.0, 0.0, 0.0, 0.2, 3.0, 0.0, 0.0, 0.6];
        let t = Texture::from_linear("t", 2, 1, 4, &px, Wrap::Extend).unwrap();
        assert!(t.has_alpha() && t.bytes() == 8 * 4);
        let a = |t: &Texture, u: f32, w: Wrap| t.lookup_alpha_with(Vec2::new(u, 0.5), w, w, Filter::Bilinear);
        assert_eq!(a(&t, 0.25, Wrap::Extend), 0.2);
        assert!((a(&t, 0.5, Wrap::Extend) - 0.4).abs() < 1e-6);
        assert!((a(&t, 0.0, Wrap::Repeat) - 0.4).abs() < 1e-6);
        assert_eq!(a(&t, -1.0, Wrap::Clip), 0.0);
        assert!((a(&t, 0.0, Wrap::Clip) - 0.1).abs() < 1e-6);
        // Without a plane: 1 inside, the coverage at a CLIP edge.
        let rgb = Texture::from_linear("rgb", 2, 1, 3, &[1.0, 0.0, 0.0, 3.0, 0.0, 0.0], Wrap::Clip).unwrap();
        assert!(!rgb.has_alpha());
        assert_eq!(a(&rgb, 0.5, Wrap::Clip), 1.0);
        assert!((a(&rgb, 0.0, Wrap::Clip) - 0.5).abs() < 1e-6);
        let e = t.lookup_encoded_with(Vec2::new(0.5, 0.5), Wrap::Extend, Wrap::Extend, Filter::Bilinear);
        assert!((e[0] - 2.0).abs() < 1e-6 && (e[3] - 0.4).abs() < 1e-6);
        // A non-finite alpha is an error like a non-finite colour.
        let e = Texture::from_linear("m", 1, 1, 4, &[0.0, 0.0, 0.0, f32::NAN], Wrap::Repeat).unwrap_err().to_string();
        assert!(e.contains("'m'") || e.contains("m"), "{e}");
    }

    #[test]
    fn bad_textures_are_reported_by_name() {
        let e = Texture::from_linear("wood", 2, 2, 3, &[0.0; 11], Wrap::Repeat).unwrap_err().to_string();
        assert!(e.contains("wood") && e.contains("12"), "{e}");
        let e = Texture::from_linear("sky", 1, 1, 3, &[0.0, f32::NAN, 0.0], Wrap::Repeat).unwrap_err().to_string();
        assert!(e.contains("sky") && e.contains("non-finite"), "{e}");
        assert!(Texture::from_srgb8("x", 1, 1, 2, &[0, 0], Wrap::Repeat).is_err());
    }
}
