//! Joining a light subpath's prefix to a camera subpath's: each
//! strategy's contribution and its MIS weight.

use glam::Vec2;

use super::vertex::{Kind, Vertex};
use crate::geometry::offset::offset_ray_origin;
use crate::geometry::Ray;
use crate::integrator::interface::{transmittance, transmittance_to_camera};
use crate::integrator::volume::mis_divisor;
use crate::integrator::walk::PathContext;
use crate::integrator::{lens_sample, PathCounters};
use crate::light::LightSource;
use crate::material::TransportMode;
use crate::sampler::Sampler;
use crate::scene::Scene;
use crate::spectrum::{SampledSpectrum, SampledWavelengths};

/// What one strategy contributes: to the sample's own pixel, or (t = 1)
/// to the pixel at `raster`.
pub(super) struct Contribution {
    pub(super) l: SampledSpectrum,
    pub(super) raster: Option<Vec2>,
}

/// The contribution of strategy (s, t), MIS weight included. `u_direct`
/// are the numbers for s = 1 (drawn from `sampler` when None).
pub(super) fn connect(
    ctx: &mut PathContext,
    light_path: &[Vertex],
    camera_path: &[Vertex],
    s: usize,
    t: usize,
    u_direct: Option<[f32; 4]>,
) -> Contribution {
    let scene: &Scene = ctx.scene;
    let wl: &SampledWavelengths = ctx.wl;
    let sampler: &mut Sampler = ctx.sampler;
    let counters: &mut PathCounters = ctx.counters;
    let none = Contribution {
        l: SampledSpectrum::ZERO,
        raster: None,
    };
    let mut sampled: Option<Vertex> = None;
    let mut raster = None;
    let l = if s == 0 {
        // The camera subpath hit a light.
        let pt = &camera_path[t - 1];
        if !pt.is_light() {
            return none;
        }
        pt.le(scene, &camera_path[t - 2], wl) * pt.beta
    } else if t == 1 {
        // A light vertex seen by the camera.
        let qs = &light_path[s - 1];
        if !qs.connectible() {
            return none;
        }
        let Some(cs) = scene.camera.sample_wi(qs.p, lens_sample(scene, sampler)) else {
            return none;
        };
        // The camera does not see a single-sided surface's back face.
        if qs
            .material
            .is_some_and(|m| scene.hides_back_face(m, qs.ng, -cs.wi))
        {
            return none;
        }
        let camera = Vertex::new(Kind::Camera, cs.p_lens, SampledSpectrum::splat(cs.weight));
        let l =
            qs.beta * qs.f(&camera, TransportMode::Importance) * camera.beta * qs.cos_to(&camera);
        if l == SampledSpectrum::ZERO {
            return none;
        }
        let origin = offset_ray_origin(qs.p, qs.p_err, qs.ng, cs.wi);
        let shadow = Ray::towards(origin, cs.p_lens).starting_in_free_space(!qs.on_surface());
        let tr = transmittance_to_camera(scene, &shadow, &qs.stack_towards(cs.wi), wl, counters);
        if tr == SampledSpectrum::ZERO {
            return none;
        }
        sampled = Some(camera);
        raster = Some(cs.raster);
        l * tr
    } else if s == 1 {
        // A point sampled on a light, joined to a camera vertex.
        let pt = &camera_path[t - 1];
        if !pt.connectible() {
            return none;
        }
        let [p0, p1, u_light, _] = u_direct.unwrap_or_else(|| sampler.next_4d());
        let Some((index, pmf)) = scene.lights.choose(u_light) else {
            return none;
        };
        let light = scene.lights.get(index);
        let Some(ls) = light.sample_li(pt.p, (p0, p1), wl) else {
            return none;
        };
        let p = match ls.point {
            Some(lp) => lp.p,
            None => {
                let far = 2.0 * scene.sphere.radius + (pt.p - scene.sphere.centre).length();
                pt.p + ls.wi * far
            }
        };
        let mut v = Vertex::new(Kind::Light, p, ls.li / (pmf * ls.pdf));
        v.light = Some(index);
        if let Some(lp) = ls.point.filter(|_| !light.is_delta()) {
            v.ng = lp.n;
            v.uv = lp.uv;
            v.p_err = lp.p_err;
        }
        v.pdf_fwd = v.pdf_light_origin(scene, pt);
        let l = pt.beta * pt.f(&v, TransportMode::Radiance) * v.beta * pt.cos_to(&v);
        if l == SampledSpectrum::ZERO {
            return none;
        }
        let origin = offset_ray_origin(pt.p, pt.p_err, pt.ng, ls.wi);
        let shadow = match ls.point {
            Some(lp) => Ray::towards(origin, offset_ray_origin(lp.p, lp.p_err, lp.n, -ls.wi)),
            None => Ray::new(origin, ls.wi),
        }
        .starting_in_free_space(!pt.on_surface());
        let tr = transmittance(scene, &shadow, &pt.stack_towards(ls.wi), wl, counters);
        if tr == SampledSpectrum::ZERO {
            return none;
        }
        sampled = Some(v);
        l * tr
    } else {
        // A shadow ray between a light vertex and a camera vertex.
        let (qs, pt) = (&light_path[s - 1], &camera_path[t - 1]);
        if !qs.connectible() || !pt.connectible() {
            return none;
        }
        let l = qs.beta
            * qs.f(pt, TransportMode::Importance)
            * pt.f(qs, TransportMode::Radiance)
            * pt.beta;
        if l == SampledSpectrum::ZERO {
            return none;
        }
        let d2 = (qs.p - pt.p).length_squared();
        if !(d2 > 0.0) {
            return none;
        }
        let g = qs.cos_to(pt) * pt.cos_to(qs) / d2;
        if g == 0.0 {
            return none;
        }
        let w = pt.dir_to(qs);
        let from = offset_ray_origin(pt.p, pt.p_err, pt.ng, w);
        let to = offset_ray_origin(qs.p, qs.p_err, qs.ng, -w);
        let tr = transmittance(
            scene,
            &Ray::towards(from, to).starting_in_free_space(!pt.on_surface()),
            &pt.stack_towards(w),
            wl,
            counters,
        );
        if tr == SampledSpectrum::ZERO {
            return none;
        }
        l * g * tr
    };
    if l == SampledSpectrum::ZERO {
        return none;
    }
    let w = mis_weight(scene, light_path, camera_path, sampled.as_ref(), s, t);
    // Spectral MIS over both subpaths' free flights: their densities multiply.
    let r_light = if s > 1 {
        light_path[s - 1].r
    } else {
        SampledSpectrum::ONE
    };
    let r_camera = if t > 1 {
        camera_path[t - 1].r
    } else {
        SampledSpectrum::ONE
    };
    let divisor = mis_divisor(r_light * r_camera, wl);
    Contribution {
        l: l * (w / divisor),
        raster,
    }
}

