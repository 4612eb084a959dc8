//! Renders a loaded scene under some settings: checks the options, starts
//! the worker threads and hands the job to the integrator, whose loop
//! (its own or a shared driver's, `crate::drive`) does the rest. The
//! result depends only on the scene, the settings, the seed and the
//! samples taken, never on threads or timing.

mod memory;

pub use crate::drive::adaptive::{
    pilot_spp, progress as adaptive_progress, targets as adaptive_targets, uniform_instead,
};
pub use crate::drive::{
    Packets, PassHook, ProgressCounts, RenderError, RenderOptions, RenderStats, Stop, Streams,
};
pub use memory::{memory_estimate, MemoryEstimate};

use crate::drive::{AovTracer, RenderJob};
use crate::film::{Film, FilmSettings, Sampling};
use crate::integrator::aov::Aovs;
use crate::integrator::Integrator;
use crate::scene::Scene;

/// How to render a scene: the integrator with its parameters, and the
/// film (size, samples, seed, spectral buckets, colour, output). Loading
/// a scene file gives the file's; change them freely, the scene stays.
#[derive(Clone, Debug)]
pub struct RenderSettings {
    pub integrator: Integrator,
    pub film: FilmSettings,
}

impl RenderSettings {
    /// One render of the whole film at the settings' samples and seed,
    /// sampled as the scene file says where the integrator takes it
    /// ([`Self::adaptive`]).
    pub fn options(&self) -> RenderOptions {
        RenderOptions {
            adaptive: self.adaptive(),
            ..RenderOptions::new(&self.film)
        }
    }

    /// Whether the scene asks for adaptive sampling (`film.sampling`).
    /// Not the default: relMSE × CPU time gained 4–7% on the Cornell Box
    /// and lost up to 1.9× on others (docs/features.md, "Adaptive
    /// sampling").
    pub fn asks_adaptive(&self) -> bool {
        self.film.sampling == Some(Sampling::Adaptive)
    }

    /// Whether a render samples adaptively: as its caller says
    /// (`explicit`), else as the scene asks where the render can use it.
    /// The line to print where the scene asked and it cannot
    /// ([`uniform_instead`]): `part` is a sample range or tile for `prism
    /// merge`, `target_error` a render stopped by its estimated error.
    pub fn adaptive_for(
        &self,
        explicit: Option<bool>,
        part: bool,
        target_error: bool,
    ) -> (bool, Option<&'static str>) {
        match explicit {
            Some(a) => (a, None),
            None if self.asks_adaptive() => {
                match uniform_instead(self.adaptive(), part, target_error) {
                    Some(reason) => (false, Some(reason)),
                    None => (true, None),
                }
            }
            None => (false, None),
        }
    }

    /// Whether a render of these settings spreads its samples adaptively
    /// unless its caller says otherwise: where the scene asks and the
    /// integrator is the path tracer, the one it was measured to help
    /// (splats cannot adapt; `path_caustics` lost 1.2× on gem-studio).
    pub fn adaptive(&self) -> bool {
        self.asks_adaptive() && matches!(self.integrator, Integrator::Path(_))
    }
}

/// Renders `scene` under `settings`. Refuses options the integrator's loop
/// cannot honour and a film whose size is not the camera's, before the
/// first sample.
pub fn render(
    scene: &Scene,
    settings: &RenderSettings,
    options: &RenderOptions,
) -> Result<(Film, RenderStats), RenderError> {
    let f = &settings.film;
    if scene.camera.resolution() != (f.width, f.height) {
        return Err(RenderError::Resolution {
            film: (f.width, f.height),
            camera: scene.camera.resolution(),
        });
    }
    settings.integrator.check_scene(scene)?;
    let integrator = settings.integrator.as_integrate();
    integrator.check(&scene.camera, f, options)?;
    let mut b = rayon::ThreadPoolBuilder::new();
    if let Some(n) = options.threads {
        check_address_space(n)?;
        b = b.num_threads(n);
    }
    let pool = b.build().map_err(|e| RenderError::Threads {
        threads: options.threads.unwrap_or(0),
        reason: e.to_string(),
    })?;
    let aovs = f.aovs.traced().then(|| Aovs::new(f.observer));
    let tracer = aovs.as_ref().map(|a| a as &dyn AovTracer);
    Ok(pool.install(|| integrator.render(RenderJob::new(scene, f, options, tracer))))
}

/// Address space a worker thread takes: its 2 MiB stack (Rust's default),
/// guard page and signal stack, rounded up.
const THREAD_ADDRESS_SPACE: u64 = 4 << 20;

/// Refuses more threads than the process's address-space limit allows
/// (with half of it left for the scene and film). Past that limit a thread
/// can start and then fail to allocate its signal stack, which the standard
/// library can only abort on.
fn check_address_space(threads: usize) -> Result<(), RenderError> {
    // SAFETY: getrlimit only writes the struct it is given.
    let limit = unsafe {
        let mut r = std::mem::zeroed::<libc::rlimit>();
        if libc::getrlimit(libc::RLIMIT_AS, &mut r) != 0 {
            return Ok(());
        }
        r.rlim_cur
    };
    if limit == libc::RLIM_INFINITY {
        return Ok(());
    }
    let need = threads as u64 * THREAD_ADDRESS_SPACE;
    if need > limit / 2 {
        return Err(RenderError::Threads {
            threads,
            reason: format!(
                "they need about {} MiB of address space and the process may use {} MiB in all (ulimit -v)",
                need >> 20,
                limit >> 20
            ),
        });
    }
    Ok(())
}
