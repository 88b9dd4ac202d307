//! Input nodes that read the hit: Texture Coordinate, UV Map, Geometry, Color Attribute,
//! Attribute, Object Info, Fresnel, Layer Weight (Cycles `kernel/svm/tex_coord.h`,
//! `geometry.h`, `attribute.h`, `fresnel.h`). Value and RGB are constants in the compiler.

use super::program::ShadingPoint;
use glam::Vec3;

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Input {
    /// Generated, Normal, UV, Object, Camera, Window, Reflection.
    TexCoord,
    /// UV of attribute slot `Some(k)`, or the default map.
    UvMap(Option<usize>),
    /// Position, Normal, Tangent, True Normal, Incoming, Parametric, Backfacing,
    /// Pointiness, Random Per Island.
    Geometry,
    /// Color, Alpha of a colour attribute slot.
    ColorAttribute(usize),
    /// Color, Vector, Fac, Alpha of an attribute slot.
    Attribute(usize),
    /// Location, Color, Alpha, Object Index, Material Index, Random.
    ObjectInfo,
    /// The Tangent node: the UV map's tangent, or radial about object axis `axis`
    /// (0, 1, 2: X, Y, Z) of the Generated coordinates.
    TangentNode {
        uv_map: bool,
        axis: u8,
        /// The attribute slot of the UV map's tangents (None: the mesh's default ones).
        slot: Option<usize>,
    },
    /// IOR, Normal → Fac.
    Fresnel,
    /// Blend, Normal → Fresnel, Facing.
    LayerWeight,
    /// One of the implicit defaults of an unlinked input (sockets.rs `Implicit`).
    Generated,
    Uv,
    Normal,
    Tangent,
    Incoming,
}

/// Cycles `fresnel_dielectric_cos`.
pub fn fresnel_dielectric_cos(cosi: f32, eta: f32) -> f32 {
    let c = cosi.abs();
    let g = eta * eta - 1.0 + c * c;
    if g > 0.0 {
        let g = g.sqrt();
        let a = (g - c) / (g + c);
        let b = (c * (g + c) - 1.0) / (c * (g - c) + 1.0);
        0.5 * a * a * (1.0 + b * b)
    } else {
        1.0
    }
}

/// The default of an unlinked Tangent input (Principled, Glossy): Cycles links it to
/// Geometry › Tangent (`ShaderGraph::default_inputs`, `SocketType::LINK_TANGENT`,
/// intern/cycles/scene/shader_graph.cpp), which is `primitive_tangent`
/// (kernel/geom/primitive.h): the radial tangent about the object's Z axis of the
/// Generated coordinates, (−(g.y − ½), g.x − ½, 0), taken to world space as a normal
/// (`object_normal_transform`) and projected onto the shading normal's plane,
/// cross(N, normalize(cross(t, N))). Zero on the Z axis itself.
pub fn radial_tangent(sp: &ShadingPoint) -> Vec3 {
    tangent_node(sp, false, 2, None)
}

/// Cycles' `svm_node_tangent` (kernel/svm/tex_coord.h): the object-space tangent, radial
/// about axis X (0, −(g.z − ½), g.y − ½), Y (−(g.z − ½), 0, g.x − ½) or Z
/// (−(g.y − ½), g.x − ½, 0) of the Generated coordinates g, or the UV map's tangent (the
/// mesh's, `ShadingPoint::tangent` taken back to object space), then taken to world
/// space as a normal (`object_normal_transform`) and projected on the shading normal's
/// plane, cross(N, normalize(cross(t, N))).
pub fn tangent_node(sp: &ShadingPoint, uv_map: bool, axis: u8, slot: Option<usize>) -> Vec3 {
    let g = sp.generated - Vec3::splat(0.5);
    let t = if uv_map {
        // World → object for a direction is mᵀ (m = L⁻ᵀ, the normal matrix).
        sp.normal_to_world.transpose() * sp.tangent_of(slot).0
    } else {
        match axis {
            0 => Vec3::new(0.0, -g.z, g.y),
            1 => Vec3::new(-g.z, 0.0, g.x),
            _ => Vec3::new(-g.y, g.x, 0.0),
        }
    };
    let t = sp.normal_to_world * t;
    sp.normal.cross(t.cross(sp.normal).normalize_or_zero())
}

fn f(x: f32) -> Vec3 {
    Vec3::new(x, 0.0, 0.0)
}

