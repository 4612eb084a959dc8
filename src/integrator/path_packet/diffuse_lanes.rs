//! The packet's diffuse bounces as a structure of arrays: every lane whose
//! path scatters from a diffuse surface and samples an area light puts
//! what its bounce needs in a slot (`DiffuseBounces::push`), then one loop
//! takes all the slots' light samples, directions and Russian roulette
//! together, which the compiler vectorises, a slot to a SIMD lane
//! (sixteen to an AVX-512 register where the CPU has it). Each slot does
//! `Lane::bounce`'s operations for a `Diffuse` surface in the same order,
//! so the image is the same bit for bit.

use std::f32::consts::FRAC_1_PI;

use glam::{Vec3, Vec4};

use crate::geometry::bvh::MAX_PACKET_WIDTH;
use crate::geometry::offset::offset_ray_origin_by_components;
use crate::geometry::Ray;
use crate::integrator::{power_heuristic, roulette_q};
use crate::light::LightPoint;
use crate::material::{cosine_hemisphere, facing_frame, ShadingGeometry};
use crate::scene::SurfaceHit;
use crate::spectrum::SampledSpectrum;

const SLOTS: usize = MAX_PACKET_WIDTH;

type Lanes = [f32; SLOTS];

/// A vector's components, a lane each.
#[derive(Clone, Copy, Default)]
struct Vectors([Lanes; 3]);

impl Vectors {
    #[inline(always)]
    fn get(&self, i: usize) -> Vec3 {
        Vec3::new(self.0[0][i], self.0[1][i], self.0[2][i])
    }

    #[inline(always)]
    fn set(&mut self, i: usize, v: Vec3) {
        (self.0[0][i], self.0[1][i], self.0[2][i]) = (v.x, v.y, v.z);
    }
}

/// A spectrum's four values, a lane each.
#[derive(Clone, Copy, Default)]
struct Spectra([Lanes; 4]);

impl Spectra {
    #[inline(always)]
    fn get(&self, i: usize) -> [f32; 4] {
        [self.0[0][i], self.0[1][i], self.0[2][i], self.0[3][i]]
    }

    #[inline(always)]
    fn set(&mut self, i: usize, v: [f32; 4]) {
        for (c, v) in v.into_iter().enumerate() {
            self.0[c][i] = v;
        }
    }
}

/// What a diffuse bounce with an area light's sample needs.
pub(super) struct DiffuseBounce<'a> {
    pub hit: &'a SurfaceHit,
    pub wo: Vec3,
    /// R/π at the path's wavelengths.
    pub f: SampledSpectrum,
    pub beta: SampledSpectrum,
    /// The light's point, its emission seen from its emitting side, whether
    /// it emits from both, its area and the probability of choosing it.
    pub point: LightPoint,
    pub emission: SampledSpectrum,
    pub two_sided: bool,
    pub area: f32,
    pub pmf: f32,
    /// The direction's numbers, the roulette's, and whether it plays.
    pub u: (f32, f32),
    pub u_rr: f32,
    pub roulette: bool,
}

/// What a bounce left its lane: the light sample's shadow ray and the
/// light it brings unblocked (None where it found none), and the path's
/// next ray and throughput, with the density of its direction (None where
/// the path ends).
pub(super) struct Bounced {
    pub shadow: Option<(Ray, SampledSpectrum)>,
    pub next: Option<(Ray, SampledSpectrum, f32)>,
}

/// The slots of a packet's diffuse bounces, inputs and answers.
#[derive(Default)]
pub(super) struct DiffuseBounces {
    /// The lane of each slot in use.
    lanes: [usize; SLOTS],
    used: usize,
    p: Vectors,
    p_err: Vectors,
    ng: Vectors,
    ns: Vectors,
    wo: Vectors,
    f: Spectra,
    beta: Spectra,
    light_p: Vectors,
    light_p_err: Vectors,
    light_n: Vectors,
    emission: Spectra,
    two_sided: [bool; SLOTS],
    area: Lanes,
    pmf: Lanes,
    u0: Lanes,
    u1: Lanes,
    u_rr: Lanes,
    roulette: [bool; SLOTS],
    // The answers.
    shadow_found: [bool; SLOTS],
    shadow_origin: Vectors,
    shadow_target: Vectors,
    unblocked: Spectra,
    goes_on: [bool; SLOTS],
    origin: Vectors,
    wi: Vectors,
    next_beta: Spectra,
    pdf: Lanes,
}

