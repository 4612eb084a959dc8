//! Spectral quantities: wavelengths sampled per path, the spectra that are
//! evaluated at them, CIE colorimetry and RGB upsampling.

pub mod cct;
pub mod cie;
pub mod csv;
pub mod formats;
pub mod memo;
pub mod rgb2spec;
mod spectra;
mod wavelengths;

pub use spectra::{RgbSpectrum, Spectrum, TabulatedSpectrum};
pub use wavelengths::{
    lanes_led_by, sample_visible_wavelength, visible_wavelength_pdf, SampledSpectrum,
    SampledWavelengths, WavelengthDistribution, N_WAVELENGTHS,
};

/// Shortest wavelength a path may carry, in nanometres.
pub const LAMBDA_MIN: f32 = 360.0;
/// Longest wavelength a path may carry, in nanometres.
pub const LAMBDA_MAX: f32 = 830.0;
