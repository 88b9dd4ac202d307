//! Heterogeneous media: a homogeneous medium's spectral σa(λ), σs(λ) scaled by a density
//! that varies in space, given as a dense 3-D grid of voxels (docs/media.md, "Grid
//! media"). The grid fills a box in the object space of the mesh that bounds the
//! medium (its instance's transform places it in the world); outside the box the
//! density is 0.
//!
//! * Density: trilinear between voxel centres, clamped to the outermost voxels up to
//!   the box's faces (pbrt-v4's `SampledGrid::Lookup` with the same cell-centred
//!   convention).
//! * Majorant: a coarse grid of the largest density that trilinear interpolation can
//!   reach inside each super-cell of [`SUPER_CELL`]³ voxels, walked by a 3-D DDA along
//!   the ray (pbrt-v4's `MajorantGrid` and `DDAMajorantIterator`). Per segment the
//!   majorant is grey: max over the carried wavelengths of σt(λ) times that density.
//! * Free flights: delta tracking against the majorant (Woodcock; pbrt-v4 `SampleT_maj`),
//!   written for any number of lanes as the homogeneous flight in
//!   `integrator/volume.rs` is: each tentative collision is real or null with the
//!   throughput-weighted average of the lanes' probabilities (one-sample MIS with the
//!   balance heuristic over lanes, Kutz et al. 2017 "Spectral and Decomposition
//!   Tracking"), and every lane is weighted by its own probability over that average,
//!   so a polychromatic path keeps its whole spectrum. One lane is analogue delta
//!   tracking; a grey medium gives weights of exactly 1 (null) and σs/σt (real).
//! * Transmittance (shadow rays, and flights through a medium that does not scatter):
//!   ratio tracking (Novák et al. 2014), the product of σn(λ)/σ_maj over tentative
//!   collisions, per wavelength, unbiased.

use super::phase::HenyeyGreenstein;
use crate::integrator::throughput::Throughput;
use crate::integrator::volume::Flight;
use crate::sampling::Rng;
use crate::spectrum::SampledSpectrum;
use glam::Vec3A;

/// Voxels per side of a super-cell of the majorant grid.
pub const SUPER_CELL: usize = 8;
/// Tentative collisions after which a flight gives up (absorbed) and ratio tracking
/// keeps its estimate so far: a guard against majorants so far above the density that
/// steps stop advancing t in f32 (no scene of sane densities gets near it).
const MAX_STEPS: usize = 1 << 20;

/// A medium whose coefficients are σa(λ)·ρ(x), σs(λ)·ρ(x) for the grid's density ρ.
#[derive(Clone, Debug)]
pub struct GridMedium {
    /// The material it belongs to (messages).
    pub name: String,
    pub sigma_a: SampledSpectrum,
    pub sigma_s: SampledSpectrum,
    /// σa + σs (at density 1).
    pub sigma_t: SampledSpectrum,
    pub phase: HenyeyGreenstein,
    dims: [usize; 3],
    /// x fastest, then y, then z.
    density: Vec<f32>,
    lo: Vec3A,
    hi: Vec3A,
    /// Voxels per unit of object-space length along each axis.
    scale: Vec3A,
    super_dims: [usize; 3],
    majorant: Vec<f32>,
    max_density: f32,
}

/// Constant media that share the path's flight with the grid (the homogeneous media on
/// the same stack): σt(λ), σs(λ) per grid lane.
#[derive(Clone, Copy, Debug)]
pub struct Base<'a> {
    pub sigma_t: &'a SampledSpectrum,
    pub sigma_s: &'a SampledSpectrum,
}

