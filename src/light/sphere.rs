//! Spherical lights: an exact sphere that emits from its outside (or, with
//! flipped normals, its inside; or both), sampled by the solid angle it
//! subtends from a point outside it, and uniformly by area from inside.

use std::f32::consts::PI;
use std::sync::Arc;

use glam::{Vec2, Vec3};

use super::point::sphere_direction;
use super::{
    cosine_emission, cosine_emission_pdf, Emitter, LightLeSample, LightLiSample, LightPoint,
    LightSource, SceneSphere,
};
use crate::geometry::sphere::Sphere;
use crate::geometry::Frame;
use crate::spectrum::{SampledSpectrum, SampledWavelengths, Spectrum};

#[derive(Clone, Debug)]
pub struct SphereLight {
    sphere: Sphere,
    emitter: Arc<Emitter>,
    /// Emits from both faces.
    two_sided: bool,
    /// The front face is the inside (the shape's normals flipped).
    inward: bool,
}

/// Below this sin²θ of the cone a sphere subtends, 1 − cos θ is taken as
/// sin²θ / 2 (its series): the subtraction would lose every digit.
const SMALL_CONE: f32 = 1e-3;

impl SphereLight {
    /// The same sphere sending out `emitter`.
    pub fn with_emitter(&self, emitter: Arc<Emitter>, two_sided: bool) -> Self {
        Self {
            emitter,
            two_sided,
            ..self.clone()
        }
    }

    pub fn new(sphere: Sphere, emitter: Arc<Emitter>, two_sided: bool, inward: bool) -> Self {
        Self {
            sphere,
            emitter,
            two_sided,
            inward,
        }
    }

    /// The front face's normal at the point of outward normal `out`.
    fn front(&self, out: Vec3) -> Vec3 {
        if self.inward {
            -out
        } else {
            out
        }
    }

    /// Radiance leaving the point of outward normal `out` towards `w`.
    fn radiance(&self, out: Vec3, uv: Vec2, w: Vec3, wl: &SampledWavelengths) -> SampledSpectrum {
        if !self.two_sided && self.front(out).dot(w) <= 0.0 {
            return SampledSpectrum::ZERO;
        }
        self.emitter.radiance(uv, wl)
    }

    /// The point of outward normal `out`, its normal facing the front.
    fn point(&self, out: Vec3) -> LightPoint {
        let (p, p_err) = self.sphere.point_at(out);
        let (uv, _) = self.sphere.coordinates(out);
        LightPoint {
            p,
            p_err,
            n: self.front(out),
            uv,
        }
    }

    /// sin²θ and 1 − cos θ of the cone the sphere subtends from a point at
    /// distance² `d2` from its centre (outside it).
    fn cone(&self, d2: f32) -> (f32, f32) {
        let sin2 = (self.sphere.radius * self.sphere.radius / d2).min(1.0);
        let one_minus_cos = if sin2 < SMALL_CONE {
            0.5 * sin2 * (1.0 + 0.25 * sin2)
        } else {
            1.0 - (1.0 - sin2).max(0.0).sqrt()
        };
        (sin2, one_minus_cos)
    }

    /// Whether `p` lies outside the sphere (by more than rounding).
    fn outside(&self, p: Vec3) -> bool {
        let r = self.sphere.radius;
        (p - self.sphere.centre).length_squared() > r * r * (1.0 + 1e-4)
    }

    /// A direction within the cone towards the sphere from `p` (outside
    /// it), and the outward normal where it meets the sphere first.
    fn sample_cone(&self, p: Vec3, u: (f32, f32)) -> (Vec3, Vec3) {
        let to_centre = self.sphere.centre - p;
        let d2 = to_centre.length_squared();
        let (sin2_max, one_minus_cos_max) = self.cone(d2);
        // cos θ uniform in [cos θmax, 1].
        let one_minus_cos = u.0 * one_minus_cos_max;
        let cos = 1.0 - one_minus_cos;
        let sin2 = (one_minus_cos * (2.0 - one_minus_cos)).max(0.0);
        // Where the ray meets the sphere, seen from its centre: the angle α
        // between −axis and the normal, from the triangle p, centre, hit.
        let d = d2.sqrt();
        let cos_alpha = sin2 / sin2_max.sqrt() + cos * (1.0 - sin2 / sin2_max).max(0.0).sqrt();
        let sin_alpha = (1.0 - cos_alpha * cos_alpha).max(0.0).sqrt();
        let phi = 2.0 * PI * u.1;
        let axis = to_centre / d;
        let frame = Frame::from_normal(-axis);
        let out = frame
            .to_world(Vec3::new(
                sin_alpha * phi.cos(),
                sin_alpha * phi.sin(),
                cos_alpha,
            ))
            .normalize();
        let (hit, _) = self.sphere.point_at(out);
        ((hit - p).normalize(), out)
    }
}

/// What the light must answer whole: see `LightSource` (light/mod.rs).
impl LightSource for SphereLight {
    fn is_delta(&self) -> bool {
        false
    }

    fn is_infinite(&self) -> bool {
        false
    }

    fn with_scene_bounds(self, _: SceneSphere) -> Self {
        self
    }

    /// Area · emitting sides · mean radiance, as for triangles.
    fn power(&self) -> f64 {
        let sides = if self.two_sided { 2.0 } else { 1.0 };
        self.sphere.area() as f64 * sides * self.emitter.mean()
    }

    fn spectrum(&self) -> Option<&Spectrum> {
        Some(&self.emitter.spectrum)
    }

