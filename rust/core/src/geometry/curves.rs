//! Curves (hair, fur, grass) and point clouds as triangle meshes; docs/camera.md, "Hair,
//! curves and point clouds", says why tessellation and at what resolution.
//!
//! A curve is a sequence of keys with a radius each, interpolated as Cycles interpolates
//! Blender's curves: uniform Catmull-Rom through the keys with the end keys repeated
//! (`catmull_rom_basis_eval` and `curve_intersect` in intern/cycles/kernel/geom/
//! curve_intersect.h), or straight segments (POLY curves). It becomes a tube: a ring of
//! `sides` vertices at `subdivisions` samples per key segment, the rings oriented by
//! parallel transport so they do not twist, with radial (smooth) normals. A tube is as
//! wide as the curve seen from any direction, and its normal across the width is what
//! Cycles gives both curve shapes (a ray-facing ribbon's rounded normal, a thick curve's
//! true one), so one tessellation stands for both. The ring's circumradius is enlarged
//! by π / (S·sin(π/S)) so the polygon's *mean* projected width equals the curve's
//! diameter (Cauchy: a convex body's mean width is its perimeter over π): thin hair
//! covers as many pixels on average as the round curve.
//!
//! A point is a sphere: a subdivided icosahedron with radial normals, scaled so that its
//! mean projected area equals the sphere's (Cauchy: a quarter of the surface area).

use crate::{Error, Result};
use glam::Vec3A;
use rayon::prelude::*;
use std::f32::consts::PI;

/// Triangles with per-vertex normals and uvs, and the curve or point each triangle
/// belongs to, in flat arrays (3 floats per vertex and normal, 2 per uv, 3 indices per
/// triangle) that go to numpy without a copy.
#[derive(Clone, Debug, Default)]
pub struct Tessellation {
    pub vertices: Vec<f32>,
    pub normals: Vec<f32>,
    /// Curves: (along the curve 0…1, around it 0…1). Points: spherical coordinates.
    pub uvs: Vec<f32>,
    pub triangles: Vec<u32>,
    pub owner: Vec<u32>,
}

/// One curve's or point's share of a [`Tessellation`]'s arrays, filled in parallel.
struct Part<'a> {
    vertices: &'a mut [f32],
    normals: &'a mut [f32],
    uvs: &'a mut [f32],
    triangles: &'a mut [u32],
    owner: &'a mut [u32],
    /// Index of the part's first vertex.
    base: u32,
}

impl Tessellation {
    /// Zeroed arrays for parts of `sizes[i] = (vertices, triangles)`.
    fn with_sizes(sizes: &[(usize, usize)]) -> Self {
        let (nv, nt) = sizes.iter().fold((0, 0), |(a, b), &(v, t)| (a + v, b + t));
        Tessellation {
            vertices: vec![0.0; nv * 3],
            normals: vec![0.0; nv * 3],
            uvs: vec![0.0; nv * 2],
            triangles: vec![0; nt * 3],
            owner: vec![0; nt],
        }
    }

    /// The arrays split into one [`Part`] per entry of `sizes`.
    fn parts<'a>(&'a mut self, sizes: &[(usize, usize)]) -> Vec<Part<'a>> {
        let (mut v, mut n, mut uv) = (&mut self.vertices[..], &mut self.normals[..], &mut self.uvs[..]);
        let (mut tr, mut ow) = (&mut self.triangles[..], &mut self.owner[..]);
        let mut base = 0u32;
        let mut out = Vec::with_capacity(sizes.len());
        for &(nv, nt) in sizes {
            let (a, rest) = std::mem::take(&mut v).split_at_mut(nv * 3);
            v = rest;
            let (b, rest) = std::mem::take(&mut n).split_at_mut(nv * 3);
            n = rest;
            let (c, rest) = std::mem::take(&mut uv).split_at_mut(nv * 2);
            uv = rest;
            let (d, rest) = std::mem::take(&mut tr).split_at_mut(nt * 3);
            tr = rest;
            let (e, rest) = std::mem::take(&mut ow).split_at_mut(nt);
            ow = rest;
            out.push(Part { vertices: a, normals: b, uvs: c, triangles: d, owner: e, base });
            base += nv as u32;
        }
        out
    }

    pub fn vertex_count(&self) -> usize {
        self.vertices.len() / 3
    }
    pub fn triangle_count(&self) -> usize {
        self.owner.len()
    }
    pub fn vertex(&self, i: usize) -> Vec3A {
        Vec3A::from_slice(&self.vertices[i * 3..i * 3 + 3])
    }
    pub fn normal(&self, i: usize) -> Vec3A {
        Vec3A::from_slice(&self.normals[i * 3..i * 3 + 3])
    }
    pub fn triangle(&self, i: usize) -> [u32; 3] {
        [self.triangles[i * 3], self.triangles[i * 3 + 1], self.triangles[i * 3 + 2]]
    }
}

