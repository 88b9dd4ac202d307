//! A spectral material parameter: a spectrum fixed when the scene is built, looked up
//! per hit. Textures (kept RGB, converted at hit time) plug in here.

use super::ShadingContext;
use crate::spectrum::SampledSpectrum;

pub enum SpectralParam {
    Constant(SampledSpectrum),
}

impl SpectralParam {
    /// Writes the parameter's spectrum at this hit into `out`.
    #[inline]
    pub fn evaluate_into(&self, _ctx: &ShadingContext, out: &mut SampledSpectrum) {
        match self {
            SpectralParam::Constant(s) => out.copy_from(s),
        }
    }
}