impl GridMedium {
    /// A grid medium from `dims` voxels (x fastest) filling the object-space box
    /// `lo`..`hi`. Errors (a message without the material's name, which the scene
    /// builder adds): a dimension of 0, a voxel count other than their product, a
    /// voxel that is not finite or negative, a box that is not finite or empty.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        name: &str,
        dims: [usize; 3],
        density: Vec<f32>,
        lo: Vec3A,
        hi: Vec3A,
        sigma_a: SampledSpectrum,
        sigma_s: SampledSpectrum,
        g: f32,
    ) -> Result<Self, String> {
        if dims.contains(&0) {
            return Err(format!("volume grid dims {dims:?} must all be > 0"));
        }
        let count = dims.iter().try_fold(1usize, |a, &n| a.checked_mul(n));
        if count != Some(density.len()) {
            return Err(format!(
                "volume grid has {} values for dims {dims:?} ({} expected)",
                density.len(),
                count.map_or("too many".to_string(), |c| c.to_string())
            ));
        }
        if let Some((k, v)) = density.iter().enumerate().find(|(_, v)| !(v.is_finite() && **v >= 0.0)) {
            return Err(format!("volume grid value {v} at index {k} must be finite and non-negative"));
        }
        if !(lo.is_finite() && hi.is_finite() && lo.cmplt(hi).all()) {
            return Err(format!("volume grid bounds {lo} .. {hi} must be finite with min < max on every axis"));
        }
        let size = hi - lo;
        let scale = Vec3A::new(dims[0] as f32, dims[1] as f32, dims[2] as f32) / size;
        let super_dims = dims.map(|n| n.div_ceil(SUPER_CELL));
        let mut majorant = vec![0.0f32; super_dims.iter().product()];
        for sz in 0..super_dims[2] {
            for sy in 0..super_dims[1] {
                for sx in 0..super_dims[0] {
                    // Trilinear lookups inside super-cell s read voxels from one before its
                    // first to one past its last (clamped to the grid).
                    let range =
                        |s: usize, n: usize| (s * SUPER_CELL).saturating_sub(1)..((s + 1) * SUPER_CELL + 1).min(n);
                    let mut m = 0.0f32;
                    for z in range(sz, dims[2]) {
                        for y in range(sy, dims[1]) {
                            for x in range(sx, dims[0]) {
                                m = m.max(density[(z * dims[1] + y) * dims[0] + x]);
                            }
                        }
                    }
                    majorant[(sz * super_dims[1] + sy) * super_dims[0] + sx] = m;
                }
            }
        }
        let max_density = majorant.iter().copied().fold(0.0, f32::max);
        let mut sigma_t = sigma_a.clone();
        sigma_t.add_assign(&sigma_s);
        Ok(Self {
            name: name.to_string(),
            sigma_a,
            sigma_s,
            sigma_t,
            phase: HenyeyGreenstein::new(g),
            dims,
            density,
            lo,
            hi,
            scale,
            super_dims,
            majorant,
            max_density,
        })
    }

    /// Scatters at some wavelength where the density is not 0.
    pub fn scatters(&self) -> bool {
        !self.sigma_s.is_black() && self.max_density > 0.0
    }

    /// The largest density anywhere.
    pub fn max_density(&self) -> f32 {
        self.max_density
    }

    /// The density at object-space point `p` (0 outside the box).
    pub fn density(&self, p: Vec3A) -> f32 {
        if !(p.cmpge(self.lo).all() && p.cmple(self.hi).all()) {
            return 0.0;
        }
        let v = (p - self.lo) * self.scale - Vec3A::splat(0.5);
        let [nx, ny, nz] = self.dims;
        let axis = |x: f32, n: usize| {
            let f = x.floor();
            let i0 = f as i64;
            let c = |i: i64| i.clamp(0, n as i64 - 1) as usize;
            (c(i0), c(i0 + 1), x - f)
        };
        let (x0, x1, fx) = axis(v.x, nx);
        let (y0, y1, fy) = axis(v.y, ny);
        let (z0, z1, fz) = axis(v.z, nz);
        let d = |x: usize, y: usize, z: usize| self.density[(z * ny + y) * nx + x];
        let lerp = |a: f32, b: f32, t: f32| a + (b - a) * t;
        let c00 = lerp(d(x0, y0, z0), d(x1, y0, z0), fx);
        let c10 = lerp(d(x0, y1, z0), d(x1, y1, z0), fx);
        let c01 = lerp(d(x0, y0, z1), d(x1, y0, z1), fx);
        let c11 = lerp(d(x0, y1, z1), d(x1, y1, z1), fx);
        lerp(lerp(c00, c10, fy), lerp(c01, c11, fy), fz).max(0.0)
    }

    /// The pieces of `o + t·dir` (object space, `dir` not necessarily unit: t is the
    /// caller's parameter) for 0 ≤ t < `tmax`, each with the largest density on it:
    /// 0 before and after the box, the super-cells' majorants inside.
    pub fn segments(&self, o: Vec3A, dir: Vec3A, tmax: f32) -> Segments<'_> {
        // Voxel space: the box is [0, dims].
        let vo = (o - self.lo) * self.scale;
        let vd = dir * self.scale;
        let n = Vec3A::new(self.dims[0] as f32, self.dims[1] as f32, self.dims[2] as f32);
        let (mut ta, mut tb) = (0.0f32, tmax);
        for a in 0..3 {
            if vd[a] == 0.0 {
                if !(vo[a] >= 0.0 && vo[a] <= n[a]) {
                    tb = -1.0;
                }
                continue;
            }
            let (t0, t1) = ((0.0 - vo[a]) / vd[a], (n[a] - vo[a]) / vd[a]);
            ta = ta.max(t0.min(t1));
            tb = tb.min(t0.max(t1));
        }
        let inside = ta < tb;
        let mut cell = [0usize; 3];
        if inside {
            let p = vo + vd * ta;
            for a in 0..3 {
                cell[a] = ((p[a] / SUPER_CELL as f32).floor().max(0.0) as usize).min(self.super_dims[a] - 1);
            }
        }
        Segments { grid: self, vo, vd, tmax, ta, tb, t: 0.0, cell, phase: if inside { 0 } else { 2 } }
    }

    /// Ratio tracking: an unbiased estimate of the transmittance per grid lane along
    /// `o + t·dir` (object space) for 0 ≤ t < `d`, multiplied into `tr`, with the
    /// constant media `base` on the same segment (their σt only). See [`transmittance`].
    pub fn transmittance(
        &self,
        o: Vec3A,
        dir: Vec3A,
        d: f32,
        base: Option<&SampledSpectrum>,
        tr: &mut SampledSpectrum,
        rng: &mut Rng,
    ) {
        transmittance(&[Placed { grid: self, o, dir }], d, base, tr, rng)
    }

    /// A free flight by delta tracking through this grid alone (and `base`); see [`fly`].
    #[allow(clippy::too_many_arguments)]
    pub fn fly<T: Throughput>(
        &self,
        o: Vec3A,
        dir: Vec3A,
        d: f32,
        base: Option<Base>,
        beta: &mut T,
        rng: &mut Rng,
        scratch: &mut SampledSpectrum,
    ) -> Flight {
        fly(&[Placed { grid: self, o, dir }], d, base, beta, rng, scratch)
    }
}