#[derive(Clone, Copy, Debug)]
pub struct CurveOptions {
    /// Most rings per key segment (Catmull-Rom): a segment gets one ring per
    /// [`RING_ANGLE`] its tangent turns, between 1 and this.
    pub subdivisions: u32,
    /// Vertices per ring.
    pub sides: u32,
    /// Straight segments between keys (Blender's POLY curves) instead of Catmull-Rom.
    pub linear: bool,
}

impl Default for CurveOptions {
    fn default() -> Self {
        Self { subdivisions: 4, sides: 8, linear: false }
    }
}

/// How far the tangent may turn between two rings (radians): straight hair segments
/// need one ring, curly ones up to [`CurveOptions::subdivisions`].
pub const RING_ANGLE: f32 = PI / 16.0;

/// Circumradius of a regular `sides`-gon whose mean width is 2 (a unit circle's).
pub fn tube_scale(sides: u32) -> f32 {
    PI / (sides as f32 * (PI / sides as f32).sin())
}

/// Uniform Catmull-Rom through (a, b, c, d) at t ∈ [0, 1] between b and c.
fn catmull_rom(p: [[f32; 4]; 4], t: f32) -> [f32; 4] {
    let s = 1.0 - t;
    let w = [-t * s * s, 2.0 + t * t * (3.0 * t - 5.0), 2.0 + s * s * (3.0 * s - 5.0), -s * t * t];
    std::array::from_fn(|c| 0.5 * (w[0] * p[0][c] + w[1] * p[1][c] + w[2] * p[2][c] + w[3] * p[3][c]))
}

/// The samples (x, y, z, radius) of one curve: each key segment split into as many
/// pieces as its turning needs (at most `subdivisions`).
fn sample_curve(keys: &[[f32; 4]], opts: &CurveOptions) -> Vec<[f32; 4]> {
    let n = keys.len();
    let pos = |k: &[f32; 4]| Vec3A::new(k[0], k[1], k[2]);
    let mut out = Vec::with_capacity((n - 1) * if opts.linear { 1 } else { opts.subdivisions as usize } + 1);
    for i in 0..n - 1 {
        let p = [keys[i.saturating_sub(1)], keys[i], keys[i + 1], keys[(i + 2).min(n - 1)]];
        let sub = if opts.linear {
            1
        } else {
            // Catmull-Rom's end tangents are (c − a)/2 and (d − b)/2.
            let (t0, t1) = (pos(&p[2]) - pos(&p[0]), pos(&p[3]) - pos(&p[1]));
            let cos = t0.normalize_or_zero().dot(t1.normalize_or_zero()).clamp(-1.0, 1.0);
            ((cos.acos() / RING_ANGLE).ceil() as u32).clamp(1, opts.subdivisions) as usize
        };
        for j in 0..sub {
            let mut s = catmull_rom(p, j as f32 / sub as f32);
            s[3] = s[3].max(0.0); // the spline may overshoot below a zero tip radius
            out.push(s);
        }
    }
    out.push(keys[n - 1]);
    out
}

/// A unit vector perpendicular to unit `t`.
fn perpendicular(t: Vec3A) -> Vec3A {
    let a = t.abs();
    let axis = if a.x <= a.y && a.x <= a.z {
        Vec3A::X
    } else if a.y <= a.z {
        Vec3A::Y
    } else {
        Vec3A::Z
    };
    t.cross(axis).normalize()
}

