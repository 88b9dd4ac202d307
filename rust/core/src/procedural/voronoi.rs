//! Blender's Voronoi Texture node (Cycles `kernel/svm/voronoi.h`, `svm_node_tex_voronoi`;
//! smooth F1 and distance to edge after Inigo Quilez, as cited there).
//!
//! One cell point per unit cell, jittered by `hash_floatN_to_floatN(cell) * randomness`;
//! F1/F2/smooth F1 search the 3^N (smooth: 5^N) neighbouring cells in Cycles' loop
//! order, so ties resolve the same way. Fractal detail sums octaves like fBM noise,
//! with lerps for positions and distances to edges.

use super::hash::{hash_float_to_float, hash_float_to_float3};
use super::math::{clamp, finite_or_zero, finite_or_zero3, min, mix, smoothstep01, Point};
use super::Dimensions;
use glam::{Vec2, Vec3, Vec4};
use serde::Deserialize;

/// What the Distance output measures (Blender's `feature`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "SCREAMING_SNAKE_CASE")]
pub enum VoronoiFeature {
    #[default]
    F1,
    F2,
    SmoothF1,
    DistanceToEdge,
    NSphereRadius,
}

/// Blender's `distance` option (ignored by 1D, as in Blender).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "SCREAMING_SNAKE_CASE")]
pub enum VoronoiMetric {
    #[default]
    Euclidean,
    Manhattan,
    Chebychev,
    Minkowski,
}

/// Options and unlinked inputs of a Voronoi Texture, with Blender 4.5's defaults.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct VoronoiTexture {
    #[serde(alias = "voronoi_dimensions")]
    pub dimensions: Dimensions,
    pub feature: VoronoiFeature,
    pub distance: VoronoiMetric,
    pub normalize: bool,
    pub scale: f32,
    /// Octaves beyond the first, 0–15.
    pub detail: f32,
    /// 0–1.
    pub roughness: f32,
    pub lacunarity: f32,
    /// Smooth F1 only, 0–1.
    pub smoothness: f32,
    /// Minkowski only.
    pub exponent: f32,
    /// 0–1.
    pub randomness: f32,
}

impl Default for VoronoiTexture {
    fn default() -> Self {
        Self {
            dimensions: Dimensions::D3,
            feature: VoronoiFeature::F1,
            distance: VoronoiMetric::Euclidean,
            normalize: false,
            scale: 5.0,
            detail: 0.0,
            roughness: 0.5,
            lacunarity: 2.0,
            smoothness: 1.0,
            exponent: 0.5,
            randomness: 1.0,
        }
    }
}

/// The node's outputs. Features that do not produce an output leave it 0, as Cycles does
/// (distance to edge: only Distance; n-sphere radius: only Radius).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct VoronoiOutput {
    pub distance: f32,
    pub color: Vec3,
    pub position: Vec3,
    pub w: f32,
    pub radius: f32,
}

/// Cycles `VoronoiParams` after the node's clamping.
#[derive(Clone, Copy)]
struct Params {
    feature: VoronoiFeature,
    metric: VoronoiMetric,
    scale: f32,
    detail: f32,
    roughness: f32,
    lacunarity: f32,
    smoothness: f32,
    exponent: f32,
    randomness: f32,
    max_distance: f32,
    normalize: bool,
}

/// One octave: Cycles `VoronoiOutput` (position as a float4, w in the last lane).
#[derive(Clone, Copy, Default)]
struct Octave {
    distance: f32,
    color: Vec3,
    position: Vec4,
}

/// A Voronoi domain: 1D (f32) has its own scalar code in Cycles; 2D–4D share the
/// generic one below.
trait Domain: Copy {
    fn scaled(self, s: f32) -> Self;
    fn f1(self, p: &Params) -> Octave;
    fn smooth_f1(self, p: &Params) -> Octave;
    fn f2(self, p: &Params) -> Octave;
    fn distance_to_edge(self, p: &Params) -> f32;
    fn n_sphere_radius(self, p: &Params) -> f32;
}

