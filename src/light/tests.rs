//! The light set's selection and spectra, and area lights' sampling.

use super::*;

fn area_light(tri: [Vec3; 3], emitter: Emitter, two_sided: bool) -> Light {
    Light::Area(AreaLight::new(
        tri,
        None,
        std::sync::Arc::new(emitter),
        two_sided,
    ))
}

fn emitter(v: f32) -> Emitter {
    Emitter {
        spectrum: Spectrum::Constant(v),
        texture: None,
    }
}

fn unit_triangle(z: f32) -> [Vec3; 3] {
    // Area 1.
    [
        Vec3::new(0.0, 0.0, z),
        Vec3::new(2.0, 0.0, z),
        Vec3::new(0.0, 1.0, z),
    ]
}

#[test]
fn selection_follows_power() {
    let set = LightSet::new(vec![
        area_light(unit_triangle(0.0), emitter(1.0), false),
        area_light(unit_triangle(1.0), emitter(3.0), false),
        area_light(unit_triangle(2.0), emitter(1.0), true),
    ]);
    let pmf: Vec<f32> = (0..3).map(|i| set.pmf(i)).collect();
    assert!((pmf[0] - 1.0 / 6.0).abs() < 1e-6);
    assert!((pmf[1] - 3.0 / 6.0).abs() < 1e-6);
    assert!((pmf[2] - 2.0 / 6.0).abs() < 1e-6);
    assert_eq!(set.choose(0.0).unwrap().0, 0);
    assert_eq!(set.choose(0.3).unwrap().0, 1);
    assert_eq!(set.choose(0.99).unwrap().0, 2);
    let dark = LightSet::new(vec![area_light(unit_triangle(0.0), emitter(0.0), false)]);
    assert!(dark.is_empty() && dark.choose(0.5).is_none());
}

#[test]
fn relative_emission_weights_each_spectrum_by_its_lights_power() {
    // A ramp lamp (400-700 nm, mean 0.5 over that range) on two
    // triangles that share it, and a flat one with three times their
    // power on a third.
    let ramp = std::sync::Arc::new(Emitter {
        spectrum: Spectrum::Table(crate::spectrum::TabulatedSpectrum::new(
            vec![400.0, 700.0],
            vec![0.0, 1.0],
        )),
        texture: None,
    });
    let shared = |z| Light::Area(AreaLight::new(unit_triangle(z), None, ramp.clone(), false));
    let mean = ramp.spectrum.average(LAMBDA_MIN, LAMBDA_MAX) as f64;
    let flat_power = 3.0 * 2.0 * mean;
    let set = LightSet::new(vec![
        shared(0.0),
        shared(1.0),
        area_light(unit_triangle(2.0), emitter(flat_power as f32), false),
    ]);
    let e = set.relative_emission(&[380.0, 550.0, 650.0]);
    // A quarter of the power is the ramp's, relative to its mean.
    let expect = |ramp_value: f64| 0.25 * ramp_value / mean + 0.75;
    for (got, want) in e
        .iter()
        .zip([expect(0.0), expect(0.5), expect(250.0 / 300.0)])
    {
        assert!((got - want).abs() < 1e-4, "{got} vs {want}");
    }
    assert_eq!(
        LightSet::new(Vec::new()).relative_emission(&[500.0]),
        vec![1.0]
    );
}

