//! BSDF sampling against evaluation: chi² goodness-of-fit of sampled
//! directions against the density `pdf()` claims (as Mitsuba's and pbrt's
//! test suites do), sample/eval consistency, energy (furnace) and
//! reciprocity, for every BSDF at several roughnesses and angles.

// Published constants are kept as published.
#![allow(clippy::excessive_precision)]

use std::f64::consts::PI;

use glam::{Vec3, Vec4};
use prism::material::{Bsdf, BsdfEval, BsdfSample, Ior, Material, ShadingGeometry, TransportMode};
use prism::sampler::Sampler;
use prism::spectrum::{SampledWavelengths, Spectrum};
use rayon::prelude::*;

const THETA_BINS: usize = 40;
const PHI_BINS: usize = 80;

fn direction(cos: f64, phi: f64) -> Vec3 {
    let sin = (1.0 - cos * cos).max(0.0).sqrt();
    Vec3::new(
        (sin * phi.cos()) as f32,
        (sin * phi.sin()) as f32,
        cos as f32,
    )
}

/// Bins uniform in θ (not cos θ): narrow lobes near the poles stay resolved.
fn bin_of(w: Vec3) -> usize {
    let theta = (w.z as f64).clamp(-1.0, 1.0).acos();
    let c = (theta / PI * THETA_BINS as f64)
        .floor()
        .clamp(0.0, THETA_BINS as f64 - 1.0) as usize;
    let mut phi = (w.y as f64).atan2(w.x as f64);
    if phi < 0.0 {
        phi += 2.0 * PI;
    }
    let p = (phi / (2.0 * PI) * PHI_BINS as f64)
        .floor()
        .clamp(0.0, PHI_BINS as f64 - 1.0) as usize;
    c * PHI_BINS + p
}

/// Regularised upper incomplete gamma Q(a, x) (Numerical Recipes' method).
fn gamma_q(a: f64, x: f64) -> f64 {
    fn ln_gamma(x: f64) -> f64 {
        let c = [
            76.18009172947146,
            -86.50532032941677,
            24.01409824083091,
            -1.231739572450155,
            0.1208650973866179e-2,
            -0.5395239384953e-5,
        ];
        let mut y = x;
        let tmp = x + 5.5 - (x + 0.5) * (x + 5.5).ln();
        let mut ser = 1.000000000190015;
        for v in c {
            y += 1.0;
            ser += v / y;
        }
        -tmp + (2.5066282746310005 * ser / x).ln()
    }
    if x <= 0.0 {
        return 1.0;
    }
    if x < a + 1.0 {
        let (mut sum, mut del, mut ap) = (1.0 / a, 1.0 / a, a);
        for _ in 0..1000 {
            ap += 1.0;
            del *= x / ap;
            sum += del;
            if del.abs() < sum.abs() * 1e-14 {
                break;
            }
        }
        1.0 - sum * (-x + a * x.ln() - ln_gamma(a)).exp()
    } else {
        let (mut b, mut c, mut d) = (x + 1.0 - a, 1.0 / 1e-300, 1.0 / (x + 1.0 - a));
        let mut h = d;
        for i in 1..1000 {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < 1e-300 {
                d = 1e-300;
            }
            c = b + an / c;
            if c.abs() < 1e-300 {
                c = 1e-300;
            }
            d = 1.0 / d;
            let del = d * c;
            h *= del;
            if (del - 1.0).abs() < 1e-14 {
                break;
            }
        }
        (-x + a * x.ln() - ln_gamma(a)).exp() * h
    }
}

/// A BSDF seen from one direction `wo`, for radiance: what a path tracer asks.
struct Seen {
    bsdf: Bsdf,
    wo: Vec3,
}

impl Seen {
    fn sample(&self, uc: f32, u: (f32, f32)) -> Option<BsdfSample> {
        self.bsdf.sample(self.wo, uc, u, TransportMode::Radiance)
    }
    fn eval(&self, wi: Vec3) -> BsdfEval {
        self.bsdf.eval(self.wo, wi, TransportMode::Radiance)
    }
    fn f(&self, wi: Vec3) -> Vec4 {
        self.eval(wi).f
    }
    fn pdf(&self, wi: Vec3) -> f32 {
        self.eval(wi).pdf
    }
    fn cos_theta(&self, wi: Vec3) -> f32 {
        self.bsdf.cos_theta(wi)
    }
}