// ---- 1D (Cycles' `float` overloads) ----

impl Domain for f32 {
    fn scaled(self, s: f32) -> Self {
        self * s
    }

    fn f1(self, p: &Params) -> Octave {
        let cell = self.floor();
        let local = self - cell;
        let (mut min_d, mut target_offset, mut target_pos) = (f32::MAX, 0.0f32, 0.0f32);
        for i in -1..=1 {
            let off = i as f32;
            let point = off + hash_float_to_float(cell + off) * p.randomness;
            let d = (local - point).abs();
            if d < min_d {
                target_offset = off;
                min_d = d;
                target_pos = point;
            }
        }
        Octave {
            distance: min_d,
            color: Vec3::from(hash_float_to_float3(cell + target_offset)),
            position: Vec4::new(0.0, 0.0, 0.0, target_pos + cell),
        }
    }

    fn smooth_f1(self, p: &Params) -> Octave {
        let cell = self.floor();
        let local = self - cell;
        let (mut sd, mut spos, mut scol, mut h) = (0.0f32, 0.0f32, Vec3::ZERO, -1.0f32);
        for i in -2..=2 {
            let off = i as f32;
            let point = off + hash_float_to_float(cell + off) * p.randomness;
            let d = (local - point).abs();
            h = if h == -1.0 { 1.0 } else { smoothstep01(0.5 + 0.5 * (sd - d) / p.smoothness) };
            let mut correction = p.smoothness * h * (1.0 - h);
            sd = mix(sd, d, h) - correction;
            correction /= 1.0 + 3.0 * p.smoothness;
            let c = Vec3::from(hash_float_to_float3(cell + off));
            scol = scol.mix(c, h) - Vec3::splat(correction);
            spos = mix(spos, point, h) - correction;
        }
        Octave { distance: sd, color: scol, position: Vec4::new(0.0, 0.0, 0.0, cell + spos) }
    }

    fn f2(self, p: &Params) -> Octave {
        let cell = self.floor();
        let local = self - cell;
        let (mut d1, mut d2) = (f32::MAX, f32::MAX);
        let (mut o1, mut p1, mut o2, mut p2) = (0.0f32, 0.0f32, 0.0f32, 0.0f32);
        for i in -1..=1 {
            let off = i as f32;
            let point = off + hash_float_to_float(cell + off) * p.randomness;
            let d = (local - point).abs();
            if d < d1 {
                (d2, d1, o2, o1, p2, p1) = (d1, d, o1, off, p1, point);
            } else if d < d2 {
                (d2, o2, p2) = (d, off, point);
            }
        }
        Octave {
            distance: d2,
            color: Vec3::from(hash_float_to_float3(cell + o2)),
            position: Vec4::new(0.0, 0.0, 0.0, p2 + cell),
        }
    }

    fn distance_to_edge(self, p: &Params) -> f32 {
        let cell = self.floor();
        let local = self - cell;
        let mid = hash_float_to_float(cell) * p.randomness;
        let left = -1.0 + hash_float_to_float(cell - 1.0) * p.randomness;
        let right = 1.0 + hash_float_to_float(cell + 1.0) * p.randomness;
        let to_mid_left = ((mid + left) / 2.0 - local).abs();
        let to_mid_right = ((mid + right) / 2.0 - local).abs();
        min(to_mid_left, to_mid_right)
    }

    fn n_sphere_radius(self, p: &Params) -> f32 {
        let cell = self.floor();
        let local = self - cell;
        let (mut closest, mut closest_off, mut min_d) = (0.0f32, 0.0f32, f32::MAX);
        for i in -1..=1 {
            let off = i as f32;
            let point = off + hash_float_to_float(cell + off) * p.randomness;
            let d = (point - local).abs();
            if d < min_d {
                min_d = d;
                closest = point;
                closest_off = off;
            }
        }
        let (mut min_d, mut closest_to_closest) = (f32::MAX, 0.0f32);
        for i in [-1, 1] {
            let off = i as f32 + closest_off;
            let point = off + hash_float_to_float(cell + off) * p.randomness;
            let d = (closest - point).abs();
            if d < min_d {
                min_d = d;
                closest_to_closest = point;
            }
        }
        (closest_to_closest - closest).abs() / 2.0
    }
}

