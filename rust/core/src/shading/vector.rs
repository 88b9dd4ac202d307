//! Vector nodes: Mapping (Cycles `kernel/svm/mapping_util.h`), Normal Map
//! (`svm_node_normal_map` in `kernel/svm/tex_coord.h`) and Bump (`svm_node_set_bump` in
//! `kernel/svm/bump.h`), and the shading normal's validity rule
//! ([`ensure_valid_specular_reflection`], `kernel/closure/bsdf_util.h`).

use super::math::{safe_divide, safe_normalize};
use super::program::{Program, Reg, ShadingPoint};
use glam::{Mat3, Vec3};

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MappingType {
    Point,
    Texture,
    Vector,
    Normal,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NormalMapSpace {
    Tangent,
    Object,
    World,
    /// Blender's own object and world conventions: Y and Z negated (Cycles'
    /// `NODE_NORMAL_MAP_BLENDER_OBJECT` / `_WORLD`).
    BlenderObject,
    BlenderWorld,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum VectorOp {
    /// Vector, Location, Rotation, Scale → Vector.
    Mapping(MappingType),
    /// Strength, Color → Normal; tangent space reads the tangents of the UV map in
    /// attribute slot `.1` (None: the mesh's default tangents).
    NormalMap(NormalMapSpace, Option<usize>),
}

/// Cycles `euler_to_transform`: rotation Z·Y·X of XYZ Euler angles, as rows.
pub fn euler_to_mat3(e: Vec3) -> Mat3 {
    let (cx, cy, cz) = (e.x.cos(), e.y.cos(), e.z.cos());
    let (sx, sy, sz) = (e.x.sin(), e.y.sin(), e.z.sin());
    let rows = [
        Vec3::new(cy * cz, sy * sx * cz - cx * sz, sy * cx * cz + sx * sz),
        Vec3::new(cy * sz, sy * sx * sz + cx * cz, sy * cx * sz - sx * cz),
        Vec3::new(-sy, cy * sx, cy * cx),
    ];
    Mat3::from_cols(rows[0], rows[1], rows[2]).transpose()
}

/// Cycles `svm_mapping`.
pub fn mapping(ty: MappingType, v: Vec3, location: Vec3, rotation: Vec3, scale: Vec3) -> Vec3 {
    let r = euler_to_mat3(rotation);
    match ty {
        MappingType::Point => r * (v * scale) + location,
        MappingType::Texture => {
            let t = r.transpose() * (v - location);
            Vec3::new(safe_divide(t.x, scale.x), safe_divide(t.y, scale.y), safe_divide(t.z, scale.z))
        }
        MappingType::Vector => r * (v * scale),
        MappingType::Normal => {
            let d = Vec3::new(safe_divide(v.x, scale.x), safe_divide(v.y, scale.y), safe_divide(v.z, scale.z));
            safe_normalize(r * d)
        }
    }
}

impl VectorOp {
    pub fn varying(&self) -> bool {
        matches!(self, VectorOp::NormalMap(..))
    }

    pub fn eval(&self, i: &[Vec3], o: &mut [Vec3], sp: &ShadingPoint) {
        match *self {
            VectorOp::Mapping(ty) => o[0] = mapping(ty, i[0], i[1], i[2], i[3]),
            VectorOp::NormalMap(space, slot) => o[0] = normal_map(space, i[0].x, i[1], sp, slot),
        }
    }
}

/// Cycles 4.5 `svm_node_normal_map` (kernel/svm/tex_coord.h). Tangent space works in
/// object space on the interpolated normal and the mesh's tangent, Strength scales the
/// map's x, y and mixes its z towards 1 (4.5's rule; older Cycles mixed normals); object
/// and world space mix the result with the shading normal by Strength. The result faces
/// the ray's side as the shading normal does. Differences: the normal and tangent here
/// are unit length and the tangent is orthogonalised against the normal at the hit
/// (Cycles uses the unnormalised interpolated ones); without mesh tangents the tangent
/// is ∂p/∂u of the default UVs (Cycles falls back to the unperturbed normal).
pub fn normal_map(space: NormalMapSpace, strength: f32, color: Vec3, sp: &ShadingPoint, slot: Option<usize>) -> Vec3 {
    let mut c = 2.0 * (color - Vec3::splat(0.5));
    let n0 = sp.normal;
    let m = sp.normal_to_world;
    let mut n = match space {
        NormalMapSpace::Tangent => {
            // The un-flipped normal: Cycles inverts for backfacing after the map.
            let nw = if sp.backfacing { -n0 } else { n0 };
            let no = m.inverse() * nw;
            // Object-space tangent of the node's UV map: world vectors map back by
            // Lᵀ⁻¹ᵀ = mᵀ (m = L⁻ᵀ).
            let (tangent, sign) = sp.tangent_of(slot);
            let to = m.transpose() * tangent;
            c.x *= strength;
            c.y *= strength;
            c.z = 1.0 + (c.z - 1.0) * strength.clamp(0.0, 1.0);
            let b = sign * no.cross(to);
            let n = safe_normalize(m * safe_normalize(c.x * to + c.y * b + c.z * no));
            if sp.backfacing {
                -n
            } else {
                n
            }
        }
        _ => {
            if matches!(space, NormalMapSpace::BlenderObject | NormalMapSpace::BlenderWorld) {
                c.y = -c.y;
                c.z = -c.z;
            }
            let mut n = match space {
                NormalMapSpace::Object | NormalMapSpace::BlenderObject => safe_normalize(m * c),
                _ => safe_normalize(c),
            };
            if sp.backfacing {
                n = -n;
            }
            if strength != 1.0 {
                let s = strength.max(0.0);
                n = safe_normalize(n0 + (n - n0) * s);
            }
            n
        }
    };
    if n == Vec3::ZERO {
        n = n0;
    }
    n
}

/// The Bump node: the height program (the ops its Height input depends on, registers
/// shared with the material's program) is evaluated at the hit moved by ± each of the
/// shading point's two steps (`ShadingPoint::diff`, small steps within the triangle that
/// move every interpolated coordinate with it). Cycles 4.5 `svm_node_set_bump`
/// (kernel/svm/bump.h) evaluates the height at the point offset by its ray differentials
/// × Filter Width and forms N' = |det| N − Distance · sign(det) · (Δh_x R_x + Δh_y R_y)
/// (R_x = dP_y × N, R_y = N × dP_x, det = dP_x · R_x): the same formula here, with
/// central differences over a step of 10⁻³ of the object's size (at most a quarter of the
/// triangle's edge) in place of the pixel footprint. So the normal is the height's
/// gradient in the limit, not Cycles' filtered one: Filter Width is not used, and a
/// height that varies within a pixel is not blurred as Cycles blurs it.
#[derive(Clone, Debug)]
pub struct Bump {
    pub height: Program,
    pub reg: Reg,
    pub invert: bool,
}

impl Bump {
    fn height_at(&self, sp: &ShadingPoint, regs: &mut Vec<Vec3>) -> f32 {
        self.height.run(sp, regs);
        regs[self.reg as usize].x
    }

    /// Strength, Distance, Normal → Normal.
    pub fn eval(&self, i: &[Vec3], o: &mut [Vec3], sp: &ShadingPoint) {
        let mut n = safe_normalize(i[2]);
        if n == Vec3::ZERO {
            n = sp.normal;
        }
        let (dx, dy) = (sp.diff[0].position, sp.diff[1].position);
        let mut regs = Vec::new();
        let mut dh = [0.0; 2];
        for (k, d) in dh.iter_mut().enumerate() {
            let hp = self.height_at(&sp.offset(k, 1.0), &mut regs);
            let hm = self.height_at(&sp.offset(k, -1.0), &mut regs);
            *d = 0.5 * (hp - hm);
        }
        let rx = dy.cross(n);
        let ry = n.cross(dx);
        let det = dx.dot(rx);
        let surfgrad = dh[0] * rx + dh[1] * ry;
        let strength = i[0].x.max(0.0);
        let distance = if self.invert { -i[1].x } else { i[1].x };
        let out = safe_normalize(det.abs() * n - distance * det.signum() * surfgrad);
        o[0] =
            if out == Vec3::ZERO || det == 0.0 { n } else { (strength * out + (1.0 - strength) * n).normalize_or(n) };
    }
}

/// Cycles `ensure_valid_specular_reflection` (kernel/closure/bsdf_util.h, applied to every
/// closure's normal through `maybe_ensure_valid_specular_reflection` in
/// kernel/svm/closure.h): if the mirror reflection of the incoming direction `i` about
/// the shading normal `n` falls below the surface (geometric normal `ng`, facing `i`),
/// `n` is bent towards `ng` just enough that it leaves at min(0.9 · i·ng, 0.01) above it.
/// All unit vectors.
pub fn ensure_valid_specular_reflection(ng: Vec3, i: Vec3, n: Vec3) -> Vec3 {
    let r = 2.0 * n.dot(i) * n - i;
    let iz = i.dot(ng);
    let threshold = (0.9 * iz).min(0.01);
    if ng.dot(r) >= threshold {
        return n;
    }
    let x = (n - n.dot(ng) * ng).try_normalize().unwrap_or(n);
    let ix = i.dot(x);
    let a = ix * ix + iz * iz;
    let b = 2.0 * (a + iz * threshold);
    let c = (threshold + iz) * (threshold + iz);
    let disc = (b * b - 4.0 * a * c).max(0.0).sqrt();
    let nz2 = if ix < 0.0 { 0.25 * (b + disc) / a } else { 0.25 * (b - disc) / a };
    let nx = (1.0 - nz2).max(0.0).sqrt();
    let nz = nz2.max(0.0).sqrt();
    (nx * x + nz * ng).normalize_or(ng)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mapping_types() {
        let v = Vec3::new(1.0, 0.0, 0.0);
        let rot = Vec3::new(0.0, 0.0, std::f32::consts::FRAC_PI_2);
        let p = mapping(MappingType::Point, v, Vec3::new(0.0, 0.0, 1.0), rot, Vec3::splat(2.0));
        assert!((p - Vec3::new(0.0, 2.0, 1.0)).length() < 1e-6, "{p}");
        // Texture is the inverse of Point.
        let t = mapping(MappingType::Texture, p, Vec3::new(0.0, 0.0, 1.0), rot, Vec3::splat(2.0));
        assert!((t - v).length() < 1e-6, "{t}");
        let n =
            mapping(MappingType::Normal, Vec3::new(1.0, 1.0, 0.0), Vec3::ZERO, Vec3::ZERO, Vec3::new(2.0, 1.0, 1.0));
        assert!((n - Vec3::new(0.5, 1.0, 0.0).normalize()).length() < 1e-6);
        // Euler order: X first, then Y, then Z.
        let r = euler_to_mat3(Vec3::new(std::f32::consts::FRAC_PI_2, 0.0, std::f32::consts::FRAC_PI_2));
        assert!((r * Vec3::Y - Vec3::new(0.0, 0.0, 1.0)).length() < 1e-6, "{}", r * Vec3::Y);
    }

    #[test]
    fn normal_map_flat_colour_keeps_the_normal_and_tilts_along_the_tangent() {
        let sp = ShadingPoint::default();
        let mut o = [Vec3::ZERO];
        VectorOp::NormalMap(NormalMapSpace::Tangent, None).eval(&[Vec3::ONE, Vec3::new(0.5, 0.5, 1.0)], &mut o, &sp);
        assert!((o[0] - Vec3::Z).length() < 1e-6);
        VectorOp::NormalMap(NormalMapSpace::Tangent, None).eval(&[Vec3::ONE, Vec3::new(1.0, 0.5, 0.5)], &mut o, &sp);
        assert!((o[0] - Vec3::X).length() < 1e-6);
        VectorOp::NormalMap(NormalMapSpace::Tangent, None).eval(&[Vec3::ZERO, Vec3::new(1.0, 0.5, 0.5)], &mut o, &sp);
        assert!((o[0] - Vec3::Z).length() < 1e-6);
    }

    #[test]
    fn valid_specular_reflection_bends_the_normal_just_enough() {
        let ng = Vec3::Z;
        let i = Vec3::new(0.3, 0.0, 1.0).normalize();
        // A small tilt keeps its normal.
        let n = Vec3::new(0.2, 0.1, 1.0).normalize();
        assert_eq!(ensure_valid_specular_reflection(ng, i, n), n);
        // A tilt that mirrors i below the surface: bent so the mirror leaves at 0.01.
        for n in [
            Vec3::new(-1.5, 0.2, 1.0).normalize(),
            Vec3::new(2.0, 0.0, 0.3).normalize(),
            Vec3::new(0.0, 1.0, -0.2).normalize(),
        ] {
            let m = ensure_valid_specular_reflection(ng, i, n);
            let r = 2.0 * m.dot(i) * m - i;
            assert!((m.length() - 1.0).abs() < 1e-5 && (r.z - 0.01).abs() < 5e-4, "{n} -> {m}: r {r}");
            // Bent within the plane of n and ng.
            assert!(m.cross(ng).normalize().dot(n.cross(ng).normalize()) > 0.999, "{n} -> {m}");
        }
    }

    /// Against its definition, over random geometry: the corrected mirror direction is at
    /// least min(0.9·i·ng, 0.01) above the surface (Cycles' threshold), the normal is
    /// unchanged when its mirror already was, and a bent normal stays unit, in the plane
    /// of n and ng, and lifts the mirror exactly to the threshold.
    #[test]
    fn valid_specular_reflection_against_its_closed_form() {
        let mut rng = crate::sampling::Rng::new(3, 5);
        let unit = |rng: &mut crate::sampling::Rng| loop {
            let v = Vec3::new(rng.uniform() * 2.0 - 1.0, rng.uniform() * 2.0 - 1.0, rng.uniform() * 2.0 - 1.0);
            if (0.01..1.0).contains(&v.length_squared()) {
                return v.normalize();
            }
        };
        let (mut kept, mut bent) = (0, 0);
        for _ in 0..20_000 {
            let ng = unit(&mut rng);
            let mut i = unit(&mut rng);
            if i.dot(ng) < 0.0 {
                i = -i;
            }
            let n = unit(&mut rng);
            if n.dot(ng) < 0.05 {
                continue;
            }
            let t = (0.9 * i.dot(ng)).min(0.01);
            let m = ensure_valid_specular_reflection(ng, i, n);
            let r = 2.0 * m.dot(i) * m - i;
            if (2.0 * n.dot(i) * n - i).dot(ng) >= t {
                assert_eq!(m, n);
                kept += 1;
                continue;
            }
            bent += 1;
            assert!((m.length() - 1.0).abs() < 1e-4, "{m}");
            assert!(r.dot(ng) >= t - 2e-3, "ng {ng} i {i} n {n}: mirror {r} at {} < {t}", r.dot(ng));
            assert!((r.dot(ng) - t).abs() < 2e-3, "lifted to {} not {t}", r.dot(ng));
            assert!(m.dot(n.cross(ng)).abs() < 1e-3, "{m} leaves the plane of {n} and {ng}");
        }
        assert!(kept > 1000 && bent > 1000, "{kept} {bent}");
    }

    #[test]
    fn normal_map_strength_and_backfacing_follow_cycles_4_5() {
        // Cycles 4.5 CPU, a plane seen from above, Color (0.7, 0.4, 0.9), Strength 0.5:
        // (0.21566555, -0.10783277, 0.97049499).
        let sp = ShadingPoint::default();
        let n = normal_map(NormalMapSpace::Tangent, 0.5, Vec3::new(0.7, 0.4, 0.9), &sp, None);
        assert!((n - Vec3::new(0.21566555, -0.10783277, 0.970495)).length() < 1e-6, "{n}");
        // From behind: the same map mirrored through the surface.
        let back = ShadingPoint { normal: -Vec3::Z, backfacing: true, ..sp };
        let b = normal_map(NormalMapSpace::Tangent, 1.0, Vec3::new(0.7, 0.4, 0.9), &back, None);
        let f = normal_map(NormalMapSpace::Tangent, 1.0, Vec3::new(0.7, 0.4, 0.9), &sp, None);
        assert!((b + f).length() < 1e-6, "{b} vs {f}");
        let w = normal_map(NormalMapSpace::BlenderWorld, 1.0, Vec3::new(0.5, 0.0, 0.0), &sp, None);
        assert!((w - Vec3::new(0.0, 1.0, 1.0).normalize()).length() < 1e-6, "{w}");
    }
}