/// The power-heuristic weight of strategy (s, t) among every strategy that
/// could have made the same path. Walks from the connection outwards along
/// each subpath, multiplying the ratio of the density of the strategy that
/// moves the connection one vertex further to that of the current one.
/// `sampled` stands in for the subpath's end vertex when s = 1 or t = 1.
fn mis_weight(
    scene: &Scene,
    light_path: &[Vertex],
    camera_path: &[Vertex],
    sampled: Option<&Vertex>,
    s: usize,
    t: usize,
) -> f32 {
    if s + t == 2 {
        return 1.0;
    }
    let qs = match s {
        0 => None,
        1 => sampled,
        _ => Some(&light_path[s - 1]),
    };
    let pt = if t == 1 {
        sampled.expect("t = 1 samples the camera")
    } else {
        &camera_path[t - 1]
    };
    let qs_minus = (s > 1).then(|| &light_path[s - 2]);
    let pt_minus = (t > 1).then(|| &camera_path[t - 2]);

    // The reverse densities that the connection defines.
    let pt_rev = match qs {
        Some(qs) => qs.pdf(scene, qs_minus, pt),
        None => pt.pdf_light_origin(scene, pt_minus.expect("s = 0 needs t > 1")),
    };
    let pt_minus_rev = pt_minus.map(|pm| match qs {
        Some(qs) => pt.pdf(scene, Some(qs), pm),
        None => pt.pdf_light(scene, pm),
    });
    let qs_rev = qs.map(|qs| pt.pdf(scene, pt_minus, qs));
    let qs_minus_rev = qs_minus.map(|qm| qs.expect("s > 1").pdf(scene, Some(pt), qm));

    let remap = |f: f32| if f != 0.0 { f } else { 1.0 };
    let sq = |r: f32| r * r;
    let mut sum = 0.0f32;

    // Camera side: vertex i moves to the light subpath.
    let mut ri = 1.0f32;
    for i in (1..t).rev() {
        let (v, rev, delta) = if i == t - 1 {
            (pt, pt_rev, false)
        } else if i == t - 2 {
            let v = &camera_path[i];
            (v, pt_minus_rev.unwrap_or(v.pdf_rev), v.delta)
        } else {
            let v = &camera_path[i];
            (v, v.pdf_rev, v.delta)
        };
        ri *= sq(remap(rev) / remap(v.pdf_fwd));
        if !delta && !camera_path[i - 1].delta {
            sum += ri;
        }
    }

    // Light side: vertex i moves to the camera subpath.
    let mut ri = 1.0f32;
    for i in (0..s).rev() {
        let (v, rev, delta) = if i == s - 1 {
            (qs.expect("s > 0"), qs_rev.unwrap_or(0.0), false)
        } else if i == s - 2 {
            let v = &light_path[i];
            (v, qs_minus_rev.unwrap_or(v.pdf_rev), v.delta)
        } else {
            let v = &light_path[i];
            (v, v.pdf_rev, v.delta)
        };
        ri *= sq(remap(rev) / remap(v.pdf_fwd));
        let delta_before = if i > 0 {
            light_path[i - 1].delta
        } else {
            v.is_delta_light(scene)
        };
        if !delta && !delta_before {
            sum += ri;
        }
    }
    let w = 1.0 / (1.0 + sum);
    if w.is_finite() {
        w
    } else {
        0.0
    }
}