// ---- 2D–4D ----

/// Cycles `voronoi_distance`.
fn distance<P: Point>(a: P, b: P, p: &Params) -> f32 {
    let d = (a - b).abs();
    match p.metric {
        VoronoiMetric::Euclidean => (a - b).cycles_len(),
        VoronoiMetric::Manhattan => d.reduce_add(),
        VoronoiMetric::Chebychev => d.reduce_max(),
        VoronoiMetric::Minkowski => d.powf(p.exponent).reduce_add().powf(1.0 / p.exponent),
    }
}

/// Cycles `voronoi_distance_bound`: orders points like [`distance`], more cheaply.
fn distance_bound<P: Point>(a: P, b: P, p: &Params) -> f32 {
    match p.metric {
        VoronoiMetric::Euclidean => {
            let d = a - b;
            d.cycles_dot(d)
        }
        VoronoiMetric::Manhattan => (a - b).abs().reduce_add(),
        VoronoiMetric::Chebychev => (a - b).abs().reduce_max(),
        VoronoiMetric::Minkowski => (a - b).abs().powf(p.exponent).reduce_add(),
    }
}

/// Cell point of the cell at `cell + off`, relative to `cell`.
#[inline]
fn cell_point<P: Point>(cell: P, off: P, p: &Params) -> P {
    off + (cell + off).hash_to_point() * p.randomness
}

impl<P: Point> Domain for P {
    fn scaled(self, s: f32) -> Self {
        self * s
    }

    fn f1(self, p: &Params) -> Octave {
        let cell = self.floor();
        let local = self - cell;
        let (mut min_d, mut target_off, mut target_pos) = (f32::MAX, P::splat(0.0), P::splat(0.0));
        P::for_each_offset(1, |off| {
            let point = cell_point(cell, off, p);
            let d = distance_bound(point, local, p);
            if d < min_d {
                target_off = off;
                min_d = d;
                target_pos = point;
            }
        });
        Octave {
            distance: distance(target_pos, local, p),
            color: (cell + target_off).hash_to_color(),
            position: (target_pos + cell).to_vec4(),
        }
    }

    fn smooth_f1(self, p: &Params) -> Octave {
        let cell = self.floor();
        let local = self - cell;
        let (mut sd, mut scol, mut spos, mut h) = (0.0f32, Vec3::ZERO, P::splat(0.0), -1.0f32);
        P::for_each_offset(2, |off| {
            let point = cell_point(cell, off, p);
            let d = distance(point, local, p);
            h = if h == -1.0 { 1.0 } else { smoothstep01(0.5 + 0.5 * (sd - d) / p.smoothness) };
            let mut correction = p.smoothness * h * (1.0 - h);
            sd = mix(sd, d, h) - correction;
            correction /= 1.0 + 3.0 * p.smoothness;
            let c = (cell + off).hash_to_color();
            scol = scol.mix(c, h) - Vec3::splat(correction);
            spos = spos.mix(point, h) - P::splat(correction);
        });
        Octave { distance: sd, color: scol, position: (cell + spos).to_vec4() }
    }

    fn f2(self, p: &Params) -> Octave {
        let cell = self.floor();
        let local = self - cell;
        let zero = P::splat(0.0);
        let (mut d1, mut d2) = (f32::MAX, f32::MAX);
        let (mut o1, mut p1, mut o2, mut p2) = (zero, zero, zero, zero);
        P::for_each_offset(1, |off| {
            let point = cell_point(cell, off, p);
            let d = distance(point, local, p);
            if d < d1 {
                (d2, d1, o2, o1, p2, p1) = (d1, d, o1, off, p1, point);
            } else if d < d2 {
                (d2, o2, p2) = (d, off, point);
            }
        });
        Octave { distance: d2, color: (cell + o2).hash_to_color(), position: (p2 + cell).to_vec4() }
    }

