//! Ray throughput: closest-hit queries for coherent camera rays and
//! incoherent random rays on the Cornell Box and on a procedural terrain of
//! about a million triangles, and whole paths per second on the Cornell Box.
//!
//!     cargo bench --bench rays

use std::path::Path;

use criterion::{criterion_group, criterion_main, BatchSize, Criterion, Throughput};
use glam::Vec3;
use prism::camera::Camera;
use prism::geometry::Ray;
use prism::integrator::{PathCounters, PathTracer};
use prism::load::load;
use prism::material::Material;
use prism::sampler::Sampler;
use prism::scene::{Mesh, Scene, ShapeInstance};
use prism::spectrum::SampledWavelengths;
use prism::spectrum::Spectrum;

fn cornell() -> Scene {
    load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-box.toml"))
        .expect("the Cornell Box loads")
        .scene
}

/// `n` camera rays on a square grid over the whole image, row by row.
fn camera_rays(scene: &Scene, n: u32) -> Vec<Ray> {
    let (w, h) = scene.camera.resolution();
    let side = (n as f32).sqrt() as u32;
    (0..side * side)
        .map(|i| {
            let (u, v) = ((i % side) as f32 + 0.5, (i / side) as f32 + 0.5);
            scene
                .camera
                .generate_ray(u / side as f32 * w as f32, v / side as f32 * h as f32)
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

/// A bumpy height field of 2·(n−1)² triangles over [−1, 1]².
fn terrain_mesh(n: u32) -> Mesh {
    let mut mesh = Mesh::default();
    for j in 0..n {
        for i in 0..n {
            let (x, z) = (
                2.0 * i as f32 / (n - 1) as f32 - 1.0,
                2.0 * j as f32 / (n - 1) as f32 - 1.0,
            );
            let y =
                0.05 * ((13.0 * x).sin() * (11.0 * z).cos() + 0.5 * (37.0 * x + 23.0 * z).sin());
            mesh.positions.push(Vec3::new(x, y, z));
        }
    }
    for j in 0..n - 1 {
        for i in 0..n - 1 {
            let a = j * n + i;
            mesh.indices.push([a, a + n, a + n + 1]);
            mesh.indices.push([a, a + n + 1, a + 1]);
        }
    }
    mesh
}

fn terrain(mesh: Mesh) -> Scene {
    let (w, h) = (512, 512);
    let camera = Camera::look_at(Vec3::new(0.0, 1.2, -1.8), Vec3::ZERO, Vec3::Y, 50.0, w, h);
    let material = Material::Diffuse {
        reflectance: Spectrum::Constant(0.5).into(),
    };
    Scene::build(
        camera,
        vec![material],
        vec![ShapeInstance {
            emission_of: None,
            mesh,
            material: 0,
            emission: None,
        }],
        Vec::new(),
        Vec::new(),
    )
}

fn bench_terrain(c: &mut Criterion) {
    let mesh = terrain_mesh(708);
    let start = std::time::Instant::now();
    let scene = terrain(mesh.clone());
    eprintln!(
        "terrain: {} triangles, BVH built in {:.2} s, {} nodes, {:.1} bytes per triangle",
        scene.triangle_count(),
        start.elapsed().as_secs_f64(),
        scene.bvh().node_count(),
        scene.bvh().size_bytes() as f64 / scene.triangle_count() as f64
    );
    let n = 1 << 16;
    let mut group = c.benchmark_group("terrain 1M triangles");
    group.throughput(Throughput::Elements(n as u64));
    let coherent = camera_rays(&scene, n);
    let hits = coherent
        .iter()
        .filter(|r| scene.intersect(r).is_some())
        .count();
    eprintln!("terrain: {hits} of {} camera rays hit", coherent.len());
    let mut s = Sampler::new(7, 7);
    let incoherent: Vec<Ray> = (0..n)
        .map(|_| {
            let o = Vec3::new(
                2.0 * s.next_f32() - 1.0,
                0.3 * s.next_f32() + 0.06,
                2.0 * s.next_f32() - 1.0,
            );
            let d = Vec3::new(s.next_f32() - 0.5, -s.next_f32(), s.next_f32() - 0.5)
                .normalize_or(-Vec3::Y);
            Ray::new(o, d)
        })
        .collect();
    if let Ok(dir) = std::env::var("PRISM_BENCH_DUMP") {
        dump(Path::new(&dir), &mesh, &coherent, &incoherent);
    }
    let hits = incoherent
        .iter()
        .filter(|r| scene.closest_triangle(r).is_some())
        .count();
    eprintln!(
        "terrain: {hits} of {} incoherent rays hit",
        incoherent.len()
    );
    // Closest hit (triangle, t, barycentrics) as Embree's rtcIntersect1
    // answers it; and with prism's shading data (normals, texture
    // coordinates, hit point error bounds) gathered as a render does.
    for (name, rays) in [
        ("coherent camera rays", &coherent),
        ("incoherent rays", &incoherent),
    ] {
        group.bench_function(name, |b| {
            b.iter(|| {
                rays.iter()
                    .filter(|r| scene.closest_triangle(r).is_some())
                    .count()
            })
        });
        group.bench_function(format!("{name}, as a stream"), |b| {
            let mut hits = vec![None; rays.len()];
            b.iter(|| {
                scene.bvh().intersect_stream(rays, &mut hits);
                hits.iter().filter(|h| h.is_some()).count()
            })
        });
        group.bench_function(format!("{name}, with shading data"), |b| {
            b.iter(|| rays.iter().filter(|r| scene.intersect(r).is_some()).count())
        });
    }
    group.finish();
}

/// Writes the terrain and both ray sets as little-endian binaries, so that
/// `tools/embree_bench.py` traces exactly the same rays with Embree.
fn dump(dir: &Path, mesh: &Mesh, coherent: &[Ray], incoherent: &[Ray]) {
    std::fs::create_dir_all(dir).unwrap();
    let floats = |v: &mut Vec<u8>, f: &[f32]| f.iter().for_each(|x| v.extend(x.to_le_bytes()));
    let mut vertices = Vec::new();
    for p in &mesh.positions {
        floats(&mut vertices, &p.to_array());
    }
    std::fs::write(dir.join("terrain_vertices.f32"), vertices).unwrap();
    let indices: Vec<u8> = mesh
        .indices
        .iter()
        .flat_map(|t| t.iter().flat_map(|i| i.to_le_bytes()))
        .collect();
    std::fs::write(dir.join("terrain_indices.u32"), indices).unwrap();
    for (name, rays) in [("coherent", coherent), ("incoherent", incoherent)] {
        let mut v = Vec::new();
        for r in rays {
            floats(&mut v, &r.origin.to_array());
            floats(&mut v, &r.dir.to_array());
        }
        std::fs::write(dir.join(format!("rays_{name}.f32")), v).unwrap();
    }
    eprintln!("wrote the terrain and its rays to {}", dir.display());
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
    let path = PathTracer {
        max_depth: 4,
        ..PathTracer::default()
    };
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
                    path.radiance(&scene, ray, &mut wl, &mut s, &mut counters);
                }
                counters.rays
            },
            BatchSize::SmallInput,
        )
    });
    group.finish();
}

criterion_group!(benches, bench, bench_terrain);
criterion_main!(benches);
