//! What a shading graph reads at a hit (docs/shading.md, "Mesh data a graph reads"):
//! the named per-vertex data of each mesh, and the [`ShadingPoint`] of a hit.

use super::{buffer_f32, MeshDesc, Scene, SurfaceInteraction};
use crate::geometry::{Instance, Mesh, Ray};
use crate::light::SurfaceEmission;
use crate::sampling::uniform_triangle;
use crate::shading::emission::GraphEmission;
use crate::shading::program::{AttributeRequest, Delta, ShadingPoint, MAX_ATTRIBUTES};
use crate::spectrum::SampledSpectrum;
use crate::{Error, Result};
use glam::{Mat3, Vec2, Vec3, Vec3A};
use std::sync::Arc;

/// Named per-vertex data of one mesh, RGBA per vertex (UV maps in xy, scalars in x).
#[derive(Clone, Default)]
pub struct MeshShadingData {
    pub bounds: (Vec3, Vec3),
    pub uv_maps: Vec<(String, Vec<[f32; 4]>)>,
    pub colors: Vec<(String, Vec<[f32; 4]>)>,
    pub attributes: Vec<(String, Vec<[f32; 4]>)>,
    /// Tangent xyz and bitangent sign per vertex (MikkTSpace from the front end, else
    /// [`smooth_tangents`] when a material perturbs the normal).
    pub tangents: Option<Vec<[f32; 4]>>,
    /// Tangent sets of named UV maps (the maps a Normal Map or Tangent node names).
    pub tangent_maps: Vec<(String, Vec<[f32; 4]>)>,
}

fn per_vertex(
    buffers: &[super::BufferView],
    i: usize,
    mesh: &str,
    what: &str,
    widths: &[usize],
    v: usize,
) -> Result<Vec<[f32; 4]>> {
    let data = buffer_f32(buffers, i, mesh, what)?;
    let Some(&w) = widths.iter().find(|&&w| data.len() == w * v) else {
        return Err(Error::object(
            "mesh",
            mesh,
            format!("{what}: buffer {i} holds {} floats, expected {v} vertices × {widths:?}", data.len()),
        ));
    };
    if data.iter().any(|x| !x.is_finite()) {
        return Err(Error::object("mesh", mesh, format!("{what}: non-finite value")));
    }
    Ok(data
        .chunks_exact(w)
        .map(|c| {
            let mut o = [0.0, 0.0, 0.0, 1.0];
            o[..w].copy_from_slice(c);
            if w == 1 {
                // A scalar reads as grey in Color and Vector outputs, as Blender does.
                o[1] = c[0];
                o[2] = c[0];
            }
            o
        })
        .collect())
}

impl MeshShadingData {
    pub fn new(md: &MeshDesc, mesh: &Mesh, buffers: &[super::BufferView]) -> Result<Self> {
        let v = mesh.positions.len();
        let name = md.name.as_str();
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for p in &mesh.positions {
            lo = lo.min(Vec3::from(*p));
            hi = hi.max(Vec3::from(*p));
        }
        let mut d = Self { bounds: (lo, hi), ..Default::default() };
        for (k, &i) in &md.uv_maps {
            d.uv_maps.push((k.clone(), per_vertex(buffers, i, name, &format!("uv map '{k}'"), &[2], v)?));
        }
        for (k, &i) in &md.colors {
            d.colors.push((k.clone(), per_vertex(buffers, i, name, &format!("colour '{k}'"), &[4, 3], v)?));
        }
        for (k, &i) in &md.attributes {
            d.attributes.push((k.clone(), per_vertex(buffers, i, name, &format!("attribute '{k}'"), &[1, 3, 4], v)?));
        }
        d.tangents = md.tangents.map(|i| per_vertex(buffers, i, name, "tangents", &[4], v)).transpose()?;
        for (k, &i) in &md.tangent_maps {
            d.tangent_maps
                .push((k.clone(), per_vertex(buffers, i, name, &format!("tangents of uv map '{k}'"), &[4], v)?));
        }
        Ok(d)
    }