/// A grid on a ray: `o + t·dir` is the ray's point at t in the grid's object space.
#[derive(Clone, Copy, Debug)]
pub struct Placed<'a> {
    pub grid: &'a GridMedium,
    pub o: Vec3A,
    pub dir: Vec3A,
}

impl Placed<'_> {
    fn density(&self, t: f32) -> f32 {
        self.grid.density(self.o + self.dir * t)
    }
}

/// Media on a stack at once: at most the stack's size.
const MAX_GRIDS: usize = super::homogeneous::STACK_SIZE;

/// The majorant of `grids` (not empty) with `base` over the lanes `carried`: the first
/// grid's segments give its part per segment, the others add their largest density
/// (overlapping grids are rare; their bound stays correct, only looser).
fn others_majorant(grids: &[Placed], sigma_max: impl Fn(&GridMedium) -> f32) -> f32 {
    grids[1..].iter().map(|g| g.grid.max_density * sigma_max(g.grid)).sum()
}

/// Ratio tracking (Novák et al. 2014) through `grids` (not empty) and the constant σt
/// `base`, for 0 ≤ t < `d`: multiplies `tr` per grid lane by the product of
/// σn(λ)/σ_maj over tentative collisions, an unbiased estimate of exp(−∫σt(λ)). Lanes
/// whose `tr` is 0 are left out of the majorant.
pub fn transmittance(
    grids: &[Placed],
    d: f32,
    base: Option<&SampledSpectrum>,
    tr: &mut SampledSpectrum,
    rng: &mut Rng,
) {
    if grids.is_empty() || grids.len() > MAX_GRIDS {
        return;
    }
    if d.is_infinite() {
        // A constant medium that never ends transmits nothing.
        for i in 0..tr.len() {
            if base.is_some_and(|b| b.get(i) > 0.0) {
                tr.set(i, 0.0);
            }
        }
    }
    let carried = |s: &SampledSpectrum, tr: &SampledSpectrum| {
        (0..tr.len()).filter(|&i| tr.get(i) != 0.0).map(|i| s.get(i)).fold(0.0, f32::max)
    };
    let first_max = carried(&grids[0].grid.sigma_t, tr);
    let others = others_majorant(grids, |g| carried(&g.sigma_t, tr));
    let base_max = base.map_or(0.0, |b| carried(b, tr));
    let mut rho = [0.0f32; MAX_GRIDS];
    let mut steps = 0;
    for (t0, t1, dmax) in grids[0].grid.segments(grids[0].o, grids[0].dir, d) {
        let mu = base_max + others + dmax * first_max;
        if !(mu > 0.0) {
            continue;
        }
        let mut t = t0;
        loop {
            t += -(1.0 - rng.uniform()).ln() / mu;
            if !(t < t1) {
                break;
            }
            steps += 1;
            if steps > MAX_STEPS {
                return;
            }
            for (r, g) in rho.iter_mut().zip(grids) {
                *r = g.density(t);
            }
            let mut alive = false;
            for i in 0..tr.len() {
                let v = tr.get(i);
                if v == 0.0 {
                    continue;
                }
                let st = base.map_or(0.0, |b| b.get(i))
                    + grids.iter().zip(&rho).map(|(g, r)| r * g.grid.sigma_t.get(i)).sum::<f32>();
                let v = v * ((mu - st) / mu).max(0.0);
                alive |= v != 0.0;
                tr.set(i, v);
            }
            if !alive {
                return;
            }
        }
    }
}