    fn distance_to_edge(self, p: &Params) -> f32 {
        let cell = self.floor();
        let local = self - cell;
        let (mut to_closest, mut min_d) = (P::splat(0.0), f32::MAX);
        P::for_each_offset(1, |off| {
            let to_point = cell_point(cell, off, p) - local;
            let d = to_point.cycles_dot(to_point);
            if d < min_d {
                min_d = d;
                to_closest = to_point;
            }
        });
        let mut min_d = f32::MAX;
        P::for_each_offset(1, |off| {
            let to_point = cell_point(cell, off, p) - local;
            let perpendicular = to_point - to_closest;
            if perpendicular.cycles_dot(perpendicular) > 0.0001 {
                let to_edge = (to_closest + to_point).cycles_div(2.0).cycles_dot(perpendicular.cycles_normalize());
                min_d = min(min_d, to_edge);
            }
        });
        min_d
    }

    fn n_sphere_radius(self, p: &Params) -> f32 {
        let cell = self.floor();
        let local = self - cell;
        let zero = P::splat(0.0);
        let (mut closest, mut closest_off, mut min_d) = (zero, zero, f32::MAX);
        P::for_each_offset(1, |off| {
            let point = cell_point(cell, off, p);
            let d = (point - local).cycles_dot(point - local);
            if d < min_d {
                min_d = d;
                closest = point;
                closest_off = off;
            }
        });
        let (mut min_d, mut closest_to_closest) = (f32::MAX, zero);
        P::for_each_offset(1, |o| {
            if o.cycles_dot(o) == 0.0 {
                return; // the closest point's own cell
            }
            let off = o + closest_off;
            let point = cell_point(cell, off, p);
            let d = (closest - point).cycles_dot(closest - point);
            if d < min_d {
                min_d = d;
                closest_to_closest = point;
            }
        });
        (closest_to_closest - closest).cycles_len() / 2.0
    }
}

// ---- fractal sums ----

/// Cycles `fractal_voronoi_x_fx`: F1, F2 and smooth F1 summed over octaves.
fn fractal_x_fx<D: Domain>(p: &Params, coord: D) -> Octave {
    let (mut amplitude, mut max_amplitude, mut scale) = (1.0f32, 0.0f32, 1.0f32);
    let mut out = Octave::default();
    let zero_input = p.detail == 0.0 || p.roughness == 0.0;
    let mut i = 0;
    while i as f32 <= p.detail.ceil() {
        let c = coord.scaled(scale);
        let octave = match p.feature {
            VoronoiFeature::F2 => c.f2(p),
            VoronoiFeature::SmoothF1 if p.smoothness != 0.0 => c.smooth_f1(p),
            _ => c.f1(p),
        };
        if zero_input {
            max_amplitude = 1.0;
            out = octave;
            break;
        }
        if i as f32 <= p.detail {
            max_amplitude += amplitude;
            out.distance += octave.distance * amplitude;
            out.color += octave.color * amplitude;
            out.position = out.position.mix(octave.position.cycles_div(scale), amplitude);
            scale *= p.lacunarity;
            amplitude *= p.roughness;
        } else {
            let remainder = p.detail - p.detail.floor();
            if remainder != 0.0 {
                max_amplitude = mix(max_amplitude, max_amplitude + amplitude, remainder);
                out.distance = mix(out.distance, out.distance + octave.distance * amplitude, remainder);
                out.color = out.color.mix(out.color + octave.color * amplitude, remainder);
                let lerped = out.position.mix(octave.position.cycles_div(scale), amplitude);
                out.position = out.position.mix(lerped, remainder);
            }
        }
        i += 1;
    }
    if p.normalize {
        out.distance /= max_amplitude * p.max_distance;
        // Cycles' `float3 /= float` multiplies by the reciprocal (unlike `float3 / float`).
        out.color *= 1.0 / max_amplitude;
    }
    // Cycles `safe_divide(float4, float)`.
    out.position = if p.scale != 0.0 { out.position.cycles_div(p.scale) } else { Vec4::ZERO };
    out
}