/// Tangents of a polyline; repeated points borrow their neighbour's direction.
fn tangents(p: &[Vec3A]) -> Vec<Vec3A> {
    let m = p.len();
    let mut t: Vec<Vec3A> = (0..m).map(|j| p[(j + 1).min(m - 1)] - p[j.saturating_sub(1)]).collect();
    for j in 1..m {
        if t[j].length_squared() == 0.0 {
            t[j] = t[j - 1];
        }
    }
    for j in (0..m - 1).rev() {
        if t[j].length_squared() == 0.0 {
            t[j] = t[j + 1];
        }
    }
    t.iter().map(|v| v.try_normalize().unwrap_or(Vec3A::Z)).collect()
}

fn tube(samples: &[[f32; 4]], sides: u32, owner: u32, out: Part<'_>) {
    let m = samples.len();
    let s = sides as usize;
    let p: Vec<Vec3A> = samples.iter().map(|q| Vec3A::new(q[0], q[1], q[2])).collect();
    let t = tangents(&p);
    let scale = tube_scale(sides);
    let ring: Vec<(f32, f32)> = (0..s).map(|k| (2.0 * PI * k as f32 / s as f32).sin_cos()).collect();
    // Parallel transport: each ring's normal is the previous one with its component
    // along the new tangent removed (the frame turns with the curve, never about it).
    let mut normal = perpendicular(t[0]);
    for j in 0..m {
        if j > 0 {
            normal = (normal - normal.dot(t[j]) * t[j]).try_normalize().unwrap_or_else(|| perpendicular(t[j]));
        }
        let binormal = t[j].cross(normal);
        let r = samples[j][3] * scale;
        for (k, &(sin, cos)) in ring.iter().enumerate() {
            let i = j * s + k;
            let radial = normal * cos + binormal * sin;
            out.vertices[i * 3..i * 3 + 3].copy_from_slice(&(p[j] + radial * r).to_array());
            out.normals[i * 3..i * 3 + 3].copy_from_slice(&radial.to_array());
            out.uvs[i * 2] = j as f32 / (m - 1).max(1) as f32;
            out.uvs[i * 2 + 1] = k as f32 / s as f32;
        }
    }
    let mut w = 0;
    for j in 0..m - 1 {
        for k in 0..s {
            let a = out.base + (j * s + k) as u32;
            let b = out.base + (j * s + (k + 1) % s) as u32;
            let (c, d) = (a + sides, b + sides);
            out.triangles[w..w + 6].copy_from_slice(&[a, b, d, a, d, c]);
            w += 6;
        }
    }
    out.owner.fill(owner);
}

