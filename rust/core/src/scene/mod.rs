//! The renderable scene: a [`SceneDesc`] compiled against one wavelength grid, with
//! every spectrum evaluated, every mesh validated, the BVH built and the lights' power
//! distribution ready.

pub mod desc;
pub mod hit;
pub mod layered;
pub mod media;
pub mod optics;

use crate::accel::{Accel, Hit};
use crate::camera::{affine_from_rows, Camera};
use crate::color::uplift::{Uplift, UpliftMethod};
use crate::color::{Observer, RgbSpace};
use crate::geometry::{Instance, Mesh, Ray};
use crate::light::{AreaTriangle, ImageEnvironment, Light, PointLight, UniformEnvironment};
use crate::material::{Bsdf, Diffuse, Material, SpectralParam, Texture};
use crate::sampling::Distribution1D;
use crate::spectrum::named::{evaluate_for, RgbToSpectrum, SpectrumRole};
use crate::spectrum::{SampledSpectrum, WavelengthGrid};
use crate::{Error, Result};
pub use desc::*;
use glam::{Vec2, Vec3A};
use std::sync::Arc;

/// What the scene is rendered with that does not belong to the scene itself.
#[derive(Clone, Debug)]
pub struct BuildOptions {
    pub grid: WavelengthGrid,
    pub space: RgbSpace,
    pub uplift: UpliftMethod,
    pub width: u32,
    pub height: u32,
}

/// The geometry of a ray's hit, in world space.
#[derive(Clone, Copy, Debug)]
pub struct SurfaceInteraction {
    pub p: Vec3A,
    /// Unit geometric normal of the triangle (its winding side).
    pub ng: Vec3A,
    /// Unit shading normal, on the same side as `ng`.
    pub ns: Vec3A,
    pub uv: Vec2,
    /// Barycentrics of vertices 1 and 2 (per-vertex data for shading graphs).
    pub b1: f32,
    pub b2: f32,
    pub material: u32,
    pub instance: u32,
    pub triangle: u32,
    pub t: f32,
    /// The shutter time of the ray that found the hit (motion blur): the path goes on
    /// at it — its bounces, shadow rays and camera connections.
    pub time: f32,
}

/// The uniform world, kept beside its light for radiance lookups on escaped rays.
pub struct EnvironmentRef {
    pub light: usize,
    /// The uniform world's radiance (zero when `image` is set).
    pub radiance: SampledSpectrum,
    /// An HDRI world (converted to radiance per lookup), shared with its light.
    pub image: Option<Arc<ImageEnvironment>>,
}

impl EnvironmentRef {
    /// Radiance arriving from direction `d` (an escaped ray's direction): the uniform
    /// radiance, or the image's, converted into `scratch`.
    #[inline]
    pub fn radiance_along<'a>(&'a self, d: Vec3A, scratch: &'a mut SampledSpectrum) -> &'a SampledSpectrum {
        match &self.image {
            None => &self.radiance,
            Some(img) => {
                img.radiance_into(d, scratch);
                scratch
            }
        }
    }

    /// Radiance from direction `d` at grid wavelength `i` (monochromatic paths).
    pub fn radiance_at(&self, d: Vec3A, i: usize) -> f32 {
        match &self.image {
            None => self.radiance.get(i),
            Some(img) => {
                let mut s = SampledSpectrum::zeros(self.radiance.len());
                img.radiance_into(d, &mut s);
                s.get(i)
            }
        }
    }
}

/// Stochastic transparency (Cycles' transparent closure, `bsdf_transparent_setup` in
/// intern/cycles/kernel/closure/bsdf_transparent.h, and the Principled BSDF's Alpha,
/// which mixes a transparent closure of weight 1 − alpha in, svm_closure.h): a path
/// passes straight through with `probability` (its throughput × `tint`), else the
/// surface is shaded; shadow rays are attenuated by `probability × tint`.
/// A varying probability (a textured Principled Alpha) is evaluated at each hit from
/// the material's program reduced to the ops it depends on.
#[derive(Clone, Debug)]
pub struct PassThrough {
    pub probability: f32,
    pub tint: SampledSpectrum,
    pub varying: Option<VaryingPass>,
}

/// A pass probability read from a program register at each hit.
#[derive(Clone, Debug)]
pub struct VaryingPass {
    pub program: crate::shading::Program,
    pub probability: crate::shading::closure::PassProbability,
}

/// A material's normal read from a program register at each hit (its first linked
/// Normal input: Normal Map, Bump), the program reduced to the ops it depends on: the
/// Normal pass. Its closures are each shaded about their own normals.
#[derive(Clone, Debug)]
pub struct VaryingNormal {
    pub program: crate::shading::Program,
    pub reg: crate::shading::program::Reg,
}

impl VaryingNormal {
    /// The unit normal at `sp` (the shading point's own normal where the graph's is 0).
    pub fn at(&self, sp: &crate::shading::ShadingPoint) -> glam::Vec3 {
        PASS_REGS.with(|regs| {
            let mut regs = regs.borrow_mut();
            self.program.run(sp, &mut regs);
            regs[self.reg as usize].try_normalize().unwrap_or(sp.normal)
        })
    }
}

thread_local! {
    static PASS_REGS: std::cell::RefCell<Vec<glam::Vec3>> = const { std::cell::RefCell::new(Vec::new()) };
}

impl PassThrough {
    /// The probability that a path passes at hit `si` of `ray`.
    pub fn probability_at(&self, scene: &Scene, ray: &Ray, si: &SurfaceInteraction) -> f32 {
        let Some(v) = &self.varying else { return self.probability };
        let sp = scene.shading_point(ray, si, &v.program.attributes);
        PASS_REGS.with(|regs| {
            let mut regs = regs.borrow_mut();
            v.program.run(&sp, &mut regs);
            v.probability.at(&|r| regs[r as usize])
        })
    }
}