impl Input {
    pub fn eval(&self, i: &[Vec3], o: &mut [Vec3], sp: &ShadingPoint) {
        let attr = |k: usize| sp.attributes.get(k).copied().unwrap_or([0.0; 4]);
        match *self {
            Input::TexCoord => {
                o[0] = sp.generated;
                o[1] = (sp.normal_to_world.inverse() * sp.normal).normalize_or_zero();
                o[2] = sp.uv.extend(0.0);
                o[3] = sp.object_position;
                o[4] = sp.camera;
                o[5] = sp.window;
                // reflect(-I, N)
                o[6] = 2.0 * sp.normal.dot(sp.incoming) * sp.normal - sp.incoming;
            }
            Input::UvMap(slot) => {
                o[0] = match slot {
                    Some(k) => {
                        let a = attr(k);
                        Vec3::new(a[0], a[1], 0.0)
                    }
                    None => sp.uv.extend(0.0),
                }
            }
            Input::Geometry => {
                o[0] = sp.position;
                o[1] = sp.normal;
                o[2] = sp.tangent;
                o[3] = sp.true_normal;
                o[4] = sp.incoming;
                o[5] = Vec3::new(1.0 - sp.parametric.x - sp.parametric.y, sp.parametric.x, 0.0);
                o[6] = f(sp.backfacing as u8 as f32);
                o[7] = f(0.5);
                o[8] = f(0.0);
            }
            Input::ColorAttribute(k) => {
                let a = attr(k);
                o[0] = Vec3::new(a[0], a[1], a[2]);
                o[1] = f(a[3]);
            }
            Input::Attribute(k) => {
                let a = attr(k);
                let c = Vec3::new(a[0], a[1], a[2]);
                o[0] = c;
                o[1] = c;
                o[2] = f(super::color::gray(c));
                o[3] = f(a[3]);
            }
            Input::ObjectInfo => {
                o[0] = sp.object_location;
                let c = sp.object_color;
                o[1] = Vec3::new(c[0], c[1], c[2]);
                o[2] = f(c[3]);
                o[3] = f(sp.object_index);
                o[4] = f(sp.material_index);
                o[5] = f(sp.object_random);
            }
            Input::Fresnel => {
                // Cycles svm_node_fresnel
                let eta = i[0].x.max(1e-5);
                let eta = if sp.backfacing { 1.0 / eta } else { eta };
                o[0] = f(fresnel_dielectric_cos(sp.incoming.dot(i[1]), eta));
            }
            Input::LayerWeight => {
                // Cycles svm_node_layer_weight
                let blend = i[0].x;
                let n = i[1];
                let eta = (1.0 - blend).max(1e-5);
                let eta = if sp.backfacing { eta } else { 1.0 / eta };
                o[0] = f(fresnel_dielectric_cos(sp.incoming.dot(n), eta));
                let mut facing = sp.incoming.dot(n).abs();
                if blend != 0.5 {
                    let b = blend.clamp(0.0, 1.0 - 1e-5);
                    let b = if b < 0.5 { 2.0 * b } else { 0.5 / (1.0 - b) };
                    facing = facing.powf(b);
                }
                o[1] = f(1.0 - facing);
            }
            Input::Generated => o[0] = sp.generated,
            Input::Uv => o[0] = sp.uv.extend(0.0),
            Input::Normal => o[0] = sp.normal,
            Input::Tangent => o[0] = radial_tangent(sp),
            Input::TangentNode { uv_map, axis, slot } => o[0] = tangent_node(sp, uv_map, axis, slot),
            Input::Incoming => o[0] = -sp.incoming,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fresnel_at_normal_incidence_is_the_closed_form() {
        let r = fresnel_dielectric_cos(1.0, 1.5);
        assert!((r - 0.04).abs() < 1e-6, "{r}");
        assert_eq!(fresnel_dielectric_cos(0.1, 1.0 / 1.5), 1.0);
        let sp = ShadingPoint { incoming: Vec3::Z, normal: Vec3::Z, ..Default::default() };
        let mut o = [Vec3::ZERO; 2];
        Input::Fresnel.eval(&[Vec3::splat(1.5), Vec3::Z], &mut o, &sp);
        assert!((o[0].x - 0.04).abs() < 1e-6);
        // Layer weight at blend 0.5 seen head-on: facing 0, fresnel of eta 2 = 1/9.
        Input::LayerWeight.eval(&[Vec3::splat(0.5), Vec3::Z], &mut o, &sp);
        assert!((o[0].x - 1.0 / 9.0).abs() < 1e-6 && o[1].x.abs() < 1e-6, "{o:?}");
        let grazing = Vec3::new(0.8, 0.0, 0.6);
        let sp = ShadingPoint { incoming: grazing, ..sp };
        Input::LayerWeight.eval(&[Vec3::splat(0.25), Vec3::Z], &mut o, &sp);
        assert!((o[1].x - (1.0 - 0.6f32.powf(0.5))).abs() < 1e-6);
    }

    /// Cycles' default tangent: on a sphere about the object's origin (Generated 0..1
    /// across its bounding box) it runs along the parallels, eastwards about +Z, and it
    /// is taken to world space as a normal is.
    #[test]
    fn radial_tangent_runs_along_the_parallels_about_z() {
        let sp = ShadingPoint { generated: Vec3::new(1.0, 0.5, 0.5), normal: Vec3::X, ..Default::default() };
        assert!((radial_tangent(&sp) - Vec3::Y).length() < 1e-6, "{}", radial_tangent(&sp));
        let n = Vec3::new(-1.0, -1.0, 1.0).normalize();
        let sp = ShadingPoint { generated: Vec3::new(0.0, 0.0, 1.0), normal: n, ..Default::default() };
        let t = radial_tangent(&sp);
        assert!((t - Vec3::new(1.0, -1.0, 0.0).normalize()).length() < 1e-6 && t.dot(n).abs() < 1e-6, "{t}");
        // An object turned 90° about Z: the tangent turns with it.
        let m = glam::Mat3::from_rotation_z(std::f32::consts::FRAC_PI_2);
        let sp = ShadingPoint {
            generated: Vec3::new(1.0, 0.5, 0.5),
            normal: Vec3::Y,
            normal_to_world: m,
            ..Default::default()
        };
        assert!((radial_tangent(&sp) + Vec3::X).length() < 1e-6, "{}", radial_tangent(&sp));
        // On the axis itself there is none.
        let sp = ShadingPoint { generated: Vec3::new(0.5, 0.5, 1.0), normal: Vec3::Z, ..Default::default() };
        assert_eq!(radial_tangent(&sp), Vec3::ZERO);
        // The Tangent node: radial about X, and the UV map's (mesh) tangent projected.
        let sp = ShadingPoint { generated: Vec3::new(0.5, 1.0, 0.5), normal: Vec3::Y, ..Default::default() };
        assert!((tangent_node(&sp, false, 0, None) - Vec3::Z).length() < 1e-6, "{}", tangent_node(&sp, false, 0, None));
        let sp = ShadingPoint { normal: Vec3::Z, tangent: Vec3::new(1.0, 1.0, 0.5), ..Default::default() };
        assert!((tangent_node(&sp, true, 2, None) - Vec3::new(1.0, 1.0, 0.0).normalize()).length() < 1e-6);
        // A named UV map's own tangent set (attribute slot 1), taken to world space by the
        // object's transform and projected; its bitangent sign goes with it. An empty slot
        // (the mesh lacks that map's set) reads the default tangents.
        let mut sp = ShadingPoint {
            normal: Vec3::Z,
            tangent: Vec3::X,
            tangent_sign: 1.0,
            normal_to_world: glam::Mat3::from_rotation_z(std::f32::consts::FRAC_PI_2),
            ..Default::default()
        };
        sp.attributes[1] = [1.0, 0.0, 0.3, -1.0];
        let (t, sign) = sp.tangent_of(Some(1));
        assert!((t - Vec3::Y).length() < 1e-6 && sign == -1.0, "{t} {sign}");
        assert!((tangent_node(&sp, true, 2, Some(1)) - Vec3::Y).length() < 1e-6);
        assert!((tangent_node(&sp, true, 2, Some(2)) - Vec3::X).length() < 1e-6);
        assert_eq!(sp.tangent_of(None), (Vec3::X, 1.0));
        let mut o = [Vec3::ZERO];
        Input::Tangent.eval(
            &[],
            &mut o,
            &ShadingPoint { generated: Vec3::new(1.0, 0.5, 0.5), normal: Vec3::X, ..Default::default() },
        );
        assert!((o[0] - Vec3::Y).length() < 1e-6);
    }
}
