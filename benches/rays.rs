//! Ray throughput on the Cornell Box: closest-hit queries for coherent
//! camera rays and incoherent random rays, and whole paths per second.
//!
//!     cargo bench --bench rays

use std::path::Path;

use criterion::{criterion_group, criterion_main, BatchSize, Criterion, Throughput};
use glam::Vec3;
use prism::geometry::Ray;
use prism::integrator::{radiance, PathCounters};
use prism::sampler::Sampler;
use prism::scene::{load, Scene};
use prism::spectrum::SampledWavelengths;

fn cornell() -> Scene {
    load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-box.toml"))
        .expect("the Cornell Box loads")
}

fn camera_rays(scene: &Scene, n: u32) -> Vec<Ray> {
    let (w, h) = scene.camera.resolution();
    (0..n)
        .map(|i| {
            let (x, y) = (i % w, (i / w) % h);
            scene.camera.generate_ray(x as f32 + 0.5, y as f32 + 0.5)
        })
        .collect()
}

fn random_rays(scene: &Scene, n: u32) -> Vec<Ray> {
    let b = scene.bounds();
    let mut s = Sampler::new(42, 7);
    (0..n)
        .map(|_| {
            let o = b.min + (b.max - b.min) * Vec3::new(s.next_f32(), s.next_f32(), s.next_f32());
            let d = Vec3::new(s.next_f32() - 0.5, s.next_f32() - 0.5, s.next_f32() - 0.5)
                .normalize_or(Vec3::Y);
            Ray::new(o * 0.98 + b.centroid() * 0.02, d)
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let scene = cornell();
    let n = 1 << 16;
    let mut group = c.benchmark_group("cornell");
    group.throughput(Throughput::Elements(n as u64));
    for (name, rays) in [
        ("coherent camera rays", camera_rays(&scene, n)),
        ("incoherent rays", random_rays(&scene, n)),
    ] {
        group.bench_function(name, |b| {
            b.iter(|| rays.iter().filter(|r| scene.intersect(r).is_some()).count())
        });
    }
    group.throughput(Throughput::Elements(4096));
    group.bench_function("paths (MIS, 4096 camera samples)", |b| {
        b.iter_batched(
            || (),
            |_| {
                let mut counters = PathCounters::default();
                for i in 0..4096u32 {
                    let mut s = Sampler::for_sample(0, i % 512, i / 512, 0);
                    let mut wl = SampledWavelengths::sample_visible(s.next_f32());
                    let ray = scene
                        .camera
                        .generate_ray((i % 512) as f32 + 0.5, (i / 512) as f32 * 64.0);
                    radiance(&scene, ray, &mut wl, &mut s, &mut counters);
                }
                counters.rays
            },
            BatchSize::SmallInput,
        )
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
