//! The BSDF at one hit: a lobe (the scattering model, in its local shading
//! frame) wrapped with the frame and the geometric normal. Every integrator
//! talks to this one interface; the lobes never see world space.
//!
//! - `f`, `pdf`, `eval` (both at once) and `sample` take both directions
//!   explicitly, so a bidirectional integrator can ask for the density of
//!   the reverse direction.
//! - The [`TransportMode`] says which quantity flows along the path:
//!   radiance (paths from the camera) or importance (paths from lights).
//!   Refraction scales radiance by 1/η'² but not importance, and shading
//!   normals make the adjoint BSDF differ from the BSDF (Veach 1997, §5.3):
//!   both are handled here, once.
//! - The geometric normal decides what reflects and what transmits: a
//!   reflection must stay on `wo`'s side of the true surface and a
//!   transmission must cross it, whatever the shading normal says.
//! - A lobe with a density samples a direction and returns its own `eval`
//!   of it, so sampling agrees with evaluation (what MIS needs; the chi²
//!   tests check it), and one guard here drops samples of zero or
//!   non-finite weight.

use glam::Vec3;

use super::conductor::ConductorLobe;
use super::dielectric::DielectricLobe;
use super::diffuse::DiffuseLobe;
use super::pbr::PbrLobe;
use crate::geometry::Frame;
use crate::spectrum::SampledSpectrum;

/// What flows along a path: radiance from the camera side, importance from
/// the light side.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TransportMode {
    Radiance,
    Importance,
}

/// Kinds of scattering a BSDF (or one sample of it) has, as bits.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct BsdfFlags(u8);

impl BsdfFlags {
    pub const REFLECTION: Self = Self(1);
    pub const TRANSMISSION: Self = Self(2);
    pub const DIFFUSE: Self = Self(4);
    pub const GLOSSY: Self = Self(8);
    /// A Dirac delta: light sampling and MIS cannot reach it.
    pub const SPECULAR: Self = Self(16);

    pub const fn union(self, other: Self) -> Self {
        Self(self.0 | other.0)
    }

    pub fn contains(self, other: Self) -> bool {
        self.0 & other.0 == other.0
    }

    #[inline]
    pub fn is_specular(self) -> bool {
        self.contains(Self::SPECULAR)
    }

    /// Has a lobe with a density (diffuse or glossy): light sampling helps.
    pub fn has_non_specular(self) -> bool {
        self.0 & (Self::DIFFUSE.0 | Self::GLOSSY.0) != 0
    }

    pub fn is_transmission(self) -> bool {
        self.contains(Self::TRANSMISSION)
    }
}

impl std::ops::BitOr for BsdfFlags {
    type Output = Self;
    fn bitor(self, rhs: Self) -> Self {
        self.union(rhs)
    }
}

/// f and its sampling density for one pair of directions.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BsdfEval {
    pub f: SampledSpectrum,
    /// Solid-angle density with which `sample` returns `wi` given `wo`.
    pub pdf: f32,
}

impl BsdfEval {
    pub const ZERO: Self = Self {
        f: SampledSpectrum::ZERO,
        pdf: 0.0,
    };
}

/// A sampled direction with its value and density (world space).
#[derive(Clone, Copy, Debug)]
pub struct BsdfSample {
    pub wi: Vec3,
    pub f: SampledSpectrum,
    pub pdf: f32,
    /// The kind of lobe that was sampled.
    pub flags: BsdfFlags,
    /// η' of a transmission (n_transmitted / n_incident); 1 for reflection.
    pub eta: f32,
}

impl BsdfSample {
    pub fn is_specular(&self) -> bool {
        self.flags.is_specular()
    }
}

/// What a lobe's `sample` returns, in its local frame. A lobe with a
/// density returns its own `eval` of the sampled direction (tests/bsdf.rs
/// checks that they agree); a Dirac lobe its value and discrete probability.
#[derive(Clone, Copy, Debug)]
pub struct LobeSample {
    pub wi: Vec3,
    pub f: SampledSpectrum,
    pub pdf: f32,
    pub flags: BsdfFlags,
    pub eta: f32,
}