/// Cycles `fractal_voronoi_distance_to_edge`.
fn fractal_distance_to_edge<D: Domain>(p: &Params, coord: D) -> f32 {
    let (mut amplitude, mut max_amplitude, mut scale) = (1.0f32, p.max_distance, 1.0f32);
    let mut distance = 8.0f32;
    let zero_input = p.detail == 0.0 || p.roughness == 0.0;
    let mut i = 0;
    while i as f32 <= p.detail.ceil() {
        let octave_distance = coord.scaled(scale).distance_to_edge(p);
        if zero_input {
            distance = octave_distance;
            break;
        }
        if i as f32 <= p.detail {
            max_amplitude = mix(max_amplitude, p.max_distance / scale, amplitude);
            distance = mix(distance, min(distance, octave_distance / scale), amplitude);
            scale *= p.lacunarity;
            amplitude *= p.roughness;
        } else {
            let remainder = p.detail - p.detail.floor();
            if remainder != 0.0 {
                let lerp_amplitude = mix(max_amplitude, p.max_distance / scale, amplitude);
                max_amplitude = mix(max_amplitude, lerp_amplitude, remainder);
                let lerp_distance = mix(distance, min(distance, octave_distance / scale), amplitude);
                distance = mix(distance, min(distance, lerp_distance), remainder);
            }
        }
        i += 1;
    }
    if p.normalize {
        distance /= max_amplitude;
    }
    distance
}

/// Cycles' `max_distance` for F1/F2/smooth F1: the distance from a cell corner to the
/// farthest possible jittered point (doubled for F2), used by Normalize.
fn max_distance<P: Point>(p: &Params) -> f32 {
    let r = 0.5 + 0.5 * p.randomness;
    let f2 = if p.feature == VoronoiFeature::F2 { 2.0 } else { 1.0 };
    distance(P::splat(0.0), P::splat(r), p) * f2
}

