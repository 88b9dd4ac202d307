//! AUTO's wavelength grid: the coarsest uniform grid (8..81 samples) on which every
//! (emitter × reflectance) pair of the scene keeps its colour within [`GRID_TOLERANCE`]
//! ΔE00 of a 1 nm reference, with extra samples at `centre + k·σ` (k = −3..3) around
//! every narrow-band emitter narrower than the grid step, so its colour is not moved to
//! the nearest uniform sample; scenes with RGB data keep a grid the uplift accepts.

use crate::color::delta_e::{de2000, lab};
use crate::color::uplift::{Uplift, UpliftMethod};
use crate::color::{Observer, RgbSpace};
use crate::material::IorDesc;
use crate::scene::{SceneDesc, SpectralItem, SpectrumUse};
use crate::spectrum::named::{NoRgb, RgbToSpectrum, SpectrumKind, SpectrumRole};
use crate::spectrum::{SpectrumDesc, WavelengthGrid};
use crate::Result;

/// Largest colour error (ΔE00, white at L* = 100) AUTO's grid may make on any
/// emitter × reflectance pair of the scene, against a 1 nm grid.
pub const GRID_TOLERANCE: f64 = 0.3;
/// Uniform grid sizes AUTO tries, coarsest first.
const CANDIDATES: [usize; 8] = [8, 12, 16, 24, 32, 41, 61, 81];

/// A spectrum of the scene and whether it emits.
#[derive(Clone)]
struct Found {
    spectrum: SpectrumDesc,
    emitter: bool,
}

/// What the scene description holds that decides the grid.
#[derive(Default)]
struct Holds {
    /// RGB data (RGB spectra or textures): judged through a fixed set of RGB colours, so
    /// the same colour given as RGB or as a one-texel texture gets the same grid.
    rgb: bool,
    /// A dielectric whose index varies with wavelength.
    dispersive: bool,
}

/// The scene's spectra that decide the grid, from the typed walk
/// [`SceneDesc::for_each_spectrum`]: emitters and other curves (reflectances, medium
/// coefficients); RGB and texture spectra, images and a graph's RGB colours mark RGB data
/// instead; conductor indices are not judged; a refracting surface whose index is not
/// constant marks dispersion.
fn collect(desc: &SceneDesc) -> (Vec<Found>, Holds) {
    let mut out = Vec::new();
    let mut holds = Holds::default();
    desc.for_each_spectrum(&mut |item| match item {
        SpectralItem::Spectrum(SpectrumUse::Index, _) => {}
        SpectralItem::Spectrum(u, sd) => {
            if matches!(sd.kind, SpectrumKind::Texture { .. } | SpectrumKind::Rgb { .. }) {
                holds.rgb = true;
            } else {
                out.push(Found { spectrum: sd.clone(), emitter: u == SpectrumUse::Emitter });
            }
        }
        SpectralItem::DielectricIor(ior) => holds.dispersive |= !matches!(ior, IorDesc::Constant { .. }),
        SpectralItem::RgbData => holds.rgb = true,
    });
    (out, holds)
}

/// Spectra evaluated on one grid: emitters and reflectances.
struct OnGrid {
    observer: Observer,
    emitters: Vec<Vec<f32>>,
    reflectances: Vec<Vec<f32>>,
}

fn on_grid(grid: &WavelengthGrid, found: &[Found], rgb_samples: &[[f32; 3]], uplift: UpliftMethod) -> Option<OnGrid> {
    let up = Uplift::new(grid, &RgbSpace::rec709(), uplift).ok();
    let needs_uplift = !rgb_samples.is_empty();
    if needs_uplift && up.is_none() {
        return None;
    }
    let conv: &dyn RgbToSpectrum = match &up {
        Some(u) => u,
        // No RGB colour is evaluated without an uplift (`needs_uplift` above).
        None => &NoRgb,
    };
    let mut emitters = Vec::new();
    let mut reflectances = vec![vec![1.0; grid.len()]];
    for f in found {
        let role = if f.emitter { SpectrumRole::Illuminant } else { SpectrumRole::Unbounded };
        let v = f.spectrum.evaluate(grid, role, conv).ok()?;
        if f.emitter {
            emitters.push(v);
        } else {
            reflectances.push(v);
        }
    }
    for &rgb in rgb_samples {
        reflectances.push(conv.convert(rgb, SpectrumRole::Reflectance));
    }
    if emitters.is_empty() {
        // No named emitter (e.g. only an HDRI): judge reflectances under D65.
        emitters.push(SpectrumDesc::new(SpectrumKind::D65).evaluate(grid, SpectrumRole::Illuminant, conv).ok()?);
    }
    Some(OnGrid { observer: Observer::new(grid), emitters, reflectances })
}