fn seen(
    material: &Material,
    geom: ShadingGeometry,
    wl: &mut SampledWavelengths,
    eta: Vec4,
) -> Seen {
    Seen {
        bsdf: material.bsdf(&geom, glam::Vec2::ZERO, wl, eta),
        wo: geom.wo,
    }
}

fn bsdf(material: &Material, wo: Vec3, eta: f32) -> Seen {
    let geom = ShadingGeometry {
        ng: Vec3::Z,
        ns: Vec3::Z,
        wo,
    };
    seen(
        material,
        geom,
        &mut SampledWavelengths::sample_visible(0.3),
        Vec4::splat(eta),
    )
}

/// Chi² test of `sample` against `pdf`; returns the p-value.
fn chi2(material: &Material, wo: Vec3, eta: f32, seed: u64) -> f64 {
    let b = bsdf(material, wo, eta);
    let n = 250_000usize;
    let mut observed = vec![0f64; THETA_BINS * PHI_BINS];
    let mut s = Sampler::new(seed, 17);
    for _ in 0..n {
        let uc = s.next_f32();
        if let Some(smp) = b.sample(uc, s.next_2d()) {
            // Sampling and evaluation agree on every sample.
            let pdf = b.pdf(smp.wi);
            assert!(
                (smp.pdf - pdf).abs() <= 1e-3 * pdf.max(1e-3),
                "pdf {} vs {pdf}",
                smp.pdf
            );
            let f = b.f(smp.wi);
            assert!(
                (smp.f - f).abs().max_element() <= 1e-3 * f.max_element().max(1e-3),
                "f {} vs {f}",
                smp.f
            );
            observed[bin_of(smp.wi)] += 1.0;
        }
    }
    // Expected counts: the pdf integrated over each bin (20 × 20 midpoint
    // rule in θ and φ, with the solid angle element sin θ dθ dφ).
    let sub = 20;
    let mut expected = vec![0f64; THETA_BINS * PHI_BINS];
    for (i, e) in expected.iter_mut().enumerate() {
        let (ct, cp) = (i / PHI_BINS, i % PHI_BINS);
        let dt = PI / THETA_BINS as f64 / sub as f64;
        let dp = 2.0 * PI / PHI_BINS as f64 / sub as f64;
        let mut sum = 0.0;
        for a in 0..sub {
            let theta = (ct * sub + a) as f64 * dt + 0.5 * dt;
            for bb in 0..sub {
                let phi = (cp * sub + bb) as f64 * dp + 0.5 * dp;
                sum += b.pdf(direction(theta.cos(), phi)) as f64 * theta.sin() * dt * dp;
            }
        }
        *e = sum * n as f64;
    }
    // Pool bins with small expectations, then Pearson's statistic.
    let (mut stat, mut dof, mut pool_o, mut pool_e) = (0.0, 0usize, 0.0, 0.0);
    for (o, e) in observed.iter().zip(&expected) {
        if *e < 5.0 {
            pool_o += o;
            pool_e += e;
        } else {
            stat += (o - e) * (o - e) / e;
            dof += 1;
        }
    }
    if pool_e > 0.0 {
        stat += (pool_o - pool_e) * (pool_o - pool_e) / pool_e.max(1e-9);
        dof += 1;
    }
    gamma_q((dof - 1) as f64 / 2.0, stat / 2.0)
}

fn conductor(alpha: f32) -> Material {
    let (eta, k) = prism::material::metals::metal("Au").unwrap();
    Material::Conductor { eta, k, alpha }
}

fn dielectric(alpha: f32) -> Material {
    Material::Dielectric {
        ior: Ior::Constant(1.5),
        alpha,
        priority: 0,
        medium: None,
        tint: None,
        opaque: None,
    }
}

/// A dielectric whose transmission is filtered by `tint` (glTF's base colour).
fn tinted(alpha: f32, tint: Spectrum) -> Material {
    Material::Dielectric {
        ior: Ior::Constant(1.5),
        alpha,
        priority: 0,
        medium: None,
        tint: Some(Box::new(tint.into())),
        opaque: None,
    }
}

/// The glTF metallic-roughness material with a constant base colour.
fn pbr(base: f32, metallic: f32, roughness: f32) -> Material {
    Material::Pbr(Box::new(prism::material::PbrMaterial {
        base_color: Spectrum::Constant(base).into(),
        metallic,
        roughness,
        metallic_roughness: None,
        ior: 1.5,
        normal_map: None,
        layers: Default::default(),
    }))
}