/// A free flight by delta tracking over 0 ≤ t < `d` through `grids` (not empty) and the
/// constant media `base` on the same segment, multiplying `beta` by its weight (see the
/// module's notes): Scattered at the first real collision (weight σs over the lanes'
/// average real-collision probability), Through past `d`. Media that scatter at no
/// wavelength get the ratio-tracking transmittance per lane instead, as a homogeneous
/// absorbing medium gets Beer–Lambert: the path stays polychromatic. `scratch`: a
/// grid-wide spectrum.
pub fn fly<T: Throughput>(
    grids: &[Placed],
    d: f32,
    base: Option<Base>,
    beta: &mut T,
    rng: &mut Rng,
    scratch: &mut SampledSpectrum,
) -> Flight {
    if grids.is_empty() || grids.len() > MAX_GRIDS {
        return Flight::Absorbed;
    }
    let n = beta.lanes();
    let base_scatters = base.is_some_and(|b| !b.sigma_s.is_black());
    if !(grids.iter().any(|g| g.grid.scatters()) || base_scatters) {
        scratch.fill(0.0);
        for j in 0..n {
            if beta.lane(j) != 0.0 {
                scratch.set(beta.lane_index(j), 1.0);
            }
        }
        transmittance(grids, d, base.map(|b| b.sigma_t), scratch, rng);
        let mut alive = false;
        for j in 0..n {
            let v = beta.lane(j) * scratch.get(beta.lane_index(j));
            alive |= v != 0.0;
            beta.set_lane(j, v);
        }
        return if alive { Flight::Through } else { Flight::Absorbed };
    }
    let mut total: f32 = (0..n).map(|j| beta.lane(j).abs()).sum();
    if !(total > 0.0 && total.is_finite()) {
        return Flight::Absorbed;
    }
    let carried = |s: &SampledSpectrum, b: &T| {
        (0..n).filter(|&j| b.lane(j) != 0.0).map(|j| s.get(b.lane_index(j))).fold(0.0, f32::max)
    };
    let majorants = |b: &T| {
        (
            carried(&grids[0].grid.sigma_t, b),
            others_majorant(grids, |g| carried(&g.sigma_t, b)) + base.map_or(0.0, |bs| carried(bs.sigma_t, b)),
        )
    };
    let (mut first_max, mut rest_max) = majorants(beta);
    let sigma_t = |i: usize, rho: &[f32]| {
        base.map_or(0.0, |b| b.sigma_t.get(i))
            + grids.iter().zip(rho).map(|(g, r)| r * g.grid.sigma_t.get(i)).sum::<f32>()
    };
    let sigma_s = |i: usize, rho: &[f32]| {
        base.map_or(0.0, |b| b.sigma_s.get(i))
            + grids.iter().zip(rho).map(|(g, r)| r * g.grid.sigma_s.get(i)).sum::<f32>()
    };
    let mut rho = [0.0f32; MAX_GRIDS];
    let mut steps = 0;
    for (t0, t1, dmax) in grids[0].grid.segments(grids[0].o, grids[0].dir, d) {
        let mut t = t0;
        loop {
            let mu = rest_max + dmax * first_max;
            if !(mu > 0.0) {
                break;
            }
            t += -(1.0 - rng.uniform()).ln() / mu;
            if !(t < t1) {
                break;
            }
            steps += 1;
            if steps > MAX_STEPS {
                return Flight::Absorbed;
            }
            for (r, g) in rho.iter_mut().zip(grids) {
                *r = g.density(t);
            }
            let rho = &rho[..grids.len()];
            // Lane j: real with σt_j/μ, null with σn_j/μ = 1 − σt_j/μ; the event is
            // chosen with the throughput-weighted averages of those.
            let p_real: f32 =
                (0..n).map(|j| beta.lane(j).abs() / total * (sigma_t(beta.lane_index(j), rho) / mu).min(1.0)).sum();
            let p_null = (1.0 - p_real).max(0.0);
            if rng.uniform() < p_real {
                let mut alive = false;
                for j in 0..n {
                    let v = beta.lane(j) * sigma_s(beta.lane_index(j), rho) / mu / p_real;
                    alive |= v != 0.0;
                    beta.set_lane(j, v);
                }
                return if alive { Flight::Scattered { t } } else { Flight::Absorbed };
            }
            let mut new_total = 0.0;
            let mut died = false;
            for j in 0..n {
                let before = beta.lane(j);
                let v = before * ((mu - sigma_t(beta.lane_index(j), rho)) / mu).max(0.0) / p_null;
                died |= v == 0.0 && before != 0.0;
                new_total += v.abs();
                beta.set_lane(j, v);
            }
            if !(new_total > 0.0 && new_total.is_finite()) {
                return Flight::Absorbed;
            }
            // The next event's lane weights follow the new throughput (as the
            // homogeneous flight chooses its lane ∝ throughput), and the majorant the
            // lanes still carried.
            total = new_total;
            if died {
                (first_max, rest_max) = majorants(beta);
            }
        }
    }
    Flight::Through
}

