//! A subpath's random walk: the shared walk (`integrator::walk`), with a
//! visitor that records each vertex and the densities of reaching it
//! from either side.

use glam::Vec3;

use super::vertex::{Kind, Vertex};
use crate::integrator::ior_stack::IorStack;
use crate::integrator::walk::{self, Event, Flow, PathContext, Scatterer, Visitor, Walk};
use crate::material::TransportMode;
use crate::scene::{Scene, SurfaceHit};
use crate::spectrum::SampledSpectrum;

/// How a subpath walks: which quantity it carries and how far it goes.
pub(super) struct Subpath {
    pub(super) mode: TransportMode,
    pub(super) max_vertices: usize,
    pub(super) rr_depth: u32,
}

/// Where a subpath starts: its first ray, what it carries and the
/// solid-angle density of that ray's direction.
pub(super) struct Start {
    pub(super) ray: crate::geometry::Ray,
    pub(super) beta: SampledSpectrum,
    pub(super) pdf_dir: f32,
    pub(super) stack: IorStack,
}

impl Subpath {
    /// Extends `path` (which holds its origin) from `start`, sampling the
    /// BSDF at each surface and recording both densities; its first bounce
    /// takes the numbers `u_first`.
    pub(super) fn run(
        &self,
        ctx: &mut PathContext,
        start: Start,
        path: &mut Vec<Vertex>,
        u_first: [f32; 4],
    ) {
        if path.len() >= self.max_vertices {
            return;
        }
        let mut state = Walk::new(start.ray, start.stack, start.beta, self.rr_depth);
        // The camera subpath's first ray leaves the camera.
        state.camera_ray = self.mode == TransportMode::Radiance;
        let mut visitor = Record {
            mode: self.mode,
            max_vertices: self.max_vertices,
            path,
            pdf_dir: start.pdf_dir,
            u_first,
        };
        walk::walk(ctx, &mut state, &mut visitor);
    }
}

/// The subpath's visitor: a vertex at every event.
struct Record<'p> {
    mode: TransportMode,
    max_vertices: usize,
    path: &'p mut Vec<Vertex>,
    /// Solid-angle density of the direction the last vertex was left by.
    pdf_dir: f32,
    u_first: [f32; 4],
}

impl Visitor for Record<'_> {
    fn mode(&self) -> TransportMode {
        self.mode
    }

    fn arrive(&mut self, _: &mut PathContext, _: &Walk, _: Option<&SurfaceHit>) -> Flow {
        Flow::Go
    }

    fn scatter_from(&mut self, ctx: &mut PathContext, walk: &Walk, event: &Event) -> Flow {
        let prev = self.path.len() - 1;
        let beta = walk.flight.beta;
        let v = match event.at {
            Scatterer::Medium { p, phase } => {
                let mut v = Vertex::new(Kind::Medium, p, beta);
                v.phase = Some(phase);
                v.wo = event.wo;
                v.stack = walk.stack;
                v.r = walk.flight.r;
                v
            }
            Scatterer::Surface { hit, bsdf, medium } => {
                let mut v = Vertex::new(Kind::Surface, hit.p, beta);
                v.stack = walk.stack;
                v.crossing = medium;
                v.r = walk.flight.r;
                v.p_err = hit.p_err;
                v.ng = hit.ng;
                v.uv = hit.uv;
                v.bsdf = Some(*bsdf);
                v.light = hit.light;
                v.material = Some(hit.material);
                v
            }
        };
        let pdf_fwd = self.path[prev].area_density(self.pdf_dir, &v, ctx.scene);
        self.path.push(Vertex { pdf_fwd, ..v });
        if self.path.len() == self.max_vertices {
            Flow::End
        } else {
            Flow::Go
        }
    }

    fn numbers(&mut self, ctx: &mut PathContext, walk: &Walk) -> [f32; 4] {
        if walk.depth == 1 {
            self.u_first
        } else {
            ctx.sampler.next_4d()
        }
    }

    fn scattered(
        &mut self,
        scene: &Scene,
        _: &Walk,
        event: &Event,
        wi: Vec3,
        pdf: f32,
        specular: bool,
    ) {
        let cur = self.path.len() - 1;
        let pdf_rev_dir = match event.at {
            // The phase function is symmetric: the reverse density is the same.
            Scatterer::Medium { .. } => {
                self.pdf_dir = pdf;
                pdf
            }
            // A Dirac lobe's density is a delta in solid angle: counted as
            // 1 in both directions, its conversions to area (cos / d²) stay
            // in the ratios of `mis_weight`, where they cancel between the
            // strategies as Veach's derivation has them. (Counting it as 1
            // per area instead, as pbrt does, weights strategies across a
            // specular chain by the wrong geometry: the caustic of a ball
            // lens then goes to camera paths that find the light by chance.)
            Scatterer::Surface { .. } if specular => {
                self.path[cur].delta = true;
                self.pdf_dir = 1.0;
                1.0
            }
            Scatterer::Surface { bsdf, .. } => {
                self.pdf_dir = pdf;
                bsdf.pdf(wi, event.wo, self.mode)
            }
        };
        let rev = self.path[cur].area_density(pdf_rev_dir, &self.path[cur - 1], scene);
        self.path[cur - 1].pdf_rev = rev;
    }

    fn escaped(&mut self, ctx: &mut PathContext, walk: &Walk) {
        let scene = ctx.scene;
        let sees_infinity = self.mode == TransportMode::Radiance
            && scene.lights.infinite().next().is_some()
            && scene.sphere.radius > 0.0;
        if sees_infinity {
            // A point far beyond the scene along the ray: only its
            // direction matters.
            let ray = walk.ray;
            let far = 2.0 * scene.sphere.radius + (ray.origin - scene.sphere.centre).length();
            let mut v = Vertex::new(Kind::Light, ray.origin + ray.dir * far, walk.flight.beta);
            v.r = walk.flight.r;
            v.pdf_fwd = self.pdf_dir;
            self.path.push(v);
        }
    }
}