impl Scene {
    /// A camera path can make a pixel transparent: a Holdout closure, a holdout object
    /// or Film > Transparent (FORWARD then traces camera rays for the alpha alone).
    pub fn has_holdouts(&self) -> bool {
        self.film_transparent || self.holdout.iter().any(Option::is_some) || self.instances.iter().any(|i| i.holdout)
    }

    /// Camera rays that leave the scene can see light: an environment, or a hittable
    /// light at infinity (a sun with an angle) visible to the camera.
    pub fn sees_infinity(&self) -> bool {
        self.environment.is_some()
            || self.hit_lights.iter().any(|&l| {
                crate::geometry::visibility::sees(self.light_visibility[l], crate::geometry::visibility::CAMERA)
            })
    }
}

/// The ray visibility of an emitter on `inst`: a held-out object's light is never seen by
/// the camera (light paths connect nothing of it there; camera paths hold out where they
/// reach it).
fn seen_unless_held_out(inst: &crate::geometry::mesh::Instance) -> u8 {
    if inst.holdout {
        inst.visibility & !crate::geometry::visibility::CAMERA
    } else {
        inst.visibility
    }
}

/// Cycles' Holdout (`integrate_surface_holdout`, kernel/integrator/shade_surface.h):
/// where a camera path that has made only transparent bounces reaches a surface with
/// Holdout closures, the pixel's alpha loses the path's mean throughput × `weight` (the
/// holdout closures' summed weight), and a full holdout ends the path. Cycles' camera
/// rays carry PATH_RAY_TRANSPARENT_BACKGROUND whatever Film > Transparent says (that
/// setting only decides the background's alpha), so a holdout is black at alpha 0 with
/// an opaque film too (measured in Blender 4.5, tests/blender/test_bsdf_grid.py); seen
/// through a mirror or glass it is only black. The Holdout closure itself reflects
/// nothing. A weight that varies per hit (a Mix Shader's Fac from a texture) is
/// evaluated from the material's program and closure template.
#[derive(Clone, Debug)]
pub struct Holdout {
    pub weight: f32,
    pub varying: Option<(crate::shading::Program, crate::shading::closure::Template)>,
}

impl Holdout {
    /// The holdout weight at hit `si` of `ray`, in 0..1.
    pub fn weight_at(&self, scene: &Scene, ray: &Ray, si: &SurfaceInteraction) -> f32 {
        let Some((program, template)) = &self.varying else { return self.weight };
        let sp = scene.shading_point(ray, si, &program.attributes);
        PASS_REGS.with(|regs| {
            let mut regs = regs.borrow_mut();
            program.run(&sp, &mut regs);
            template.holdout_weight(&|r| regs[r as usize])
        })
    }
}

pub struct Scene {
    pub grid: WavelengthGrid,
    pub observer: Observer,
    pub space: RgbSpace,
    /// The RGB → spectrum map (eq. 10) for this grid; None when the grid is too coarse
    /// for one, in which case any RGB data in the scene is reported as an error.
    pub uplift: Option<Arc<Uplift>>,
    pub camera: Camera,
    pub meshes: Vec<Mesh>,
    pub instances: Vec<Instance>,
    pub accel: Accel,
    pub materials: Vec<Material>,
    pub lights: Vec<Box<dyn Light>>,
    /// Lights ∝ spectral power (eq. 7): where light paths start, and the light sample
    /// of BIDIRECTIONAL's camera paths (its MIS weights count both with one pmf).
    pub light_distribution: Distribution1D,
    /// The light sample of BACKWARD camera paths: the same, without a uniform world,
    /// which BSDF sampling finds as well as light sampling could (cosine or lobe-shaped
    /// directions against uniform ones) — so the other lights get all the samples and
    /// a uniform world under a sun is not noise. Cycles' world sampling on Auto does
    /// not sample a solid-colour world as a light either (a diffuse plane under one
    /// renders without noise there).
    pub nee_distribution: Distribution1D,
    /// The light choice of `nee_distribution`'s lights by the shading point: a tree
    /// over their bounds (`light::tree`, the `light_tree` setting).
    pub light_tree: crate::light::LightTree,
    /// For instances with emissive triangles: the light index of each triangle
    /// (u32::MAX where the triangle does not emit), for MIS on BSDF-sampled hits.
    pub triangle_lights: Vec<Option<Vec<u32>>>,
    pub environment: Option<EnvironmentRef>,
    /// Bytes held by textures and HDRIs (texels plus importance-sampling tables).
    pub texture_bytes: usize,
    /// Centre and radius of a sphere bounding all geometry.
    pub bounds_center: Vec3A,
    pub bounds_radius: f32,
    /// Instances whose emissive triangles deform or change scale over the shutter: they
    /// are not sampled as lights (next-event estimation, light paths), only found by
    /// paths that hit them. Emitters moved rigidly are lights carried by their keys.
    pub moving_emitters: Vec<String>,
    /// What the scene's description asked for and the build left out or approximated
    /// (unsupported nodes and node options), one line each.
    pub warnings: Vec<String>,
    /// Homogeneous media (docs/media.md), and per material the medium inside closed
    /// meshes that use it.
    pub media: Vec<crate::medium::HomogeneousMedium>,
    /// Per entry of `media`, its density grid when it is a grid medium (its entry in
    /// `media` holds the coefficients at density 1 and the phase function).
    pub medium_grid: Vec<Option<crate::medium::GridMedium>>,
    pub material_medium: Vec<Option<u32>>,
    /// The world's medium (index into `media`): fills all space, outside and inside meshes.
    pub world_medium: Option<u32>,
    /// The media around the camera, where camera paths start ([`Scene::media_at`]).
    pub camera_media: crate::medium::MediumStack,
    /// Per material: no surface, rays pass straight through (`BsdfDesc::Null`).
    pub null_surface: Vec<bool>,
    /// Per material: stochastic transparency (a top-level Transparent BSDF, Principled
    /// Alpha), see [`PassThrough`].
    pub pass_through: Vec<Option<PassThrough>>,
    /// Per material: its Holdout closures, if any ([`Holdout`]).
    pub holdout: Vec<Option<Holdout>>,
    /// Cycles' Film > Transparent: the background seen directly (through transparent
    /// bounces only) makes the film's alpha 0 there and adds no radiance.
    pub film_transparent: bool,
    /// Any medium, null surface or pass-through material ([`Scene::has_media`]), kept
    /// from the build: paths ask per vertex, and the materials may be thousands.
    has_media: bool,
    /// Per mesh: the named vertex data shading graphs read, and its bounds.
    pub mesh_data: Vec<hit::MeshShadingData>,
    /// Per light: the ray visibility of the instance it lies on (`visibility::ALL` for
    /// lights that are no geometry), so light paths do not show the camera an emitter
    /// camera rays pass through.
    pub light_visibility: Vec<u8>,
    /// The lights that are no geometry but that rays reach ([`Light::hittable`]: suns
    /// with an angle, sphere lights), which camera paths look for along every segment.
    pub hit_lights: Vec<usize>,
    /// The white Lambertian a subsurface walk leaves through (Cycles'
    /// `subsurface_shader_data_setup`), shaded at the exit point.
    pub subsurface_exit: Material,
}

