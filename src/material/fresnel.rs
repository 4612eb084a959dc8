//! Fresnel reflectance of dielectric and conducting interfaces.

/// Unpolarised reflectance of a dielectric interface for a ray with
/// cos θi = `cos_i` (negative: arriving from inside) and relative index
/// η = n_inside / n_outside. 1 under total internal reflection.
pub fn dielectric(cos_i: f32, eta: f32) -> f32 {
    let (mut cos_i, mut eta) = (cos_i.clamp(-1.0, 1.0), eta);
    if cos_i < 0.0 {
        eta = 1.0 / eta;
        cos_i = -cos_i;
    }
    let sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin2_t).max(0.0).sqrt();
    let parallel = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let perpendicular = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    (parallel * parallel + perpendicular * perpendicular) * 0.5
}

#[derive(Clone, Copy, Debug, PartialEq)]
struct Complex {
    re: f32,
    im: f32,
}

impl Complex {
    fn new(re: f32, im: f32) -> Self {
        Self { re, im }
    }
    fn add(self, o: Self) -> Self {
        Self::new(self.re + o.re, self.im + o.im)
    }
    fn sub(self, o: Self) -> Self {
        Self::new(self.re - o.re, self.im - o.im)
    }
    fn mul(self, o: Self) -> Self {
        Self::new(
            self.re * o.re - self.im * o.im,
            self.re * o.im + self.im * o.re,
        )
    }
    fn div(self, o: Self) -> Self {
        let d = o.re * o.re + o.im * o.im;
        Self::new(
            (self.re * o.re + self.im * o.im) / d,
            (self.im * o.re - self.re * o.im) / d,
        )
    }
    fn norm(self) -> f32 {
        self.re * self.re + self.im * self.im
    }
    fn sqrt(self) -> Self {
        let n = self.norm().sqrt();
        if n == 0.0 {
            return Self::new(0.0, 0.0);
        }
        let t1 = (0.5 * (n + self.re.abs())).sqrt();
        let t2 = 0.5 * self.im / t1;
        if self.re >= 0.0 {
            Self::new(t1, t2)
        } else {
            Self::new(t2.abs(), t1.copysign(self.im))
        }
    }
}

/// Unpolarised reflectance of a conductor with complex index n + ik
/// (relative to the outside medium) at cos θi = `cos_i` ∈ [0, 1].
pub fn conductor(cos_i: f32, n: f32, k: f32) -> f32 {
    let cos_i = cos_i.clamp(0.0, 1.0);
    let eta = Complex::new(n, k);
    let sin2_i = 1.0 - cos_i * cos_i;
    let sin2_t = Complex::new(sin2_i, 0.0).div(eta.mul(eta));
    let cos_t = Complex::new(1.0, 0.0).sub(sin2_t).sqrt();
    let ci = Complex::new(cos_i, 0.0);
    let parallel = eta.mul(ci).sub(cos_t).div(eta.mul(ci).add(cos_t));
    let perpendicular = ci.sub(eta.mul(cos_t)).div(ci.add(eta.mul(cos_t)));
    ((parallel.norm() + perpendicular.norm()) * 0.5).clamp(0.0, 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dielectric_known_values() {
        // Normal incidence: ((η − 1)/(η + 1))².
        assert!((dielectric(1.0, 1.5) - 0.04).abs() < 1e-6);
        assert!((dielectric(-1.0, 1.5) - 0.04).abs() < 1e-6);
        // Matched media reflect nothing; grazing reflects everything.
        assert!(dielectric(0.3, 1.0).abs() < 1e-7);
        assert!((dielectric(0.0, 1.5) - 1.0).abs() < 1e-6);
        // Total internal reflection beyond the critical angle from inside.
        let critical = (1.0f32 / 1.5).asin();
        assert_eq!(dielectric(-(critical + 0.01).cos(), 1.5), 1.0);
        assert!(dielectric(-(critical - 0.05).cos(), 1.5) < 1.0);
        // Brewster's angle: tan θB = η; the parallel part vanishes.
        let brewster = 1.5f32.atan();
        let r = dielectric(brewster.cos(), 1.5);
        let cos_t = (1.0 - brewster.sin().powi(2) / 2.25).sqrt();
        let perp = (brewster.cos() - 1.5 * cos_t) / (brewster.cos() + 1.5 * cos_t);
        assert!((r - perp * perp / 2.0).abs() < 1e-6);
    }

    #[test]
    fn conductor_matches_normal_incidence_formula_and_data() {
        // ((n − 1)² + k²) / ((n + 1)² + k²) at normal incidence.
        let (n, k) = (0.3504f32, 2.7141f32);
        let r0 = ((n - 1.0).powi(2) + k * k) / ((n + 1.0).powi(2) + k * k);
        assert!((conductor(1.0, n, k) - r0).abs() < 1e-5);
        assert!((r0 - 0.848).abs() < 1e-3, "gold at 550 nm: {r0}");
        // k = 0 reduces to the dielectric formula.
        for c in [0.1f32, 0.5, 0.9] {
            assert!((conductor(c, 1.5, 0.0) - dielectric(c, 1.5)).abs() < 1e-5);
        }
        assert!((conductor(0.0, n, k) - 1.0).abs() < 1e-5);
    }
}