/// The majorant segments of a ray through a [`GridMedium`]: (t0, t1, max density).
pub struct Segments<'a> {
    grid: &'a GridMedium,
    vo: Vec3A,
    vd: Vec3A,
    tmax: f32,
    /// The ray's piece inside the box.
    ta: f32,
    tb: f32,
    t: f32,
    cell: [usize; 3],
    /// 0: before the box, 1: inside, 2: after it, 3: done.
    phase: u8,
}

impl Iterator for Segments<'_> {
    type Item = (f32, f32, f32);
    fn next(&mut self) -> Option<Self::Item> {
        loop {
            match self.phase {
                0 => {
                    self.phase = 1;
                    if self.ta > 0.0 {
                        self.t = self.ta;
                        return Some((0.0, self.ta, 0.0));
                    }
                    self.t = self.ta;
                }
                1 => {
                    let g = self.grid;
                    let [sx, sy, _] = g.super_dims;
                    let c = self.cell;
                    let m = g.majorant[(c[2] * sy + c[1]) * sx + c[0]];
                    // The nearest face of the super-cell ahead, per axis.
                    let mut exit = f32::INFINITY;
                    let mut axis = 0;
                    for a in 0..3 {
                        let d = self.vd[a];
                        if d == 0.0 {
                            continue;
                        }
                        let face =
                            if d > 0.0 { ((c[a] + 1) * SUPER_CELL).min(g.dims[a]) } else { c[a] * SUPER_CELL } as f32;
                        let t = (face - self.vo[a]) / d;
                        if t < exit {
                            exit = t;
                            axis = a;
                        }
                    }
                    let t0 = self.t;
                    let t1 = exit.max(t0).min(self.tb);
                    self.t = t1;
                    let step_out = if self.vd[axis] > 0.0 {
                        self.cell[axis] += 1;
                        self.cell[axis] >= g.super_dims[axis]
                    } else if self.cell[axis] == 0 {
                        true
                    } else {
                        self.cell[axis] -= 1;
                        false
                    };
                    if t1 >= self.tb || step_out {
                        self.t = self.tb;
                        self.phase = 2;
                    }
                    if t1 > t0 {
                        return Some((t0, t1, m));
                    }
                }
                2 => {
                    self.phase = 3;
                    let t0 = if self.ta < self.tb { self.tb } else { 0.0 };
                    if t0 < self.tmax {
                        return Some((t0, self.tmax, 0.0));
                    }
                }
                _ => return None,
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::integrator::throughput::SingleWavelength;

    fn spectrum(v: &[f32]) -> SampledSpectrum {
        SampledSpectrum::from_slice(v)
    }

    fn constant(dims: [usize; 3], rho: f32, lo: Vec3A, hi: Vec3A, sa: &[f32], ss: &[f32]) -> GridMedium {
        let n = dims.iter().product();
        GridMedium::new("Smoke", dims, vec![rho; n], lo, hi, spectrum(sa), spectrum(ss), 0.0).unwrap()
    }

    /// The length of `o + t·dir`, 0 ≤ t < d, inside the box lo..hi (slab test).
    fn chord(o: Vec3A, dir: Vec3A, d: f32, lo: Vec3A, hi: Vec3A) -> f32 {
        let (mut a, mut b) = (0.0f32, d);
        for k in 0..3 {
            let (t0, t1) = ((lo[k] - o[k]) / dir[k], (hi[k] - o[k]) / dir[k]);
            a = a.max(t0.min(t1));
            b = b.min(t0.max(t1));
        }
        (b - a).max(0.0) * dir.length()
    }

    /// Mean and standard error of samples.
    fn mean_se(x: &[f64]) -> (f64, f64) {
        let n = x.len() as f64;
        let m = x.iter().sum::<f64>() / n;
        let var = x.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / (n - 1.0);
        (m, (var / n).sqrt())
    }

    /// (a) A grid of constant density ρ is the homogeneous medium of density ρ: ratio
    /// tracking estimates exp(−σt(λ)·ρ·L) per wavelength within 3 standard errors, and
    /// delta tracking's expected weights are the homogeneous closed forms, through
    /// exp(−σt·ρ·L) and scattered (σs/σt)(1 − exp(−σt·ρ·L)), for a 4-lane spectrum of
    /// very different extinctions (spectral MIS) and per single wavelength. The box is
    /// 20×9×10 voxels (3×2×2 super-cells, the last ones partial), the ray oblique.
    #[test]
    fn constant_grid_is_the_homogeneous_medium() {
        let (lo, hi) = (Vec3A::new(-1.0, -0.5, 0.0), Vec3A::new(1.0, 1.5, 2.0));
        let (sa, ss) = ([0.1f32, 1.0, 2.5, 0.0], [0.5f32, 0.2, 1.0, 0.0]);
        let rho = 0.7f32;
        let g = constant([20, 9, 10], rho, lo, hi, &sa, &ss);
        let o = Vec3A::new(-2.0, 0.3, 0.7);
        let dir = Vec3A::new(1.0, 0.2, 0.1).normalize();
        let d = 5.0;
        let l = chord(o, dir, d, lo, hi) as f64;
        assert!(l > 1.9, "chord {l}");
        let mut rng = Rng::new(7, 3);
        let n = 20_000;
        let mut est = vec![Vec::new(); 4];
        let mut tr = SampledSpectrum::zeros(4);
        for _ in 0..n {
            tr.fill(1.0);
            g.transmittance(o, dir, d, None, &mut tr, &mut rng);
            (0..4).for_each(|i| est[i].push(tr.get(i) as f64));
        }
        for i in 0..4 {
            let exact = (-((sa[i] + ss[i]) as f64) * rho as f64 * l).exp();
            let (m, se) = mean_se(&est[i]);
            eprintln!("ratio tracking lane {i}: {m:.5} ± {se:.5} vs {exact:.5}");
            assert!((m - exact).abs() <= 3.0 * se + 1e-6, "lane {i}: {m} ± {se} vs {exact}");
        }
        // Delta tracking: weights per lane.
        let mut scratch = SampledSpectrum::zeros(4);
        let (mut through, mut scattered) = (vec![vec![0.0f64; n]; 4], vec![vec![0.0f64; n]; 4]);
        let (mut s_through, mut s_scattered) = (vec![vec![0.0f64; n]; 4], vec![vec![0.0f64; n]; 4]);
        for k in 0..n {
            let mut b = SampledSpectrum::splat(4, 1.0);
            match g.fly(o, dir, d, None, &mut b, &mut rng, &mut scratch) {
                Flight::Through => (0..4).for_each(|i| through[i][k] = b.get(i) as f64),
                Flight::Scattered { t } => {
                    assert!(t < d);
                    (0..4).for_each(|i| scattered[i][k] = b.get(i) as f64)
                }
                Flight::Absorbed => {}
            }
            for i in 0..4 {
                let mut s = SingleWavelength { index: i, value: 1.0 };
                match g.fly(o, dir, d, None, &mut s, &mut rng, &mut scratch) {
                    Flight::Through => s_through[i][k] = s.value as f64,
                    Flight::Scattered { .. } => s_scattered[i][k] = s.value as f64,
                    Flight::Absorbed => {}
                }
            }
        }
        for i in 0..4 {
            let st = (sa[i] + ss[i]) as f64 * rho as f64;
            let tr = (-st * l).exp();
            let sc = if st > 0.0 { ss[i] as f64 * rho as f64 / st * (1.0 - tr) } else { 0.0 };
            for (what, t, s) in [("MIS", &through[i], &scattered[i]), ("single", &s_through[i], &s_scattered[i])] {
                let ((mt, set), (ms, ses)) = (mean_se(t), mean_se(s));
                eprintln!(
                    "{what} lane {i}: through {mt:.4}±{set:.4} vs {tr:.4}, scattered {ms:.4}±{ses:.4} vs {sc:.4}"
                );
                assert!((mt - tr).abs() <= 3.0 * set + 1e-6, "{what} lane {i}: through {mt} ± {set} vs {tr}");
                assert!((ms - sc).abs() <= 3.0 * ses + 1e-6, "{what} lane {i}: scattered {ms} ± {ses} vs {sc}");
            }
        }
    }

    /// (b) A density ramp ρ(x) = k·x along x (voxel centres on the line; the half voxels
    /// at the faces hold the end values, ρ = k·h/2 and k·(X − h/2)): the interpolated
    /// density is the line, and the transmittance along x is exp(−σt·∫ρ) with the
    /// integral in closed form, across the box (entering and leaving it) and between
    /// two interior points, within 3 standard errors per wavelength.
    #[test]
    fn linear_ramp_transmittance_is_exp_of_the_integral() {
        let (nx, x_len, k) = (16usize, 2.0f32, 1.5f32);
        let h = x_len / nx as f32;
        let dims = [nx, 2, 2];
        let mut values = Vec::new();
        for _z in 0..2 {
            for _y in 0..2 {
                for i in 0..nx {
                    values.push(k * (i as f32 + 0.5) * h);
                }
            }
        }
        let (sa, ss) = ([0.3f32, 1.2, 0.0], [0.2f32, 0.0, 0.0]);
        let g = GridMedium::new(
            "Ramp",
            dims,
            values,
            Vec3A::ZERO,
            Vec3A::new(x_len, 1.0, 1.0),
            spectrum(&sa),
            spectrum(&ss),
            0.0,
        )
        .unwrap();
        for x in [0.1f32, 0.5, 1.0, 1.37, 1.9] {
            let want = k * x.clamp(h / 2.0, x_len - h / 2.0);
            let got = g.density(Vec3A::new(x, 0.3, 0.8));
            assert!((got - want).abs() < 1e-5, "ρ({x}) = {got} vs {want}");
        }
        let (kd, hd, xd) = (k as f64, h as f64, x_len as f64);
        let a = hd / 2.0;
        let across = kd * a * a + kd * ((xd - a).powi(2) - a * a) / 2.0 + kd * (xd - a) * a;
        let inner = kd * (1.5f64 * 1.5 - 0.5 * 0.5) / 2.0;
        let mut rng = Rng::new(5, 1);
        let n = 20_000;
        for (o, d, integral) in [(Vec3A::new(-1.0, 0.5, 0.5), 4.0f32, across), (Vec3A::new(0.5, 0.5, 0.5), 1.0, inner)]
        {
            let mut est = vec![Vec::new(); 3];
            let mut tr = SampledSpectrum::zeros(3);
            for _ in 0..n {
                tr.fill(1.0);
                g.transmittance(o, Vec3A::X, d, None, &mut tr, &mut rng);
                (0..3).for_each(|i| est[i].push(tr.get(i) as f64));
            }
            for i in 0..3 {
                let exact = (-((sa[i] + ss[i]) as f64) * integral).exp();
                let (m, se) = mean_se(&est[i]);
                eprintln!("ramp ∫ρ = {integral:.4}, lane {i}: {m:.5} ± {se:.5} vs {exact:.5}");
                assert!((m - exact).abs() <= 3.0 * se + 1e-6, "∫ρ {integral} lane {i}: {m} ± {se} vs {exact}");
            }
        }
    }

    /// The DDA's segments tile [0, d) without gaps, and every density on a segment is
    /// at most its majorant (random grids, rays from outside and inside the box).
    #[test]
    fn majorant_segments_tile_the_ray_and_bound_the_density() {
        let mut rng = Rng::new(9, 9);
        let dims = [19usize, 8, 13];
        let values: Vec<f32> = (0..dims.iter().product::<usize>()).map(|_| rng.uniform().powi(4) * 3.0).collect();
        let (lo, hi) = (Vec3A::new(-1.0, 0.0, 0.5), Vec3A::new(1.0, 0.7, 1.8));
        let g = GridMedium::new("Noise", dims, values, lo, hi, spectrum(&[1.0]), spectrum(&[0.0]), 0.0).unwrap();
        for _ in 0..2000 {
            let r = |rng: &mut Rng| rng.uniform() * 2.0 - 1.0;
            let o = Vec3A::new(r(&mut rng) * 2.0, r(&mut rng) * 1.5, r(&mut rng) * 2.0 + 1.0);
            let mut dir = Vec3A::new(r(&mut rng), r(&mut rng), r(&mut rng));
            if rng.uniform() < 0.2 {
                dir.y = 0.0; // parallel to a face
            }
            let d = 4.0 * rng.uniform();
            let mut t = 0.0f32;
            for (t0, t1, m) in g.segments(o, dir, d) {
                assert!((t0 - t).abs() <= 1e-5 * (1.0 + t), "gap {t} .. {t0}");
                assert!(t1 > t0);
                for s in 0..16 {
                    let ts = t0 + (t1 - t0) * (s as f32 + 0.5) / 16.0;
                    let rho = g.density(o + dir * ts);
                    assert!(rho <= m * (1.0 + 1e-5) + 1e-6, "ρ {rho} > majorant {m} at t {ts} of {t0}..{t1}");
                }
                t = t1;
            }
            assert!((t - d).abs() <= 1e-5 * (1.0 + d), "ends at {t}, not {d}");
        }
    }

    /// (c) Delta tracking's free-flight distances in a constant grid are exponential
    /// with rate σt·ρ (Kolmogorov–Smirnov against 1 − exp(−σt·ρ·t), the flights past
    /// the box's end at its length), with null collisions: another row of voxels in the
    /// same super-cells is denser, so the majorant is 2.5× the density on the ray.
    #[test]
    fn delta_tracking_distances_are_exponential() {
        let dims = [24usize, 2, 1];
        let mut values = vec![2.0f32; 48];
        values[24..].fill(5.0); // row y = 1
        let g = GridMedium::new(
            "Fog",
            dims,
            values,
            Vec3A::ZERO,
            Vec3A::new(2.0, 4.0, 1.0),
            spectrum(&[0.0]),
            spectrum(&[1.5]),
            0.0,
        )
        .unwrap();
        let rate = 1.5f64 * 2.0;
        let (o, d) = (Vec3A::new(0.0, 0.5, 0.5), 2.0f32); // row y = 0 (density 2, clamped)
        let mut rng = Rng::new(3, 4);
        let n = 20_000;
        let mut scratch = SampledSpectrum::zeros(1);
        let mut ts = Vec::with_capacity(n);
        for _ in 0..n {
            let mut s = SingleWavelength { index: 0, value: 1.0 };
            match g.fly(o, Vec3A::X, d, None, &mut s, &mut rng, &mut scratch) {
                Flight::Scattered { t } => {
                    assert!((s.value - 1.0).abs() < 1e-6, "albedo 1: weight {}", s.value);
                    ts.push(t as f64)
                }
                Flight::Through => ts.push(d as f64),
                Flight::Absorbed => panic!("σa = 0"),
            }
        }
        ts.sort_by(f64::total_cmp);
        let mut ks = 0.0f64;
        for (i, &t) in ts.iter().enumerate() {
            if t >= d as f64 {
                break;
            }
            let f = 1.0 - (-rate * t).exp();
            ks = ks.max((f - i as f64 / n as f64).abs()).max((f - (i + 1) as f64 / n as f64).abs());
        }
        let through = ts.iter().filter(|&&t| t >= d as f64).count() as f64 / n as f64;
        let bound = 1.63 / (n as f64).sqrt(); // α = 0.01
        eprintln!("KS D = {ks:.5} (bound {bound:.5}); through {through:.5} vs {:.5}", (-rate * 2.0).exp());
        assert!(ks < bound, "KS D {ks} ≥ {bound}");
    }

    /// (d) An empty grid (all zeros) transmits exactly 1 and never scatters, also with
    /// scattering coefficients; NaN and negative voxels, zero dims, a wrong voxel count
    /// and an empty box are rejected with a message naming the voxel.
    #[test]
    fn empty_grid_is_vacuum_and_bad_grids_are_rejected() {
        let g = constant([9, 3, 17], 0.0, Vec3A::ZERO, Vec3A::ONE, &[0.5, 2.0], &[1.0, 3.0]);
        assert!(!g.scatters());
        let mut rng = Rng::new(1, 2);
        let mut scratch = SampledSpectrum::zeros(2);
        for k in 0..1000 {
            let o = Vec3A::new(-0.5, 0.5, 0.5);
            let dir = Vec3A::new(1.0, 0.01 * k as f32, 0.3).normalize();
            let mut tr = SampledSpectrum::splat(2, 1.0);
            g.transmittance(o, dir, 3.0, None, &mut tr, &mut rng);
            assert_eq!(tr.values(), &[1.0, 1.0]);
            let mut b = SampledSpectrum::from_slice(&[0.25, 0.75]);
            assert_eq!(g.fly(o, dir, f32::INFINITY, None, &mut b, &mut rng, &mut scratch), Flight::Through);
            assert_eq!(b.values(), &[0.25, 0.75]);
        }
        let new = |dims: [usize; 3], v: Vec<f32>, hi: Vec3A| {
            GridMedium::new("M", dims, v, Vec3A::ZERO, hi, spectrum(&[1.0]), spectrum(&[1.0]), 0.0)
        };
        let err = |r: Result<GridMedium, String>| r.expect_err("rejected");
        let mut v = vec![1.0f32; 8];
        v[5] = f32::NAN;
        assert!(err(new([2, 2, 2], v.clone(), Vec3A::ONE)).contains("NaN at index 5"));
        v[5] = -0.5;
        assert!(err(new([2, 2, 2], v, Vec3A::ONE)).contains("-0.5 at index 5"));
        assert!(err(new([2, 0, 2], vec![], Vec3A::ONE)).contains("> 0"));
        assert!(err(new([2, 2, 2], vec![1.0; 7], Vec3A::ONE)).contains("7 values"));
        assert!(err(new([1, 1, 1], vec![1.0], Vec3A::new(1.0, 0.0, 1.0))).contains("bounds"));
    }
}