impl DiffuseBounces {
    /// Takes `lane`'s bounce.
    #[inline(always)]
    pub fn push(&mut self, lane: usize, b: DiffuseBounce) {
        let i = self.used;
        self.lanes[i] = lane;
        self.used += 1;
        self.p.set(i, b.hit.p);
        self.p_err.set(i, b.hit.p_err);
        self.ng.set(i, b.hit.ng);
        self.ns.set(i, b.hit.ns);
        self.wo.set(i, b.wo);
        self.f.set(i, b.f.to_array());
        self.beta.set(i, b.beta.to_array());
        self.light_p.set(i, b.point.p);
        self.light_p_err.set(i, b.point.p_err);
        self.light_n.set(i, b.point.n);
        self.emission.set(i, b.emission.to_array());
        self.two_sided[i] = b.two_sided;
        self.area[i] = b.area;
        self.pmf[i] = b.pmf;
        (self.u0[i], self.u1[i]) = b.u;
        self.u_rr[i] = b.u_rr;
        self.roulette[i] = b.roulette;
    }

    /// Every bounce taken, then `answer(lane, what it left)` for each, in
    /// the order they were taken; the slots are then free again.
    pub fn finish(&mut self, mut answer: impl FnMut(usize, Bounced)) {
        if self.used == 0 {
            return;
        }
        self.run();
        for i in 0..self.used {
            let shadow = self.shadow_found[i].then(|| {
                let ray = Ray::towards(self.shadow_origin.get(i), self.shadow_target.get(i));
                (ray, Vec4::from_array(self.unblocked.get(i)))
            });
            let next = self.goes_on[i].then(|| {
                let ray = Ray::new(self.origin.get(i), self.wi.get(i));
                (ray, Vec4::from_array(self.next_beta.get(i)), self.pdf[i])
            });
            answer(self.lanes[i], Bounced { shadow, next });
        }
        self.used = 0;
    }

    /// The slots' bounces: sixteen compiled for AVX-512 where the packets
    /// are sixteen paths (the CPU has it), else eight.
    fn run(&mut self) {
        #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
        if crate::geometry::bvh::packet_width() == 16 {
            // SAFETY: packets are sixteen wide only where the CPU has
            // AVX-512F.
            unsafe { self.run_sixteen() };
            return;
        }
        if self.used <= 8 {
            self.run_lanes::<8>();
        } else {
            self.run_lanes::<SLOTS>();
        }
    }

    /// # Safety
    /// Only where the CPU has AVX-512F.
    #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
    #[target_feature(enable = "avx512f")]
    unsafe fn run_sixteen(&mut self) {
        self.run_lanes::<SLOTS>();
    }

    /// `Lane::bounce` for a `Diffuse` surface and an area light's sample,
    /// in the first `N` slots, without branches: a loop the compiler
    /// vectorises.
    #[inline(always)]
    fn run_lanes<const N: usize>(&mut self) {
        for i in 0..N {
            let (p, p_err, ng_hit, wo) = (
                self.p.get(i),
                self.p_err.get(i),
                self.ng.get(i),
                self.wo.get(i),
            );
            // `Diffuse::at`: the frame of the shading normal on wo's side.
            let geometry = ShadingGeometry {
                ng: ng_hit,
                ns: self.ns.get(i),
                wo,
            };
            let (frame, ng) = facing_frame(&geometry);
            let wo_local = frame.to_local(wo);
            let wo_ng = wo.dot(ng);
            let (f, beta) = (self.f.get(i), self.beta.get(i));

            // The light sample (`AreaLight::li_from`, `Diffuse::eval`).
            let (lp, ln) = (self.light_p.get(i), self.light_n.get(i));
            let to_light = lp - p;
            let dist2 = to_light.length_squared();
            let wi = to_light / dist2.sqrt();
            let front = self.two_sided[i] | !(ln.dot(-to_light) <= 0.0);
            let emission = self.emission.get(i);
            let li = emission.map(|e| if front { e } else { 0.0 });
            let cos_light = ln.dot(wi).abs();
            let light_pdf_sa = dist2 / (cos_light * self.area[i]);
            let wi_local = frame.to_local(wi);
            let reflects = (wo_local.z * wi_local.z > 0.0) & (wo_ng * wi.dot(ng) > 0.0);
            let cos = wi_local.z.abs();
            let fc = f.map(|f| if reflects { f * cos } else { 0.0 });
            let scattering_pdf = if reflects { cos * FRAC_1_PI } else { 0.0 };
            let light_pdf = self.pmf[i] * light_pdf_sa;
            let scale = power_heuristic(light_pdf, scattering_pdf) / light_pdf;
            let unblocked: [f32; 4] = std::array::from_fn(|c| beta[c] * (fc[c] * li[c] * scale));
            let any = |s: [f32; 4]| (s[0] != 0.0) | (s[1] != 0.0) | (s[2] != 0.0) | (s[3] != 0.0);
            self.shadow_found[i] =
                (dist2 != 0.0) & any(li) & (cos_light != 0.0) & reflects & any(fc);
            self.shadow_origin
                .set(i, offset_ray_origin_by_components(p, p_err, ng_hit, wi));
            let (lp_err, to) = (self.light_p_err.get(i), -wi);
            self.shadow_target
                .set(i, offset_ray_origin_by_components(lp, lp_err, ln, to));
            self.unblocked.set(i, unblocked);

            // The bounce (`Diffuse::sample`) and Russian roulette.
            let mut local = cosine_hemisphere((self.u0[i], self.u1[i]));
            if wo_local.z < 0.0 {
                local.z = -local.z;
            }
            let wi = frame.to_world(local);
            let reflects = (wo_local.z * local.z > 0.0) & (wo_ng * wi.dot(ng) > 0.0);
            let pdf = local.z.abs() * FRAC_1_PI;
            let scale = frame.n.dot(wi).abs() / pdf;
            let beta: [f32; 4] = std::array::from_fn(|c| beta[c] * (f[c] * scale));
            let max_beta = beta[0].max(beta[1]).max(beta[2]).max(beta[3]);
            let q = roulette_q(max_beta, 1.0, self.roulette[i]);
            self.next_beta.set(i, beta.map(|b| b / (1.0 - q)));
            let survives = (self.u_rr[i] >= q) & (max_beta > 0.0);
            self.goes_on[i] = reflects & (pdf > 0.0) & pdf.is_finite() & survives;
            self.origin
                .set(i, offset_ray_origin_by_components(p, p_err, ng_hit, wi));
            self.wi.set(i, wi);
            self.pdf[i] = pdf;
        }
    }
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use glam::Vec2;