    fn find<'a>(list: &'a [(String, Vec<[f32; 4]>)], name: &str) -> Option<&'a [[f32; 4]]> {
        list.iter().find(|(n, _)| n == name).map(|(_, v)| v.as_slice())
    }

    /// The data a request reads (None: the mesh lacks it, which reads 0 as in Blender).
    pub fn lookup(&self, r: &AttributeRequest) -> Option<&[[f32; 4]]> {
        match r {
            AttributeRequest::Uv(n) => Self::find(&self.uv_maps, n),
            AttributeRequest::Color(n) if n.is_empty() => self.colors.first().map(|(_, v)| v.as_slice()),
            AttributeRequest::Color(n) => Self::find(&self.colors, n),
            AttributeRequest::Generic(n) => Self::find(&self.attributes, n)
                .or_else(|| Self::find(&self.colors, n))
                .or_else(|| Self::find(&self.uv_maps, n)),
            AttributeRequest::Tangent(n) => Self::find(&self.tangent_maps, n),
            AttributeRequest::Differentials => None,
        }
    }
}

impl Scene {
    /// The shading point of a hit for a graph reading `requests`.
    pub fn shading_point(&self, ray: &Ray, si: &SurfaceInteraction, requests: &[AttributeRequest]) -> ShadingPoint {
        shading_point_in(&self.instances, &self.meshes, &self.mesh_data, ray, si, requests)
    }
}

/// Blender's automatic texture space of a mesh with bounds (lo, hi), as the corner and
/// extent Generated coordinates map to 0..1 (BKE_mesh_texspace_calc): an axis of zero
/// extent gets half-size 1 (a flat plane's Generated z is 0.5), one below 1e-5 gets 1e-5.
fn texture_space((lo, hi): (Vec3, Vec3)) -> (Vec3, Vec3) {
    let mid = 0.5 * (lo + hi);
    let half = (0.5 * (hi - lo)).to_array().map(|h| if h == 0.0 { 1.0 } else { h.max(1e-5) });
    let half = Vec3::from_array(half);
    (mid - half, 2.0 * half)
}

pub(crate) fn shading_point_in(
    instances: &[Instance],
    meshes: &[Mesh],
    mesh_data: &[MeshShadingData],
    ray: &Ray,
    si: &SurfaceInteraction,
    requests: &[AttributeRequest],
) -> ShadingPoint {
    let inst = &instances[si.instance as usize];
    shading_point_of(inst, &meshes[inst.mesh as usize], &mesh_data[inst.mesh as usize], ray, si, requests)
}

/// The shading point of a hit on `inst` (instance number `si.instance`), whose mesh
/// and shading data are `mesh` and `data`.
pub(crate) fn shading_point_of(
    inst: &Instance,
    mesh: &Mesh,
    data: &MeshShadingData,
    ray: &Ray,
    si: &SurfaceInteraction,
    requests: &[AttributeRequest],
) -> ShadingPoint {
    let (_, to_object, normal_to_world) = inst.transforms_at(ray.time);
    let [i0, i1, i2] = mesh.indices[si.triangle as usize].map(|i| i as usize);
    let (b1, b2) = (si.b1, si.b2);
    let b0 = 1.0 - b1 - b2;
    let lerp = |v: &[[f32; 4]]| -> [f32; 4] { std::array::from_fn(|c| v[i0][c] * b0 + v[i1][c] * b1 + v[i2][c] * b2) };
    let incoming = Vec3::from(-ray.direction);
    let backfacing = si.ng.dot(-ray.direction) < 0.0;
    let flip = |n: Vec3A| Vec3::from(if backfacing { -n } else { n });
    let normal = flip(si.ns);
    let object_position = Vec3::from(to_object.transform_point3a(si.p));
    let (lo, size) = texture_space(data.bounds);
    let generated = (object_position - lo) / size;
    let n2w = Mat3::from(normal_to_world);
    // Tangent: the mesh's MikkTSpace tangent or smooth_tangents', else the triangle's ∂p/∂u.
    let (tangent, tangent_sign) = match &data.tangents {
        Some(t) => {
            let t = lerp(t);
            let w = inst.transforms_at(ray.time).0;
            let tw = Vec3::from(w.transform_vector3a(Vec3A::new(t[0], t[1], t[2])));
            let tw = if tw.length_squared() > 1e-12 {
                tw
            } else {
                uv_tangent(inst, mesh, si, ray.time).unwrap_or_else(|| any_tangent(normal))
            };
            (tw, if t[3] < 0.0 { -1.0 } else { 1.0 })
        }
        None => (uv_tangent(inst, mesh, si, ray.time).unwrap_or_else(|| any_tangent(normal)), 1.0),
    };
    // Orthogonalise against the shading normal.
    let tangent = (tangent - normal * normal.dot(tangent)).try_normalize().unwrap_or_else(|| any_tangent(normal));
    let mut attributes = [[0.0; 4]; MAX_ATTRIBUTES];
    for (k, r) in requests.iter().enumerate().take(MAX_ATTRIBUTES) {
        if let Some(v) = data.lookup(r) {
            attributes[k] = lerp(v);
        }
    }
    let diff = if requests.contains(&AttributeRequest::Differentials) {
        differentials(inst, mesh, data, si, requests, ray.time)
    } else {
        [Delta::default(); 2]
    };
    ShadingPoint {
        diff,
        position: Vec3::from(si.p),
        object_position,
        generated,
        normal,
        true_normal: flip(si.ng),
        tangent,
        tangent_sign,
        incoming,
        backfacing,
        uv: si.uv,
        parametric: Vec2::new(b1, b2),
        camera: Vec3::ZERO,
        window: Vec3::ZERO,
        normal_to_world: n2w,
        object_location: Vec3::from(inst.transforms_at(ray.time).0.translation),
        object_color: [1.0; 4],
        object_index: si.instance as f32,
        material_index: si.material as f32,
        object_random: inst.random,
        attributes,
    }
}