/// The RGB → spectrum map while building: where the grid has none, the first RGB
/// colour evaluated becomes an error naming its object.
struct BuildUplift<'a> {
    uplift: std::result::Result<&'a Arc<Uplift>, String>,
    n: usize,
    used_missing: std::cell::Cell<bool>,
}

impl<'a> BuildUplift<'a> {
    fn new(uplift: std::result::Result<&'a Arc<Uplift>, &Error>, n: usize) -> Self {
        Self { uplift: uplift.map_err(|e| e.to_string()), n, used_missing: std::cell::Cell::new(false) }
    }

    fn evaluate(
        &self,
        d: &crate::spectrum::SpectrumDesc,
        grid: &WavelengthGrid,
        role: SpectrumRole,
        kind: &'static str,
        name: &str,
        what: &str,
    ) -> Result<Vec<f32>> {
        let v = evaluate_for(d, grid, role, self, kind, name, what)?;
        if self.used_missing.replace(false) {
            let why = self.uplift.as_ref().err().cloned().unwrap_or_default();
            return Err(Error::object(
                kind,
                name,
                format!("{what}: RGB colours cannot be used on this wavelength grid ({why})"),
            ));
        }
        Ok(v)
    }
}

impl RgbToSpectrum for BuildUplift<'_> {
    fn convert(&self, rgb: [f32; 3], role: SpectrumRole) -> Vec<f32> {
        match self.uplift {
            Ok(u) => u.convert(rgb, role),
            Err(_) => {
                self.used_missing.set(true);
                vec![0.0; self.n]
            }
        }
    }
}

/// The per-hit BSDF of a graph material whose closure inputs vary.
fn graph_bsdf(
    name: &str,
    compiled: &crate::shading::CompiledMaterial,
    grid: &WavelengthGrid,
    uplift: Option<&Arc<Uplift>>,
    textures: &[Arc<Texture>],
) -> Result<crate::shading::bsdf::GraphBsdf> {
    let Some(up) = uplift.cloned() else {
        return Err(Error::object(
            "material",
            name,
            "its node graph varies over the surface, which needs an RGB → spectrum map this wavelength grid lacks",
        ));
    };
    let (grid, textures, name) = (grid.clone(), textures.to_vec(), name.to_string());
    let build = move |d: &BsdfDesc| -> Result<Box<dyn Bsdf>> {
        let rgb = BuildUplift::new(Ok(&up), grid.len());
        let b = layered::BsdfBuild { grid: &grid, rgb: &rgb, textures: &textures, uplift: Some(&up) };
        layered::build_bsdf(&b, &name, d)
    };
    crate::shading::bsdf::GraphBsdf::new(
        compiled.program.clone(),
        compiled.template.clone(),
        Box::new(build),
        // Lobe normals and anisotropic tangents are placed in the vertex's frame.
        compiled.normal.is_some() || compiled.template.needs_tangent(),
    )
}

fn buffer_f32<'a>(buffers: &[BufferView<'a>], i: usize, mesh: &str, what: &str) -> Result<&'a [f32]> {
    match buffers.get(i) {
        Some(BufferView::F32(v)) => Ok(v),
        Some(BufferView::U32(_)) => {
            Err(Error::object("mesh", mesh, format!("{what} buffer {i} holds integers, expected floats")))
        }
        Some(BufferView::U8(_)) => {
            Err(Error::object("mesh", mesh, format!("{what} buffer {i} holds bytes, expected floats")))
        }
        None => Err(Error::object("mesh", mesh, format!("{what} buffer {i} does not exist"))),
    }
}

fn buffer_u32<'a>(buffers: &[BufferView<'a>], i: usize, mesh: &str, what: &str) -> Result<&'a [u32]> {
    match buffers.get(i) {
        Some(BufferView::U32(v)) => Ok(v),
        Some(BufferView::F32(_)) => {
            Err(Error::object("mesh", mesh, format!("{what} buffer {i} holds floats, expected integers")))
        }
        Some(BufferView::U8(_)) => {
            Err(Error::object("mesh", mesh, format!("{what} buffer {i} holds bytes, expected 32-bit integers")))
        }
        None => Err(Error::object("mesh", mesh, format!("{what} buffer {i} does not exist"))),
    }
}

impl Scene {
    pub fn build<B: AsBufferView>(desc: &SceneDesc, buffers: &[B], opts: &BuildOptions) -> Result<Self> {
        let views: Vec<BufferView> = buffers.iter().map(|b| b.view()).collect();
        Self::build_from(desc, &views, opts)
    }

