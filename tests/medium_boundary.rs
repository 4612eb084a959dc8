//! Where a free flight in a medium ends next to the medium's boundary: the
//! end point stays inside, so the path leaves the medium exactly once
//! (a point rounded outside would miss the exit, or enter the medium a
//! second time: the IOR stack would fill with copies of one medium).

use crate::common::scene;
use crate::media::box_shapes;
use glam::Vec3;
use prism::geometry::Ray;
use prism::sampler::Sampler;
use prism::scene::SurfaceHit;

/// A fog inside `shapes` (TOML), and flights from `origin` that end
/// within a few floats of its boundary: from every end point, rays in
/// any direction meet the boundary first from the inside (so the path
/// leaves the medium once, and never enters it twice). Returns how
/// many of the end points that rule fails for.
fn ends_outside(shapes: &str, origin: Vec3, end: impl Fn(&Ray, f32, &SurfaceHit) -> Vec3) -> usize {
    let text = format!(
        "[camera]\nposition = [0, 0, -5]\nlook_at = [0, 0, 0]\n\
         [materials.fog]\ntype = \"interface\"\nmedium = {{ scattering = 1 }}\n{shapes}"
    );
    let loaded = scene(&text);
    let scene = &loaded.scene;
    let exits_first = |p: Vec3, dir: Vec3| {
        scene
            .intersect(&Ray::new(p, dir).starting_in_free_space(true))
            .is_some_and(|h| dir.dot(h.ng) > 0.0)
    };
    let mut sampler = Sampler::new(7, 0);
    let mut outside = 0;
    for _ in 0..2000 {
        let (u, v) = sampler.next_2d();
        let z = 1.0 - 2.0 * u;
        let r = (1.0 - z * z).max(0.0).sqrt();
        let phi = std::f32::consts::TAU * v;
        let dir = Vec3::new(r * phi.cos(), r * phi.sin(), z);
        let ray = Ray::new(origin, dir);
        let hit = scene.intersect(&ray).expect("the ray leaves the fog");
        let frame = prism::geometry::Frame::from_normal(dir);
        let (a, b) = (frame.to_world(Vec3::X), frame.to_world(Vec3::Y));
        let mut t = hit.t;
        for _ in 0..48 {
            t = t.next_down();
            let p = end(&ray, t, &hit);
            let directions = [dir, -dir, a, -b, (dir + a).normalize()];
            outside += usize::from(!directions.iter().all(|&w| exits_first(p, w)));
        }
    }
    outside
}

/// The end points as `flight_end` places them never fail; the plain
/// point along the ray does (so the check can fail).
fn ends_stay_inside(shapes: &str, origin: Vec3) {
    let plain = ends_outside(shapes, origin, |ray, t, _| ray.origin + ray.dir * t);
    let kept = ends_outside(shapes, origin, |ray, t, hit| {
        prism::integrator::flight_end(ray, t, Some(hit))
    });
    eprintln!("{plain} of 96000 plain ends are outside, {kept} kept by flight_end");
    assert!(plain > 0, "the plain points never fail");
    assert_eq!(kept, 0, "{kept} of 96000 ends outside ({plain} unmoved)");
}

const SPHERE: &str = "[[shape]]\ntype = \"sphere\"\ncenter = [0.3, -0.2, 0.1]\n\
                      radius = 1.7\nmaterial = \"fog\"\n";

#[test]
fn flights_end_inside_an_exact_sphere() {
    ends_stay_inside(SPHERE, Vec3::new(0.35, -0.1, 0.05));
}

#[test]
fn flights_end_inside_a_tessellated_sphere() {
    let shapes = format!("{SPHERE}tessellate = true\nsegments = 48\n");
    ends_stay_inside(&shapes, Vec3::new(0.35, -0.1, 0.05));
}

#[test]
fn flights_end_inside_a_box() {
    let shapes = box_shapes([-1.0, -0.5, -1.5], [2.0, 1.0, 0.5], "fog");
    ends_stay_inside(&shapes, Vec3::new(0.1, 0.05, -0.2));
}
