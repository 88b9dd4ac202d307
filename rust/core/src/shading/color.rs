//! Colour nodes as Cycles computes them: Mix (float, vector, colour with every blend
//! mode), Hue/Saturation/Value, Invert, Gamma, Bright/Contrast, RGB to BW, Separate and
//! Combine Color (RGB, HSV, HSL) and XYZ, Color Ramp, RGB/Vector/Float Curves.
//! Sources: Cycles `kernel/svm/mix.h`, `color_util.h`, `util/color.h`, `ramp.h`,
//! `gamma.h`, `brightness.h`, `hsv.h`, `sepcomb_color.h`; Blender `BKE_colorband_evaluate`.

use super::props::Props;
use crate::Result;
use glam::Vec3;
use serde::Deserialize;

/// Blender's default scene-linear luminance (Rec.709), `linear_rgb_to_gray`.
pub const LUMA: Vec3 = Vec3::new(0.2126, 0.7152, 0.0722);

#[inline]
pub fn gray(c: Vec3) -> f32 {
    c.dot(LUMA)
}

/// Cycles `rgb_to_hsv`.
pub fn rgb_to_hsv(rgb: Vec3) -> Vec3 {
    let cmax = rgb.max_element();
    let cmin = rgb.min_element();
    let cdelta = cmax - cmin;
    let v = cmax;
    let s = if cmax != 0.0 { cdelta / cmax } else { 0.0 };
    let mut h = 0.0;
    if s != 0.0 {
        let c = (Vec3::splat(cmax) - rgb) / cdelta;
        h = if rgb.x == cmax {
            c.z - c.y
        } else if rgb.y == cmax {
            2.0 + c.x - c.z
        } else {
            4.0 + c.y - c.x
        };
        h /= 6.0;
        if h < 0.0 {
            h += 1.0;
        }
    }
    Vec3::new(h, s, v)
}

/// Cycles `hsv_to_rgb`.
pub fn hsv_to_rgb(hsv: Vec3) -> Vec3 {
    let (mut h, s, v) = (hsv.x, hsv.y, hsv.z);
    if s == 0.0 {
        return Vec3::splat(v);
    }
    if h == 1.0 {
        h = 0.0;
    }
    h *= 6.0;
    let i = h.floor();
    let f = h - i;
    let p = v * (1.0 - s);
    let q = v * (1.0 - s * f);
    let t = v * (1.0 - s * (1.0 - f));
    match i as i32 {
        0 => Vec3::new(v, t, p),
        1 => Vec3::new(q, v, p),
        2 => Vec3::new(p, v, t),
        3 => Vec3::new(p, q, v),
        4 => Vec3::new(t, p, v),
        _ => Vec3::new(v, p, q),
    }
}

/// Cycles `rgb_to_hsl`.
pub fn rgb_to_hsl(rgb: Vec3) -> Vec3 {
    let cmax = rgb.max_element();
    let cmin = rgb.min_element();
    let l = ((cmax + cmin) / 2.0).min(1.0);
    if cmax == cmin {
        return Vec3::new(0.0, 0.0, l);
    }
    let d = cmax - cmin;
    let s = if l > 0.5 { d / (2.0 - cmax - cmin) } else { d / (cmax + cmin) };
    let h = if cmax == rgb.x {
        (rgb.y - rgb.z) / d + if rgb.y < rgb.z { 6.0 } else { 0.0 }
    } else if cmax == rgb.y {
        (rgb.z - rgb.x) / d + 2.0
    } else {
        (rgb.x - rgb.y) / d + 4.0
    };
    Vec3::new(h / 6.0, s, l)
}