    fn build_from(desc: &SceneDesc, buffers: &[BufferView], opts: &BuildOptions) -> Result<Self> {
        let grid = opts.grid.clone();
        let n = grid.len();
        let uplift_result = Uplift::new(&grid, &opts.space, opts.uplift).map(Arc::new);
        let rgb = BuildUplift::new(uplift_result.as_ref(), n);
        let uplift = uplift_result.as_ref().ok().cloned();
        let camera = Camera::new(&desc.camera, opts.width, opts.height)?;

        // Textures: kept RGB, converted at each hit (docs/design.md#rgb-data).
        let textures: Vec<Arc<Texture>> =
            desc.textures.iter().map(|t| Texture::from_desc(t, buffers).map(Arc::new)).collect::<Result<_>>()?;

        // Materials.
        let mut materials = Vec::with_capacity(desc.materials.len().max(1));
        let mut warnings = Vec::new();
        let (mut media, mut material_medium, mut null_surface) = (Vec::new(), Vec::new(), Vec::new());
        let mut medium_grid = Vec::new();
        let mut pass_through = Vec::new();
        let mut holdout = Vec::new();
        for m in &desc.materials {
            let spectrum = |d, role, what| -> Result<SampledSpectrum> {
                Ok(SampledSpectrum::from_slice(&rgb.evaluate(d, &grid, role, "material", &m.name, what)?))
            };
            // A node graph that folds to constants is built as the fixed material it equals.
            let (compiled, constant);
            let mut per_hit = None;
            let mut hit_attributes = None;
            let mut transparency = None;
            let mut material_holdout = None;
            let mut compiled_program = None;
            let opaque_rest;
            let mut graph_emission = None;
            let mut normal = None;
            let (bsdf_desc, emission_desc) = match &m.bsdf {
                BsdfDesc::Graph(g) => {
                    compiled = crate::shading::compile_material(&m.name, g, &textures)?;
                    warnings.extend(compiled.warnings.iter().cloned());
                    if let Some(terms) = &compiled.varying_emission {
                        let Some(up) = &uplift else {
                            return Err(Error::object(
                                "material",
                                &m.name,
                                "its emission varies over the surface, which needs an RGB → spectrum map this wavelength grid lacks",
                            ));
                        };
                        graph_emission = Some(Arc::new(crate::shading::emission::GraphEmission {
                            program: compiled.program.clone(),
                            terms: terms.clone(),
                            uplift: up.clone(),
                        }));
                        hit_attributes = Some(compiled.program.attributes.clone());
                        if m.one_sided {
                            warnings.push(format!(
                                "material '{}': one_sided is not applied to an emission that varies over the \
                                 surface (it emits from both faces)",
                                m.name
                            ));
                        }
                    }
                    constant = compiled.constant_surface().unwrap_or(BsdfDesc::None);
                    if !compiled.template.is_constant() {
                        per_hit = Some(self::graph_bsdf(&m.name, &compiled, &grid, uplift.as_ref(), &textures)?);
                        hit_attributes = Some(compiled.program.attributes.clone());
                    }
                    if let Some(reg) = compiled.normal {
                        normal = Some(VaryingNormal { program: compiled.program.pruned_for(reg), reg });
                        hit_attributes = Some(compiled.program.attributes.clone());
                    }
                    transparency = compiled.transparency.clone();
                    material_holdout = compiled.template.has_holdout().then(|| {
                        let init = &compiled.program.init;
                        Holdout {
                            weight: compiled.template.holdout_weight(&|r| init[r as usize]),
                            varying: (!compiled.template.is_constant())
                                .then(|| (compiled.program.clone(), compiled.template.clone())),
                        }
                    });
                    compiled_program = Some(&compiled.program);
                    (&constant, compiled.emission.as_ref())
                }
                d => match d.split_transparent() {
                    Some((p, color, rest)) => {
                        transparency = Some((crate::shading::closure::PassProbability::Constant(p), color));
                        opaque_rest = rest;
                        (&opaque_rest, m.emission.as_ref())
                    }
                    None => (d, m.emission.as_ref()),
                },
            };
            if bsdf_desc.has_transparent() {
                warnings.push(format!(
                    "material '{}': a Transparent BSDF that is not the material's top closure (or one side of a \
                     constant Mix Shader there) is not supported yet; it reflects nothing",
                    m.name
                ));
            }
            holdout.push(material_holdout);
            let varying = match (&transparency, &compiled_program) {
                (Some((p @ crate::shading::closure::PassProbability::Register { reg, .. }, _)), Some(program)) => {
                    Some(VaryingPass { program: program.pruned_for(*reg), probability: *p })
                }
                _ => None,
            };
            pass_through.push(match transparency {
                Some((p, color)) if varying.is_some() || p.at(&|_| glam::Vec3::ZERO) > 0.0 => Some(PassThrough {
                    probability: p.at(&|_| glam::Vec3::ZERO),
                    varying,
                    tint: {
                        let mut t = SampledSpectrum::from_slice(&rgb.evaluate(
                            &color,
                            &grid,
                            SpectrumRole::Reflectance,
                            "material",
                            &m.name,
                            "transparent colour",
                        )?);
                        t.values_mut()
                            .iter_mut()
                            .for_each(|x| *x = if x.is_finite() { x.clamp(0.0, 1.0) } else { 0.0 });
                        t
                    },
                }),
                _ => None,
            });
            // One builder for every material: a fixed description, a graph folded to
            // constants at load, and (per hit, through `GraphBsdf`) a varying graph's
            // instantiated description all go through `layered::build_bsdf`.
            let bsdf: Box<dyn Bsdf> = match per_hit.take() {
                Some(g) => Box::new(g),
                None => {
                    let b = layered::BsdfBuild { grid: &grid, rgb: &rgb, textures: &textures, uplift: uplift.as_ref() };
                    layered::build_bsdf(&b, &m.name, bsdf_desc)?
                }
            };
            let emission = match emission_desc {
                Some(e) => Some(spectrum(e, SpectrumRole::Illuminant, "emission")?).filter(|s| !s.is_black()),
                None => None,
            };
            materials.push(Material {
                name: m.name.clone(),
                bsdf,
                emission,
                one_sided: m.one_sided,
                see_through: m.see_through,
                hit_attributes,
                graph_emission,
                normal,
            });
            // A graph with a volume and no surface is volume-only (Cycles' SD_HAS_ONLY_VOLUME).
            null_surface.push(match &m.bsdf {
                BsdfDesc::Null => true,
                BsdfDesc::Graph(g) => g.output.surface.is_none() && m.volume.is_some(),
                _ => false,
            });
            material_medium.push(match &m.volume {
                Some(v) => media::build_medium("material", &m.name, v, |d, role, what| {
                    Ok(SampledSpectrum::from_slice(&rgb.evaluate(d, &grid, role, "material", &m.name, what)?))
                })?
                .map(|(medium, grid)| {
                    media.push(medium);
                    medium_grid.push(grid);
                    media.len() as u32 - 1
                }),
                None => None,
            });
        }
        if materials.is_empty() {
            let grey = SampledSpectrum::splat(n, 0.8);
            materials.push(Material {
                name: "default".into(),
                bsdf: Box::new(Diffuse { reflectance: SpectralParam::Constant(grey) }),
                emission: None,
                one_sided: false,
                see_through: false,
                hit_attributes: None,
                graph_emission: None,
                normal: None,
            });
            material_medium.push(None);
            null_surface.push(false);
            pass_through.push(None);
            holdout.push(None);
        }

        // Meshes.
        let mut meshes = Vec::with_capacity(desc.meshes.len());
        let mut mesh_data = Vec::with_capacity(desc.meshes.len());
        for md in &desc.meshes {
            let name = md.name.as_str();
            let positions = buffer_f32(buffers, md.vertices, name, "vertices")?;
            let indices = buffer_u32(buffers, md.triangles, name, "triangles")?;
            let normals = md.normals.map(|i| buffer_f32(buffers, i, name, "normals")).transpose()?;
            let uvs = md.uvs.map(|i| buffer_f32(buffers, i, name, "uvs")).transpose()?;
            let nt = indices.len() / 3;
            let ids: Vec<u32> = match (md.material_ids, md.material) {
                (Some(i), _) => buffer_u32(buffers, i, name, "material_ids")?.to_vec(),
                (None, m) => vec![m.unwrap_or(0); nt],
            };
            if let Some(&bad) = ids.iter().find(|&&k| k as usize >= materials.len()) {
                return Err(Error::object(
                    "mesh",
                    name,
                    format!("uses material {bad} but the scene has {} materials", materials.len()),
                ));
            }
            let mut mesh = Mesh::from_buffers(name, positions, indices, normals, uvs, &ids)?;
            if !md.motion_vertices.is_empty() {
                let keys: Vec<&[f32]> = md
                    .motion_vertices
                    .iter()
                    .map(|&i| buffer_f32(buffers, i, name, "motion_vertices"))
                    .collect::<Result<_>>()?;
                let normal_keys: Option<Vec<&[f32]>> = (!md.motion_normals.is_empty())
                    .then(|| {
                        md.motion_normals.iter().map(|&i| buffer_f32(buffers, i, name, "motion_normals")).collect()
                    })
                    .transpose()?;
                mesh.set_motion(&keys, normal_keys.as_deref())?;
            } else if !md.motion_normals.is_empty() {
                return Err(Error::object("mesh", name, "motion_normals given without motion_vertices"));
            }
            let mut data = hit::MeshShadingData::new(md, &mesh, buffers)?;
            // A mesh without tangents whose materials perturb the normal: smooth per-vertex
            // tangents of its default UVs (docs/shading.md, "Normal Map and Bump").
            if data.tangents.is_none()
                && mesh
                    .material_ids
                    .iter()
                    .any(|&m| materials.get(m as usize).is_some_and(|t: &Material| t.normal.is_some()))
            {
                data.tangents = hit::smooth_tangents(&mesh);
            }
            mesh_data.push(data);
            meshes.push(mesh);
        }

        // Instances.
        let mut instances: Vec<Instance> = match &desc.instances {
            None => (0..meshes.len())
                .map(|k| Instance::new(&meshes[k].name, k as u32, glam::Affine3A::IDENTITY))
                .collect::<Result<_>>()?,
            Some(list) => list
                .iter()
                .map(|i| {
                    if i.mesh as usize >= meshes.len() {
                        return Err(Error::object(
                            "instance",
                            &i.name,
                            format!("refers to mesh {} but the scene has {}", i.mesh, meshes.len()),
                        ));
                    }
                    let to_world = affine_from_rows(&i.transform);
                    let mut inst = if i.motion.is_empty() {
                        Instance::new(&i.name, i.mesh, to_world)?
                    } else {
                        let keys: Vec<glam::Affine3A> = i.motion.iter().map(affine_from_rows).collect();
                        Instance::with_motion(&i.name, i.mesh, to_world, &keys)?
                    };
                    inst.visibility = i.visibility.mask();
                    inst.holdout = i.holdout;
                    if let Some(r) = i.random {
                        if !(r.is_finite() && (0.0..=1.0).contains(&r)) {
                            return Err(Error::object("instance", &i.name, format!("random {r} must be in 0..1")));
                        }
                        inst.random = r;
                    }
                    Ok(inst)
                })
                .collect::<Result<_>>()?,
        };
        for inst in &mut instances {
            let ids = &meshes[inst.mesh as usize].material_ids;
            if !ids.is_empty() && ids.iter().all(|&m| materials.get(m as usize).is_some_and(|m| m.see_through)) {
                // See-through surfaces (Cycles' lights) never block shadow rays.
                inst.visibility &= !crate::geometry::visibility::SHADOW;
            }
        }
        // A transform can carry valid vertices out of range, which overflows the BVH's
        // boxes (obvhs panics): reject it naming the instance (found by proptest).
        for inst in &instances {
            let limit = crate::geometry::mesh::MAX_COORDINATE;
            let keys = inst.motion.as_ref().map_or(1, |m| m.key_count());
            if let Some(w) = (0..keys)
                .flat_map(|k| {
                    let t = if keys > 1 { k as f32 / (keys - 1) as f32 } else { 0.5 };
                    let m = inst.transforms_at(t).0;
                    meshes[inst.mesh as usize].all_positions().map(move |p| m.transform_point3a(p))
                })
                .find(|w| !(w.is_finite() && w.abs().max_element() <= limit))
            {
                return Err(Error::object(
                    "instance",
                    &inst.name,
                    format!("places a vertex at {w} (beyond ±{limit:e})"),
                ));
            }
        }
        let accel = Accel::build(&meshes, &instances);

        // Motion blur: rays get shutter times when anything moves.
        let mut camera = camera;
        if camera.moves()
            || meshes.iter().any(|m| m.motion.is_some())
            || instances.iter().any(|i| i.motion.is_some())
            || desc.lights.iter().any(|l| !l.motion().is_empty())
        {
            camera.enable_motion_blur();
        }

        // Scene bounds, for infinite lights (over the whole shutter).
        let (mut lo, mut hi) = (Vec3A::splat(f32::INFINITY), Vec3A::splat(f32::NEG_INFINITY));
        for inst in &instances {
            let keys = inst.motion.as_ref().map_or(1, |m| 16 * (m.key_count() - 1) + 1);
            for k in 0..keys {
                let m = inst.transforms_at(if keys > 1 { k as f32 / (keys - 1) as f32 } else { 0.5 }).0;
                for p in meshes[inst.mesh as usize].all_positions() {
                    let w = m.transform_point3a(p);
                    lo = lo.min(w);
                    hi = hi.max(w);
                }
            }
        }
        let (bounds_center, bounds_radius) =
            if lo.x <= hi.x { ((lo + hi) * 0.5, (hi - lo).length() * 0.5) } else { (Vec3A::ZERO, 1.0) };

        // Lights: emissive triangles, explicit lights, the world.
        let mut lights: Vec<Box<dyn Light>> = Vec::new();
        let mut triangle_lights = vec![None; instances.len()];
        let mut moving_emitters = Vec::new();
        let mut light_visibility = Vec::new();
        // Varying emitters' copies of their meshes (shared by the instances of one mesh).
        let mut emitter_meshes = std::collections::HashMap::new();
        for (k, inst) in instances.iter().enumerate() {
            let mesh = &meshes[inst.mesh as usize];
            let emits =
                |m: u32| materials[m as usize].emission.is_some() || materials[m as usize].graph_emission.is_some();
            if !mesh.material_ids.iter().any(|&m| emits(m)) {
                continue;
            }
            // An emitter moved rigidly by its instance's keys: its lights are built at the
            // frame and carried over the shutter (light/moving.rs), as moving lights. One
            // that deforms or changes scale is no light to sample: its triangles are
            // elsewhere at each path's time in ways no rigid motion follows. Paths that
            // hit it still see its emission (MIS weight 1, as for any emitter without a
            // light).
            let carried = match (&inst.motion, &mesh.motion) {
                (None, None) => None,
                (Some(m), None) if crate::light::MovingLight::moves_rigidly(m, &inst.to_world) => Some(m.clone()),
                _ => {
                    moving_emitters.push(inst.name.clone());
                    continue;
                }
            };
            let first_light = lights.len();
            let mut map = vec![u32::MAX; mesh.indices.len()];
            // Varying emitters: one light per (instance, material) over its triangles,
            // which samples a triangle by a cdf of cheap power estimates (docs/shading.md).
            let mut varying: Vec<(u32, Vec<(u32, [Vec3A; 3])>)> = Vec::new();
            for (t, &m) in mesh.material_ids.iter().enumerate() {
                let material = &materials[m as usize];
                let local = mesh.triangle(t);
                let p = local.map(|v| inst.to_world.transform_point3a(v));
                match (&material.emission, &material.graph_emission) {
                    (Some(e), _) => {
                        if let Some(mut tri) = AreaTriangle::new(p, e.clone()) {
                            if material.one_sided {
                                // The front is where the hit's geometric normal points (the
                                // object-space winding normal through the inverse transpose, which
                                // a mirroring transform does not turn around).
                                let ng = inst.normal_to_world * (local[1] - local[0]).cross(local[2] - local[0]);
                                tri.make_one_sided(ng.dot(tri.normal) < 0.0);
                            }
                            map[t] = lights.len() as u32;
                            lights.push(Box::new(tri));
                            light_visibility.push(seen_unless_held_out(inst));
                        }
                    }
                    (None, Some(_)) => match varying.iter_mut().find(|(vm, _)| *vm == m) {
                        Some((_, tris)) => tris.push((t as u32, p)),
                        None => varying.push((m, vec![(t as u32, p)])),
                    },
                    (None, None) => {}
                }
            }
            for (m, tris) in varying {
                let Some(g) = &materials[m as usize].graph_emission else { continue };
                let (mesh_arc, data_arc) = emitter_meshes
                    .entry(inst.mesh)
                    .or_insert_with(|| (Arc::new(mesh.clone()), Arc::new(mesh_data[inst.mesh as usize].clone())))
                    .clone();
                let surface = Arc::new(hit::MeshEmission {
                    emission: g.clone(),
                    instance: inst.clone(),
                    index: k as u32,
                    mesh: mesh_arc,
                    data: data_arc,
                });
                let ids: Vec<u32> = tris.iter().map(|t| t.0).collect();
                if let Some(light) = crate::light::MeshLight::new(tris, surface, grid.weights()) {
                    for t in ids {
                        map[t as usize] = lights.len() as u32;
                    }
                    lights.push(Box::new(light));
                    light_visibility.push(seen_unless_held_out(inst));
                }
            }
            if let Some(motion) = carried {
                let built: Vec<Box<dyn Light>> = lights.drain(first_light..).collect();
                for l in built {
                    lights.push(Box::new(crate::light::MovingLight::carried(l, motion.clone(), inst.to_world)));
                }
            }
            triangle_lights[k] = Some(map);
        }
        for l in &desc.lights {
            let visibility = match l {
                LightDesc::Point { visibility, .. }
                | LightDesc::Spot { visibility, .. }
                | LightDesc::Distant { visibility, .. } => visibility.mask(),
            };
            light_visibility.resize(lights.len(), crate::geometry::visibility::ALL);
            light_visibility.push(visibility);
            match l {
                LightDesc::Point { name, position, intensity, radius, profile, .. } => {
                    let position = Vec3A::from(*position);
                    if !position.is_finite() {
                        return Err(Error::object("light", name, "position is not finite"));
                    }
                    let radius = optics::light_radius(name, *radius)?;
                    let intensity =
                        rgb.evaluate(intensity, &grid, SpectrumRole::Illuminant, "light", name, "intensity")?;
                    lights.push(Box::new(PointLight {
                        position,
                        intensity: SampledSpectrum::from_slice(&intensity),
                        radius,
                        profile: profile.as_ref().map(|p| p.build(name)).transpose()?,
                    }));
                }
                LightDesc::Spot {
                    name,
                    position,
                    direction,
                    intensity,
                    spot_size,
                    spot_blend,
                    radius,
                    profile,
                    ..
                } => {
                    let intensity =
                        rgb.evaluate(intensity, &grid, SpectrumRole::Illuminant, "light", name, "intensity")?;
                    lights.push(optics::build_spot(
                        name,
                        *position,
                        *direction,
                        SampledSpectrum::from_slice(&intensity),
                        *spot_size,
                        *spot_blend,
                        *radius,
                        profile.as_ref().map(|p| p.build(name)).transpose()?,
                    )?);
                }
                LightDesc::Distant { name, direction, irradiance, angle, .. } => {
                    let irradiance =
                        rgb.evaluate(irradiance, &grid, SpectrumRole::Illuminant, "light", name, "irradiance")?;
                    lights.push(optics::build_distant(
                        name,
                        *direction,
                        SampledSpectrum::from_slice(&irradiance),
                        *angle,
                    )?);
                }
            }
            // A moving light: the light as built (at the frame) carried over the shutter
            // by its keys (light/moving.rs); a sun only turns, about the scene's centre.
            if !l.motion().is_empty() {
                let inner = lights.pop().expect("the light just built");
                let keys: Vec<glam::Affine3A> = l.motion().iter().map(affine_from_rows).collect();
                let moving = crate::light::MovingLight::new(l.name(), inner, l.frame(), &keys)?;
                let moving = if matches!(l, LightDesc::Distant { .. }) { moving.turning_only() } else { moving };
                lights.push(Box::new(moving));
            }
        }
        let environment = match &desc.world {
            None => None,
            Some(w) => match w.texture {
                Some(t) => {
                    let texture = textures.get(t).ok_or_else(|| {
                        Error::object(
                            "world",
                            "World",
                            format!("texture {t} does not exist ({} textures)", textures.len()),
                        )
                    })?;
                    let Some(up) = &uplift else {
                        return Err(Error::object("world", "World", format!("texture '{}': RGB images cannot be used on this wavelength grid (no RGB → spectrum map)", texture.name)));
                    };
                    if !(w.strength.is_finite() && w.strength >= 0.0 && w.rotation.is_finite()) {
                        return Err(Error::object(
                            "world",
                            "World",
                            format!(
                                "strength {} must be finite and non-negative, rotation {} finite",
                                w.strength, w.rotation
                            ),
                        ));
                    }
                    let mut img = ImageEnvironment::new(
                        texture.clone(),
                        up.clone(),
                        w.strength,
                        w.rotation,
                        w.importance_sampling,
                    );
                    // Before it is shared with the lookups of escaped rays.
                    img.preprocess(bounds_center, bounds_radius);
                    let img = Arc::new(img);
                    if w.strength == 0.0 {
                        None
                    } else {
                        lights.push(Box::new(img.clone()));
                        Some(EnvironmentRef {
                            light: lights.len() - 1,
                            radiance: SampledSpectrum::zeros(n),
                            image: Some(img),
                        })
                    }
                }
                None => {
                    let d = w.radiance.clone().unwrap_or_else(|| crate::spectrum::SpectrumDesc::constant(0.0));
                    let radiance = SampledSpectrum::from_slice(&rgb.evaluate(
                        &d,
                        &grid,
                        SpectrumRole::Illuminant,
                        "world",
                        "World",
                        "radiance",
                    )?);
                    if radiance.is_black() {
                        None
                    } else {
                        lights.push(Box::new(UniformEnvironment {
                            radiance: radiance.clone(),
                            scene_center: Vec3A::ZERO,
                            scene_radius: 1.0,
                        }));
                        Some(EnvironmentRef { light: lights.len() - 1, radiance, image: None })
                    }
                }
            },
        };
        light_visibility.resize(lights.len(), crate::geometry::visibility::ALL);
        // Every light learns the scene's bounding sphere (lights at infinity start their
        // light paths on a disk of its radius and count their power through it).
        for l in lights.iter_mut() {
            l.preprocess(bounds_center, bounds_radius);
        }
        // The world's medium (Blender's World > Volume), validated as a material's.
        let world_medium = match desc.world.as_ref().and_then(|w| w.volume.as_ref()) {
            Some(v) => media::build_medium("world", "World", v, |d, role, what| {
                Ok(SampledSpectrum::from_slice(&rgb.evaluate(d, &grid, role, "world", "World", what)?))
            })?
            .map(|(medium, grid)| {
                media.push(medium);
                medium_grid.push(grid);
                media.len() as u32 - 1
            }),
            None => None,
        };
        let texture_bytes = textures.iter().map(|t| t.bytes()).sum::<usize>()
            + environment.as_ref().and_then(|e| e.image.as_ref()).map_or(0, |i| i.bytes() - i.texture.bytes());
        let powers: Vec<f64> = lights.iter().map(|l| l.power(grid.weights())).collect();
        let light_distribution = Distribution1D::new(&powers);
        let mut nee_powers = powers.clone();
        if let Some(env) = environment.as_ref().filter(|e| e.image.is_none()) {
            nee_powers[env.light] = 0.0;
        }
        let nee_distribution = Distribution1D::new(&nee_powers);
        let light_bounds: Vec<_> = lights.iter().map(|l| l.bounds()).collect();
        let light_tree = crate::light::LightTree::new(&light_bounds, &nee_powers);
        let hit_lights = (0..lights.len()).filter(|&l| lights[l].hittable()).collect();

        let has_media =
            !media.is_empty() || null_surface.iter().any(|&b| b) || pass_through.iter().any(Option::is_some);
        let mut scene = Self {
            observer: Observer::new(&grid),
            grid,
            space: opts.space,
            uplift,
            camera,
            meshes,
            instances,
            accel,
            materials,
            lights,
            light_distribution,
            nee_distribution,
            light_tree,
            triangle_lights,
            environment,
            texture_bytes,
            bounds_center,
            bounds_radius,
            moving_emitters,
            warnings,
            media,
            medium_grid,
            material_medium,
            null_surface,
            pass_through,
            holdout,
            film_transparent: desc.film_transparent,
            has_media,
            mesh_data,
            light_visibility,
            hit_lights,
            world_medium,
            camera_media: crate::medium::MediumStack::default(),
            subsurface_exit: Material {
                name: "subsurface exit".into(),
                bsdf: Box::new(Diffuse { reflectance: SpectralParam::Constant(SampledSpectrum::splat(n, 1.0)) }),
                emission: None,
                one_sided: false,
                see_through: false,
                hit_attributes: None,
                graph_emission: None,
                normal: None,
            },
        };
        if scene.has_media() {
            scene.camera_media = scene.media_at(scene.camera.position(), 0.5);
        }
        Ok(scene)
    }