    use super::super::surface::{Diffuse, Surface};
    use super::*;
    use crate::geometry::offset::offset_ray_origin;
    use crate::integrator::russian_roulette;
    use crate::light::{AreaLight, Emitter};
    use crate::material::Reflectance;
    use crate::spectrum::memo::SpectrumMemo;
    use crate::spectrum::{SampledWavelengths, Spectrum, TabulatedSpectrum};
    use crate::test_random::XorShift64;

    /// What a lane leaves, as bits: the shadow ray and its light, the next
    /// ray, throughput and density.
    type Bits = (Option<[u32; 11]>, Option<[u32; 12]>);

    fn bits(b: &Bounced) -> Bits {
        let ray = |r: &Ray| {
            let (o, d) = (r.origin.to_array(), r.dir.to_array());
            [o[0], o[1], o[2], d[0], d[1], d[2], r.t_max].map(f32::to_bits)
        };
        let shadow = b.shadow.map(|(r, s)| {
            let (r, s) = (ray(&r), s.to_array().map(f32::to_bits));
            std::array::from_fn(|k| if k < 7 { r[k] } else { s[k - 7] })
        });
        let next = b.next.map(|(r, beta, pdf)| {
            let (r, s) = (ray(&r), beta.to_array().map(f32::to_bits));
            std::array::from_fn(|k| match k {
                0..7 => r[k],
                7..11 => s[k - 7],
                _ => pdf.to_bits(),
            })
        });
        (shadow, next)
    }

    /// A diffuse bounce with an area light's sample as the packet core
    /// takes it one lane at a time (`Lane::sample_light` and
    /// `Lane::bounce` with a `Diffuse` surface), from the scalar pieces.
    fn one_lane(b: &DiffuseBounce, r: f32, light: &AreaLight, wl: &SampledWavelengths) -> Bits {
        let hit = b.hit;
        let mut memo = SpectrumMemo::default();
        let reflectance = Reflectance::from(Spectrum::Constant(r));
        let surface = Diffuse::at(&reflectance, hit, b.wo, wl, &mut memo);
        let shadow = light
            .li_from(b.point, hit.p, wl, |s| s.sample(wl))
            .and_then(|ls| {
                let (f, scattering_pdf) = surface.eval(ls.wi);
                if f == SampledSpectrum::ZERO {
                    return None;
                }
                let lp = ls.point.expect("an area light's point");
                let origin = offset_ray_origin(hit.p, hit.p_err, hit.ng, ls.wi);
                let ray = Ray::towards(origin, offset_ray_origin(lp.p, lp.p_err, lp.n, -ls.wi));
                let light_pdf = b.pmf * ls.pdf;
                let weight = power_heuristic(light_pdf, scattering_pdf);
                Some((ray, b.beta * (f * ls.li * (weight / light_pdf))))
            });
        let drawn = Diffuse::draw([b.u.0, b.u.1, 0.5, b.u_rr]);
        let next = surface.sample(drawn).and_then(|(wi, weight, pdf, _)| {
            let mut beta = b.beta * weight;
            let ray = Ray::new(offset_ray_origin(hit.p, hit.p_err, hit.ng, wi), wi);
            let depth = if b.roulette { 5 } else { 1 };
            russian_roulette(&mut beta, 1.0, depth, 3, b.u_rr).then_some((ray, beta, pdf))
        });
        bits(&Bounced { shadow, next })
    }

