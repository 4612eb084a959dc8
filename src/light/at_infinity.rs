//! The `LightSource` answers every light at infinity with extent shares
//! (`light_at_infinity!`), written once.

/// `LightSource` for a light at infinity with extent, sampled by direction
/// from an image or a model (the environment map, the sky, the sun): its
/// inherent `with_scene`, `power`, `radiance`, `radiance_and_pdf`,
/// `sample_li(u, λ)`, `pdf_li(wi)`, `sample_le` and `pdf_le(dir)` answer;
/// `spectrum` is the given expression of `self`. No surface sends light
/// (`l` is zero) and only escaped rays find it.
macro_rules! light_at_infinity {
    ($ty:ident, |$light:ident| $spectrum:expr) => {
        impl super::LightSource for $ty {
            fn is_delta(&self) -> bool {
                false
            }

            fn is_infinite(&self) -> bool {
                true
            }

            fn with_scene_bounds(self, sphere: super::SceneSphere) -> Self {
                self.with_scene(sphere)
            }

            fn power(&self) -> f64 {
                $ty::power(self)
            }

            fn spectrum(&self) -> Option<&crate::spectrum::Spectrum> {
                let $light = self;
                $spectrum
            }

            #[inline]
            fn sample_li(
                &self,
                _: glam::Vec3,
                u: (f32, f32),
                wl: &crate::spectrum::SampledWavelengths,
            ) -> Option<super::LightLiSample> {
                $ty::sample_li(self, u, wl)
            }

            #[inline]
            fn pdf_li(&self, _: glam::Vec3, wi: glam::Vec3, p_light: Option<glam::Vec3>) -> f32 {
                match p_light {
                    None => $ty::pdf_li(self, wi),
                    Some(_) => 0.0,
                }
            }

            #[inline]
            fn l(
                &self,
                _: glam::Vec2,
                _: glam::Vec3,
                _: &crate::spectrum::SampledWavelengths,
            ) -> crate::spectrum::SampledSpectrum {
                crate::spectrum::SampledSpectrum::ZERO
            }

            /// `dir` travels away from the scene: the light seen that way.
            #[inline]
            fn le(
                &self,
                dir: glam::Vec3,
                wl: &crate::spectrum::SampledWavelengths,
            ) -> crate::spectrum::SampledSpectrum {
                self.radiance(dir, wl)
            }

            #[inline]
            fn le_and_pdf_li(
                &self,
                _: glam::Vec3,
                dir: glam::Vec3,
                wl: &crate::spectrum::SampledWavelengths,
            ) -> (crate::spectrum::SampledSpectrum, f32) {
                self.radiance_and_pdf(dir, wl)
            }

            fn sample_le(
                &self,
                u_pos: (f32, f32),
                u_dir: (f32, f32),
                wl: &crate::spectrum::SampledWavelengths,
            ) -> Option<super::LightLeSample> {
                $ty::sample_le(self, u_pos, u_dir, wl)
            }

            fn pdf_le(&self, _: glam::Vec2, dir: glam::Vec3) -> (f32, f32) {
                $ty::pdf_le(self, dir)
            }
        }
    };
}