impl VoronoiTexture {
    /// All outputs at `vector` (Blender's Vector input) and `w` (the W input, used by 1D
    /// and 4D). Non-finite results become 0.
    pub fn evaluate(&self, vector: Vec3, w: f32) -> VoronoiOutput {
        let mut p = Params {
            feature: self.feature,
            metric: self.distance,
            scale: self.scale,
            detail: clamp(self.detail, 0.0, 15.0),
            roughness: clamp(self.roughness, 0.0, 1.0),
            lacunarity: self.lacunarity,
            smoothness: clamp(self.smoothness / 2.0, 0.0, 0.5),
            exponent: self.exponent,
            randomness: clamp(self.randomness, 0.0, 1.0),
            max_distance: 0.0,
            normalize: self.normalize,
        };
        let v = vector * p.scale;
        let w = w * p.scale;
        let mut out = VoronoiOutput::default();
        match p.feature {
            VoronoiFeature::DistanceToEdge => {
                p.max_distance = 0.5 + 0.5 * p.randomness;
                out.distance = match self.dimensions {
                    Dimensions::D1 => fractal_distance_to_edge(&p, w),
                    Dimensions::D2 => fractal_distance_to_edge(&p, Vec2::new(v.x, v.y)),
                    Dimensions::D3 => fractal_distance_to_edge(&p, v),
                    Dimensions::D4 => fractal_distance_to_edge(&p, v.extend(w)),
                };
            }
            VoronoiFeature::NSphereRadius => {
                out.radius = match self.dimensions {
                    Dimensions::D1 => w.n_sphere_radius(&p),
                    Dimensions::D2 => Vec2::new(v.x, v.y).n_sphere_radius(&p),
                    Dimensions::D3 => v.n_sphere_radius(&p),
                    Dimensions::D4 => v.extend(w).n_sphere_radius(&p),
                };
            }
            _ => {
                let octave = match self.dimensions {
                    Dimensions::D1 => {
                        let f2 = if p.feature == VoronoiFeature::F2 { 2.0 } else { 1.0 };
                        p.max_distance = (0.5 + 0.5 * p.randomness) * f2;
                        fractal_x_fx(&p, w)
                    }
                    Dimensions::D2 => {
                        p.max_distance = max_distance::<Vec2>(&p);
                        fractal_x_fx(&p, Vec2::new(v.x, v.y))
                    }
                    Dimensions::D3 => {
                        p.max_distance = max_distance::<Vec3>(&p);
                        fractal_x_fx(&p, v)
                    }
                    Dimensions::D4 => {
                        p.max_distance = max_distance::<Vec4>(&p);
                        fractal_x_fx(&p, v.extend(w))
                    }
                };
                out.distance = octave.distance;
                out.color = octave.color;
                out.position = octave.position.truncate();
                out.w = octave.position.w;
            }
        }
        VoronoiOutput {
            distance: finite_or_zero(out.distance),
            color: finite_or_zero3(out.color),
            position: finite_or_zero3(out.position),
            w: finite_or_zero(out.w),
            radius: finite_or_zero(out.radius),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn randomness_zero_puts_points_on_the_lattice() {
        // With no jitter every cell point sits at its cell's corner, so F1 is the
        // distance to the nearest integer point: closed form.
        let t = VoronoiTexture { scale: 1.0, randomness: 0.0, ..Default::default() };
        let p = Vec3::new(0.3, 1.8, -2.4);
        let o = t.evaluate(p, 0.0);
        let nearest = p.round();
        assert!((o.distance - (p - nearest).length()).abs() < 1e-6);
        assert!((o.position - nearest).abs().max_element() < 1e-6);
        let t1 = VoronoiTexture { dimensions: Dimensions::D1, ..t };
        assert!((t1.evaluate(Vec3::ZERO, 2.3).distance - 0.3).abs() < 1e-6);
    }

    #[test]
    fn f2_is_not_below_f1_and_edge_distance_is_not_negative() {
        for i in 0..50 {
            let p = Vec3::new(i as f32 * 0.37 - 9.0, i as f32 * 0.11, 2.0 - i as f32 * 0.05);
            for dimensions in [Dimensions::D1, Dimensions::D2, Dimensions::D3, Dimensions::D4] {
                let t = VoronoiTexture { dimensions, ..Default::default() };
                let f1 = t.evaluate(p, 0.3 * i as f32).distance;
                let f2 = VoronoiTexture { feature: VoronoiFeature::F2, ..t }.evaluate(p, 0.3 * i as f32).distance;
                assert!(f2 >= f1, "{dimensions:?} {p}");
                let e = VoronoiTexture { feature: VoronoiFeature::DistanceToEdge, ..t }.evaluate(p, 0.3 * i as f32);
                assert!(e.distance >= -1e-6);
            }
        }
    }

    #[test]
    fn non_finite_inputs_give_zero() {
        for feature in [
            VoronoiFeature::F1,
            VoronoiFeature::F2,
            VoronoiFeature::SmoothF1,
            VoronoiFeature::DistanceToEdge,
            VoronoiFeature::NSphereRadius,
        ] {
            for bad in [f32::NAN, f32::INFINITY, 1e38] {
                let t = VoronoiTexture {
                    feature,
                    dimensions: Dimensions::D4,
                    detail: bad,
                    lacunarity: bad,
                    exponent: bad,
                    distance: VoronoiMetric::Minkowski,
                    normalize: true,
                    ..Default::default()
                };
                let o = t.evaluate(Vec3::splat(bad), bad);
                assert!([o.distance, o.w, o.radius].iter().all(|v| v.is_finite()));
                assert!(o.color.is_finite() && o.position.is_finite());
            }
        }
    }
}
