//! Vector nodes: Mapping (Cycles `kernel/svm/mapping_util.h`) and Normal Map
//! (`kernel/svm/normal_map.h` in `tex_coord.h`).

use super::math::{safe_divide, safe_normalize};
use super::program::ShadingPoint;
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
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum VectorOp {
    /// Vector, Location, Rotation, Scale → Vector.
    Mapping(MappingType),
    /// Strength, Color → Normal.
    NormalMap(NormalMapSpace),
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
        matches!(self, VectorOp::NormalMap(_))
    }

    pub fn eval(&self, i: &[Vec3], o: &mut [Vec3], sp: &ShadingPoint) {
        match *self {
            VectorOp::Mapping(ty) => o[0] = mapping(ty, i[0], i[1], i[2], i[3]),
            VectorOp::NormalMap(space) => {
                // Cycles svm_node_normal_map
                let strength = i[0].x;
                let color = 2.0 * (i[1] - Vec3::splat(0.5));
                let n0 = sp.normal;
                let mut n = match space {
                    NormalMapSpace::Tangent => {
                        let t = sp.tangent;
                        let b = sp.tangent_sign * n0.cross(t);
                        safe_normalize(color.x * t + color.y * b + color.z * n0)
                    }
                    NormalMapSpace::Object => safe_normalize(sp.normal_to_world * color),
                    NormalMapSpace::World => safe_normalize(color),
                };
                if strength != 1.0 {
                    let s = strength.max(0.0);
                    n = safe_normalize(n0 + (n - n0) * s);
                }
                if n == Vec3::ZERO {
                    n = n0;
                }
                o[0] = n;
            }
        }
    }
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
        VectorOp::NormalMap(NormalMapSpace::Tangent).eval(&[Vec3::ONE, Vec3::new(0.5, 0.5, 1.0)], &mut o, &sp);
        assert!((o[0] - Vec3::Z).length() < 1e-6);
        VectorOp::NormalMap(NormalMapSpace::Tangent).eval(&[Vec3::ONE, Vec3::new(1.0, 0.5, 0.5)], &mut o, &sp);
        assert!((o[0] - Vec3::X).length() < 1e-6);
        VectorOp::NormalMap(NormalMapSpace::Tangent).eval(&[Vec3::ZERO, Vec3::new(1.0, 0.5, 0.5)], &mut o, &sp);
        assert!((o[0] - Vec3::Z).length() < 1e-6);
    }
}