/// `pbr` with the glTF extension layers: specular (weight, colour),
/// clear coat (weight, roughness), thin film (weight, thickness nm).
fn layered(
    base: f32,
    metallic: f32,
    roughness: f32,
    specular: Option<(f32, [f32; 3])>,
    clearcoat: Option<(f32, f32)>,
    film: Option<(f32, f32)>,
    sheen: Option<([f32; 3], f32)>,
) -> Material {
    use prism::material::{ClearcoatLayer, IridescenceLayer, PbrLayers, SheenLayer, SpecularLayer};
    let Material::Pbr(mut m) = pbr(base, metallic, roughness) else {
        unreachable!()
    };
    m.layers = PbrLayers {
        specular: specular.map(|(weight, c)| SpecularLayer {
            weight,
            texture: None,
            colour: Spectrum::rgb_unbounded(Vec3::from(c)).into(),
        }),
        clearcoat: clearcoat.map(|(weight, roughness)| ClearcoatLayer {
            weight,
            texture: None,
            roughness,
            roughness_texture: None,
        }),
        iridescence: film.map(|(weight, t)| IridescenceLayer {
            weight,
            texture: None,
            ior: 1.3,
            thickness: [100.0, t],
            thickness_texture: None,
        }),
        sheen: sheen.map(|(c, roughness)| SheenLayer {
            colour: Spectrum::rgb_reflectance(Vec3::from(c)).into(),
            roughness,
            roughness_texture: None,
        }),
    };
    Material::Pbr(m)
}

/// The layered materials every BSDF test takes.
fn layered_cases() -> Vec<(&'static str, Material)> {
    let tinted = Some((0.5, [1.0, 0.6, 0.3]));
    vec![
        (
            "specular ½ tinted",
            layered(0.8, 0.0, 0.4, tinted, None, None, None),
        ),
        (
            "clear coat over rough plastic",
            layered(0.7, 0.0, 0.7, None, Some((1.0, 0.35)), None, None),
        ),
        (
            "clear coat over metal",
            layered(0.9, 1.0, 0.5, None, Some((0.6, 0.3)), None, None),
        ),
        (
            "thin film on plastic",
            layered(0.5, 0.0, 0.3, None, None, Some((1.0, 450.0)), None),
        ),
        (
            "thin film on metal",
            layered(0.8, 1.0, 0.3, None, None, Some((0.8, 300.0)), None),
        ),
        (
            "sheen on cloth",
            layered(
                0.6,
                0.0,
                0.9,
                None,
                None,
                None,
                Some(([1.0, 0.9, 0.8], 0.5)),
            ),
        ),
        (
            "smooth sheen on metal",
            layered(
                0.7,
                1.0,
                0.4,
                None,
                None,
                None,
                Some(([0.5, 0.5, 1.0], 0.2)),
            ),
        ),
        (
            "all four",
            layered(
                0.6,
                0.3,
                0.5,
                Some((0.8, [0.9, 1.0, 1.2])),
                Some((0.5, 0.35)),
                Some((0.7, 380.0)),
                Some(([0.8, 0.8, 0.8], 0.6)),
            ),
        ),
    ]
}

fn incident(theta_deg: f32) -> Vec3 {
    let t = theta_deg.to_radians();
    Vec3::new(t.sin(), 0.0, t.cos())
}

