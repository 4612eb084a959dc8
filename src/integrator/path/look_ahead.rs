//! Looking ahead at smooth glass: both lobes' rays are traced, the light
//! each meets first (the sky, a lamp, a softbox of the studio map) is
//! counted exactly, and the path goes on along one of the lobes that met
//! a surface. A path drawing one lobe by its Fresnel probability finds a
//! bright light seen along the other only now and then: inside a gem,
//! where every facet both reflects and refracts, that choice is most of
//! the noise. The estimate is unbiased: what each lobe meets first is a
//! fixed function of the surface, so the rule that picks which lobes go
//! on depends on no random number.

use super::Gather;
use crate::integrator::interface::{trace, FirstHit, Next};
use crate::integrator::walk::{self, Event, Flow, PathContext, Visitor, Walk};
use crate::material::Bsdf;

impl Gather<'_, '_> {
    /// Whether the path looks ahead from a surface with `bsdf`: smooth
    /// glass, past the first surface (which `split_glass` splits), met
    /// through surfaces without a diffuse lobe alone (past a diffuse one
    /// the light is dim or the photons' caustics; past rough ice or
    /// frosted glass a lamp seen through smooth glass is still bright),
    /// where no medium scatters (a ray traced ahead would draw no free
    /// flight).
    pub(super) fn looks_ahead(&self, ctx: &PathContext, bsdf: &Bsdf) -> bool {
        // `no_diffuse` first: it is false on most surfaces of most paths.
        self.no_diffuse
            && self.tracer.look_ahead
            && bsdf.is_specular()
            && bsdf.has_two_lobes()
            && !ctx.scene.has_scattering()
    }

    /// Traces both lobes from the glass of `event`, counts the light they
    /// meet first and walks the path on along one of those that met a
    /// surface (chosen by the lobes' probabilities when both did), to its
    /// end.
    pub(super) fn look_ahead(&mut self, ctx: &mut PathContext, walk: &Walk, event: &Event) {
        // The numbers a bounce draws, drawn as the bounce would.
        let [u0, u1, uc, u_rr] = ctx.sampler.next_4d();
        // Each lobe's walk, its probability, and what it met if it was
        // traced: only lobes out in the open (inside no object) are.
        let mut lobes: [Option<(Walk, f32, Option<Next>)>; 2] = [None, None];
        for (slot, reflect) in lobes.iter_mut().zip([true, false]) {
            let mut lobe = walk.clone();
            let Some(p) = walk::bounce_along_lobe(ctx, &mut lobe, event, reflect, (u0, u1), self)
            else {
                continue;
            };
            if !lobe.stack.is_empty() {
                *slot = Some((lobe, p, None));
                continue;
            }
            let next = trace(
                ctx.scene,
                &mut lobe.ray,
                FirstHit::Unknown,
                false,
                &mut lobe.stack,
                ctx.wl,
                &mut lobe.flight,
                None,
                ctx.counters,
            );
            match next {
                Next::Escaped => self.escaped(ctx, &lobe),
                Next::Surface { ref hit, .. } => {
                    self.add_emission(ctx, &lobe, hit);
                    *slot = Some((lobe, p, Some(next)));
                }
                // No medium scatters here; a lost ray carries nothing.
                Next::Medium { .. } | Next::Lost => {}
            }
        }
        let (mut lobe, next) = match lobes {
            [Some((r, p_r, next_r)), Some((t, p_t, next_t))] => {
                // Both go on: one sample of the two, by their probabilities.
                let q = p_r / (p_r + p_t);
                let (mut lobe, q, next) = if uc < q {
                    (r, q, next_r)
                } else {
                    (t, 1.0 - q, next_t)
                };
                lobe.flight.beta /= q;
                (lobe, next)
            }
            [Some((lobe, _, next)), None] | [None, Some((lobe, _, next))] => (lobe, next),
            [None, None] => return,
        };
        if !walk::roulette(ctx, &mut lobe, u_rr) {
            return;
        }
        // The rest of the path is walked here, within this step of a
        // stream: its shadow rays are traced as they come.
        self.defers_shadows = false;
        let go = match next {
            Some(next) => {
                self.counted_emission = true;
                walk::take(ctx, &mut lobe, next, self)
            }
            None => Flow::Go,
        };
        if go == Flow::Go {
            walk::walk(ctx, &mut lobe, self);
        }
    }
}