    /// From outside: a direction in the cone the sphere subtends (the
    /// near cap, which is all a point outside can see of it). From inside:
    /// a uniform point of the sphere.
    #[inline]
    fn sample_li(
        &self,
        p_ref: Vec3,
        u: (f32, f32),
        wl: &SampledWavelengths,
    ) -> Option<LightLiSample> {
        let (wi, out) = if self.outside(p_ref) {
            self.sample_cone(p_ref, u)
        } else {
            let out = sphere_direction(1.0 - 2.0 * u.0, u.1);
            let (p, _) = self.sphere.point_at(out);
            ((p - p_ref).normalize(), out)
        };
        let lp = self.point(out);
        let li = self.radiance(out, lp.uv, -wi, wl);
        let pdf = self.pdf_li(p_ref, wi, Some(lp.p));
        if li == SampledSpectrum::ZERO || !(pdf > 0.0) || !wi.is_finite() {
            return None;
        }
        Some(LightLiSample {
            wi,
            li,
            pdf,
            point: Some(lp),
        })
    }

    #[inline]
    fn pdf_li(&self, p_ref: Vec3, _: Vec3, p_light: Option<Vec3>) -> f32 {
        let Some(p) = p_light else { return 0.0 };
        if self.outside(p_ref) {
            let d2 = (self.sphere.centre - p_ref).length_squared();
            let (_, one_minus_cos) = self.cone(d2);
            return 1.0 / (2.0 * PI * one_minus_cos);
        }
        let d = p - p_ref;
        let dist2 = d.length_squared();
        let out = (p - self.sphere.centre).normalize();
        let cos = out.dot(d).abs() / dist2.sqrt();
        if !(cos > 0.0 && dist2 > 0.0) {
            return 0.0;
        }
        dist2 / (cos * self.sphere.area())
    }

    #[inline]
    fn l(&self, uv: Vec2, w: Vec3, wl: &SampledWavelengths) -> SampledSpectrum {
        self.radiance(self.sphere.normal_at(uv), uv, w, wl)
    }

    #[inline]
    fn le(&self, _: Vec3, _: &SampledWavelengths) -> SampledSpectrum {
        SampledSpectrum::ZERO
    }

    /// A uniform point, a cosine-weighted direction on an emitting side
    /// (either, evenly, when two-sided).
    fn sample_le(
        &self,
        u_pos: (f32, f32),
        u_dir: (f32, f32),
        wl: &SampledWavelengths,
    ) -> Option<LightLeSample> {
        let out = sphere_direction(1.0 - 2.0 * u_pos.0, u_pos.1);
        let lp = self.point(out);
        let (dir, n) = cosine_emission(lp.n, self.two_sided, u_dir);
        let le = self.radiance(out, lp.uv, dir, wl);
        let (pdf_pos, pdf_dir) = self.pdf_le(lp.uv, dir);
        if le == SampledSpectrum::ZERO || pdf_dir == 0.0 {
            return None;
        }
        Some(LightLeSample {
            point: LightPoint { n, ..lp },
            dir,
            le,
            pdf_pos,
            pdf_dir,
        })
    }

    fn pdf_le(&self, uv: Vec2, dir: Vec3) -> (f32, f32) {
        let front = self.front(self.sphere.normal_at(uv));
        let pdf_dir = cosine_emission_pdf(front, self.two_sided, dir);
        (1.0 / self.sphere.area(), pdf_dir)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lamp(radius: f32) -> SphereLight {
        SphereLight::new(
            Sphere::new(Vec3::new(0.0, 0.0, 3.0), radius),
            Arc::new(Emitter {
                spectrum: Spectrum::Constant(1.0),
                texture: None,
            }),
            false,
            false,
        )
    }

    /// Irradiance at the origin, normal +z, from a sphere of radiance 1:
    /// π sin²θ for a sphere wholly above the horizon.
    fn irradiance(light: &SphereLight, n: u32) -> f64 {
        let wl = SampledWavelengths::sample_visible(0.5);
        let mut sum = 0.0;
        for i in 0..n {
            for j in 0..n {
                let u = ((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
                if let Some(s) = light.sample_li(Vec3::ZERO, u, &wl) {
                    sum += (s.li[0] * s.wi.z.max(0.0) / s.pdf) as f64;
                }
            }
        }
        sum / (n * n) as f64
    }

    #[test]
    fn irradiance_from_a_sphere_matches_its_closed_form() {
        for r in [1.0, 0.3, 1e-3] {
            let expected = std::f64::consts::PI * (r as f64 / 3.0).powi(2);
            let got = irradiance(&lamp(r), 256);
            assert!(
                ((got - expected) / expected).abs() < 1e-3,
                "r {r}: {got} vs {expected}"
            );
        }
    }

    #[test]
    fn cone_samples_land_on_the_visible_cap_with_their_density() {
        let light = lamp(1.0);
        let wl = SampledWavelengths::sample_visible(0.5);
        let p = Vec3::new(0.2, -0.1, 0.0);
        for (a, b) in [(0.1, 0.2), (0.5, 0.9), (0.999, 0.3)] {
            let s = light.sample_li(p, (a, b), &wl).unwrap();
            let q = s.point.unwrap().p;
            assert!(((q - light.sphere.centre).length() - 1.0).abs() < 1e-5);
            // The direction meets the sphere first at that point.
            let hit = light
                .sphere
                .intersect(&crate::geometry::Ray::new(p, s.wi), f32::INFINITY)
                .unwrap();
            assert!((hit.p - q).length() < 1e-4, "{} vs {q}", hit.p);
            assert_eq!(s.pdf, light.pdf_li(p, s.wi, Some(q)));
        }
    }
}