#[test]
fn chi2_sampling_matches_evaluation() {
    let diffuse = Material::Diffuse {
        reflectance: Spectrum::Constant(0.5).into(),
    };
    let mut cases: Vec<(String, Material, Vec3, f32)> =
        vec![("diffuse 30°".into(), diffuse, incident(30.0), 1.0)];
    for alpha in [0.1f32, 0.3, 1.0] {
        for theta in [0.0f32, 45.0, 80.0, 89.0] {
            cases.push((
                format!("conductor α {alpha} θ {theta}"),
                conductor(alpha),
                incident(theta),
                1.0,
            ));
            // Dielectric from outside, and from inside (total internal
            // reflection beyond 41.8°).
            cases.push((
                format!("dielectric α {alpha} θ {theta} outside"),
                dielectric(alpha),
                incident(theta),
                1.5,
            ));
            let inside = incident(theta) * Vec3::new(1.0, 1.0, -1.0);
            cases.push((
                format!("dielectric α {alpha} θ {theta} inside"),
                dielectric(alpha),
                inside,
                1.5,
            ));
        }
    }
    for (metallic, roughness) in [(0.0f32, 0.3f32), (0.0, 0.8), (0.5, 0.5), (1.0, 0.4)] {
        for theta in [0.0f32, 60.0, 85.0] {
            cases.push((
                format!("glTF pbr metallic {metallic} roughness {roughness} θ {theta}"),
                pbr(0.7, metallic, roughness),
                incident(theta),
                1.0,
            ));
        }
    }
    for (name, m) in layered_cases() {
        for theta in [20.0f32, 75.0] {
            cases.push((
                format!("glTF layers: {name} θ {theta}"),
                m.clone(),
                incident(theta),
                1.0,
            ));
        }
    }
    // Bonferroni: an overall significance of 1%.
    let threshold = 0.01 / cases.len() as f64;
    let p_values: Vec<f64> = cases
        .par_iter()
        .enumerate()
        .map(|(i, (_, m, wo, eta))| chi2(m, *wo, *eta, i as u64))
        .collect();
    let report: Vec<String> = cases
        .iter()
        .zip(&p_values)
        .map(|(c, p)| format!("{}: p = {p:.3}", c.0))
        .collect();
    eprintln!("{}", report.join("\n"));
    for (case, p) in cases.iter().zip(&p_values) {
        assert!(
            *p > threshold,
            "{}: chi² p-value {p:.2e} below {threshold:.1e}",
            case.0
        );
    }
}

/// Directional albedo ∫ f cos dωi two ways: Monte Carlo with the BSDF's own
/// sampling, and a deterministic quadrature of `eval` over the sphere.
fn albedo(b: &Seen, seed: u64) -> ((f64, f64), f64) {
    let mut s = Sampler::new(seed, 3);
    let n = 200_000;
    let (mut sum, mut sq) = (0.0, 0.0);
    for _ in 0..n {
        let uc = s.next_f32();
        let w = match b.sample(uc, s.next_2d()) {
            Some(smp) => (smp.f.x * b.cos_theta(smp.wi) / smp.pdf) as f64,
            None => 0.0,
        };
        sum += w;
        sq += w * w;
    }
    let mean = sum / n as f64;
    let se = ((sq / n as f64 - mean * mean) / n as f64).sqrt();
    let (nc, np) = (1000, 400);
    let mut quad = 0.0;
    for i in 0..nc {
        let cos = -1.0 + (i as f64 + 0.5) * 2.0 / nc as f64;
        for j in 0..np {
            let phi = (j as f64 + 0.5) * 2.0 * PI / np as f64;
            let wi = direction(cos, phi);
            quad +=
                (b.f(wi).x * b.cos_theta(wi)) as f64 * (2.0 / nc as f64) * (2.0 * PI / np as f64);
        }
    }
    ((mean, se), quad)
}

#[test]
fn furnace_rough_surfaces_lose_only_what_single_scattering_loses() {
    // A perfect reflector (k → ∞: Fresnel = 1): the albedo is the GGX
    // single-scattering albedo, below 1, falling with roughness, → 1 as α → 0.
    let mirror_like = |alpha| Material::Conductor {
        eta: Spectrum::Constant(1.0),
        k: Spectrum::Constant(1e4),
        alpha,
    };
    let mut previous = 1.0;
    for alpha in [0.01f32, 0.2, 0.5, 1.0] {
        let b = bsdf(&mirror_like(alpha), incident(30.0), 1.0);
        let ((mc, se), quad) = albedo(&b, alpha.to_bits() as u64);
        eprintln!("perfect reflector α {alpha} at 30°: albedo {mc:.4} ± {se:.4} (sampled), {quad:.4} (quadrature)");
        assert!(
            (mc - quad).abs() < 4.0 * se + 0.01 * quad,
            "α {alpha}: sampled {mc} ± {se}, quadrature {quad}"
        );
        assert!(
            mc <= 1.0 + 4.0 * se && mc <= previous + 4.0 * se,
            "α {alpha}: albedo {mc} after {previous}"
        );
        if alpha == 0.01 {
            assert!(mc > 0.99, "nearly smooth loses almost nothing: {mc}");
        }
        previous = mc;
    }
    // Rough glass: reflection + transmission (radiance scaled by 1/η'²)
    // integrate to at most 1 from outside; from inside by at most η².
    for alpha in [0.2f32, 0.6] {
        let b = bsdf(&dielectric(alpha), incident(40.0), 1.5);
        let ((mc, se), quad) = albedo(&b, 7);
        eprintln!("glass η 1.5 α {alpha} at 40° from outside: R + T/η² = {mc:.4} ± {se:.4} (sampled), {quad:.4} (quadrature)");
        assert!(
            (mc - quad).abs() < 4.0 * se + 0.01 * quad,
            "glass α {alpha}: {mc} ± {se} vs {quad}"
        );
        assert!(
            mc <= 1.0 / 2.25 + 0.05 + 4.0 * se,
            "glass α {alpha}: albedo {mc}"
        );
    }
}