/// Two steps across the hit's triangle for the Bump node (`ShadingPoint::diff`): along
/// its edges p1 − p0 and p2 − p0 by 10⁻³ of the mesh's bounding-box diagonal (at most a
/// quarter of the edge), with every interpolated quantity's change over that step (all
/// are linear in the barycentrics on a triangle).
fn differentials(
    inst: &Instance,
    mesh: &Mesh,
    data: &MeshShadingData,
    si: &SurfaceInteraction,
    requests: &[AttributeRequest],
    time: f32,
) -> [Delta; 2] {
    let [i0, i1, i2] = mesh.indices[si.triangle as usize].map(|i| i as usize);
    let [p0, p1, p2] = mesh.triangle_at(si.triangle as usize, time);
    let w = inst.transforms_at(time).0;
    let (lo, hi) = data.bounds;
    let size = hi - lo;
    let step = 1e-3 * size.length();
    std::array::from_fn(|k| {
        let (i, p) = if k == 0 { (i1, p1) } else { (i2, p2) };
        let e = p - p0;
        let len = e.length();
        if !(len > 0.0 && step > 0.0) {
            return Delta::default();
        }
        let s = (step / len).min(0.25);
        let de = Vec3::from(e) * s;
        let mut d = Delta {
            position: Vec3::from(w.transform_vector3a(e * s)),
            object_position: de,
            generated: de / texture_space(data.bounds).1,
            uv: mesh.uvs.as_ref().map_or(Vec2::ZERO, |uv| (uv[i] - uv[i0]) * s),
            attributes: [[0.0; 4]; MAX_ATTRIBUTES],
        };
        for (a, r) in d.attributes.iter_mut().zip(requests) {
            if let Some(v) = data.lookup(r) {
                *a = std::array::from_fn(|c| (v[i][c] - v[i0][c]) * s);
            }
        }
        d
    })
}

/// ∂p/∂u of the hit triangle from its default UVs, in world space.
fn uv_tangent(inst: &Instance, mesh: &Mesh, si: &SurfaceInteraction, time: f32) -> Option<Vec3> {
    let uvs = mesh.uvs.as_ref()?;
    let [i0, i1, i2] = mesh.indices[si.triangle as usize].map(|i| i as usize);
    let [p0, p1, p2] = mesh.triangle_at(si.triangle as usize, time);
    let (d1, d2) = (uvs[i1] - uvs[i0], uvs[i2] - uvs[i0]);
    let det = d1.x * d2.y - d1.y * d2.x;
    if det.abs() < 1e-12 {
        return None;
    }
    let t = ((p1 - p0) * d2.y - (p2 - p0) * d1.y) / det;
    let w = inst.transforms_at(time).0;
    Some(Vec3::from(w.transform_vector3a(t)))
}

