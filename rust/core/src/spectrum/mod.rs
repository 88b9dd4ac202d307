//! Spectra: the wavelength grid with its quadrature weights (eq. 6), sampled spectra
//! sized to the grid, and the named spectra a scene can refer to.

pub mod grid;
pub mod measured;
pub mod named;
pub mod rgb_channels;
pub mod sampled;
pub mod tables;

pub use grid::WavelengthGrid;
pub use named::SpectrumDesc;
pub use sampled::SampledSpectrum;
