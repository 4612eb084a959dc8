//! A subpath's vertices: where they are, what they carry, their densities
//! in both directions, and what a light vertex emits.

use glam::{Vec2, Vec3};

use crate::integrator::interface::stack_towards;
use crate::integrator::ior_stack::{Entry, IorStack};
use crate::light::LightSource;
use crate::material::{Bsdf, TransportMode};
use crate::medium::HenyeyGreenstein;
use crate::scene::Scene;
use crate::spectrum::{SampledSpectrum, SampledWavelengths};

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Kind {
    Camera,
    /// A point on a light, or where a camera ray left the scene.
    Light,
    Surface,
    /// A scattering event inside a medium.
    Medium,
}

/// One vertex of a subpath.
#[derive(Clone, Copy, Debug)]
pub(super) struct Vertex {
    pub(super) kind: Kind,
    pub(super) p: Vec3,
    pub(super) p_err: Vec3,
    /// Geometric normal; zero off surfaces (the pinhole, a point light, a
    /// light at infinity), where no cosine converts densities.
    pub(super) ng: Vec3,
    pub(super) uv: Vec2,
    /// The subpath's throughput up to here, over its density.
    pub(super) beta: SampledSpectrum,
    /// Surfaces only.
    pub(super) bsdf: Option<Bsdf>,
    /// Medium vertices only, with the direction back along the subpath.
    pub(super) phase: Option<HenyeyGreenstein>,
    pub(super) wo: Vec3,
    /// The media the subpath arrived in, and (surfaces) what `trace` said
    /// of the surface: connections start in the media on their side.
    pub(super) stack: IorStack,
    pub(super) crossing: Option<(Entry, bool)>,
    /// The subpath's spectral-MIS density ratios up to here (`volume`).
    pub(super) r: SampledSpectrum,
    /// The light this vertex lies on (an emissive surface or a sampled
    /// light). None on a `Light` vertex: a camera ray that escaped, which
    /// sees every light at infinity at once.
    pub(super) light: Option<usize>,
    /// Reached through a Dirac lobe: no connection can make this vertex.
    pub(super) delta: bool,
    /// The surface's material (surfaces only): whether the camera sees it.
    pub(super) material: Option<u32>,
    /// Area density (solid angle for lights at infinity) of this vertex
    /// from its own subpath, and from the other direction.
    pub(super) pdf_fwd: f32,
    pub(super) pdf_rev: f32,
}

impl Vertex {
    pub(super) fn new(kind: Kind, p: Vec3, beta: SampledSpectrum) -> Self {
        Self {
            kind,
            p,
            p_err: Vec3::ZERO,
            ng: Vec3::ZERO,
            uv: Vec2::ZERO,
            beta,
            bsdf: None,
            phase: None,
            wo: Vec3::ZERO,
            stack: IorStack::default(),
            crossing: None,
            r: SampledSpectrum::ONE,
            light: None,
            delta: false,
            material: None,
            pdf_fwd: 0.0,
            pdf_rev: 0.0,
        }
    }

    pub(super) fn on_surface(&self) -> bool {
        self.ng != Vec3::ZERO
    }

    pub(super) fn is_light(&self) -> bool {
        self.kind == Kind::Light || self.light.is_some()
    }

    pub(super) fn is_infinite_light(&self, scene: &Scene) -> bool {
        self.kind == Kind::Light && self.light.is_none_or(|i| scene.lights.get(i).is_infinite())
    }

    pub(super) fn is_delta_light(&self, scene: &Scene) -> bool {
        self.kind == Kind::Light && self.light.is_some_and(|i| scene.lights.get(i).is_delta())
    }

    /// Can a connection (a shadow ray) end at this subpath vertex? Only a
    /// surface with a lobe that has a density: connections to the camera
    /// and to lights sample fresh endpoints (t = 1, s = 1), and a camera ray
    /// that escaped has no point to aim at.
    pub(super) fn connectible(&self) -> bool {
        match self.kind {
            Kind::Surface => self.bsdf.is_some_and(|b| b.flags().has_non_specular()),
            Kind::Medium => true,
            _ => false,
        }
    }

    /// The media a connection leaving this vertex towards `w` starts in.
    pub(super) fn stack_towards(&self, w: Vec3) -> IorStack {
        match &self.bsdf {
            Some(b) => stack_towards(&self.stack, self.crossing, b.wo(), w, self.ng),
            None => self.stack,
        }
    }

    pub(super) fn dir_to(&self, v: &Vertex) -> Vec3 {
        (v.p - self.p).normalize_or_zero()
    }