    /// Anything in the scene moves over the shutter (rays carry times).
    pub fn has_motion_blur(&self) -> bool {
        self.camera.has_motion_blur()
    }

    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        self.accel.intersect(&self.meshes, &self.instances, ray)
    }
    pub fn occluded(&self, ray: &Ray) -> bool {
        self.accel.occluded(&self.meshes, &self.instances, ray)
    }
    /// Closest hit of `ray` on instance `instance` alone, never on its triangle `skip`
    /// (a subsurface walk's boundary).
    pub fn intersect_instance(&self, ray: &Ray, instance: u32, skip: Option<u32>) -> Option<Hit> {
        self.accel.intersect_instance(&self.meshes, &self.instances, ray, instance, skip)
    }

    /// World-space geometry at a hit.
    pub fn interaction(&self, ray: &Ray, hit: &Hit) -> SurfaceInteraction {
        interaction_in(&self.instances, &self.meshes, ray, hit)
    }

    /// The light index of an emissive triangle, if it is one.
    pub fn triangle_light(&self, instance: u32, triangle: u32) -> Option<usize> {
        let map = self.triangle_lights[instance as usize].as_ref()?;
        let l = map[triangle as usize];
        (l != u32::MAX).then_some(l as usize)
    }
}

/// World-space geometry at a hit.
pub(crate) fn interaction_in(instances: &[Instance], meshes: &[Mesh], ray: &Ray, hit: &Hit) -> SurfaceInteraction {
    let inst = &instances[hit.instance as usize];
    interaction_of(inst, &meshes[inst.mesh as usize], ray, hit)
}