/// Smooth per-vertex tangents (object space) and bitangent signs of a mesh's default
/// UVs, for a mesh given without tangents: each triangle's ∂p/∂u and ∂p/∂v, weighted by
/// the triangle's angle at the vertex, summed onto its vertices; the sum made orthogonal
/// to the vertex normal (Gram–Schmidt) and the sign that of (n × t) · Σ ∂p/∂v. Like
/// MikkTSpace (Mikkelsen 2008, the angle-weighted accumulation) but over the mesh's own
/// vertices: no splitting of vertices where tangents disagree, and triangles with
/// degenerate UVs add nothing (a vertex with no tangent reads the triangle's ∂p/∂u).
pub(crate) fn smooth_tangents(mesh: &Mesh) -> Option<Vec<[f32; 4]>> {
    let uvs = mesh.uvs.as_ref()?;
    let n = mesh.positions.len();
    let (mut ts, mut bs, mut ns) = (vec![Vec3::ZERO; n], vec![Vec3::ZERO; n], vec![Vec3::ZERO; n]);
    for tri in &mesh.indices {
        let idx = tri.map(|i| i as usize);
        let p = idx.map(|i| Vec3::from(mesh.positions[i]));
        let (e1, e2) = (p[1] - p[0], p[2] - p[0]);
        let (d1, d2) = (uvs[idx[1]] - uvs[idx[0]], uvs[idx[2]] - uvs[idx[0]]);
        let det = d1.x * d2.y - d1.y * d2.x;
        let face = e1.cross(e2);
        if det.abs() < 1e-12 || face.length_squared() == 0.0 {
            continue;
        }
        let t = ((e1 * d2.y - e2 * d1.y) / det).normalize_or_zero();
        let b = ((e2 * d1.x - e1 * d2.x) / det).normalize_or_zero();
        for k in 0..3 {
            let (a, c) = (p[(k + 1) % 3] - p[k], p[(k + 2) % 3] - p[k]);
            let angle = a.angle_between(c);
            if angle.is_finite() {
                ts[idx[k]] += t * angle;
                bs[idx[k]] += b * angle;
                ns[idx[k]] += face.normalize() * angle;
            }
        }
    }
    Some(
        (0..n)
            .map(|i| {
                let normal = mesh.normals.as_ref().map_or(ns[i], |v| Vec3::from(v[i])).normalize_or_zero();
                let t = (ts[i] - normal * normal.dot(ts[i])).normalize_or_zero();
                let sign = if normal.cross(t).dot(bs[i]) < 0.0 { -1.0 } else { 1.0 };
                [t.x, t.y, t.z, sign]
            })
            .collect(),
    )
}

fn any_tangent(n: Vec3) -> Vec3 {
    n.any_orthonormal_vector()
}

/// A varying emitter's surface as a [`crate::light::MeshLight`] samples it: the
/// emission's program run at the shading point of the sampled point, exactly as when a
/// path hits it there.
pub(crate) struct MeshEmission {
    pub emission: Arc<GraphEmission>,
    pub instance: Instance,
    /// The instance's number in the scene (Object Info › Random, Object Index).
    pub index: u32,
    pub mesh: Arc<Mesh>,
    pub data: Arc<MeshShadingData>,
}

impl MeshEmission {
    /// The shading point at barycentrics (b1, b2) of `triangle`, seen along `incoming`
    /// (None: from the front face).
    fn point(&self, triangle: u32, b1: f32, b2: f32, incoming: Option<Vec3A>) -> ShadingPoint {
        let hit = crate::accel::Hit { t: 1.0, instance: self.index, triangle, b1, b2 };
        let probe = Ray::new(Vec3A::ZERO, -incoming.unwrap_or(Vec3A::Z));
        let si = super::interaction_of(&self.instance, &self.mesh, &probe, &hit);
        let ray = match incoming {
            Some(_) => probe,
            None => Ray::new(si.p + si.ng, -si.ng),
        };
        shading_point_of(&self.instance, &self.mesh, &self.data, &ray, &si, self.emission.requests())
    }
}

impl SurfaceEmission for MeshEmission {
    fn radiance(&self, triangle: u32, b1: f32, b2: f32, incoming: Vec3A, out: &mut SampledSpectrum) {
        self.emission.radiance(&self.point(triangle, b1, b2, Some(incoming)), out);
    }
    fn estimate(&self, triangle: u32, strata: usize, out: &mut SampledSpectrum) {
        let s = strata.max(1);
        let mut sum = Vec3::ZERO;
        for i in 0..s {
            for j in 0..s {
                let (u, v) = ((i as f32 + 0.5) / s as f32, (j as f32 + 0.5) / s as f32);
                // One point: the centroid; more: square → triangle as the light samples.
                let (b1, b2) = if s == 1 { (1.0 / 3.0, 1.0 / 3.0) } else { uniform_triangle(Vec2::new(u, v)) };
                sum += self.emission.rgb(&self.point(triangle, b1, b2, None));
            }
        }
        let mean = sum / (s * s) as f32;
        self.emission.uplift.illuminant_into(mean.to_array(), out.values_mut());
    }
}