impl LobeSample {
    /// A sampled direction of a lobe with a density, with its evaluation.
    #[inline]
    pub fn evaluated(wi: Vec3, e: BsdfEval, flags: BsdfFlags, eta: f32) -> Self {
        Self {
            wi,
            f: e.f,
            pdf: e.pdf,
            flags,
            eta,
        }
    }
}

/// The scattering models. Adding one: a module with a lobe type that has
/// `flags`, `eval` and `sample` in local coordinates (normal +z), a variant
/// here, and one line in each `dispatch!` below.
#[derive(Clone, Copy, Debug)]
pub enum Lobe {
    Diffuse(DiffuseLobe),
    Conductor(ConductorLobe),
    Dielectric(DielectricLobe),
    Pbr(PbrLobe),
}

macro_rules! dispatch {
    ($lobe:expr, $b:ident => $call:expr) => {
        match $lobe {
            Lobe::Diffuse($b) => $call,
            Lobe::Conductor($b) => $call,
            Lobe::Dielectric($b) => $call,
            Lobe::Pbr($b) => $call,
        }
    };
}

impl Lobe {
    #[inline]
    fn flags(&self) -> BsdfFlags {
        dispatch!(self, b => b.flags())
    }

    #[inline]
    fn eval(&self, wo: Vec3, wi: Vec3, mode: TransportMode) -> BsdfEval {
        dispatch!(self, b => b.eval(wo, wi, mode))
    }

    #[inline]
    fn sample(&self, wo: Vec3, uc: f32, u: (f32, f32), mode: TransportMode) -> Option<LobeSample> {
        dispatch!(self, b => b.sample(wo, uc, u, mode))
    }
}

/// The BSDF at one hit, for one set of wavelengths, in world space.
#[derive(Clone, Copy, Debug)]
pub struct Bsdf {
    frame: Frame,
    /// Geometric normal (either orientation: only sides are compared).
    ng: Vec3,
    lobe: Lobe,
    /// The direction the path arrived from, in world and local space: most
    /// queries ask about it, so its transform is done once.
    wo: Vec3,
    wo_local: Vec3,
}

impl Bsdf {
    /// The BSDF of `lobe` in `frame`, at a hit reached from direction `wo`.
    #[inline]
    pub fn new(frame: Frame, ng: Vec3, lobe: Lobe, wo: Vec3) -> Self {
        Self {
            frame,
            ng,
            lobe,
            wo,
            wo_local: frame.to_local(wo),
        }
    }

    #[inline]
    fn local(&self, w: Vec3) -> Vec3 {
        if w == self.wo {
            self.wo_local
        } else {
            self.frame.to_local(w)
        }
    }

    /// `wo` in the local frame, None where it grazes the surface (no
    /// lobe can be sampled from there).
    #[inline(always)]
    fn sampling_wo(&self, wo: Vec3) -> Option<Vec3> {
        let wo_l = self.local(wo);
        (wo_l.z != 0.0).then_some(wo_l)
    }

    pub fn flags(&self) -> BsdfFlags {
        self.lobe.flags()
    }

    /// The direction the path arrived from (the `wo` it was built with).
    pub fn wo(&self) -> Vec3 {
        self.wo
    }

    /// Only Dirac lobes: light sampling cannot help.
    pub fn is_specular(&self) -> bool {
        !self.flags().has_non_specular()
    }

    /// |cos| between `w` and the shading normal, for the rendering equation.
    #[inline]
    pub fn cos_theta(&self, w: Vec3) -> f32 {
        self.frame.n.dot(w).abs()
    }

    /// Whether the geometric surface agrees with what the shading frame
    /// calls a reflection (`reflect`) or a transmission.
    #[inline]
    fn geometry_agrees(&self, wo: Vec3, wi: Vec3, reflect: bool) -> bool {
        (wo.dot(self.ng) * wi.dot(self.ng) > 0.0) == reflect
    }

    /// Veach's adjoint correction for shading normals, for importance:
    /// |wo·ns| |wi·ng| / (|wo·ng| |wi·ns|).
    #[inline]
    fn importance_correction(&self, wo: Vec3, wi: Vec3) -> f32 {
        let den = wo.dot(self.ng).abs() * self.frame.n.dot(wi).abs();
        if den == 0.0 {
            return 0.0;
        }
        self.frame.n.dot(wo).abs() * wi.dot(self.ng).abs() / den
    }