/// Curves → tubes. `keys` in order, `radii` per key, `counts` keys per curve (each ≥ 2).
/// `name` names the object in errors.
pub fn tessellate_curves(
    name: &str,
    keys: &[[f32; 3]],
    radii: &[f32],
    counts: &[u32],
    opts: &CurveOptions,
) -> Result<Tessellation> {
    let bad = |p: String| Error::object("curves", name, p);
    if radii.len() != keys.len() {
        return Err(bad(format!("{} radii for {} keys", radii.len(), keys.len())));
    }
    let total: u64 = counts.iter().map(|&c| c as u64).sum();
    if total != keys.len() as u64 {
        return Err(bad(format!("counts add up to {total} keys, but there are {}", keys.len())));
    }
    if let Some(c) = counts.iter().position(|&c| c < 2) {
        return Err(bad(format!("curve {c} has {} keys; each needs at least 2", counts[c])));
    }
    if let Some(i) = keys.iter().position(|k| !k.iter().all(|v| v.is_finite())) {
        return Err(bad(format!("key {i} is not finite")));
    }
    if let Some(i) = radii.iter().position(|r| !(r.is_finite() && *r >= 0.0)) {
        return Err(bad(format!("key {i} has radius {}; radii must be finite and not negative", radii[i])));
    }
    if opts.subdivisions < 1 || opts.sides < 3 {
        return Err(bad(format!("subdivisions {} must be ≥ 1 and sides {} ≥ 3", opts.subdivisions, opts.sides)));
    }
    let mut first = Vec::with_capacity(counts.len());
    let mut at = 0usize;
    for &c in counts {
        first.push(at);
        at += c as usize;
    }
    let samples: Vec<Vec<[f32; 4]>> = (0..counts.len())
        .into_par_iter()
        .map(|c| {
            let k: Vec<[f32; 4]> = (first[c]..first[c] + counts[c] as usize)
                .map(|i| [keys[i][0], keys[i][1], keys[i][2], radii[i]])
                .collect();
            sample_curve(&k, opts)
        })
        .collect();
    let sides = opts.sides as usize;
    let sizes: Vec<(usize, usize)> = samples.iter().map(|s| (s.len() * sides, (s.len() - 1) * sides * 2)).collect();
    if sizes.iter().map(|s| s.0 as u64).sum::<u64>() > u32::MAX as u64 {
        return Err(bad("too many vertices for one mesh; split the curves".into()));
    }
    let mut out = Tessellation::with_sizes(&sizes);
    out.parts(&sizes).into_par_iter().enumerate().for_each(|(c, part)| tube(&samples[c], opts.sides, c as u32, part));
    Ok(out)
}

/// The unit icosphere of `level` subdivisions: vertices and outward-wound triangles.
fn icosphere(level: u32) -> (Vec<Vec3A>, Vec<[u32; 3]>) {
    let g = (1.0 + 5f32.sqrt()) / 2.0;
    let mut v: Vec<Vec3A> = [
        [-1.0, g, 0.0],
        [1.0, g, 0.0],
        [-1.0, -g, 0.0],
        [1.0, -g, 0.0],
        [0.0, -1.0, g],
        [0.0, 1.0, g],
        [0.0, -1.0, -g],
        [0.0, 1.0, -g],
        [g, 0.0, -1.0],
        [g, 0.0, 1.0],
        [-g, 0.0, -1.0],
        [-g, 0.0, 1.0],
    ]
    .iter()
    .map(|p| Vec3A::from(*p).normalize())
    .collect();
    let mut f: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..level {
        let mut mid = std::collections::HashMap::new();
        let mut midpoint = |a: u32, b: u32, v: &mut Vec<Vec3A>| -> u32 {
            *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                v.push((v[a as usize] + v[b as usize]).normalize());
                v.len() as u32 - 1
            })
        };
        let mut next = Vec::with_capacity(f.len() * 4);
        for &[a, b, c] in &f {
            let (ab, bc, ca) = (midpoint(a, b, &mut v), midpoint(b, c, &mut v), midpoint(c, a, &mut v));
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        f = next;
    }
    (v, f)
}

/// Circumradius of the `level` icosphere whose surface area is 4π, so that its mean
/// projected area is a unit sphere's.
pub fn sphere_scale(level: u32) -> f32 {
    let (v, f) = icosphere(level);
    let area: f32 = f
        .iter()
        .map(|t| 0.5 * (v[t[1] as usize] - v[t[0] as usize]).cross(v[t[2] as usize] - v[t[0] as usize]).length())
        .sum();
    (4.0 * PI / area).sqrt()
}