/// Largest ΔE00 between the colours of every emitter × reflectance pair on `a` and on
/// the reference `r`, each pair normalised so the emitter alone has Y = 1.
fn max_error(a: &OnGrid, r: &OnGrid) -> f64 {
    let mut worst = 0.0f64;
    for (ea, er) in a.emitters.iter().zip(&r.emitters) {
        let ya = a.observer.xyz(ea)[1];
        let yr = r.observer.xyz(er)[1];
        if !(ya > 0.0 && yr > 0.0) {
            continue;
        }
        for (ra, rr) in a.reflectances.iter().zip(&r.reflectances) {
            let pa: Vec<f32> = ea.iter().zip(ra).map(|(e, x)| e * x).collect();
            let pr: Vec<f32> = er.iter().zip(rr).map(|(e, x)| e * x).collect();
            // Normalised by the reference emitter's luminance: an energy error shows.
            let xa = a.observer.xyz(&pa).map(|v| v / yr);
            let xr = r.observer.xyz(&pr).map(|v| v / yr);
            worst = worst.max(de2000(lab(xa), lab(xr)));
        }
    }
    worst
}

/// Narrow bands (centre, σ) of the scene's emitters.
fn narrow_bands(found: &[Found]) -> Vec<(f32, f32)> {
    found
        .iter()
        .filter(|f| f.emitter)
        .filter_map(|f| match f.spectrum.kind {
            SpectrumKind::NarrowBand { center, width } if center.is_finite() && width > 0.0 => {
                Some((center, width / (8.0 * std::f32::consts::LN_2).sqrt()))
            }
            _ => None,
        })
        .collect()
}

/// A uniform grid of `n` samples on [min, max] with samples at c + k·σ (k = −3..3)
/// around each narrow band narrower than the grid step (uniform samples within 3.5σ of
/// the centre dropped).
fn refined(n: usize, min: f32, max: f32, bands: &[(f32, f32)]) -> Vec<f32> {
    let step = (max - min) / (n - 1) as f32;
    let mut l: Vec<f32> = (0..n).map(|i| min + step * i as f32).collect();
    for &(c, sigma) in bands {
        if 2.355 * sigma >= 2.0 * step || c < min || c > max {
            continue;
        }
        let sigma = sigma.max(0.02);
        l.retain(|&x| (x - c).abs() > 3.5 * sigma || x == min || x == max);
        for k in -3..=3 {
            let x = c + k as f32 * sigma;
            if x > min && x < max {
                l.push(x);
            }
        }
    }
    l.sort_by(|a, b| a.total_cmp(b));
    l.dedup_by(|a, b| (*a - *b).abs() < 0.01);
    l.truncate(crate::spectrum::grid::MAX_SAMPLES);
    l
}

/// AUTO's grid for a scene: the coarsest candidate within [`GRID_TOLERANCE`], refined
/// around narrow-band emitters, and the reasons.
pub fn auto_grid(desc: &SceneDesc, min: f32, max: f32, uplift: UpliftMethod) -> Result<(Vec<f32>, Vec<String>)> {
    let (found, holds) = collect(desc);
    grid_for(&found, &holds, min, max, uplift)
}