#[test]
fn a_tinted_dielectric_filters_only_what_it_transmits() {
    // Albedo = R + tint · T: tint 0 leaves the reflection alone, tint ½
    // halves the transmission; sampling agrees with the quadrature.
    for alpha in [0.2f32, 0.6] {
        let at = |m: &Material| albedo(&bsdf(m, incident(40.0), 1.5), 11);
        let (_, clear) = at(&dielectric(alpha));
        let (_, reflected) = at(&tinted(alpha, Spectrum::Constant(0.0)));
        let ((mc, se), half) = at(&tinted(alpha, Spectrum::Constant(0.5)));
        let expected = reflected + 0.5 * (clear - reflected);
        eprintln!("tinted glass α {alpha}: R {reflected:.4}, R + T/η² {clear:.4}, tint ½ {half:.4} (sampled {mc:.4} ± {se:.4})");
        assert!(reflected < 0.5 * clear, "α {alpha}: {reflected} vs {clear}");
        assert!(
            (half - expected).abs() < 1e-4,
            "α {alpha}: {half} vs {expected}"
        );
        assert!(
            (mc - half).abs() < 4.0 * se + 0.01 * half,
            "α {alpha}: {mc} ± {se} vs {half}"
        );
    }
}

#[test]
fn gltf_brdf_conserves_energy_and_sampling_matches_quadrature() {
    // A white base: diffuse + coat (dielectric) or a white metal reflect at
    // most everything; sampled albedo and the quadrature of eval agree.
    for (metallic, roughness) in [(0.0f32, 0.2f32), (0.0, 1.0), (1.0, 0.3), (0.5, 0.6)] {
        for theta in [10.0f32, 70.0] {
            let b = bsdf(&pbr(1.0, metallic, roughness), incident(theta), 1.0);
            let ((mc, se), quad) = albedo(&b, (metallic * 10.0 + roughness * 100.0) as u64);
            eprintln!(
                "glTF pbr base 1 metallic {metallic} roughness {roughness} θ {theta}: albedo {mc:.4} ± {se:.4} (sampled), {quad:.4} (quadrature)"
            );
            assert!(
                (mc - quad).abs() < 4.0 * se + 0.01 * quad,
                "metallic {metallic} roughness {roughness} θ {theta}: {mc} ± {se} vs {quad}"
            );
            assert!(mc <= 1.0 + 4.0 * se, "gains energy: {mc}");
        }
    }
    // With the extension layers, on a white base: never above 1, and
    // sampling agrees with the quadrature.
    for (name, m) in layered_cases() {
        let Material::Pbr(mut white) = m else {
            unreachable!()
        };
        white.base_color = Spectrum::Constant(1.0).into();
        let m = Material::Pbr(white);
        for theta in [10.0f32, 70.0] {
            let b = bsdf(&m, incident(theta), 1.0);
            let ((mc, se), quad) = albedo(&b, theta as u64 + 3);
            eprintln!("glTF layers {name}, white base, θ {theta}: albedo {mc:.4} ± {se:.4} (sampled), {quad:.4} (quadrature)");
            assert!(
                (mc - quad).abs() < 4.0 * se + 0.01 * quad,
                "{name} θ {theta}: {mc} ± {se} vs {quad}"
            );
            assert!(quad <= 1.0 + 0.01, "{name} θ {theta}: gains energy: {quad}");
        }
    }
    // A black dielectric base still reflects the coat: ≈ 4% at normal
    // incidence for index 1.5 (Schlick F0 = 0.04), a little less when rough.
    let b = bsdf(&pbr(0.0, 0.0, 0.1), incident(0.0), 1.0);
    let ((mc, _), _) = albedo(&b, 5);
    assert!(mc > 0.035 && mc < 0.045, "black plastic albedo {mc}");
}

