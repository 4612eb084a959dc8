//! Spectra remembered at one path's wavelengths. A path keeps its
//! wavelengths from camera to end, so a spectrum it meets again (the white
//! of a room's walls, the lamp it samples at every bounce) has the same
//! values each time; looking them up again is the cost saved.

use super::{SampledSpectrum, SampledWavelengths, Spectrum};

/// Spectra remembered: how many at once.
const ENTRIES: usize = 4;

/// The last few spectra sampled at one path's wavelengths, each known by
/// its address (the scene's spectra do not move while it renders). Forget
/// them ([`SpectrumMemo::forget`]) when the wavelengths change.
#[derive(Clone, Debug, Default)]
pub struct SpectrumMemo {
    keys: [usize; ENTRIES],
    values: [SampledSpectrum; ENTRIES],
    /// The entry written next (the oldest).
    next: usize,
}

impl SpectrumMemo {
    /// `spectrum` at `wl`, the same wavelengths as every call since the
    /// last `forget`.
    #[inline]
    pub fn sample(&mut self, spectrum: &Spectrum, wl: &SampledWavelengths) -> SampledSpectrum {
        let key = spectrum as *const Spectrum as usize;
        if let Some(i) = self.keys.iter().position(|&k| k == key) {
            return self.values[i];
        }
        let value = spectrum.sample(wl);
        self.keys[self.next] = key;
        self.values[self.next] = value;
        self.next = (self.next + 1) % ENTRIES;
        value
    }

    /// Forgets every spectrum (the path's wavelengths changed).
    #[inline]
    pub fn forget(&mut self) {
        self.keys = [0; ENTRIES];
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spectrum::TabulatedSpectrum;

    /// The memo answers as the spectrum does, for more spectra than it
    /// holds, in any order, and again after forgetting at new wavelengths.
    #[test]
    fn remembers_what_the_spectra_say() {
        let spectra: Vec<Spectrum> = (0..6)
            .map(|k| {
                let v = (0..5).map(|i| (i * k) as f32 * 0.1 + 0.05).collect();
                Spectrum::Table(TabulatedSpectrum::new(
                    vec![360.0, 480.0, 600.0, 720.0, 830.0],
                    v,
                ))
            })
            .collect();
        let mut memo = SpectrumMemo::default();
        for (round, u) in [0.1f32, 0.7].into_iter().enumerate() {
            let wl = SampledWavelengths::sample_visible(u);
            memo.forget();
            for k in [0, 1, 0, 2, 3, 4, 5, 0, 5, 1, 1, 2] {
                let want = spectra[k].sample(&wl);
                assert_eq!(
                    memo.sample(&spectra[k], &wl),
                    want,
                    "round {round}, spectrum {k}"
                );
            }
        }
    }
}