fn grid_for(
    found: &[Found],
    holds: &Holds,
    min: f32,
    max: f32,
    uplift: UpliftMethod,
) -> Result<(Vec<f32>, Vec<String>)> {
    let found = found.to_vec();
    // RGB data stands for arbitrary RGB: judge a few saturated colours.
    let rgb_samples: Vec<[f32; 3]> =
        if holds.rgb { vec![[0.8, 0.1, 0.1], [0.1, 0.8, 0.1], [0.1, 0.1, 0.8], [0.8, 0.8, 0.1]] } else { Vec::new() };
    let bands = narrow_bands(&found);
    let mut why = Vec::new();
    let n_ref =
        (((max - min) as usize) + 1).clamp(crate::spectrum::grid::MIN_SAMPLES, crate::spectrum::grid::MAX_SAMPLES);
    let fallback = || WavelengthGrid::uniform(41, min, max).map(|g| g.lambdas().to_vec());
    let reference = WavelengthGrid::uniform(n_ref, min, max)?;
    let Some(r) = on_grid(&reference, &found, &rgb_samples, uplift) else {
        why.push("grid: 41 uniform (the scene's spectra could not be judged on a 1 nm grid)".into());
        return Ok((fallback()?, why));
    };
    let mut best: Option<(Vec<f32>, f64, usize)> = None;
    // Dispersion spreads the wavelengths apart in space: a coarse grid would show as
    // separate coloured copies (banding) instead of a continuous spread.
    let floor = if holds.dispersive { 41 } else { 0 };
    for n in CANDIDATES.into_iter().filter(|&n| n >= floor) {
        let lambdas = refined(n, min, max, &bands);
        let Ok(g) = WavelengthGrid::from_wavelengths(lambdas.clone()) else {
            continue;
        };
        let Some(a) = on_grid(&g, &found, &rgb_samples, uplift) else {
            continue;
        };
        let err = max_error(&a, &r);
        if err <= GRID_TOLERANCE {
            best = Some((lambdas, err, n));
            break;
        }
        best = match best {
            Some(b) if b.1 <= err => Some(b),
            _ => Some((lambdas, err, n)),
        };
    }
    let Some((lambdas, err, n)) = best else {
        why.push("grid: 41 uniform (no candidate grid could be built)".into());
        return Ok((fallback()?, why));
    };
    why.push(format!(
        "grid: {} wavelengths ({} uniform{}): largest emitter×reflectance colour error {:.2} ΔE00 vs 1 nm{}",
        lambdas.len(),
        n,
        if bands.is_empty() { String::new() } else { format!(" + 7 around each of {} narrow band(s)", bands.len()) },
        err,
        if err > GRID_TOLERANCE { format!(" (above the {GRID_TOLERANCE} target even at 81)") } else { String::new() },
    ));
    if holds.dispersive {
        why.push("dispersive glass: at least 41 wavelengths, and wavelength collapse (eq. 9) at it".into());
    } else {
        why.push("nothing disperses: no path ever collapses to one wavelength".into());
    }
    if holds.rgb {
        why.push(format!("RGB data: the grid keeps the {uplift:?} uplift valid"));
    }
    Ok((lambdas, why))
}
#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{BsdfDesc, LightDesc, MaterialDesc, VolumeDesc, WorldDesc};

    #[test]
    fn refinement_brackets_a_narrow_band() {
        // σ = 1 nm: samples at 586..592 every nm replace the uniform ones within 3.5σ.
        let l = refined(41, 380.0, 780.0, &[(589.0, 1.0)]);
        let near: Vec<f32> = l.iter().copied().filter(|x| (x - 589.0).abs() < 3.5).collect();
        assert_eq!(near, vec![586.0, 587.0, 588.0, 589.0, 590.0, 591.0, 592.0]);
        assert!(l.contains(&580.0) && l.contains(&600.0));
        assert!(l.windows(2).all(|w| w[0] < w[1]));
        // A band wider than two grid steps needs no refinement.
        assert_eq!(refined(41, 380.0, 780.0, &[(589.0, 10.0)]).len(), 41);
    }

    fn point(intensity: SpectrumDesc) -> LightDesc {
        LightDesc::Point {
            name: "lamp".into(),
            position: [0.0, 0.0, 1.0],
            intensity,
            radius: 0.0,
            visibility: Default::default(),
            profile: None,
            motion: Vec::new(),
        }
    }

    fn material(bsdf: BsdfDesc) -> MaterialDesc {
        MaterialDesc { name: "m".into(), bsdf, emission: None, volume: None, one_sided: false, see_through: false }
    }

    fn diffuse(kind: SpectrumKind) -> BsdfDesc {
        BsdfDesc::Diffuse { reflectance: SpectrumDesc::new(kind) }
    }

    /// A smooth reflectance: a ramp from 0.1 at 400 nm to 0.9 at 700 nm.
    fn ramp() -> SpectrumKind {
        SpectrumKind::Tabulated { wavelengths: vec![400.0, 700.0], values: vec![0.1, 0.9] }
    }

    fn scene(materials: Vec<MaterialDesc>, lights: Vec<LightDesc>) -> SceneDesc {
        SceneDesc { materials, lights, ..Default::default() }
    }

    /// Scenes covering every kind of spectrum the walk meets.
    fn scenes() -> Vec<(&'static str, SceneDesc)> {
        let led = SpectrumDesc::new(SpectrumKind::NarrowBand { center: 589.0, width: 2.0 });
        let f11 = SpectrumDesc::new(SpectrumKind::Fluorescent { index: 11 });
        let rgb = SpectrumKind::Rgb { rgb: [0.8, 0.2, 0.1] };
        let glass = BsdfDesc::Dielectric { ior: IorDesc::Named { name: "N-BK7".into() }, roughness: 0.0 };
        let metal = BsdfDesc::Conductor {
            metal: None,
            eta: Some(SpectrumDesc::new(SpectrumKind::Rgb { rgb: [0.2, 0.4, 1.1] })),
            k: Some(SpectrumDesc::constant(3.0)),
            roughness: 0.1,
        };
        let mix = BsdfDesc::Mix { a: Box::new(metal), b: Box::new(diffuse(ramp())), factor: 0.5, factor_from: None };
        let mut emissive = material(BsdfDesc::None);
        emissive.emission = Some(led.clone());
        let mut medium = material(BsdfDesc::Null);
        medium.volume = Some(VolumeDesc {
            absorption: Some(SpectrumDesc::new(ramp())),
            scattering: Some(SpectrumDesc::constant(0.5)),
            anisotropy: 0.0,
            emission: None,
            density_grid: None,
        });
        let graph = crate::shading::GraphDesc {
            nodes: vec![crate::shading::NodeDesc {
                kind: "ShaderNodeBsdfDiffuse".into(),
                name: "d".into(),
                props: Default::default(),
                inputs: [(
                    "Color".to_string(),
                    crate::shading::InputDesc::Spectrum { spectrum: SpectrumDesc::new(ramp()) },
                )]
                .into(),
            }],
            output: crate::shading::OutputDesc { surface: Some((0, "BSDF".into())), ..Default::default() },
        };
        let world = WorldDesc {
            radiance: Some(SpectrumDesc::new(SpectrumKind::D65)),
            texture: None,
            strength: 1.0,
            rotation: 0.0,
            importance_sampling: true,
            volume: None,
        };
        vec![
            ("F11 × smooth", scene(vec![material(diffuse(ramp()))], vec![point(f11.clone())])),
            ("LED × smooth", scene(vec![material(diffuse(ramp()))], vec![point(led.clone())])),
            (
                "RGB only",
                scene(
                    vec![material(diffuse(rgb.clone()))],
                    vec![point(SpectrumDesc::new(SpectrumKind::Rgb { rgb: [1.0; 3] }))],
                ),
            ),
            ("glass under A", scene(vec![material(glass)], vec![point(SpectrumDesc::new(SpectrumKind::A))])),
            (
                "metal mix, emissive LED, medium, graph",
                SceneDesc {
                    world: Some(world),
                    ..scene(
                        vec![material(mix), emissive, medium, material(BsdfDesc::Graph(Box::new(graph)))],
                        vec![point(f11)],
                    )
                },
            ),
        ]
    }

    fn grid_of(d: &SceneDesc) -> Vec<f32> {
        auto_grid(d, 380.0, 780.0, UpliftMethod::default()).unwrap().0
    }

    fn node(kind: &str, inputs: Vec<(&str, crate::shading::InputDesc)>) -> crate::shading::NodeDesc {
        crate::shading::NodeDesc {
            kind: kind.into(),
            name: kind.into(),
            props: Default::default(),
            inputs: inputs.into_iter().map(|(k, v)| (k.to_string(), v)).collect(),
        }
    }

    fn graph_material(nodes: Vec<crate::shading::NodeDesc>, out: usize) -> MaterialDesc {
        let g = crate::shading::GraphDesc {
            nodes,
            output: crate::shading::OutputDesc { surface: Some((out, "BSDF".into())), ..Default::default() },
        };
        material(BsdfDesc::Graph(Box::new(g)))
    }

    /// A graph gets the grid of the same scene written without a graph: its emission
    /// spectrum counts as an emitter (the LED's line is sampled), its RGB colours as RGB
    /// data, a dispersive index on its Glass node as dispersion.
    #[test]
    fn graph_spectra_count_as_their_fixed_twins() {
        use crate::shading::InputDesc;
        let led = SpectrumDesc::new(SpectrumKind::NarrowBand { center: 589.0, width: 2.0 });
        let smooth = || InputDesc::Spectrum { spectrum: SpectrumDesc::new(ramp()) };
        // Narrow-band emission through an Emission node, a smooth diffuse lit by it.
        let emissive = graph_material(
            vec![node("ShaderNodeEmission", vec![("Color", InputDesc::Spectrum { spectrum: led.clone() })])],
            0,
        );
        let diffuse_graph = graph_material(vec![node("ShaderNodeBsdfDiffuse", vec![("Color", smooth())])], 0);
        let mut fixed_emitter = material(BsdfDesc::None);
        fixed_emitter.emission = Some(led.clone());
        let twin = scene(vec![material(diffuse(ramp())), fixed_emitter], vec![]);
        let g = grid_of(&scene(vec![diffuse_graph.clone(), emissive], vec![]));
        assert_eq!(g, grid_of(&twin));
        assert!(g.iter().any(|x| (x - 589.0).abs() < 0.01), "the LED line is sampled: {g:?}");

        // An RGB constant on a graph: the grid an RGB diffuse gets.
        let rgb = InputDesc::Array(vec![0.8, 0.1, 0.1, 1.0]);
        let f11 = || point(SpectrumDesc::new(SpectrumKind::Fluorescent { index: 11 }));
        let rgb_graph = graph_material(vec![node("ShaderNodeBsdfDiffuse", vec![("Color", rgb)])], 0);
        let rgb_twin = scene(vec![material(diffuse(SpectrumKind::Rgb { rgb: [0.8, 0.1, 0.1] }))], vec![f11()]);
        assert_eq!(grid_of(&scene(vec![rgb_graph], vec![f11()])), grid_of(&rgb_twin));
        // A spectral-only graph is not RGB data: the grid of its fixed twin.
        assert_eq!(
            grid_of(&scene(vec![diffuse_graph], vec![f11()])),
            grid_of(&scene(vec![material(diffuse(ramp()))], vec![f11()]))
        );

        // Dispersion: a Glass node or a transmissive Principled with N-BK7.
        let bk7 = || InputDesc::Ior { ior: IorDesc::Named { name: "N-BK7".into() } };
        let glass = graph_material(vec![node("ShaderNodeBsdfGlass", vec![("Color", smooth()), ("IOR", bk7())])], 0);
        assert!(grid_of(&scene(vec![glass], vec![f11()])).len() >= 41);
        let clear = |w: f32| {
            graph_material(
                vec![node(
                    "ShaderNodeBsdfPrincipled",
                    vec![("IOR", bk7()), ("Transmission Weight", InputDesc::Number(w))],
                )],
                0,
            )
        };
        assert!(grid_of(&scene(vec![clear(1.0)], vec![f11()])).len() >= 41);
        // Without transmission nothing refracts: the grid of an RGB diffuse (Base Color
        // is Blender's RGB default).
        assert_eq!(grid_of(&scene(vec![clear(0.0)], vec![f11()])), grid_of(&rgb_twin));
        // The fixed Principled too.
        let principled = |t: f32| BsdfDesc::Principled {
            base_color: SpectrumDesc::new(ramp()),
            metallic: 0.0,
            roughness: 0.0,
            ior: IorDesc::Named { name: "N-BK7".into() },
            transmission: t,
            specular_tint: None,
            thin_film_thickness: 0.0,
            thin_film_ior: 1.33,
            specular_ior_level: 0.5,
            diffuse_roughness: 0.0,
            anisotropic: 0.0,
            anisotropic_rotation: 0.0,
            coat: None,
            sheen: None,
            subsurface: None,
            normals: None,
        };
        assert!(grid_of(&scene(vec![material(principled(1.0))], vec![f11()])).len() >= 41);
        assert_eq!(
            grid_of(&scene(vec![material(principled(0.0))], vec![f11()])),
            grid_of(&scene(vec![material(diffuse(ramp()))], vec![f11()]))
        );
    }

    /// An HDRI world is RGB data: its grid is the one an RGB surface gets under D65.
    #[test]
    fn hdri_world_is_rgb_data() {
        let world = WorldDesc {
            radiance: None,
            texture: Some(0),
            strength: 1.0,
            rotation: 0.0,
            importance_sampling: true,
            volume: None,
        };
        let hdri = SceneDesc { world: Some(world), ..scene(vec![material(diffuse(ramp()))], vec![]) };
        let twin =
            scene(vec![material(diffuse(ramp())), material(diffuse(SpectrumKind::Rgb { rgb: [0.5; 3] }))], vec![]);
        assert_eq!(grid_of(&hdri), grid_of(&twin));
        assert!(Uplift::new(
            &WavelengthGrid::from_wavelengths(grid_of(&hdri)).unwrap(),
            &RgbSpace::rec709(),
            UpliftMethod::default()
        )
        .is_ok());
    }

    /// Properties of AUTO's grid against independent expectations.
    #[test]
    fn grid_properties() {
        for (name, d) in scenes() {
            let (l, _) = auto_grid(&d, 380.0, 780.0, UpliftMethod::default()).unwrap();
            assert!(l.windows(2).all(|w| w[0] < w[1]), "{name}: ascending");
            assert!(l[0] == 380.0 && *l.last().unwrap() == 780.0, "{name}: spans the range");
            // 8..81 uniform samples, plus 7 around a narrow band.
            assert!((8..=81 + 7).contains(&l.len()), "{name}: {} samples", l.len());
        }
        let grid = |i: usize| auto_grid(&scenes()[i].1, 380.0, 780.0, UpliftMethod::default()).unwrap().0;
        // A 2 nm LED at 589 nm (σ = 2/2.3548 = 0.85 nm): a sample at the centre and at ±σ.
        let led = grid(1);
        let sigma = 2.0 / (8.0 * std::f32::consts::LN_2).sqrt();
        for k in [-1.0, 0.0, 1.0] {
            assert!(led.iter().any(|x| (x - (589.0 + k * sigma)).abs() < 0.01), "LED: no sample at 589 + {k}σ");
        }
        // CIE F11's mercury lines (435.8, 546.1 nm) and its 611 nm europium band sit in
        // 5 nm bins: a grid keeping its colour within 0.3 ΔE00 samples within 10 nm of each.
        let f11 = grid(0);
        for line in [435.8f32, 546.1, 611.0] {
            assert!(f11.iter().any(|x| (x - line).abs() <= 10.0), "F11: nothing near {line} nm");
        }
        // RGB data: the uplift must accept the grid.
        assert!(Uplift::new(
            &WavelengthGrid::from_wavelengths(grid(2)).unwrap(),
            &RgbSpace::rec709(),
            UpliftMethod::default()
        )
        .is_ok());
        // Dispersive glass: at least 41 wavelengths (no banding in the spread).
        assert!(grid(3).len() >= 41);
    }
}
