//! The watertight ray/triangle test of Woop, Benthin & Wald (2013): rays
//! that hit a shared edge or vertex hit exactly one of its triangles, with a
//! conservative bound that rejects hits whose t is not surely positive.

use glam::{DVec3, Vec3};

use super::{gamma, Ray};

/// Per-ray values of the test: the axis permutation that makes the ray
/// direction's largest component z, and the shear that aligns it with +z.
#[derive(Clone, Copy, Debug)]
pub struct RayShear {
    pub origin: Vec3,
    pub kx: usize,
    pub ky: usize,
    pub kz: usize,
    pub sx: f32,
    pub sy: f32,
    pub sz: f32,
    /// The factor of the rounding bound that a hit's t must exceed: 3
    /// (pbrt's), or 0 for a ray from free space (`Ray::in_free_space`).
    pub t_bound_factor: f32,
}

impl RayShear {
    pub fn new(ray: &Ray) -> Self {
        let d = ray.dir;
        let a = d.abs();
        let kz = if a.x > a.y && a.x > a.z {
            0
        } else if a.y > a.z {
            1
        } else {
            2
        };
        let kx = (kz + 1) % 3;
        let ky = (kx + 1) % 3;
        Self {
            origin: ray.origin,
            kx,
            ky,
            kz,
            sx: -d[kx] / d[kz],
            sy: -d[ky] / d[kz],
            sz: 1.0 / d[kz],
            t_bound_factor: if ray.in_free_space { 0.0 } else { 3.0 },
        }
    }
}

/// A triangle hit: distance along the ray and barycentrics of p0, p1, p2.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriangleHit {
    pub t: f32,
    pub b: [f32; 3],
}

/// Intersects a ray (pre-sheared) with triangle `p` for t in (0, t_max).
#[inline]
pub fn intersect(s: &RayShear, p: &[Vec3; 3], t_max: f32) -> Option<TriangleHit> {
    // Translate to the ray origin, permute and shear so the ray is +z.
    let tr = |v: Vec3| {
        let v = v - s.origin;
        Vec3::new(v[s.kx], v[s.ky], v[s.kz])
    };
    let (mut p0, mut p1, mut p2) = (tr(p[0]), tr(p[1]), tr(p[2]));
    p0.x += s.sx * p0.z;
    p0.y += s.sy * p0.z;
    p1.x += s.sx * p1.z;
    p1.y += s.sy * p1.z;
    p2.x += s.sx * p2.z;
    p2.y += s.sy * p2.z;

    // Edge functions: signed areas seen from the ray.
    let mut e0 = p1.x * p2.y - p1.y * p2.x;
    let mut e1 = p2.x * p0.y - p2.y * p0.x;
    let mut e2 = p0.x * p1.y - p0.y * p1.x;
    if e0 == 0.0 || e1 == 0.0 || e2 == 0.0 {
        // Exactly on an edge in f32: decide in f64 so neighbours agree.
        let (q0, q1, q2) = (p0.as_dvec3(), p1.as_dvec3(), p2.as_dvec3());
        let edge = |a: DVec3, b: DVec3| (a.x * b.y - a.y * b.x) as f32;
        e0 = edge(q1, q2);
        e1 = edge(q2, q0);
        e2 = edge(q0, q1);
    }
    if (e0 < 0.0 || e1 < 0.0 || e2 < 0.0) && (e0 > 0.0 || e1 > 0.0 || e2 > 0.0) {
        return None;
    }
    let det = e0 + e1 + e2;
    if det == 0.0 {
        return None;
    }

    // Scaled distance, compared against the range without dividing.
    p0.z *= s.sz;
    p1.z *= s.sz;
    p2.z *= s.sz;
    let t_scaled = e0 * p0.z + e1 * p1.z + e2 * p2.z;
    if det < 0.0 && (t_scaled >= 0.0 || t_scaled < t_max * det) {
        return None;
    }
    if det > 0.0 && (t_scaled <= 0.0 || t_scaled > t_max * det) {
        return None;
    }
    let inv_det = 1.0 / det;
    let t = t_scaled * inv_det;
    if !(t < t_max) {
        return None;
    }

    // Reject t that is not surely positive given the rounding above.
    let max_z = p0.z.abs().max(p1.z.abs()).max(p2.z.abs());
    let max_x = p0.x.abs().max(p1.x.abs()).max(p2.x.abs());
    let max_y = p0.y.abs().max(p1.y.abs()).max(p2.y.abs());
    let delta_z = gamma(3) * max_z;
    let delta_x = gamma(5) * (max_x + max_z);
    let delta_y = gamma(5) * (max_y + max_z);
    let delta_e = 2.0 * (gamma(2) * max_x * max_y + delta_y * max_x + delta_x * max_y);
    let max_e = e0.abs().max(e1.abs()).max(e2.abs());
    let delta_t = s.t_bound_factor
        * (gamma(3) * max_e * max_z + delta_e * max_z + delta_z * max_e)
        * inv_det.abs();
    if t <= delta_t {
        return None;
    }
    Some(TriangleHit {
        t,
        b: [e0 * inv_det, e1 * inv_det, e2 * inv_det],
    })
}

/// Twice the area is |(p1 − p0) × (p2 − p0)|; zero for degenerate triangles.
pub fn area(p: &[Vec3; 3]) -> f32 {
    0.5 * (p[1] - p[0]).cross(p[2] - p[0]).length()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn hit(o: Vec3, d: Vec3, p: &[Vec3; 3]) -> Option<TriangleHit> {
        let r = Ray::new(o, d);
        intersect(&RayShear::new(&r), p, r.t_max)
    }

    #[test]
    fn hits_inside_misses_outside() {
        let tri = [Vec3::ZERO, Vec3::X, Vec3::Y];
        let h = hit(Vec3::new(0.25, 0.25, 1.0), -Vec3::Z, &tri).unwrap();
        assert!((h.t - 1.0).abs() < 1e-6);
        assert!((h.b[0] - 0.5).abs() < 1e-6 && (h.b[1] - 0.25).abs() < 1e-6);
        assert!(hit(Vec3::new(0.75, 0.75, 1.0), -Vec3::Z, &tri).is_none());
        // Behind the origin.
        assert!(hit(Vec3::new(0.25, 0.25, 1.0), Vec3::Z, &tri).is_none());
        // Degenerate triangle.
        assert!(hit(
            Vec3::new(0.0, 0.0, 1.0),
            -Vec3::Z,
            &[Vec3::ZERO, Vec3::X, Vec3::X * 2.0]
        )
        .is_none());
    }

    #[test]
    fn shared_edges_are_watertight() {
        // Two triangles sharing the diagonal of a unit square: rays aimed
        // exactly at the diagonal hit at least one of them.
        let a = [Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0)];
        let b = [Vec3::ZERO, Vec3::new(1.0, 1.0, 0.0), Vec3::Y];
        for i in 1..1000 {
            let x = i as f32 / 1000.0;
            let o = Vec3::new(0.1234 + x, 0.7 - x, 3.0);
            let dir = Vec3::new(x, x, 0.0) - o;
            let n = hit(o, dir, &a).is_some() as u32 + hit(o, dir, &b).is_some() as u32;
            assert!(n >= 1, "ray through the shared edge at {x} leaked");
        }
    }
}