/// Points → spheres (icospheres of `level`: 20·4^level triangles each).
pub fn tessellate_points(name: &str, positions: &[[f32; 3]], radii: &[f32], level: u32) -> Result<Tessellation> {
    let bad = |p: String| Error::object("point cloud", name, p);
    if radii.len() != positions.len() {
        return Err(bad(format!("{} radii for {} points", radii.len(), positions.len())));
    }
    if let Some(i) = positions.iter().position(|k| !k.iter().all(|v| v.is_finite())) {
        return Err(bad(format!("point {i} is not finite")));
    }
    if let Some(i) = radii.iter().position(|r| !(r.is_finite() && *r >= 0.0)) {
        return Err(bad(format!("point {i} has radius {}; radii must be finite and not negative", radii[i])));
    }
    if level > 5 {
        return Err(bad(format!("sphere level {level} is above 5")));
    }
    let (unit, faces) = icosphere(level);
    let scale = sphere_scale(level);
    let uv: Vec<[f32; 2]> = unit
        .iter()
        .map(|d| [(d.y.atan2(d.x) / (2.0 * PI)).rem_euclid(1.0), (-d.z).clamp(-1.0, 1.0).acos() / PI])
        .collect();
    if positions.len() as u64 * unit.len() as u64 > u32::MAX as u64 {
        return Err(bad("too many vertices for one mesh; split the point cloud".into()));
    }
    let sizes = vec![(unit.len(), faces.len()); positions.len()];
    let mut out = Tessellation::with_sizes(&sizes);
    out.parts(&sizes).into_par_iter().enumerate().for_each(|(i, part)| {
        let c = Vec3A::from(positions[i]);
        let r = radii[i] * scale;
        for (k, d) in unit.iter().enumerate() {
            part.vertices[k * 3..k * 3 + 3].copy_from_slice(&(c + *d * r).to_array());
            part.normals[k * 3..k * 3 + 3].copy_from_slice(&d.to_array());
            part.uvs[k * 2..k * 2 + 2].copy_from_slice(&uv[k]);
        }
        for (f, tri) in faces.iter().enumerate() {
            part.triangles[f * 3..f * 3 + 3].copy_from_slice(&tri.map(|v| v + part.base));
        }
        part.owner.fill(i as u32);
    });
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn catmull_rom_passes_through_the_keys_with_the_ends_repeated() {
        let keys = [[0.0, 0.0, 0.0, 1.0], [1.0, 0.0, 0.0, 2.0], [2.0, 1.0, 0.0, 3.0], [3.0, 1.0, 1.0, 0.0]];
        let s = sample_curve(&keys, &CurveOptions { subdivisions: 4, ..Default::default() });
        for key in &keys {
            assert!(s.iter().any(|got| (0..4).all(|c| (got[c] - key[c]).abs() < 1e-6)), "{key:?} not in {s:?}");
        }
        assert!(s.len() > keys.len() && s.len() <= 13, "{}", s.len());
        // The first segment's midpoint with the first key repeated (Cycles: ka = k0):
        // 0.5·(−t s² a + (2 + t²(3t − 5)) b + (2 + s²(3s − 5)) c − s t² d) at t = ½.
        let mid = catmull_rom([keys[0], keys[0], keys[1], keys[2]], 0.5);
        let expect = 0.5 * (-0.125 * 0.0 + 1.125 * 0.0 + 1.125 * 1.0 - 0.125 * 2.0);
        assert!((mid[0] - expect).abs() < 1e-6, "{mid:?}");
        // A straight curve needs one ring per key; straight segments keep only the keys.
        let straight = [[0.0, 0.0, 0.0, 1.0], [0.0, 0.0, 1.0, 1.0], [0.0, 0.0, 2.0, 1.0]];
        assert_eq!(sample_curve(&straight, &CurveOptions::default()).len(), 3);
        assert_eq!(sample_curve(&keys, &CurveOptions { linear: true, ..Default::default() }).len(), 4);
    }

    #[test]
    fn tube_rings_sit_at_the_scaled_radius_with_radial_normals_and_do_not_twist() {
        // A helix: the transported frame must turn smoothly (no ring rotated about the tangent).
        let n = 40;
        let keys: Vec<[f32; 3]> =
            (0..n).map(|i| [(i as f32 * 0.3).cos(), (i as f32 * 0.3).sin(), i as f32 * 0.1]).collect();
        let radii = vec![0.05; n];
        let opts = CurveOptions { subdivisions: 3, sides: 8, linear: false };
        let t = tessellate_curves("helix", &keys, &radii, &[n as u32], &opts).unwrap();
        let m = t.vertex_count() / 8;
        assert!(m > n, "the helix turns: more rings than keys ({m})");
        assert_eq!(t.vertex_count(), m * 8);
        assert_eq!(t.triangle_count(), (m - 1) * 16);
        let r = 0.05 * tube_scale(8);
        for j in 0..m {
            let ring: Vec<Vec3A> = (0..8).map(|k| t.vertex(j * 8 + k)).collect();
            let centre = ring.iter().fold(Vec3A::ZERO, |a, v| a + *v) / 8.0;
            for (k, v) in ring.iter().enumerate() {
                let d = *v - centre;
                assert!((d.length() - r).abs() < 1e-4, "ring {j}: {}", d.length());
                assert!((d.normalize() - t.normal(j * 8 + k)).length() < 1e-3);
            }
            if j > 0 {
                // Transported, not twisted: vertex 0's radial direction turns only as much
                // as the curve does between two rings (at most RING_ANGLE, plus slack).
                let turn = t.normal(j * 8).dot(t.normal((j - 1) * 8));
                assert!(turn > (1.5 * RING_ANGLE).cos(), "ring {j} twisted: {turn}");
            }
        }
        assert!(t.owner.iter().all(|&o| o == 0));
    }

    #[test]
    fn mean_width_of_the_polygon_is_the_diameter() {
        // Average over directions of the ring's projected width (Cauchy's formula check).
        let sides = 6;
        let r = tube_scale(sides);
        let pts: Vec<Vec3A> = (0..sides)
            .map(|k| {
                let a = 2.0 * PI * k as f32 / sides as f32;
                Vec3A::new(a.cos() * r, a.sin() * r, 0.0)
            })
            .collect();
        let n = 3600;
        let mean: f32 = (0..n)
            .map(|i| {
                let d = Vec3A::new((PI * i as f32 / n as f32).cos(), (PI * i as f32 / n as f32).sin(), 0.0);
                let proj: Vec<f32> = pts.iter().map(|p| p.dot(d)).collect();
                proj.iter().cloned().fold(f32::MIN, f32::max) - proj.iter().cloned().fold(f32::MAX, f32::min)
            })
            .sum::<f32>()
            / n as f32;
        assert!((mean - 2.0).abs() < 1e-3, "{mean}");
    }

    #[test]
    fn spheres_have_the_area_of_the_sphere_and_radial_normals() {
        let t = tessellate_points("cloud", &[[1.0, 2.0, 3.0], [0.0, 0.0, 0.0]], &[0.5, 2.0], 1).unwrap();
        assert_eq!(t.triangle_count(), 160);
        for (i, &(c, r)) in [(Vec3A::new(1.0, 2.0, 3.0), 0.5f32), (Vec3A::ZERO, 2.0)].iter().enumerate() {
            let tris: Vec<[u32; 3]> = (i * 80..(i + 1) * 80).map(|f| t.triangle(f)).collect();
            let area: f32 = tris
                .iter()
                .map(|tr| {
                    let [a, b, cc] = tr.map(|k| t.vertex(k as usize));
                    0.5 * (b - a).cross(cc - a).length()
                })
                .sum();
            assert!((area - 4.0 * PI * r * r).abs() < 1e-4 * area, "{area}");
            for k in tris.iter().flatten() {
                let v = t.vertex(*k as usize) - c;
                assert!((v.normalize() - t.normal(*k as usize)).length() < 1e-5);
            }
        }
        assert_eq!(t.owner[79], 0);
        assert_eq!(t.owner[80], 1);
    }

    #[test]
    fn bad_curves_name_the_object() {
        let e = tessellate_curves("Hair", &[[0.0; 3]; 3], &[0.1; 3], &[3, 1], &CurveOptions::default()).unwrap_err();
        assert!(e.to_string().contains("curves 'Hair'") && e.to_string().contains("counts add up"), "{e}");
        let e = tessellate_curves("Hair", &[[0.0; 3]; 2], &[0.1, -1.0], &[2], &CurveOptions::default()).unwrap_err();
        assert!(e.to_string().contains("radius"), "{e}");
        let e = tessellate_points("P", &[[f32::NAN, 0.0, 0.0]], &[0.1], 1).unwrap_err();
        assert!(e.to_string().contains("point cloud 'P'"), "{e}");
    }
}