#[test]
fn smooth_interfaces_are_exact() {
    // IOR 1: invisible. Every sample passes straight through with weight 1.
    let b = bsdf(&dielectric(0.0), incident(35.0), 1.0);
    let mut s = Sampler::new(1, 1);
    for _ in 0..100 {
        let uc = s.next_f32();
        let smp = b.sample(uc, s.next_2d()).unwrap();
        assert!((smp.wi + incident(35.0)).length() < 1e-5);
        assert!((smp.f.x * b.cos_theta(smp.wi) / smp.pdf - 1.0).abs() < 1e-5);
    }
    // Glass at normal incidence reflects 4 %: the reflection branch is
    // chosen that often and carries weight 1.
    let b = bsdf(&dielectric(0.0), Vec3::Z, 1.5);
    let (mut reflected, n) = (0, 100_000);
    for _ in 0..n {
        let uc = s.next_f32();
        let smp = b.sample(uc, s.next_2d()).unwrap();
        if smp.wi.z > 0.0 {
            reflected += 1;
            assert!((smp.f.x * b.cos_theta(smp.wi) / smp.pdf - 1.0).abs() < 1e-5);
        } else {
            // Transmitted radiance is divided by η² = 2.25.
            assert!((smp.f.x * b.cos_theta(smp.wi) / smp.pdf - 1.0 / 2.25).abs() < 1e-5);
        }
    }
    let frac = reflected as f64 / n as f64;
    assert!(
        (frac - 0.04).abs() < 4.0 * (0.04 * 0.96 / n as f64).sqrt(),
        "{frac}"
    );
    // Beyond the critical angle from inside: total internal reflection.
    let inside = incident(50.0) * Vec3::new(1.0, 1.0, -1.0);
    let b = bsdf(&dielectric(0.0), inside, 1.5);
    for _ in 0..100 {
        let uc = s.next_f32();
        let smp = b.sample(uc, s.next_2d()).unwrap();
        assert!(smp.wi.z < 0.0 && (smp.f.x * b.cos_theta(smp.wi) / smp.pdf - 1.0).abs() < 1e-5);
    }
}

#[test]
fn reflection_is_reciprocal() {
    let mut s = Sampler::new(9, 9);
    for m in [
        conductor(0.3),
        dielectric(0.3),
        tinted(0.3, Spectrum::rgb_reflectance(Vec3::new(0.9, 0.4, 0.2))),
        conductor(0.8),
        pbr(0.6, 0.0, 0.4),
        pbr(0.6, 0.5, 0.7),
    ]
    .into_iter()
    .chain(layered_cases().into_iter().map(|(_, m)| m))
    {
        for _ in 0..200 {
            let a = direction(
                s.next_f32() as f64 * 0.98 + 0.01,
                s.next_f32() as f64 * 2.0 * PI,
            );
            let c = direction(
                s.next_f32() as f64 * 0.98 + 0.01,
                s.next_f32() as f64 * 2.0 * PI,
            );
            let fa = bsdf(&m, a, 1.5).f(c).x;
            let fc = bsdf(&m, c, 1.5).f(a).x;
            assert!(
                (fa - fc).abs() <= 1e-4 * fa.max(fc).max(1e-6),
                "{m:?}: {fa} vs {fc}"
            );
        }
    }
}

#[test]
fn transmission_obeys_the_generalised_reciprocity() {
    // For radiance, f(ωo→ωi)·n_o²... : f(a, c) / n_c² = f(c, a) / n_a², with
    // n the index on each direction's side (outside 1, inside 1.5).
    let mut s = Sampler::new(4, 4);
    let m = dielectric(0.4);
    for _ in 0..200 {
        let a = direction(
            s.next_f32() as f64 * 0.98 + 0.01,
            s.next_f32() as f64 * 2.0 * PI,
        );
        let c = direction(
            -(s.next_f32() as f64 * 0.98 + 0.01),
            s.next_f32() as f64 * 2.0 * PI,
        );
        let (na, nc) = (1.0f32, 1.5f32);
        let fac = bsdf(&m, a, 1.5).f(c).x;
        let fca = bsdf(&m, c, 1.5).f(a).x;
        let (x, y) = (fac * nc * nc, fca * na * na);
        assert!((x - y).abs() <= 1e-3 * x.max(y).max(1e-6), "{x} vs {y}");
    }
}