/// Cycles `hsl_to_rgb`.
pub fn hsl_to_rgb(hsl: Vec3) -> Vec3 {
    let (h, s, l) = (hsl.x, hsl.y, hsl.z);
    let nr = ((h * 6.0 - 3.0).abs() - 1.0).clamp(0.0, 1.0);
    let ng = (2.0 - (h * 6.0 - 2.0).abs()).clamp(0.0, 1.0);
    let nb = (2.0 - (h * 6.0 - 4.0).abs()).clamp(0.0, 1.0);
    let chroma = (1.0 - (2.0 * l - 1.0).abs()) * s;
    Vec3::new((nr - 0.5) * chroma + l, (ng - 0.5) * chroma + l, (nb - 0.5) * chroma + l)
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Blend {
    Mix,
    Darken,
    Multiply,
    Burn,
    Lighten,
    Screen,
    Dodge,
    Add,
    Overlay,
    SoftLight,
    LinearLight,
    Difference,
    Exclusion,
    Subtract,
    Divide,
    Hue,
    Saturation,
    Color,
    Value,
}

const BLENDS: &[(&str, Blend)] = &[
    ("MIX", Blend::Mix),
    ("DARKEN", Blend::Darken),
    ("MULTIPLY", Blend::Multiply),
    ("BURN", Blend::Burn),
    ("LIGHTEN", Blend::Lighten),
    ("SCREEN", Blend::Screen),
    ("DODGE", Blend::Dodge),
    ("ADD", Blend::Add),
    ("OVERLAY", Blend::Overlay),
    ("SOFT_LIGHT", Blend::SoftLight),
    ("LINEAR_LIGHT", Blend::LinearLight),
    ("DIFFERENCE", Blend::Difference),
    ("EXCLUSION", Blend::Exclusion),
    ("SUBTRACT", Blend::Subtract),
    ("DIVIDE", Blend::Divide),
    ("HUE", Blend::Hue),
    ("SATURATION", Blend::Saturation),
    ("COLOR", Blend::Color),
    ("VALUE", Blend::Value),
];

#[inline]
fn interp(a: Vec3, b: Vec3, t: f32) -> Vec3 {
    (1.0 - t) * a + t * b
}

fn per_channel(c1: Vec3, c2: Vec3, f: impl Fn(f32, f32) -> f32) -> Vec3 {
    Vec3::new(f(c1.x, c2.x), f(c1.y, c2.y), f(c1.z, c2.z))
}

/// Cycles `svm_mix` (kernel/svm/mix.h / color_util.h `svm_mix_*`).
pub fn blend(mode: Blend, t: f32, c1: Vec3, c2: Vec3) -> Vec3 {
    let tm = 1.0 - t;
    let one = Vec3::ONE;
    match mode {
        Blend::Mix => interp(c1, c2, t),
        Blend::Add => interp(c1, c1 + c2, t),
        Blend::Multiply => interp(c1, c1 * c2, t),
        Blend::Screen => one - (Vec3::splat(tm) + t * (one - c2)) * (one - c1),
        Blend::Overlay => per_channel(c1, c2, |a, b| {
            if a < 0.5 {
                a * (tm + 2.0 * t * b)
            } else {
                1.0 - (tm + 2.0 * t * (1.0 - b)) * (1.0 - a)
            }
        }),
        Blend::Subtract => interp(c1, c1 - c2, t),
        Blend::Divide => per_channel(c1, c2, |a, b| if b != 0.0 { tm * a + t * a / b } else { a }),
        Blend::Difference => interp(c1, (c1 - c2).abs(), t),
        Blend::Exclusion => interp(c1, c1 + c2 - 2.0 * c1 * c2, t),
        Blend::Darken => interp(c1, c1.min(c2), t),
        Blend::Lighten => interp(c1, c1.max(c2), t),
        Blend::Dodge => per_channel(c1, c2, |a, b| {
            if a == 0.0 {
                return a;
            }
            let tmp = 1.0 - t * b;
            if tmp <= 0.0 {
                1.0
            } else {
                (a / tmp).min(1.0)
            }
        }),
        Blend::Burn => per_channel(c1, c2, |a, b| {
            let tmp = tm + t * b;
            if tmp <= 0.0 {
                0.0
            } else {
                (1.0 - (1.0 - a) / tmp).clamp(0.0, 1.0)
            }
        }),
        Blend::Hue => {
            let hsv2 = rgb_to_hsv(c2);
            if hsv2.y == 0.0 {
                return c1;
            }
            let mut hsv = rgb_to_hsv(c1);
            hsv.x = hsv2.x;
            interp(c1, hsv_to_rgb(hsv), t)
        }
        Blend::Saturation => {
            let mut hsv = rgb_to_hsv(c1);
            if hsv.y == 0.0 {
                return c1;
            }
            let hsv2 = rgb_to_hsv(c2);
            hsv.y = tm * hsv.y + t * hsv2.y;
            hsv_to_rgb(hsv)
        }
        Blend::Value => {
            let mut hsv = rgb_to_hsv(c1);
            let hsv2 = rgb_to_hsv(c2);
            hsv.z = tm * hsv.z + t * hsv2.z;
            hsv_to_rgb(hsv)
        }
        Blend::Color => {
            let hsv2 = rgb_to_hsv(c2);
            if hsv2.y == 0.0 {
                return c1;
            }
            let mut hsv = rgb_to_hsv(c1);
            hsv.x = hsv2.x;
            hsv.y = hsv2.y;
            interp(c1, hsv_to_rgb(hsv), t)
        }
        Blend::SoftLight => {
            let scr = one - (one - c2) * (one - c1);
            tm * c1 + t * ((one - c1) * c2 * c1 + c1 * scr)
        }
        Blend::LinearLight => c1 + t * (2.0 * c2 - one),
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MixType {
    Float,
    Vector,
    Color,
}

/// The Mix node (Cycles `svm_node_mix_float/vector/color`). Inputs in socket order:
/// Factor_Float, Factor_Vector, A_Float, B_Float, A_Vector, B_Vector, A_Color, B_Color,
/// A_Rotation, B_Rotation; outputs Result_Float, Result_Vector, Result_Color, Result_Rotation.
#[derive(Clone, Copy, Debug)]
pub struct Mix {
    pub ty: MixType,
    pub blend: Blend,
    pub non_uniform: bool,
    pub clamp_factor: bool,
    pub clamp_result: bool,
}

impl Mix {
    pub fn parse(p: &Props) -> Result<Self> {
        let ty = p.enumeration(
            "data_type",
            &[("FLOAT", MixType::Float), ("VECTOR", MixType::Vector), ("RGBA", MixType::Color)],
            MixType::Float,
        )?;
        Ok(Self {
            ty,
            blend: p.enumeration("blend_type", BLENDS, Blend::Mix)?,
            non_uniform: p.enumeration("factor_mode", &[("UNIFORM", false), ("NON_UNIFORM", true)], false)?,
            clamp_factor: p.boolean("clamp_factor", true)?,
            clamp_result: p.boolean("clamp_result", false)?,
        })
    }
    pub fn eval(&self, i: &[Vec3], o: &mut [Vec3]) {
        let sat = |t: f32| if self.clamp_factor { t.clamp(0.0, 1.0) } else { t };
        match self.ty {
            MixType::Float => {
                let t = sat(i[0].x);
                o[0].x = (1.0 - t) * i[2].x + t * i[3].x;
            }
            MixType::Vector => {
                let t = if self.non_uniform {
                    let f = i[1];
                    if self.clamp_factor {
                        f.clamp(Vec3::ZERO, Vec3::ONE)
                    } else {
                        f
                    }
                } else {
                    Vec3::splat(sat(i[0].x))
                };
                o[1] = (Vec3::ONE - t) * i[4] + t * i[5];
            }
            MixType::Color => {
                let c = blend(self.blend, sat(i[0].x), i[6], i[7]);
                o[2] = if self.clamp_result { c.clamp(Vec3::ZERO, Vec3::ONE) } else { c };
            }
        }
    }
}

/// Nodes of one colour operation each.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ColorOp {
    /// Hue, Saturation, Value, Fac, Color → Color (Cycles `svm_node_hsv`).
    HueSaturation,
    /// Fac, Color → Color.
    Invert,
    /// Color, Gamma → Color (Cycles `svm_math_gamma_color`).
    Gamma,
    /// Color, Bright, Contrast → Color (Cycles `svm_brightness_contrast`).
    BrightContrast,
    /// Color → Val.
    RgbToBw,
    /// Color → Red, Green, Blue (or H, S, V / H, S, L).
    Separate(ColorMode),
    /// Red, Green, Blue → Color.
    Combine(ColorMode),
    SeparateXyz,
    CombineXyz,
    /// Temperature → Color: Cycles' Rec.709 fit of a blackbody's colour (luminance ≈ 1).
    Blackbody,
    /// Wavelength → Color: the CIE 1931 colour of one wavelength, as Cycles shows it.
    Wavelength,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ColorMode {
    Rgb,
    Hsv,
    Hsl,
}

pub fn color_mode(p: &Props) -> Result<ColorMode> {
    p.enumeration("mode", &[("RGB", ColorMode::Rgb), ("HSV", ColorMode::Hsv), ("HSL", ColorMode::Hsl)], ColorMode::Rgb)
}

impl ColorOp {
    pub fn eval(&self, i: &[Vec3], o: &mut [Vec3]) {
        match *self {
            ColorOp::HueSaturation => {
                let (hue, sat, val, fac, input) = (i[0].x, i[1].x, i[2].x, i[3].x, i[4]);
                let mut hsv = rgb_to_hsv(input);
                let h = hsv.x + hue + 0.5;
                hsv.x = h - h.floor();
                hsv.y = (hsv.y * sat).clamp(0.0, 1.0);
                hsv.z *= val;
                let c = hsv_to_rgb(hsv);
                o[0] = (fac * c + (1.0 - fac) * input).max(Vec3::ZERO);
            }
            ColorOp::Invert => o[0] = interp(i[1], Vec3::ONE - i[1], i[0].x),
            ColorOp::Gamma => {
                let g = i[1].x;
                o[0] = Vec3::new(
                    if i[0].x > 0.0 { i[0].x.powf(g) } else { i[0].x },
                    if i[0].y > 0.0 { i[0].y.powf(g) } else { i[0].y },
                    if i[0].z > 0.0 { i[0].z.powf(g) } else { i[0].z },
                );
            }
            ColorOp::BrightContrast => {
                let (bright, contrast) = (i[1].x, i[2].x);
                let a = 1.0 + contrast;
                let b = bright - contrast * 0.5;
                o[0] = (a * i[0] + Vec3::splat(b)).max(Vec3::ZERO);
            }
            ColorOp::RgbToBw => o[0].x = gray(i[0]),
            ColorOp::Blackbody => o[0] = blackbody_rec709(i[0].x).max(Vec3::ZERO),
            ColorOp::Wavelength => o[0] = wavelength_rec709(i[0].x),
            ColorOp::Separate(mode) => {
                let c = match mode {
                    ColorMode::Rgb => i[0],
                    ColorMode::Hsv => rgb_to_hsv(i[0]),
                    ColorMode::Hsl => rgb_to_hsl(i[0]),
                };
                o[0].x = c.x;
                o[1].x = c.y;
                o[2].x = c.z;
            }
            ColorOp::Combine(mode) => {
                let c = Vec3::new(i[0].x, i[1].x, i[2].x);
                o[0] = match mode {
                    ColorMode::Rgb => c,
                    ColorMode::Hsv => hsv_to_rgb(c),
                    ColorMode::Hsl => hsl_to_rgb(c),
                };
            }
            ColorOp::SeparateXyz => {
                o[0].x = i[0].x;
                o[1].x = i[0].y;
                o[2].x = i[0].z;
            }
            ColorOp::CombineXyz => o[0] = Vec3::new(i[0].x, i[1].x, i[2].x),
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "SCREAMING_SNAKE_CASE")]
pub enum RampInterpolation {
    Linear,
    Ease,
    Constant,
    BSpline,
    Cardinal,
}

/// `"color_ramp"` of docs/shading.md.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ColorRampDesc {
    #[serde(default = "linear")]
    pub interpolation: RampInterpolation,
    #[serde(default = "rgb")]
    pub color_mode: String,
    #[serde(default)]
    pub hue_interpolation: Option<String>,
    pub elements: Vec<(f32, [f32; 4])>,
}

fn linear() -> RampInterpolation {
    RampInterpolation::Linear
}
fn rgb() -> String {
    "RGB".into()
}

/// A Color Ramp: Fac → Color, Alpha, evaluated as Blender's `BKE_colorband_evaluate`
/// (Linear, Ease, Constant; B-Spline and Cardinal are evaluated as Linear with a warning).
#[derive(Clone, Debug)]
pub struct ColorRamp {
    pub interpolation: RampInterpolation,
    /// Sorted by position.
    pub elements: Vec<(f32, [f32; 4])>,
}

impl ColorRamp {
    /// The ramp from props; the second value names what is approximated, if anything.
    pub fn parse(p: &Props) -> Result<(Self, Option<String>)> {
        let Some(v) = p.get("color_ramp") else {
            return Err(p.error("Color Ramp without its 'color_ramp' property"));
        };
        let d: ColorRampDesc =
            serde_json::from_value(v.clone()).map_err(|e| p.error(format!("property 'color_ramp': {e}")))?;
        if d.elements.is_empty() {
            return Err(p.error("Color Ramp has no elements"));
        }
        if d.elements.iter().any(|(x, c)| !x.is_finite() || c.iter().any(|v| !v.is_finite())) {
            return Err(p.error("Color Ramp element is not finite"));
        }
        let mut elements = d.elements;
        elements.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut approx = None;
        let mut interpolation = d.interpolation;
        if matches!(interpolation, RampInterpolation::BSpline | RampInterpolation::Cardinal) {
            approx = Some(format!("{:?} interpolation (evaluated as Linear)", interpolation));
            interpolation = RampInterpolation::Linear;
        }
        if d.color_mode != "RGB" {
            approx = Some(format!("colour mode {} (interpolated in RGB)", d.color_mode));
        }
        Ok((Self { interpolation, elements }, approx))
    }

    pub fn evaluate(&self, fac: f32) -> [f32; 4] {
        let e = &self.elements;
        let first = e[0];
        let last = e[e.len() - 1];
        if fac <= first.0 || e.len() == 1 {
            return first.1;
        }
        if fac >= last.0 {
            return last.1;
        }
        // e[k-1].0 < fac <= e[k].0
        let k = e.iter().position(|x| x.0 >= fac).unwrap_or(e.len() - 1);
        let (lo, hi) = (e[k - 1], e[k]);
        if self.interpolation == RampInterpolation::Constant {
            return if fac >= hi.0 { hi.1 } else { lo.1 };
        }
        let mut t = if hi.0 > lo.0 { (fac - lo.0) / (hi.0 - lo.0) } else { 0.0 };
        if self.interpolation == RampInterpolation::Ease {
            t = t * t * (3.0 - 2.0 * t);
        }
        std::array::from_fn(|c| (1.0 - t) * lo.1[c] + t * hi.1[c])
    }

    pub fn eval(&self, i: &[Vec3], o: &mut [Vec3]) {
        let c = self.evaluate(i[0].x);
        o[0] = Vec3::new(c[0], c[1], c[2]);
        o[1].x = c[3];
    }
}

/// `"curves"` of docs/shading.md: tables baked over [min_x, max_x].
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CurvesDesc {
    #[serde(default)]
    pub min_x: f32,
    #[serde(default = "one")]
    pub max_x: f32,
    pub tables: Vec<Vec<f32>>,
    #[serde(default = "yes")]
    pub extrapolate: bool,
}

fn one() -> f32 {
    1.0
}
fn yes() -> bool {
    true
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CurvesKind {
    /// Fac, Color → Color; tables C, R, G, B.
    Rgb,
    /// Fac, Vector → Vector; tables X, Y, Z.
    Vector,
    /// Factor, Value → Value; one table.
    Float,
}

#[derive(Clone, Debug)]
pub struct Curves {
    pub kind: CurvesKind,
    pub min_x: f32,
    pub range: f32,
    pub tables: Vec<Vec<f32>>,
    pub extrapolate: bool,
}

/// Cycles `float_ramp_lookup` over a baked table at relative position `f`.
fn table_lookup(table: &[f32], f: f32, extrapolate: bool) -> f32 {
    let n = table.len();
    if n == 1 {
        return table[0];
    }
    if !(0.0..=1.0).contains(&f) && extrapolate {
        let (t0, dy, f) = if f < 0.0 {
            (table[0], table[0] - table[1], -f)
        } else {
            (table[n - 1], table[n - 1] - table[n - 2], f - 1.0)
        };
        return t0 + dy * f * (n - 1) as f32;
    }
    let f = f.clamp(0.0, 1.0) * (n - 1) as f32;
    let i = (f as usize).min(n - 1);
    let t = f - i as f32;
    if t > 0.0 && i + 1 < n {
        (1.0 - t) * table[i] + t * table[i + 1]
    } else {
        table[i]
    }
}

impl Curves {
    pub fn parse(p: &Props, kind: CurvesKind) -> Result<Self> {
        let Some(v) = p.get("curves") else { return Err(p.error("curve node without its 'curves' property")) };
        let d: CurvesDesc =
            serde_json::from_value(v.clone()).map_err(|e| p.error(format!("property 'curves': {e}")))?;
        let want = match kind {
            CurvesKind::Rgb => 4,
            CurvesKind::Vector => 3,
            CurvesKind::Float => 1,
        };
        if d.tables.len() != want || d.tables.iter().any(|t| t.is_empty()) {
            return Err(p.error(format!("'curves' needs {want} non-empty tables, got {}", d.tables.len())));
        }
        if d.tables.iter().flatten().any(|v| !v.is_finite()) || !(d.min_x.is_finite() && d.max_x.is_finite()) {
            return Err(p.error("'curves' holds a non-finite value"));
        }
        let range = d.max_x - d.min_x;
        if range == 0.0 {
            return Err(p.error("'curves' has min_x equal to max_x"));
        }
        Ok(Self { kind, min_x: d.min_x, range, tables: d.tables, extrapolate: d.extrapolate })
    }

    fn lookup(&self, k: usize, x: f32) -> f32 {
        table_lookup(&self.tables[k], (x - self.min_x) / self.range, self.extrapolate)
    }

    /// Cycles `svm_node_curves` / `svm_node_curve`: the curve result mixed with the input by Fac.
    pub fn eval(&self, i: &[Vec3], o: &mut [Vec3]) {
        let fac = i[0].x;
        match self.kind {
            CurvesKind::Float => {
                let v = i[1].x;
                o[0].x = (1.0 - fac) * v + fac * self.lookup(0, v);
            }
            CurvesKind::Vector => {
                let v = i[1];
                let r = Vec3::new(self.lookup(0, v.x), self.lookup(1, v.y), self.lookup(2, v.z));
                o[0] = (1.0 - fac) * v + fac * r;
            }
            CurvesKind::Rgb => {
                // Cycles bakes each channel as channel(C(x)).
                let c = i[1];
                let r = Vec3::new(
                    self.lookup(1, self.lookup(0, c.x)),
                    self.lookup(2, self.lookup(0, c.y)),
                    self.lookup(3, self.lookup(0, c.z)),
                );
                o[0] = (1.0 - fac) * c + fac * r;
            }
        }
    }
}

/// Cycles' fit of the Rec.709 colour of a blackbody at `t` kelvin: `a/t + b·t + c` for
/// red and green, a cubic for blue, in seven ranges over 800..12000 K, constant outside
/// (Cycles `svm_math_blackbody_color_rec709`, intern/cycles/kernel/svm/math_util.h,
/// coefficients `blackbody_table_r/g/b` of intern/cycles/kernel/tables.h, Blender 4.5).
/// Negative components (outside the Rec.709 gamut) are the caller's to clamp.
// The coefficients as Cycles prints them, beyond f32 precision.
#[allow(clippy::excessive_precision)]
pub fn blackbody_rec709(t: f32) -> Vec3 {
    const R: [[f32; 3]; 7] = [
        [1.619_191_1e3, -2.050_109_2e-3, 5.029_957_6],
        [2.488_454_7e3, -1.113_309_1e-3, 3.226_215_4],
        [3.341_431_9e3, -4.865_512e-4, 1.764_867_7],
        [4.094_617_4e3, -1.274_465_8e-4, 7.257_316_4e-1],
        [4.670_280_4e3, 2.912_582e-5, 1.267_034_4e-1],
        [4.595_091_8e3, 2.874_956_5e-5, 1.503_450_2e-1],
        [3.787_174_5e3, 9.359_078e-6, 3.990_758_7e-1],
    ];
    const G: [[f32; 3]; 7] = [
        [-4.889_997_5e2, 6.043_307_5e-4, -7.558_075e-2],
        [-7.559_942_8e2, 3.167_301e-4, 4.783_061_4e-1],
        [-1.023_639_8e3, 1.202_234_7e-4, 9.366_623_2e-1],
        [-1.265_713_2e3, 4.873_409e-6, 1.270_545],
        [-1.425_293_3e3, -4.011_504_3e-5, 1.439_727_8],
        [-1.175_548_2e3, -2.163_780_5e-5, 1.304_080_2],
        [-5.007_995_7e2, -4.598_320_3e-6, 1.090_987_6],
    ];
    const B: [[f32; 4]; 7] = [
        [5.969_453e-11, -4.857_428_9e-8, -9.706_222_5e-5, -4.079_361_5e-3],
        [2.404_303_7e-11, 5.550_210_8e-8, -1.985_037_1e-4, 2.893_128_6e-2],
        [-1.409_497_3e-11, 1.898_789_7e-7, -3.566_328_2e-4, 9.107_677_8e-2],
        [-3.614_608_7e-11, 2.848_220_1e-7, -4.932_113e-4, 1.567_234_4e-1],
        [-1.970_757_4e-11, 1.753_593_5e-7, -2.505_428_2e-4, -2.227_832_7e-2],
        [-1.619_979_6e-13, -1.642_160_1e-8, 3.862_162_7e-4, -7.380_774e-1],
        [6.726_503e-13, -2.730_788_1e-8, 4.240_982_6e-4, -7.523_357e-1],
    ];
    if t >= 12000.0 {
        return Vec3::new(0.826_295_5, 0.994_508_05, 1.566_307_7);
    }
    // Below 800 K (and NaN): Cycles' arbitrary lower limit, matching OSL.
    if t < 800.0 || t.is_nan() {
        return Vec3::new(5.413_294_5, -0.203_193_9, -0.082_253_52);
    }
    let i = [965.0, 1167.0, 1449.0, 1902.0, 3315.0, 6365.0].iter().filter(|&&edge| t >= edge).count();
    let (r, g, b) = (R[i], G[i], B[i]);
    Vec3::new(r[0] / t + r[1] * t + r[2], g[0] / t + g[1] * t + g[2], ((b[0] * t + b[1]) * t + b[2]) * t + b[3])
}

/// Blender 4.5's XYZ (D65, its `cie_xyz_d65_interchange` role, "to determine XYZ for
/// rendering") to Linear Rec.709: the matrix of datafiles/colormanagement/config.ocio.
#[allow(clippy::excessive_precision)]
const XYZ_D65_TO_REC709: glam::Mat3 = glam::Mat3::from_cols_array(&[
    3.240_437_4,
    -0.969_267_5,
    0.055_643_45,
    -1.537_130_5,
    1.876_013_7,
    -0.204_025_97,
    -0.498_528_8,
    0.041_556_08,
    1.057_225_5,
]);

/// The colour Cycles gives a wavelength in nm: CIE 1931 x̄ȳz̄ sampled every 5 nm from
/// 380 nm, interpolated linearly, to Rec.709, scaled by 1/2.52 ("so all components are
/// ≤ 1") and clamped at 0; black from 780 nm on (Cycles `svm_node_wavelength`,
/// intern/cycles/kernel/svm/wavelength.h). The colour-matching values come from the
/// core's CIE table, which Cycles' 4-decimal `cie_color_match` rounds.
pub fn wavelength_rec709(lambda_nm: f32) -> Vec3 {
    use crate::spectrum::tables::{CIE_LAMBDA_MIN, CIE_X, CIE_Y, CIE_Z};
    let ii = (lambda_nm - 380.0) / 5.0;
    // Truncation toward zero, as Cycles' float_to_int: 375..380 nm extrapolates entry 0.
    let i = ii as i32;
    if !(0..80).contains(&i) || ii.is_nan() {
        return Vec3::ZERO;
    }
    let f = ii - i as f32;
    let at = |k: i32| {
        let j = (380.0 + 5.0 * k as f32 - CIE_LAMBDA_MIN) as usize;
        Vec3::new(CIE_X[j], CIE_Y[j], CIE_Z[j])
    };
    let xyz = at(i) * (1.0 - f) + at(i + 1) * f;
    (XYZ_D65_TO_REC709 * xyz / 2.52).max(Vec3::ZERO)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: Vec3, b: Vec3) -> bool {
        (a - b).abs().max_element() < 1e-5
    }

    #[test]
    fn hsv_and_hsl_round_trip_and_match_known_values() {
        assert!(close(rgb_to_hsv(Vec3::new(1.0, 0.0, 0.0)), Vec3::new(0.0, 1.0, 1.0)));
        assert!(close(rgb_to_hsv(Vec3::new(0.0, 0.5, 0.5)), Vec3::new(0.5, 1.0, 0.5)));
        assert!(close(rgb_to_hsl(Vec3::new(0.0, 0.5, 0.5)), Vec3::new(0.5, 1.0, 0.25)));
        for c in [Vec3::new(0.2, 0.7, 0.4), Vec3::new(0.9, 0.1, 0.5), Vec3::new(0.3, 0.3, 0.8)] {
            assert!(close(hsv_to_rgb(rgb_to_hsv(c)), c), "{c}");
            assert!(close(hsl_to_rgb(rgb_to_hsl(c)), c), "{c}");
        }
    }

    #[test]
    fn blend_modes_follow_their_formulas() {
        let a = Vec3::new(0.2, 0.6, 0.8);
        let b = Vec3::new(0.5, 0.25, 1.0);
        let t = 0.5;
        assert!(close(blend(Blend::Mix, t, a, b), (a + b) / 2.0));
        assert!(close(blend(Blend::Multiply, 1.0, a, b), a * b));
        assert!(close(blend(Blend::Add, 1.0, a, b), a + b));
        assert!(close(blend(Blend::Subtract, 1.0, a, b), a - b));
        assert!(close(blend(Blend::Screen, 1.0, a, b), Vec3::ONE - (Vec3::ONE - a) * (Vec3::ONE - b)));
        assert!(close(blend(Blend::Difference, 1.0, a, b), (a - b).abs()));
        assert!(close(blend(Blend::Exclusion, 1.0, a, b), a + b - 2.0 * a * b));
        assert!(close(blend(Blend::Darken, 1.0, a, b), a.min(b)));
        assert!(close(blend(Blend::Lighten, 1.0, a, b), a.max(b)));
        assert!(close(blend(Blend::Divide, 1.0, a, b), a / b));
        assert!(close(blend(Blend::LinearLight, 1.0, a, b), a + 2.0 * b - Vec3::ONE));
        // Overlay: 2ab below 0.5, 1 − 2(1−a)(1−b) above.
        let o = blend(Blend::Overlay, 1.0, a, b);
        assert!((o.x - 2.0 * 0.2 * 0.5).abs() < 1e-6 && (o.z - (1.0 - 2.0 * 0.2 * 0.0)).abs() < 1e-6);
        assert!((o.y - (1.0 - 2.0 * 0.4 * 0.75)).abs() < 1e-6);
        // Dodge a/(1−b), capped at 1; Burn 1 − (1−a)/b, floored at 0.
        let d = blend(Blend::Dodge, 1.0, a, b);
        assert!((d.x - 0.4).abs() < 1e-6 && d.z == 1.0);
        let bu = blend(Blend::Burn, 1.0, a, b);
        assert!(bu.x == 0.0 && (bu.z - 0.8).abs() < 1e-6);
        // Soft light at t=1: (1−a)·b·a + a·screen.
        let scr = Vec3::ONE - (Vec3::ONE - b) * (Vec3::ONE - a);
        assert!(close(blend(Blend::SoftLight, 1.0, a, b), (Vec3::ONE - a) * b * a + a * scr));
        // Value takes b's value, keeps a's hue and saturation.
        let v = blend(Blend::Value, 1.0, a, b);
        let (ha, hv) = (rgb_to_hsv(a), rgb_to_hsv(v));
        assert!((hv.z - 1.0).abs() < 1e-6 && (hv.x - ha.x).abs() < 1e-5 && (hv.y - ha.y).abs() < 1e-5);
        // Hue takes b's hue; Color b's hue and saturation.
        let h = rgb_to_hsv(blend(Blend::Hue, 1.0, a, b));
        assert!((h.x - rgb_to_hsv(b).x).abs() < 1e-5 && (h.z - ha.z).abs() < 1e-5);
        let c = rgb_to_hsv(blend(Blend::Color, 1.0, a, b));
        assert!((c.y - rgb_to_hsv(b).y).abs() < 1e-5 && (c.z - ha.z).abs() < 1e-5);
        let s = rgb_to_hsv(blend(Blend::Saturation, 1.0, a, b));
        assert!((s.y - rgb_to_hsv(b).y).abs() < 1e-5 && (s.x - ha.x).abs() < 1e-5);
    }

    #[test]
    fn colour_adjustments() {
        let c = Vec3::new(0.25, 0.5, 1.0);
        let mut o = [Vec3::ZERO; 3];
        ColorOp::Invert.eval(&[Vec3::splat(1.0), c], &mut o);
        assert!(close(o[0], Vec3::ONE - c));
        ColorOp::Gamma.eval(&[c, Vec3::splat(2.0)], &mut o);
        assert!(close(o[0], c * c));
        ColorOp::BrightContrast.eval(&[c, Vec3::splat(0.1), Vec3::splat(1.0)], &mut o);
        assert!(close(o[0], (2.0 * c + Vec3::splat(0.1 - 0.5)).max(Vec3::ZERO)));
        ColorOp::RgbToBw.eval(&[c], &mut o);
        assert!((o[0].x - (0.2126 * 0.25 + 0.7152 * 0.5 + 0.0722)).abs() < 1e-6);
        // Hue 0.5, saturation 1, value 1 leaves a colour unchanged; value 2 doubles it.
        ColorOp::HueSaturation.eval(&[Vec3::splat(0.5), Vec3::ONE, Vec3::ONE, Vec3::ONE, c], &mut o);
        assert!(close(o[0], c));
        ColorOp::HueSaturation.eval(&[Vec3::splat(0.5), Vec3::ONE, Vec3::splat(2.0), Vec3::ONE, c], &mut o);
        assert!(close(o[0], 2.0 * c));
        // Saturation 0 gives grey at the colour's value.
        ColorOp::HueSaturation.eval(&[Vec3::splat(0.5), Vec3::ZERO, Vec3::ONE, Vec3::ONE, c], &mut o);
        assert!(close(o[0], Vec3::ONE));
        ColorOp::Separate(ColorMode::Hsv).eval(&[Vec3::new(0.0, 0.5, 0.5)], &mut o);
        assert!((o[0].x - 0.5).abs() < 1e-6 && o[1].x == 1.0 && o[2].x == 0.5);
        ColorOp::Combine(ColorMode::Hsl).eval(&[Vec3::splat(0.5), Vec3::splat(1.0), Vec3::splat(0.25)], &mut o);
        assert!(close(o[0], Vec3::new(0.0, 0.5, 0.5)));
    }

    #[test]
    fn mix_float_vector_and_clamps() {
        let mut i = [Vec3::ZERO; 10];
        let mut o = [Vec3::ZERO; 4];
        i[0] = Vec3::splat(1.5);
        i[2] = Vec3::splat(1.0);
        i[3] = Vec3::splat(3.0);
        let mut m =
            Mix { ty: MixType::Float, blend: Blend::Mix, non_uniform: false, clamp_factor: true, clamp_result: false };
        m.eval(&i, &mut o);
        assert_eq!(o[0].x, 3.0);
        m.clamp_factor = false;
        m.eval(&i, &mut o);
        assert_eq!(o[0].x, 4.0);
        m.ty = MixType::Vector;
        m.non_uniform = true;
        m.clamp_factor = true;
        i[1] = Vec3::new(0.0, 0.5, 1.0);
        i[4] = Vec3::ZERO;
        i[5] = Vec3::splat(2.0);
        m.eval(&i, &mut o);
        assert_eq!(o[1], Vec3::new(0.0, 1.0, 2.0));
        m.ty = MixType::Color;
        m.blend = Blend::Add;
        m.clamp_result = true;
        i[0] = Vec3::splat(1.0);
        i[6] = Vec3::splat(0.7);
        i[7] = Vec3::splat(0.7);
        m.eval(&i, &mut o);
        assert_eq!(o[2], Vec3::ONE);
    }

    #[test]
    fn color_ramp_interpolations() {
        let mut r = ColorRamp {
            interpolation: RampInterpolation::Linear,
            elements: vec![(0.25, [0.0, 0.0, 0.0, 1.0]), (0.75, [1.0, 0.5, 0.0, 0.0])],
        };
        assert_eq!(r.evaluate(0.0), [0.0, 0.0, 0.0, 1.0]);
        assert_eq!(r.evaluate(1.0), [1.0, 0.5, 0.0, 0.0]);
        assert_eq!(r.evaluate(0.5), [0.5, 0.25, 0.0, 0.5]);
        r.interpolation = RampInterpolation::Ease;
        let e = r.evaluate(0.375)[0];
        assert!((e - 0.15625).abs() < 1e-6);
        r.interpolation = RampInterpolation::Constant;
        assert_eq!(r.evaluate(0.7), [0.0, 0.0, 0.0, 1.0]);
        assert_eq!(r.evaluate(0.75), [1.0, 0.5, 0.0, 0.0]);
    }

    #[test]
    fn curve_tables_interpolate_and_extrapolate() {
        let c = Curves {
            kind: CurvesKind::Float,
            min_x: 0.0,
            range: 1.0,
            tables: vec![vec![0.0, 0.5, 2.0]],
            extrapolate: true,
        };
        let mut o = [Vec3::ZERO];
        c.eval(&[Vec3::ONE, Vec3::splat(0.25)], &mut o);
        assert!((o[0].x - 0.25).abs() < 1e-6);
        c.eval(&[Vec3::ONE, Vec3::splat(0.75)], &mut o);
        assert!((o[0].x - 1.25).abs() < 1e-6);
        // Beyond 1 the last segment's slope continues: 2 + 1.5·(0.5·2) = 3.5.
        c.eval(&[Vec3::ONE, Vec3::splat(1.5)], &mut o);
        assert!((o[0].x - 3.5).abs() < 1e-6);
        // Fac 0 returns the input.
        c.eval(&[Vec3::ZERO, Vec3::splat(0.75)], &mut o);
        assert_eq!(o[0].x, 0.75);
    }

    /// Cycles' blackbody fit against Planck's law: the chromaticity of the core's
    /// blackbody spectrum (CIE 1931 at 1 nm) in Rec.709, normalised to luminance 1,
    /// within 2 % per component where the colour is inside the gamut; a wavelength's
    /// colour is its colour-matching values in Rec.709 / 2.52.
    #[test]
    fn blackbody_and_wavelength_match_their_definitions() {
        use crate::color::Observer;
        use crate::spectrum::named::{NoRgb, SpectrumKind, SpectrumRole};
        use crate::spectrum::{SpectrumDesc, WavelengthGrid};
        let grid = WavelengthGrid::uniform(401, 380.0, 780.0).unwrap();
        let obs = Observer::new(&grid);
        for t in [2500.0f32, 4000.0, 5000.0, 6500.0, 9000.0, 11000.0] {
            let s = SpectrumDesc::new(SpectrumKind::Blackbody { temperature: t })
                .evaluate(&grid, SpectrumRole::Illuminant, &NoRgb)
                .unwrap();
            let xyz = obs.xyz(&s);
            let xyz = Vec3::new(xyz[0] as f32, xyz[1] as f32, xyz[2] as f32) / xyz[1] as f32;
            let planck = XYZ_D65_TO_REC709 * xyz;
            let fit = blackbody_rec709(t);
            let lum = 0.2126 * fit.x + 0.7152 * fit.y + 0.0722 * fit.z;
            assert!((lum - 1.0).abs() < 0.03, "{t} K: luminance {lum}");
            assert!((fit - planck).abs().max_element() < 0.02 * planck.max_element(), "{t} K: {fit} vs {planck}");
        }
        // Out of range: Cycles' constants; negative components are clamped by the node.
        assert_eq!(blackbody_rec709(100.0), blackbody_rec709(799.0));
        assert_eq!(blackbody_rec709(12000.0), blackbody_rec709(1e6));
        let mut o = [Vec3::ZERO];
        ColorOp::Blackbody.eval(&[Vec3::splat(500.0)], &mut o);
        assert!(o[0].min_element() >= 0.0 && o[0].x > 5.0);
        // 555 nm: ȳ ≈ 1 (CIE 1931), so green ≈ M·(x̄, ȳ, z̄)/2.52; beyond 780 nm, black.
        let c = wavelength_rec709(555.0);
        assert!(c.y > 0.5 && c.x > 0.0 && c.z == 0.0, "{c}");
        assert_eq!(wavelength_rec709(780.0), Vec3::ZERO);
        assert_eq!(wavelength_rec709(300.0), Vec3::ZERO);
        // The matrix maps D65 white (XYZ 0.9505, 1, 1.089) to RGB (1, 1, 1).
        let w = XYZ_D65_TO_REC709 * Vec3::new(0.950_47, 1.0, 1.088_83);
        assert!((w - Vec3::ONE).abs().max_element() < 1e-3, "{w}");
    }
}
