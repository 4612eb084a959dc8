//! How a camera path branches: into `split` continuations at its first
//! surface that is not a Dirac one, along both lobes of glass met first
//! (`split_glass`), and into one path per wavelength at dispersive glass.
//! Each branch is a copy of the path with a branch of the sampler.

use super::Gather;
use crate::integrator::walk::{self, Dispersion, Event, PathContext, Walk};
use crate::spectrum::{SampledSpectrum, SampledWavelengths, N_WAVELENGTHS};

impl<'t, 's> Gather<'t, 's> {
    /// Branch `k` of `n` of this path: its own copy of the walk and of the
    /// wavelengths, branch `k` of the sampler and a visitor with this one's
    /// state, which `go` takes on from here. The branch's light,
    /// and the wavelengths it ended with.
    fn branch(
        &self,
        ctx: &mut PathContext,
        walk: &Walk,
        (k, n): (u32, u32),
        split: u32,
        go: impl FnOnce(&mut PathContext, &mut Walk, &mut Gather<'t, 's>),
    ) -> (SampledSpectrum, SampledWavelengths) {
        let mut branch = walk.clone();
        let mut wl_k = *ctx.wl;
        let mut sampler_k = ctx.sampler.branch(k, n);
        let mut ctx_k = PathContext {
            scene: ctx.scene,
            wl: &mut wl_k,
            sampler: &mut sampler_k,
            counters: &mut *ctx.counters,
        };
        // This path's state, nothing gathered yet, no `stop`, no splitting.
        let mut visitor = Gather {
            specular: self.specular,
            prev_bsdf_pdf: self.prev_bsdf_pdf,
            caustics: self.caustics,
            met_diffuse: self.met_diffuse,
            no_diffuse: self.no_diffuse,
            in_caustic: self.in_caustic,
            disperses: self.disperses,
            splits_glass: self.splits_glass,
            ..Gather::new(self.tracer, None, split)
        };
        go(&mut ctx_k, &mut branch, &mut visitor);
        (visitor.l, wl_k)
    }

    /// The `split` continuations of the path from the surface of `event`,
    /// each with its own copy of the path, wavelengths and a branch of the
    /// sampler; their mean, each branch's light per its wavelengths' density.
    pub(super) fn branches(
        &self,
        ctx: &mut PathContext,
        walk: &Walk,
        event: &Event,
    ) -> SampledSpectrum {
        let mut per_density = SampledSpectrum::ZERO;
        for k in 0..self.split {
            let (l_k, wl_k) =
                self.branch(ctx, walk, (k, self.split), 1, |ctx_k, branch, visitor| {
                    let u = ctx_k.sampler.next_4d();
                    if walk::scatter_from_surface(ctx_k, branch, event, u, visitor) {
                        walk::walk(ctx_k, branch, visitor);
                    }
                });
            per_density += per_wavelength_density(l_k, &wl_k);
        }
        per_density * ctx.wl.pdf / self.split as f32
    }

    /// The two continuations of the path from glass (`event`'s BSDF
    /// `has_two_lobes`), one along its reflection and one along its
    /// transmission, each weighted by the probability one sample would
    /// have chosen it: their sum, as `branches` weighs it.
    pub(super) fn lobe_branches(
        &self,
        ctx: &mut PathContext,
        walk: &Walk,
        event: &Event,
    ) -> SampledSpectrum {
        let mut per_density = SampledSpectrum::ZERO;
        for (k, reflect) in [true, false].into_iter().enumerate() {
            let (l_k, wl_k) = self.branch(
                ctx,
                walk,
                (k as u32, 2),
                self.split,
                |ctx_k, branch, visitor| {
                    let u = ctx_k.sampler.next_4d();
                    if walk::scatter_along_lobe(ctx_k, branch, event, reflect, u, visitor) {
                        walk::walk(ctx_k, branch, visitor);
                    }
                },
            );
            per_density += per_wavelength_density(l_k, &wl_k);
        }
        per_density * ctx.wl.pdf
    }

    /// At a dispersive interface, each wavelength goes on alone, with a
    /// branch of the sampler, and brings back its own light: the sample
    /// keeps all four where the hero alone would carry its one four times
    /// over (colour grain through glass). Branch k's light is wavelength
    /// k's.
    pub(super) fn dispersion_branches(
        &self,
        ctx: &mut PathContext,
        walk: &Walk,
        at: &Dispersion,
        by_lobe: bool,
    ) -> SampledSpectrum {
        // With `by_lobe` (glass met first) the reflection, which does not
        // disperse, is one more branch with all four wavelengths.
        let n = N_WAVELENGTHS as u32 + u32::from(by_lobe);
        let mut l = SampledSpectrum::ZERO;
        for k in 0..N_WAVELENGTHS {
            let (l_k, _) = self.branch(
                ctx,
                walk,
                (k as u32, n),
                self.split,
                |ctx_k, branch, visitor| {
                    visitor.disperses = false;
                    if by_lobe {
                        at.follow_refraction(ctx_k, branch, k, visitor);
                    } else {
                        at.follow(ctx_k, branch, k, visitor);
                    }
                },
            );
            l[k] = l_k.x;
        }
        if by_lobe {
            let (l_r, wl_r) = self.branch(
                ctx,
                walk,
                (n - 1, n),
                self.split,
                |ctx_k, branch, visitor| {
                    at.reflect_all(ctx_k, branch, visitor);
                },
            );
            l += per_wavelength_density(l_r, &wl_r) * ctx.wl.pdf;
        }
        l
    }
}

/// A branch's light per the density of the wavelengths it ended with (zero
/// at wavelengths it ended), for a sum over branches that may have ended
/// different secondaries.
fn per_wavelength_density(l: SampledSpectrum, wl: &SampledWavelengths) -> SampledSpectrum {
    let live = wl.pdf.cmpgt(SampledSpectrum::ZERO);
    SampledSpectrum::select(live, l / wl.pdf, SampledSpectrum::ZERO)
}
