//! Thin-film interference (KHR_materials_iridescence), exactly per
//! wavelength: the reflectance of a film of index n₁ and thickness d
//! between the outside (n₀ = 1) and a base of real index n₂ is the Airy
//! sum of its multiple reflections,
//!
//! R = (r₀₁² + r₁₂² + 2 r₀₁ r₁₂ cos δ) / (1 + r₀₁² r₁₂² + 2 r₀₁ r₁₂ cos δ),
//! δ = 4π n₁ d cos θ₁ / λ,
//!
//! for each polarisation (Fresnel amplitude coefficients r), averaged over
//! s and p. An RGB renderer has to integrate this over its primaries
//! (Belcour & Barla 2017); a spectral one evaluates it at each wavelength.

/// Reflectance of the film at wavelength `lambda` (nm) for light meeting
/// it at `cos0` (outside the film), film index `n1`, thickness `d` (nm),
/// base index `n2`.
pub fn reflectance(cos0: f32, lambda: f32, n1: f32, d: f32, n2: f32) -> f32 {
    let cos0 = cos0.clamp(0.0, 1.0);
    let sin2_0 = 1.0 - cos0 * cos0;
    let cos1 = (1.0 - sin2_0 / (n1 * n1)).max(0.0).sqrt();
    let sin2_2 = sin2_0 / (n2 * n2);
    if sin2_2 >= 1.0 {
        return 1.0;
    }
    let cos2 = (1.0 - sin2_2).sqrt();
    let delta = 4.0 * std::f32::consts::PI * n1 * d * cos1 / lambda;
    let airy = |r01: f32, r12: f32| {
        let c = 2.0 * r01 * r12 * delta.cos();
        let num = r01 * r01 + r12 * r12 + c;
        let den = 1.0 + r01 * r01 * r12 * r12 + c;
        if den > 0.0 {
            (num / den).clamp(0.0, 1.0)
        } else {
            1.0
        }
    };
    let s = airy(
        (cos0 - n1 * cos1) / (cos0 + n1 * cos1),
        (n1 * cos1 - n2 * cos2) / (n1 * cos1 + n2 * cos2),
    );
    let p = airy(
        (n1 * cos0 - cos1) / (n1 * cos0 + cos1),
        (n2 * cos1 - n1 * cos2) / (n2 * cos1 + n1 * cos2),
    );
    0.5 * (s + p)
}

/// The real index whose normal-incidence reflectance is `f0` (Schlick's
/// relation inverted): how a metal's base colour gives the film its base.
pub fn ior_from_f0(f0: f32) -> f32 {
    let s = f0.clamp(0.0, 0.99).sqrt();
    (1.0 + s) / (1.0 - s)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fresnel(cos0: f32, n: f32) -> f32 {
        crate::material::fresnel::dielectric(cos0, n)
    }

    #[test]
    fn a_film_of_no_thickness_or_of_the_base_index_is_the_bare_interface() {
        for cos in [1.0f32, 0.8, 0.4, 0.1] {
            for lambda in [400.0f32, 550.0, 700.0] {
                let bare = fresnel(cos, 1.5);
                assert!((reflectance(cos, lambda, 1.3, 0.0, 1.5) - bare).abs() < 1e-5);
                assert!((reflectance(cos, lambda, 1.5, 320.0, 1.5) - bare).abs() < 1e-5);
            }
        }
    }

    #[test]
    fn a_quarter_wave_film_is_an_antireflection_coating_and_a_half_wave_one_vanishes() {
        // n1 = √n2 and n1 d = λ/4: no reflection at normal incidence.
        let (n2, lambda) = (1.69f32, 550.0f32);
        let n1 = n2.sqrt();
        assert!(reflectance(1.0, lambda, n1, lambda / (4.0 * n1), n2) < 1e-6);
        // A half-wave film (n1 d = λ/2) reflects as the bare base does.
        let half = reflectance(1.0, lambda, 1.3, lambda / (2.0 * 1.3), n2);
        assert!((half - fresnel(1.0, n2)).abs() < 1e-5);
        // Reflectance stays in [0, 1] and varies with wavelength.
        let r: Vec<f32> = (400..=700)
            .step_by(20)
            .map(|l| reflectance(0.7, l as f32, 1.3, 400.0, 1.5))
            .collect();
        assert!(r.iter().all(|x| (0.0..=1.0).contains(x)));
        let (lo, hi) = r
            .iter()
            .fold((1.0f32, 0.0f32), |(a, b), &x| (a.min(x), b.max(x)));
        assert!(hi - lo > 0.02, "interference colours: {lo} .. {hi}");
    }
}
