//! The scene's lights, the distribution that picks one, and the spectral
//! shape of their emission.

use super::{Light, LightSource, PowerSelection};
use crate::spectrum::{Spectrum, LAMBDA_MAX, LAMBDA_MIN};

/// The scene's lights and the distribution that picks one to sample.
#[derive(Clone, Debug, Default)]
pub struct LightSet {
    lights: Vec<Light>,
    selection: PowerSelection,
    /// Indices of the lights at infinity.
    infinite: Vec<usize>,
}

impl LightSet {
    pub fn new(lights: Vec<Light>) -> Self {
        // The plain spectral mean (not luminance) keeps every light that
        // emits anything selectable, also where the eye barely sees it.
        let power: Vec<f64> = lights.iter().map(Light::power).collect();
        let infinite = (0..lights.len())
            .filter(|&i| lights[i].is_infinite())
            .collect();
        Self {
            selection: PowerSelection::new(&power),
            lights,
            infinite,
        }
    }

    pub fn len(&self) -> usize {
        self.lights.len()
    }

    /// The lights, to change and make a set of anew.
    pub fn into_lights(self) -> Vec<Light> {
        self.lights
    }

    /// No light emits anything.
    pub fn is_empty(&self) -> bool {
        self.selection.is_empty()
    }

    #[inline]
    pub fn get(&self, light: usize) -> &Light {
        &self.lights[light]
    }

    /// Chooses a light to sample; returns its index and probability.
    #[inline]
    pub fn choose(&self, u: f32) -> Option<(usize, f32)> {
        self.selection.choose(u)
    }

    /// Probability that `choose` picks `light`.
    #[inline]
    pub fn pmf(&self, light: usize) -> f32 {
        self.selection.pmf(light)
    }

    /// The lights' emission at each of `lambdas`, relative to its mean over
    /// the spectrum, averaged over the lights weighted by their power (a
    /// light without one spectrum counts as flat); all 1 without lights.
    pub fn relative_emission(&self, lambdas: &[f32]) -> Vec<f64> {
        // Power per distinct spectrum: an emissive mesh's triangles share one.
        let mut by_spectrum: Vec<(Option<&Spectrum>, f64)> = Vec::new();
        let mut index = std::collections::HashMap::new();
        for light in &self.lights {
            let power = light.power();
            if !(power > 0.0) {
                continue;
            }
            let spectrum = light.spectrum();
            let key = spectrum.map_or(std::ptr::null(), |s| s as *const Spectrum);
            let k = *index.entry(key).or_insert_with(|| {
                by_spectrum.push((spectrum, 0.0));
                by_spectrum.len() - 1
            });
            by_spectrum[k].1 += power;
        }
        let mut sum = vec![0.0; lambdas.len()];
        let mut total = 0.0;
        for (spectrum, power) in by_spectrum {
            let mean = spectrum.map_or(1.0, |s| s.average(LAMBDA_MIN, LAMBDA_MAX) as f64);
            if !(mean > 0.0) {
                continue;
            }
            for (out, &lambda) in sum.iter_mut().zip(lambdas) {
                let e = spectrum.map_or(1.0, |s| s.eval(lambda).max(0.0) as f64);
                *out += power * e / mean;
            }
            total += power;
        }
        if total > 0.0 {
            sum.iter().map(|s| s / total).collect()
        } else {
            vec![1.0; lambdas.len()]
        }
    }

    /// The lights at infinity, with their indices.
    #[inline]
    pub fn infinite(&self) -> impl Iterator<Item = (usize, &Light)> {
        self.infinite.iter().map(|&i| (i, &self.lights[i]))
    }
}