/// World-space geometry at a hit on `inst` (instance number `hit.instance`) of `mesh`.
pub(crate) fn interaction_of(inst: &Instance, mesh: &Mesh, ray: &Ray, hit: &Hit) -> SurfaceInteraction {
    let [i0, i1, i2] = mesh.indices[hit.triangle as usize].map(|i| i as usize);
    let (b1, b2) = (hit.b1, hit.b2);
    let b0 = 1.0 - b1 - b2;
    // Where the geometry is at the ray's time (motion blur).
    let (to_world, _, normal_to_world) = inst.transforms_at(ray.time);
    let [p0, p1, p2] = mesh.triangle_at(hit.triangle as usize, ray.time);
    let p_obj = p0 * b0 + p1 * b1 + p2 * b2;
    let p = to_world.transform_point3a(p_obj);
    let ng = (normal_to_world * (p1 - p0).cross(p2 - p0)).normalize_or_zero();
    let motion_normals = mesh.motion.as_ref().filter(|m| m.normals.is_some());
    let normal = |i: usize| match motion_normals {
        Some(m) => m.normal(i, ray.time).unwrap_or(Vec3A::ZERO),
        None => mesh.normals.as_ref().map_or(Vec3A::ZERO, |n| n[i]),
    };
    let ns = match &mesh.normals {
        Some(_) => {
            let s = (normal_to_world * (normal(i0) * b0 + normal(i1) * b1 + normal(i2) * b2)).normalize_or_zero();
            if s == Vec3A::ZERO {
                ng
            } else if s.dot(ng) < 0.0 {
                -s
            } else {
                s
            }
        }
        None => ng,
    };
    let uv = match &mesh.uvs {
        Some(uv) => uv[i0] * b0 + uv[i1] * b1 + uv[i2] * b2,
        None => Vec2::new(b1, b2),
    };
    // Fall back to the ray's position if the barycentric point lost precision.
    let p = if p.is_finite() { p } else { ray.at(hit.t) };
    SurfaceInteraction {
        p,
        ng,
        ns,
        uv,
        b1,
        b2,
        material: mesh.material_ids[hit.triangle as usize],
        instance: hit.instance,
        triangle: hit.triangle,
        t: hit.t,
        time: ray.time,
    }
}