#[test]
fn extreme_parameters_stay_finite() {
    let mut s = Sampler::new(2, 2);
    for alpha in [0.0f32, 1e-4, 1.0] {
        for eta in [1.0001f32, 1.5, 3.0, 0.982, 0.7] {
            for theta in [0.0f32, 60.0, 89.9, 90.0] {
                for side in [1.0f32, -1.0] {
                    let wo = incident(theta) * Vec3::new(1.0, 1.0, side);
                    for m in [dielectric(alpha), conductor(alpha)] {
                        let b = bsdf(&m, wo.normalize(), eta);
                        for _ in 0..200 {
                            let uc = s.next_f32();
                            if let Some(smp) = b.sample(uc, s.next_2d()) {
                                let w = smp.f * b.cos_theta(smp.wi) / smp.pdf;
                                assert!(
                                    w.is_finite() && smp.pdf > 0.0,
                                    "α {alpha} η {eta} θ {theta}: {smp:?}"
                                );
                                // Radiance crossing into a less dense medium grows by
                                // the squared ratio of the indices (1/η² going in, η² coming out).
                                let bound = if side > 0.0 {
                                    1.0 / (eta * eta)
                                } else {
                                    eta * eta
                                }
                                .max(1.0);
                                assert!(
                                    w.max_element() <= bound * (1.0 + 1e-3),
                                    "energy gain {w} at α {alpha} η {eta} θ {theta}"
                                );
                            }
                            let probe = direction(
                                s.next_f32() as f64 * 2.0 - 1.0,
                                s.next_f32() as f64 * 2.0 * PI,
                            );
                            assert!(b.f(probe).is_finite() && b.pdf(probe).is_finite());
                        }
                    }
                }
            }
        }
    }
}

#[test]
fn spectral_mis_only_averages_over_live_wavelengths() {
    // A rough interface between dispersive media: with all four wavelengths
    // alive the sampling density is their average; once a smooth dispersive
    // interface has terminated the secondaries, it is the hero's alone
    // (averaging over dead wavelengths would inflate the hero fourfold).
    let m = dielectric(0.05);
    let geom = ShadingGeometry {
        ng: Vec3::Z,
        ns: Vec3::Z,
        wo: incident(30.0),
    };
    let eta = Vec4::new(1.50, 1.52, 1.54, 1.56);
    let mut alive = SampledWavelengths::sample_visible(0.3);
    let mut dead = alive;
    dead.terminate_secondary();
    let b_alive = seen(&m, geom, &mut alive, eta);
    let b_dead = seen(&m, geom, &mut dead, eta);
    let hero_only = seen(
        &m,
        geom,
        &mut SampledWavelengths::sample_visible(0.3),
        Vec4::splat(1.50),
    );
    let mut s = Sampler::new(8, 8);
    let mut checked = 0;
    for _ in 0..1000 {
        let uc = s.next_f32();
        let Some(smp) = b_dead.sample(uc, s.next_2d()) else {
            continue;
        };
        let hero_pdf = hero_only.pdf(smp.wi);
        assert!(
            (smp.pdf - hero_pdf).abs() <= 1e-3 * hero_pdf,
            "{} vs {hero_pdf}",
            smp.pdf
        );
        checked += 1;
    }
    assert!(checked > 900);
    // Alive: the sampled density is the average, which differs from the hero's.
    let mut differs = 0;
    for _ in 0..1000 {
        let uc = s.next_f32();
        let Some(smp) = b_alive.sample(uc, s.next_2d()) else {
            continue;
        };
        assert!((smp.pdf - b_alive.pdf(smp.wi)).abs() <= 1e-3 * smp.pdf);
        if (smp.pdf - hero_only.pdf(smp.wi)).abs() > 0.05 * smp.pdf {
            differs += 1;
        }
    }
    assert!(differs > 100, "spectral MIS changed no density: {differs}");
}