    /// The slots answer each lane as the lane alone would, bit for bit:
    /// random surfaces, sides, lights (one- and two-sided, above and below),
    /// throughputs and numbers, packets of 1 to 16 bounces.
    #[test]
    fn slots_bounce_as_one_lane_does() {
        let mut random = XorShift64(0x9e37_79b9_7f4a_7c15);
        let mut u = move || random.next_f64() as f32;
        let mut slots = DiffuseBounces::default();
        let (mut shadows, mut nexts) = (0, 0);
        for round in 0..64 {
            let used = 1 + round % SLOTS;
            let unit =
                |u: &mut dyn FnMut() -> f32| Vec3::new(u() - 0.5, u() - 0.5, u() - 0.5).normalize();
            let cases: Vec<_> = (0..used)
                .map(|_| {
                    let ng = unit(&mut u);
                    // A shading normal near the geometric one, or on its far side.
                    let ns = (ng + 0.6 * unit(&mut u)).normalize();
                    let p = Vec3::new(u(), u(), u()) * 4.0 - 2.0;
                    let hit = SurfaceHit {
                        t: 1.0,
                        p,
                        p_err: p.abs() * 1e-6,
                        ng,
                        ns,
                        uv: Vec2::ZERO,
                        tangent: glam::Vec4::ZERO,
                        material: 0,
                        light: None,
                    };
                    let c = Vec3::new(u() - 0.5, 2.0 * u() - 1.0, u() - 0.5) * 6.0;
                    let tri = [
                        c,
                        c + Vec3::new(1.0, 0.0, 0.0),
                        c + Vec3::new(0.0, u(), 1.0),
                    ];
                    let level = if u() < 0.2 { 0.0 } else { 1.0 + 9.0 * u() };
                    let emitter = Emitter {
                        spectrum: Spectrum::Table(TabulatedSpectrum::new(
                            vec![360.0, 560.0, 830.0],
                            vec![level, 0.5 * level, 2.0 * level],
                        )),
                        texture: None,
                    };
                    let light = AreaLight::new(tri, None, Arc::new(emitter), u() < 0.3);
                    let wl = SampledWavelengths::sample_visible(u());
                    (hit, light, wl, unit(&mut u), u())
                })
                .collect();
            let bounces: Vec<_> = cases
                .iter()
                .map(|(hit, light, wl, wo, r)| DiffuseBounce {
                    hit,
                    wo: *wo,
                    f: SampledSpectrum::splat(*r) * std::f32::consts::FRAC_1_PI,
                    beta: SampledSpectrum::new(u(), u(), u(), u()) * 3.0,
                    point: light.sample_point((u(), u())),
                    emission: light.front_emission_by(Vec2::ZERO, wl, |s| s.sample(wl)),
                    two_sided: light.two_sided(),
                    area: light.area(),
                    pmf: 0.25 + 0.75 * u(),
                    u: (u(), u()),
                    u_rr: u(),
                    roulette: u() < 0.5,
                })
                .collect();
            let want: Vec<Bits> = bounces
                .iter()
                .zip(&cases)
                .map(|(b, (_, light, wl, _, r))| one_lane(b, *r, light, wl))
                .collect();
            for (k, b) in bounces.into_iter().enumerate() {
                slots.push(k, b);
            }
            slots.finish(|k, got| {
                let got = bits(&got);
                shadows += got.0.is_some() as u32;
                nexts += got.1.is_some() as u32;
                assert_eq!(got, want[k], "round {round}, lane {k}");
            });
        }
        // Both outcomes of each step were met.
        let all = (0..64).map(|r| 1 + r % SLOTS as u32).sum::<u32>();
        assert!(
            shadows > all / 8 && shadows < all,
            "{shadows} shadow rays of {all}"
        );
        assert!(
            nexts > all / 8 && nexts < all,
            "{nexts} paths going on of {all}"
        );
    }
}
