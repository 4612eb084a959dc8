//! Paths through homogeneous media: Beer–Lambert attenuation for media
//! that only absorb, and free-flight sampling with spectral MIS for media
//! that scatter (Wilkie et al. 2014, "Hero wavelength spectral sampling";
//! pbrt-v4's VolPathIntegrator for the bookkeeping).
//!
//! The hero wavelength's extinction σt(λ₀) draws each free flight. Each of
//! the four wavelengths could have been the hero (the secondaries are the
//! hero's rotations, so the set is the same whichever one leads), and the
//! balance heuristic over those four techniques weights a path by
//! f(λ) / mean_i p_i(path). A [`Flight`] keeps β = f / p₀ and the ratios
//! r_i = p_i / p₀ over the whole path; a contribution is β / mean(r)
//! ([`Flight::weight`]). Once the secondaries are terminated (a dispersive
//! refraction) only the hero remains and the weight is β alone.

use super::russian_roulette;
use crate::medium::{transmittance, Medium};
use crate::sampler::Sampler;
use crate::scene::Scene;
use crate::spectrum::{SampledSpectrum, SampledWavelengths};

/// A path's throughput with its spectral-MIS ratios.
#[derive(Clone, Copy, Debug)]
pub struct Flight {
    /// Path value over the hero's path density.
    pub beta: SampledSpectrum,
    /// Per wavelength, its path density over the hero's (1 until a
    /// scattering medium is crossed).
    pub r: SampledSpectrum,
}

impl Flight {
    pub fn new(beta: SampledSpectrum) -> Self {
        Self {
            beta,
            r: SampledSpectrum::ONE,
        }
    }

    /// The spectral-MIS divisor: mean_i r_i (1 with the hero alone).
    #[inline]
    pub fn divisor(&self, wl: &SampledWavelengths) -> f32 {
        mis_divisor(self.r, wl)
    }

    /// What the path carries per wavelength: β / mean(r).
    #[inline]
    pub fn weight(&self, wl: &SampledWavelengths) -> SampledSpectrum {
        self.beta / self.divisor(wl)
    }

    /// Russian roulette (`super::russian_roulette`) on what the path
    /// carries, β over its spectral-MIS divisor; `eta_scale` as there.
    #[inline]
    pub fn roulette(
        &mut self,
        wl: &SampledWavelengths,
        eta_scale: f32,
        depth: u32,
        rr_depth: u32,
        u: f32,
    ) -> bool {
        let divisor = self.divisor(wl);
        russian_roulette(&mut self.beta, eta_scale / divisor, depth, rr_depth, u)
    }
}

/// The hero's optical depth to the next scattering event, drawn from
/// `sampler`: one number per segment in scenes with scattering media, none
/// elsewhere (their sample dimensions stay as they were, and the depth is
/// never used). Without a sampler (first-hit queries such as AOVs) the
/// path never scatters.
#[inline]
pub fn optical_depth(scene: &Scene, sampler: Option<&mut Sampler>) -> f32 {
    match sampler {
        Some(s) if scene.has_scattering() => {
            let u = s.next_4d()[0];
            // Clamped so the depth stays finite.
            -(1.0 - u.min(1.0 - f32::EPSILON)).ln()
        }
        Some(_) => 0.0,
        None => f32::INFINITY,
    }
}

/// The spectral-MIS divisor of a path whose density ratios are `r`:
/// mean_i r_i, or 1 once the secondaries are terminated.
#[inline]
pub fn mis_divisor(r: SampledSpectrum, wl: &SampledWavelengths) -> f32 {
    if wl.secondary_terminated() {
        return 1.0;
    }
    let m = r.element_sum() / 4.0;
    if m > 0.0 {
        m
    } else {
        1.0
    }
}

/// Carries `flight` over a segment of length `d` (may be infinite) in
/// medium `m`. In a medium that only absorbs, multiplies by exp(−σa d).
/// In a scattering one, spends the hero's `optical_depth`: if it runs out
/// within the segment, the path scatters there and the distance along the
/// segment is returned (β gains σs·Tr / p₀ and r the densities σt·Tr);
/// otherwise the path passes (β and r gain Tr / Tr₀).
#[inline]
pub fn fly(
    m: &Medium,
    wl: &SampledWavelengths,
    d: f32,
    optical_depth: &mut f32,
    flight: &mut Flight,
) -> Option<f32> {
    let c = m.coefficients(wl);
    if !m.scatters() {
        flight.beta *= transmittance(c.sigma_a, d);
        return None;
    }
    let sigma_t = c.sigma_t();
    let hero = sigma_t.x;
    let t = if hero > 0.0 {
        *optical_depth / hero
    } else {
        f32::INFINITY
    };
    if t < d {
        let tr = transmittance(sigma_t, t);
        let pdf = sigma_t * tr;
        let p0 = pdf.x;
        flight.beta *= c.sigma_s * tr / p0;
        flight.r *= pdf / p0;
        return Some(t);
    }
    if hero > 0.0 {
        *optical_depth -= hero * d;
    }
    let tr = transmittance(sigma_t, d);
    let p0 = tr.x;
    flight.beta *= tr / p0;
    flight.r *= tr / p0;
    None
}