    /// f(wo, wi) and the density of sampling `wi` from `wo` (zero for Dirac lobes).
    #[inline]
    pub fn eval(&self, wo: Vec3, wi: Vec3, mode: TransportMode) -> BsdfEval {
        let (wo_l, wi_l) = (self.local(wo), self.frame.to_local(wi));
        if wo_l.z == 0.0 || !self.geometry_agrees(wo, wi, wo_l.z * wi_l.z > 0.0) {
            return BsdfEval::ZERO;
        }
        let mut e = self.lobe.eval(wo_l, wi_l, mode);
        if mode == TransportMode::Importance {
            e.f *= self.importance_correction(wo, wi);
        }
        e
    }

    pub fn f(&self, wo: Vec3, wi: Vec3, mode: TransportMode) -> SampledSpectrum {
        self.eval(wo, wi, mode).f
    }

    pub fn pdf(&self, wo: Vec3, wi: Vec3, mode: TransportMode) -> f32 {
        self.eval(wo, wi, mode).pdf
    }

    /// Samples `wi` given `wo`: `uc` chooses between lobes, `u` within one.
    #[inline]
    pub fn sample(
        &self,
        wo: Vec3,
        uc: f32,
        u: (f32, f32),
        mode: TransportMode,
    ) -> Option<BsdfSample> {
        let wo_l = self.sampling_wo(wo)?;
        let smp = self.lobe.sample(wo_l, uc, u, mode)?;
        self.in_world(wo, wo_l, smp, mode)
    }

    /// Whether the BSDF is a dielectric's that both reflects and
    /// transmits, so that a path may follow each lobe (`sample_lobe`).
    pub fn has_two_lobes(&self) -> bool {
        matches!(&self.lobe, Lobe::Dielectric(d) if d.has_two_lobes())
    }

    /// For a BSDF that `has_two_lobes`: a sample of its reflection
    /// (`reflect`) or of its transmission, with the probability `sample`
    /// gives that lobe there. The two samples, each weighted by its
    /// probability, estimate what one sample does.
    pub fn sample_lobe(
        &self,
        wo: Vec3,
        reflect: bool,
        u: (f32, f32),
        mode: TransportMode,
    ) -> Option<(BsdfSample, f32)> {
        let Lobe::Dielectric(lobe) = &self.lobe else {
            return None;
        };
        let wo_l = self.sampling_wo(wo)?;
        let (smp, probability) = lobe.sample_lobe(wo_l, reflect, u, mode)?;
        Some((self.in_world(wo, wo_l, smp, mode)?, probability))
    }

    /// A lobe's sample in world space, or None where it would cross the
    /// geometric surface the wrong way or carry nothing.
    #[inline(always)]
    fn in_world(
        &self,
        wo: Vec3,
        wo_l: Vec3,
        smp: LobeSample,
        mode: TransportMode,
    ) -> Option<BsdfSample> {
        let wi = self.frame.to_world(smp.wi);
        if !self.geometry_agrees(wo, wi, wo_l.z * smp.wi.z > 0.0) {
            return None;
        }
        let f = match mode {
            TransportMode::Radiance => smp.f,
            TransportMode::Importance => smp.f * self.importance_correction(wo, wi),
        };
        // One guard for every lobe: no sample of zero or non-finite weight.
        if !(smp.pdf > 0.0 && smp.pdf.is_finite() && f.is_finite()) {
            return None;
        }
        Some(BsdfSample {
            wi,
            f,
            pdf: smp.pdf,
            flags: smp.flags,
            eta: smp.eta,
        })
    }
}

/// `wo` and `wi` mirrored to `wo`'s upper hemisphere, for lobes that are
/// symmetric about the surface (both faces reflect alike).
pub(crate) fn upper(wo: Vec3, wi: Vec3) -> (Vec3, Vec3) {
    if wo.z < 0.0 {
        (Vec3::new(wo.x, wo.y, -wo.z), Vec3::new(wi.x, wi.y, -wi.z))
    } else {
        (wo, wi)
    }
}

/// Mirrors a local direction to the hemisphere of `wo`.
pub(crate) fn to_side_of(wo: Vec3, w: Vec3) -> Vec3 {
    if wo.z < 0.0 {
        Vec3::new(w.x, w.y, -w.z)
    } else {
        w
    }
}