    /// Converts a solid-angle density at this vertex into the area density
    /// of `next`.
    pub(super) fn area_density(&self, pdf_dir: f32, next: &Vertex, scene: &Scene) -> f32 {
        if next.is_infinite_light(scene) {
            return pdf_dir;
        }
        let w = next.p - self.p;
        let d2 = w.length_squared();
        if !(d2 > 0.0) {
            return 0.0;
        }
        let mut pdf = pdf_dir / d2;
        if next.on_surface() {
            pdf *= next.ng.dot(w).abs() / d2.sqrt();
        }
        pdf
    }

    /// The BSDF (or importance) value for leaving this vertex towards `next`.
    pub(super) fn f(&self, next: &Vertex, mode: TransportMode) -> SampledSpectrum {
        match (&self.bsdf, &self.phase) {
            (Some(b), _) => b.f(b.wo(), self.dir_to(next), mode),
            (None, Some(phase)) => SampledSpectrum::splat(phase.p(-self.wo, self.dir_to(next))),
            _ => SampledSpectrum::ZERO,
        }
    }

    /// |cos| at this vertex towards `next`, by the shading normal (1 off surfaces).
    pub(super) fn cos_to(&self, next: &Vertex) -> f32 {
        match &self.bsdf {
            Some(b) => b.cos_theta(self.dir_to(next)),
            None => 1.0,
        }
    }

    /// Area density with which this vertex, reached from `prev`, samples `next`.
    pub(super) fn pdf(&self, scene: &Scene, prev: Option<&Vertex>, next: &Vertex) -> f32 {
        let pdf_dir = match self.kind {
            Kind::Light => return self.pdf_light(scene, next),
            Kind::Camera => scene.camera.pdf_we(self.p, self.dir_to(next)),
            Kind::Surface => match (prev, &self.bsdf) {
                (Some(prev), Some(b)) => b.pdf(
                    self.dir_to(prev),
                    self.dir_to(next),
                    TransportMode::Radiance,
                ),
                _ => 0.0,
            },
            Kind::Medium => match (prev, &self.phase) {
                (Some(prev), Some(phase)) => phase.p(prev.dir_to(self), self.dir_to(next)),
                _ => 0.0,
            },
        };
        self.area_density(pdf_dir, next, scene)
    }

    /// Area density with which this light vertex sends a ray to `next`.
    pub(super) fn pdf_light(&self, scene: &Scene, next: &Vertex) -> f32 {
        let w = self.dir_to(next);
        let mut pdf = if self.is_infinite_light(scene) {
            // Rays from infinity start uniformly on the scene's disc.
            scene.sphere.disc_pdf()
        } else {
            let Some(i) = self.light else { return 0.0 };
            let d2 = (next.p - self.p).length_squared();
            if !(d2 > 0.0) {
                return 0.0;
            }
            scene.lights.get(i).pdf_le(self.uv, w).1 / d2
        };
        if next.on_surface() {
            pdf *= next.ng.dot(w).abs();
        }
        pdf
    }

    /// Density of choosing this light vertex as a light subpath's origin
    /// (solid angle of the direction for lights at infinity), given that
    /// the subpath goes on to `next`.
    pub(super) fn pdf_light_origin(&self, scene: &Scene, next: &Vertex) -> f32 {
        let w = self.dir_to(next);
        if self.is_infinite_light(scene) {
            return infinite_density(scene, next.p, -w);
        }
        let Some(i) = self.light else { return 0.0 };
        scene.lights.pmf(i) * scene.lights.get(i).pdf_le(self.uv, w).0
    }

    /// Radiance this light vertex sends towards `to`.
    pub(super) fn le(
        &self,
        scene: &Scene,
        to: &Vertex,
        wl: &SampledWavelengths,
    ) -> SampledSpectrum {
        if !self.is_light() {
            return SampledSpectrum::ZERO;
        }
        let w = self.dir_to(to);
        if self.is_infinite_light(scene) {
            let mut le = SampledSpectrum::ZERO;
            for (_, light) in scene.lights.infinite() {
                le += light.le(-w, wl);
            }
            return le;
        }
        match self.light {
            Some(i) => scene.lights.get(i).l(self.uv, w, wl),
            None => SampledSpectrum::ZERO,
        }
    }
}

/// Density (solid angle, selection included) with which the lights at
/// infinity would be sampled from `p` in direction `wi` (towards them).
pub(super) fn infinite_density(scene: &Scene, p: Vec3, wi: Vec3) -> f32 {
    scene
        .lights
        .infinite()
        .map(|(i, light)| scene.lights.pmf(i) * light.pdf_li(p, wi, None))
        .sum()
}
