//! A spectral material parameter: a spectrum fixed when the scene is built, looked up
//! per hit. Textures (kept RGB, converted at hit time) plug in here.

use super::texture::Texture;
use super::ShadingContext;
use crate::color::uplift::Uplift;
use crate::spectrum::SampledSpectrum;
use std::sync::Arc;

pub enum SpectralParam {
    Constant(SampledSpectrum),
    /// An RGB image texture converted to a reflectance at each hit (deferred conversion,
    /// docs/design.md#rgb-data): the bilinear RGB at the hit's uv goes through `uplift.reflectance_into`,
    /// then is multiplied by `scale`. The uplift is shared (one per scene), not copied.
    Texture {
        texture: Arc<Texture>,
        uplift: Arc<Uplift>,
        scale: f32,
    },
}

impl SpectralParam {
    /// Multiplies `target` by the parameter's spectrum at this hit; constant spectra need
    /// no temporary (the common case on every diffuse bounce).
    #[inline]
    pub fn multiply_into(&self, ctx: &ShadingContext, target: &mut SampledSpectrum) {
        match self {
            SpectralParam::Constant(s) => target.mul_assign(s),
            SpectralParam::Texture { .. } => {
                let mut tmp = SampledSpectrum::zeros(target.len());
                self.evaluate_into(ctx, &mut tmp);
                target.mul_assign(&tmp);
            }
        }
    }

    /// Writes the parameter's spectrum at this hit into `out`.
    #[inline]
    pub fn evaluate_into(&self, ctx: &ShadingContext, out: &mut SampledSpectrum) {
        match self {
            SpectralParam::Constant(s) => out.copy_from(s),
            SpectralParam::Texture { texture, uplift, scale } => {
                let rgb = texture.lookup(ctx.uv);
                uplift.reflectance_into(rgb, out.values_mut());
                if *scale != 1.0 {
                    out.scale(*scale);
                }
            }
        }
    }
}