#[test]
fn importance_transport_is_the_adjoint_of_radiance() {
    // A path from the camera and one from a light must weigh a vertex alike
    // in the geometric measure (Veach 1997, §5.3): the camera side's kernel
    // f(b, a)·|a·ns| / |a·ng| (radiance arriving from a, leaving towards b)
    // equals the light side's f*(a, b)·|b·ns| / |b·ng| (importance arriving
    // arriving from a, leaving towards b, as a light path carries it).
    // This fixes both the missing 1/η'² of importance and Veach's shading
    // normal correction; the shading normal here is tilted 25° off ng.
    let ng = Vec3::Z;
    let ns = Vec3::new(25f32.to_radians().sin(), 0.0, 25f32.to_radians().cos());
    let mut s = Sampler::new(21, 5);
    let uniform = |s: &mut Sampler| {
        let (u0, u1) = s.next_2d();
        direction(1.0 - 2.0 * u0 as f64, 2.0 * PI * u1 as f64)
    };
    for (name, m) in [
        (
            "diffuse",
            Material::Diffuse {
                reflectance: Spectrum::Constant(0.8).into(),
            },
        ),
        ("conductor", conductor(0.3)),
        ("glass", dielectric(0.3)),
        ("plastic", pbr(0.6, 0.0, 0.5)),
    ] {
        let (mut compared, mut transmitted) = (0, 0);
        for _ in 0..4000 {
            let (a, b) = (uniform(&mut s), uniform(&mut s));
            let geom = ShadingGeometry { ng, ns, wo: b };
            let bsdf = m.bsdf(
                &geom,
                glam::Vec2::ZERO,
                &mut SampledWavelengths::sample_visible(0.3),
                Vec4::splat(1.5),
            );
            let camera =
                bsdf.f(b, a, TransportMode::Radiance).x * ns.dot(a).abs() / ng.dot(a).abs();
            let light =
                bsdf.f(a, b, TransportMode::Importance).x * ns.dot(b).abs() / ng.dot(b).abs();
            // 1 %: single-precision Fresnel near the critical angle; a
            // missing η'² is a factor 2.25 and the correction at this tilt
            // ranges over factors of several.
            assert!(
                (camera - light).abs() <= 1e-2 * camera.max(light) + 1e-6,
                "{name}: a {a}, b {b}: camera side {camera}, light side {light}"
            );
            if camera > 0.0 {
                compared += 1;
                transmitted += (a.z * b.z < 0.0) as u32;
            }
        }
        assert!(compared > 500, "{name}: only {compared} non-zero pairs");
        if name == "glass" {
            assert!(transmitted > 200, "glass: {transmitted} transmitted pairs");
        }
    }
}

#[test]
fn importance_is_not_compressed_by_refraction() {
    // Radiance entering glass at normal incidence is divided by η² = 2.25
    // (smooth_interfaces_are_exact); importance passes with weight 1.
    let b = bsdf(&dielectric(0.0), Vec3::Z, 1.5);
    let mut s = Sampler::new(4, 4);
    let mut transmitted = 0;
    for _ in 0..1000 {
        let uc = s.next_f32();
        let smp = b
            .bsdf
            .sample(b.wo, uc, s.next_2d(), TransportMode::Importance)
            .unwrap();
        if smp.wi.z < 0.0 {
            transmitted += 1;
            assert!((smp.f.x * b.cos_theta(smp.wi) / smp.pdf - 1.0).abs() < 1e-5);
            assert!(smp.flags.is_transmission() && smp.is_specular());
        }
    }
    assert!(transmitted > 900);
}

/// Every kind of material of the list (`MaterialKind::ALL`), so a new one
/// is tested without editing this file: its samples agree with its own
/// evaluation (chi², where it has a density), and it keeps energy (the
/// directional albedo of radiance arriving from outside is at most 1).
#[test]
fn every_kind_of_material_samples_what_it_evaluates_and_keeps_energy() {
    use prism::material::MaterialKind;
    let kinds = MaterialKind::ALL;
    let thetas = [20.0f32, 70.0];
    // Bonferroni over the chi² tests: an overall significance of 1%.
    let threshold = 0.01 / (kinds.len() * thetas.len()) as f64;
    for (k, &kind) in kinds.iter().enumerate() {
        let m = kind.example();
        assert_eq!(m.kind(), kind);
        let eta = m.ior().map_or(1.0, |ior| ior.eval(550.0));
        for (t, &theta) in thetas.iter().enumerate() {
            let seed = (k * thetas.len() + t) as u64;
            let b = bsdf(&m, incident(theta), eta);
            let ((mean, se), _) = albedo(&b, seed);
            assert!(
                mean.is_finite() && mean <= 1.0 + 5.0 * se.max(0.0) + 1e-6,
                "{} θ {theta}: albedo {mean} ± {se}",
                kind.name()
            );
            if !b.bsdf.is_specular() {
                let p = chi2(&m, incident(theta), eta, seed);
                assert!(
                    p > threshold,
                    "{} θ {theta}: chi² p-value {p:.2e} below {threshold:.1e}",
                    kind.name()
                );
            }
        }
    }
}
