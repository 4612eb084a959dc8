//! `Integrate` for integrators that hand their job to a shared loop of
//! `crate::drive`, written once: `renders_by_pixels!` for a
//! `PixelEstimator` (samples measure their own pixel), `renders_by_splats!`
//! for a `SplatEstimator` (samples add light to any pixel). Each takes the
//! type, and `renders_by_pixels!` the field that holds the depth limit
//! where it is not `max_depth`.

macro_rules! renders_by_pixels {
    ($ty:ty) => {
        renders_by_pixels!($ty, max_depth);
    };
    ($ty:ty, $($depth:ident).+) => {
        impl $crate::integrator::Integrate for $ty {
            fn check(
                &self,
                _: &$crate::camera::Camera,
                _: &$crate::film::FilmSettings,
                options: &$crate::drive::RenderOptions,
            ) -> Result<(), $crate::drive::RenderError> {
                $crate::drive::pixels::check(options)
            }

            fn loop_memory(
                &self,
                scene: &$crate::scene::Scene,
                film: &$crate::film::FilmSettings,
                options: &$crate::drive::RenderOptions,
            ) -> (u64, u64) {
                $crate::drive::pixels::memory(self, scene, film, options)
            }

            fn render(
                &self,
                job: $crate::drive::RenderJob,
            ) -> ($crate::film::Film, $crate::drive::RenderStats) {
                $crate::drive::pixels::render(job, self)
            }

            fn max_depth(&self) -> u32 {
                self.$($depth).+
            }
        }
    };
}

macro_rules! renders_by_splats {
    ($ty:ty) => {
        impl $crate::integrator::Integrate for $ty {
            fn check(
                &self,
                camera: &$crate::camera::Camera,
                film: &$crate::film::FilmSettings,
                options: &$crate::drive::RenderOptions,
            ) -> Result<(), $crate::drive::RenderError> {
                $crate::drive::splats::check(self, camera, film, options)
            }

            fn loop_memory(
                &self,
                _: &$crate::scene::Scene,
                film: &$crate::film::FilmSettings,
                options: &$crate::drive::RenderOptions,
            ) -> (u64, u64) {
                $crate::drive::splats::memory(self, film, options)
            }

            fn render(
                &self,
                job: $crate::drive::RenderJob,
            ) -> ($crate::film::Film, $crate::drive::RenderStats) {
                $crate::drive::splats::render(job, self)
            }

            fn max_depth(&self) -> u32 {
                self.max_depth
            }
        }
    };
}