#[test]
fn cut_out_lights_emit_only_where_present() {
    use crate::material::cutout::{Cutout, CutoutMode};
    let wl = SampledWavelengths::sample_visible(0.3);
    let tri = [Vec3::ZERO, Vec3::X, Vec3::Y];
    let light = |mode| {
        let cutout = Cutout {
            factor: 0.25,
            texture: None,
            mode,
        };
        AreaLight::new(tri, None, std::sync::Arc::new(emitter(2.0)), false)
            .with_cutout(std::sync::Arc::new(cutout))
    };
    let whole = AreaLight::new(tri, None, std::sync::Arc::new(emitter(2.0)), false);
    let p = Vec3::new(0.2, 0.2, 1.0);
    let (u, d) = ((0.3, 0.6), (0.4, 0.7));
    // Blending: a quarter of the emission, at the same density.
    let (a, b) = (
        whole.sample_li(p, u, &wl).unwrap(),
        light(CutoutMode::Blend).sample_li(p, u, &wl).unwrap(),
    );
    assert_eq!((a.wi, a.pdf), (b.wi, b.pdf));
    assert!((b.li - a.li * 0.25).abs().max_element() < 1e-6);
    let (a, b) = (
        whole.sample_le(u, d, &wl).unwrap(),
        light(CutoutMode::Blend).sample_le(u, d, &wl).unwrap(),
    );
    assert_eq!((a.dir, a.pdf_pos, a.pdf_dir), (b.dir, b.pdf_pos, b.pdf_dir));
    assert!((b.le - a.le * 0.25).abs().max_element() < 1e-6);
    // A mask whose alpha is below the cutoff: nothing there emits.
    let masked = light(CutoutMode::Mask { cutoff: 0.5 });
    assert!(masked.sample_li(p, u, &wl).is_none());
    assert!(masked.sample_le(u, d, &wl).is_none());
    // A ray that finds the surface present sees its whole emission.
    assert_eq!(
        masked.l(Vec2::ZERO, Vec3::Z, &wl),
        whole.l(Vec2::ZERO, Vec3::Z, &wl)
    );
}

#[test]
fn triangle_points_are_uniform_and_densities_agree() {
    let light = area_light([Vec3::ZERO, Vec3::X, Vec3::Y], emitter(1.0), false);
    let Light::Area(area) = &light else {
        unreachable!("an area light")
    };
    let wl = SampledWavelengths::sample_visible(0.5);
    let p_ref = Vec3::new(0.2, 0.3, 2.0);
    let mut s = crate::sampler::Sampler::new(1, 2);
    let n = 100_000;
    let mut mean = Vec3::ZERO;
    for _ in 0..n {
        let smp = light.sample_li(p_ref, s.next_2d(), &wl).unwrap();
        let p = smp.point.unwrap().p;
        assert!(p.x >= 0.0 && p.y >= 0.0 && p.x + p.y <= 1.0 + 1e-6);
        let pdf = light.pdf_li(p_ref, smp.wi, Some(p));
        assert!((smp.pdf - pdf).abs() <= 1e-4 * pdf);
        mean += p / n as f32;
    }
    // Centroid (1/3, 1/3); standard error ≈ 0.24/√n.
    assert!(
        (mean - Vec3::new(1.0 / 3.0, 1.0 / 3.0, 0.0)).length() < 4e-3,
        "{mean}"
    );
    assert_eq!(area.area(), 0.5);
}

#[test]
fn emitted_rays_are_cosine_distributed_on_emitting_sides() {
    let wl = SampledWavelengths::sample_visible(0.5);
    for two_sided in [false, true] {
        let light = area_light(unit_triangle(0.0), emitter(2.0), two_sided);
        let mut s = crate::sampler::Sampler::new(7, 2);
        let n = 50_000;
        let (mut back, mut cos_mean) = (0, 0.0f64);
        for _ in 0..n {
            let smp = light.sample_le(s.next_2d(), s.next_2d(), &wl).unwrap();
            let (pdf_pos, pdf_dir) = light.pdf_le(Vec2::ZERO, smp.dir);
            assert_eq!((pdf_pos, pdf_dir), (smp.pdf_pos, smp.pdf_dir));
            assert_eq!(smp.le, SampledSpectrum::splat(2.0));
            back += (smp.dir.z < 0.0) as u32;
            cos_mean += smp.dir.z.abs() as f64 / n as f64;
        }
        // E[cos] = 2/3 under a cosine distribution.
        assert!((cos_mean - 2.0 / 3.0).abs() < 5e-3, "{cos_mean}");
        let frac = back as f64 / n as f64;
        if two_sided {
            assert!((frac - 0.5).abs() < 0.01, "{frac}");
        } else {
            assert_eq!(back, 0);
        }
    }
}
