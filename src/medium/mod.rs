//! Participating media: homogeneous volumes bound to closed meshes (a
//! dielectric or an index-matched `interface`), or filling the world.
//!
//! A medium is its absorption σa(λ) and scattering σs(λ) coefficients (per
//! scene unit, converted from 1/m by the scene's `units`) and a
//! Henyey–Greenstein phase function. Which medium a ray is in follows from
//! its IOR stack: the active entry's material's medium, or the world's when
//! the stack is empty. Media that only absorb are never sampled: a segment
//! multiplies the path by exp(−σa d) (Beer–Lambert). Scattering media are
//! sampled by free-flight distance with the hero wavelength's extinction,
//! with spectral MIS over the path's wavelengths (`integrator::volume`).

mod phase;
pub mod water;

pub use phase::HenyeyGreenstein;

use crate::spectrum::{
    SampledSpectrum, SampledWavelengths, Spectrum, TabulatedSpectrum, LAMBDA_MAX, LAMBDA_MIN,
};

#[derive(Clone, Debug, PartialEq)]
pub struct Medium {
    /// Absorption coefficient, per scene unit.
    pub sigma_a: Spectrum,
    /// Scattering coefficient, per scene unit; None: the medium only absorbs.
    pub sigma_s: Option<Spectrum>,
    pub phase: HenyeyGreenstein,
}

/// A medium's coefficients at a path's wavelengths.
#[derive(Clone, Copy, Debug)]
pub struct Coefficients {
    pub sigma_a: SampledSpectrum,
    pub sigma_s: SampledSpectrum,
}

impl Coefficients {
    pub fn sigma_t(&self) -> SampledSpectrum {
        self.sigma_a + self.sigma_s
    }
}

impl Medium {
    /// glTF's attenuation (KHR_materials_volume): white light becomes the
    /// linear sRGB `colour` (components in (0, 1]) after `distance`, so
    /// σa(λ) = −ln c(λ) / distance for the colour's smooth spectrum
    /// (Jakob–Hanika upsampling), tabulated every 5 nm.
    pub fn attenuation(colour: [f32; 3], distance: f32) -> Spectrum {
        let c = Spectrum::rgb_reflectance(glam::Vec3::from(colour));
        let lambdas: Vec<f32> = (0..=((LAMBDA_MAX - LAMBDA_MIN) / 5.0) as usize)
            .map(|i| LAMBDA_MIN + 5.0 * i as f32)
            .collect();
        let values = lambdas
            .iter()
            .map(|&l| -c.eval(l).clamp(1e-6, 1.0).ln() / distance)
            .collect();
        Spectrum::Table(TabulatedSpectrum::new(lambdas, values))
    }

    /// A medium that only absorbs, by glTF's attenuation.
    pub fn absorbing(colour: [f32; 3], distance: f32) -> Medium {
        Medium {
            sigma_a: Medium::attenuation(colour, distance),
            sigma_s: None,
            phase: HenyeyGreenstein { g: 0.0 },
        }
    }

    /// The same medium with every coefficient multiplied by `s` (a change
    /// of length unit).
    pub fn scaled(self, s: f32) -> Medium {
        Medium {
            sigma_a: self.sigma_a.scaled(s),
            sigma_s: self.sigma_s.map(|x| x.scaled(s)),
            phase: self.phase,
        }
    }

    pub fn scatters(&self) -> bool {
        self.sigma_s.is_some()
    }

    #[inline]
    pub fn coefficients(&self, wl: &SampledWavelengths) -> Coefficients {
        Coefficients {
            sigma_a: self.sigma_a.sample(wl),
            sigma_s: self
                .sigma_s
                .as_ref()
                .map_or(SampledSpectrum::ZERO, |s| s.sample(wl)),
        }
    }
}

/// exp(−σ d) per wavelength, with exp(−0 · ∞) = 1 (a wavelength the medium
/// does not attenuate stays whole along an infinite ray).
#[inline]
pub fn transmittance(sigma: SampledSpectrum, d: f32) -> SampledSpectrum {
    SampledSpectrum::from_array(
        sigma
            .to_array()
            .map(|s| if s > 0.0 { (-s * d).exp() } else { 1.0 }),
    )
}
