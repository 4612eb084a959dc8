//! Which light to sample: a discrete distribution in proportion to power.

/// Selection probabilities and their running sum, one per light.
#[derive(Clone, Debug, Default)]
pub struct PowerSelection {
    /// Cumulative probabilities (last = 1).
    cdf: Vec<f32>,
    pmf: Vec<f32>,
}

impl PowerSelection {
    /// From each light's power (any common unit). Lights of zero power are
    /// never chosen (and never need to be).
    pub fn new(power: &[f64]) -> Self {
        let total: f64 = power.iter().sum();
        let (mut cdf, mut pmf) = (
            Vec::with_capacity(power.len()),
            Vec::with_capacity(power.len()),
        );
        let mut acc = 0.0;
        for p in power {
            let w = if total > 0.0 { p / total } else { 0.0 };
            acc += w;
            pmf.push(w as f32);
            cdf.push(acc as f32);
        }
        if let Some(last) = cdf.last_mut() {
            *last = 1.0;
        }
        Self { cdf, pmf }
    }

    /// Nothing can be chosen: no lights, or none with power.
    pub fn is_empty(&self) -> bool {
        self.pmf.iter().all(|&p| p == 0.0)
    }

    /// A light index and its probability.
    #[inline]
    pub fn choose(&self, u: f32) -> Option<(usize, f32)> {
        if self.is_empty() {
            return None;
        }
        let i = self
            .cdf
            .partition_point(|&c| c <= u)
            .min(self.cdf.len() - 1);
        let pmf = self.pmf[i];
        (pmf > 0.0).then_some((i, pmf))
    }

    #[inline]
    pub fn pmf(&self, light: usize) -> f32 {
        self.pmf[light]
    }
}
