//! Ray visibility, as Cycles' object *Visibility > Ray Visibility* (`visible_camera`,
//! `visible_shadow`, `visible_diffuse`, `visible_glossy`, `visible_transmission`;
//! intern/cycles/blender/object.cpp `object_ray_visibility`): an instance carries the
//! kinds of rays that see it and every ray says which kind it is; the acceleration
//! structure skips instances a ray's kind does not see (the ray goes on through them).
//!
//! Which kind a ray is: camera rays (and light paths' connections to the camera, the
//! same segment traced the other way); shadow rays of next-event estimation; rays a BSDF
//! sampled: transmission when they leave through the surface, glossy for a specular
//! reflection, else the kind of the BSDF's reflection lobes (`Bsdf::lobe_kinds`: diffuse
//! or glossy, or either when it mixes both, as the sample does not say which lobe it
//! came from). Next-event estimation skips a light that the lobes lit along the
//! connection do not see (`of_connection`; Cycles' SHADER_EXCLUDE_*). Rays leaving
//! lights (light paths) see everything visible to any kind.

use serde::{Deserialize, Serialize};

pub const CAMERA: u8 = 1;
pub const SHADOW: u8 = 2;
pub const DIFFUSE: u8 = 4;
pub const GLOSSY: u8 = 8;
pub const TRANSMISSION: u8 = 16;
/// Every kind: what instances and rays are unless told otherwise.
pub const ALL: u8 = CAMERA | SHADOW | DIFFUSE | GLOSSY | TRANSMISSION;

/// The kinds of rays that see an instance (all by default), as a scene describes it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct VisibilityDesc {
    pub camera: bool,
    pub shadow: bool,
    pub diffuse: bool,
    pub glossy: bool,
    pub transmission: bool,
}

impl Default for VisibilityDesc {
    fn default() -> Self {
        Self { camera: true, shadow: true, diffuse: true, glossy: true, transmission: true }
    }
}

impl VisibilityDesc {
    pub fn mask(&self) -> u8 {
        [
            (self.camera, CAMERA),
            (self.shadow, SHADOW),
            (self.diffuse, DIFFUSE),
            (self.glossy, GLOSSY),
            (self.transmission, TRANSMISSION),
        ]
        .iter()
        .filter(|(on, _)| *on)
        .fold(0, |m, (_, bit)| m | bit)
    }
}

/// The kinds of rays that see a light that is no geometry (point, spot and sun lights):
/// as [`VisibilityDesc`], except that the camera sees a sun's disk or a sphere light
/// only when asked, as Cycles' lights are invisible to camera rays by default
/// (`visible_camera`). Diffuse, glossy and transmission rays see it (and next-event
/// estimation from lobes of those kinds lights with it) unless turned off; `shadow` has
/// no effect (such lights block nothing).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LightVisibilityDesc {
    pub camera: bool,
    pub shadow: bool,
    pub diffuse: bool,
    pub glossy: bool,
    pub transmission: bool,
}

impl Default for LightVisibilityDesc {
    fn default() -> Self {
        Self { camera: false, shadow: true, diffuse: true, glossy: true, transmission: true }
    }
}

impl LightVisibilityDesc {
    pub fn mask(&self) -> u8 {
        let Self { camera, shadow, diffuse, glossy, transmission } = *self;
        VisibilityDesc { camera, shadow, diffuse, glossy, transmission }.mask()
    }
}

/// The kind of a ray a BSDF with lobes `lobe_kinds` ([`crate::material::Bsdf::lobe_kinds`])
/// sampled (see the module docs): transmission when it left through the surface, glossy
/// for a specular reflection, else the BSDF's reflection kind — diffuse or glossy when
/// it has one of them only, either when it has both (the sample does not say which
/// lobe it came from).
#[inline]
pub fn of_bsdf_ray(transmitted: bool, specular: bool, lobe_kinds: u8) -> u8 {
    if transmitted {
        TRANSMISSION
    } else if specular {
        GLOSSY
    } else {
        match lobe_kinds & (DIFFUSE | GLOSSY) {
            0 => DIFFUSE | GLOSSY,
            k => k,
        }
    }
}

/// The kinds of light a BSDF with lobes `lobe_kinds` takes along a connection to a light
/// (next-event estimation) on the transmitted side or not: a light invisible to all of
/// them is skipped there, as Cycles excludes a light's closures by kind
/// (SHADER_EXCLUDE_DIFFUSE/GLOSSY/TRANSMIT).
#[inline]
pub fn of_connection(transmitted: bool, lobe_kinds: u8) -> u8 {
    lobe_kinds & if transmitted { TRANSMISSION } else { DIFFUSE | GLOSSY }
}

/// Whether an instance of visibility `mask` is seen by a ray of kind `kind`.
#[inline]
pub fn sees(mask: u8, kind: u8) -> bool {
    mask & kind != 0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn masks_and_ray_kinds() {
        assert_eq!(VisibilityDesc::default().mask(), ALL);
        let light = VisibilityDesc { camera: false, ..Default::default() };
        assert_eq!(light.mask(), ALL & !CAMERA);
        assert!(!sees(light.mask(), CAMERA) && sees(light.mask(), SHADOW));
        assert_eq!(of_bsdf_ray(true, false, ALL), TRANSMISSION);
        assert_eq!(of_bsdf_ray(false, true, ALL), GLOSSY);
        assert_eq!(of_bsdf_ray(false, false, DIFFUSE), DIFFUSE);
        assert_eq!(of_bsdf_ray(false, false, GLOSSY | TRANSMISSION), GLOSSY);
        let no_diffuse = VisibilityDesc { diffuse: false, ..Default::default() }.mask();
        assert!(sees(no_diffuse, of_bsdf_ray(false, false, ALL)), "a rough reflection of a mixed BSDF may be glossy");
        assert!(!sees(no_diffuse, of_bsdf_ray(false, false, DIFFUSE)));
        assert!(!sees(
            VisibilityDesc { diffuse: false, glossy: false, ..Default::default() }.mask(),
            of_bsdf_ray(false, false, ALL)
        ));
        assert_eq!(of_connection(false, DIFFUSE | TRANSMISSION), DIFFUSE);
        assert_eq!(of_connection(true, GLOSSY), 0);
        let lamp: LightVisibilityDesc = serde_json::from_str(r#"{"diffuse": false}"#).unwrap();
        assert_eq!(lamp.mask(), ALL & !CAMERA & !DIFFUSE, "lights: camera off unless asked");
        assert_eq!(LightVisibilityDesc::default().mask(), ALL & !CAMERA);
        let parsed: VisibilityDesc = serde_json::from_str(r#"{"camera": false}"#).unwrap();
        assert_eq!(parsed, light);
        assert!(serde_json::from_str::<VisibilityDesc>(r#"{"camra": false}"#).is_err());
    }
}
