//! Exact spheres: the ray test, and a bounding volume hierarchy of their
//! own beside the triangles' (spheres are few; their tree is binary and
//! scalar).
//!
//! The quadratic is solved in f64 with the discriminant written as
//! r² − |o − (o·d̂)d̂|² (no cancellation between two large terms when the
//! ray starts far away) and the smaller root taken as c/q; the hit point is
//! then projected onto the sphere, which bounds its error by a few ulps of
//! its distance from the centre (`p_err`), so robust origins leave it
//! cleanly, outwards or inwards.

use glam::{DVec3, Mat3, Vec2, Vec3};

use super::{angles, gamma, Aabb, Ray};

/// A sphere with an orientation for its texture coordinates: the local
/// z axis is the pole (v = 0 at +z), u runs round it from +x.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sphere {
    pub centre: Vec3,
    pub radius: f32,
    /// Local → world rotation (orthonormal).
    pub rotation: Mat3,
}

/// Where a ray meets a sphere.
#[derive(Clone, Copy, Debug)]
pub struct SphereHit {
    pub t: f32,
    pub p: Vec3,
    /// Bound on the absolute error of `p`.
    pub p_err: Vec3,
    /// Unit outward normal.
    pub n: Vec3,
    pub uv: Vec2,
    /// ∂p/∂u, the direction of increasing u (zero at the poles).
    pub dpdu: Vec3,
}

impl Sphere {
    pub fn new(centre: Vec3, radius: f32) -> Self {
        Self {
            centre,
            radius,
            rotation: Mat3::IDENTITY,
        }
    }

    pub fn bounds(&self) -> Aabb {
        let r = Vec3::splat(self.radius * (1.0 + 2.0 * gamma(1)));
        Aabb {
            min: self.centre - r,
            max: self.centre + r,
        }
    }

    pub fn area(&self) -> f32 {
        4.0 * std::f32::consts::PI * self.radius * self.radius
    }

    /// The nearest hit within (0, t_max).
    pub fn intersect(&self, ray: &Ray, t_max: f32) -> Option<SphereHit> {
        let (t, local) = self.nearest(ray, t_max)?;
        Some(self.hit_at(local, t))
    }

    /// The distance to the nearest hit within (0, t_max), and the hit
    /// point relative to the centre: all a shadow ray, or a hit that a
    /// nearer one will replace, needs. The rest (`hit_at`: normal,
    /// texture coordinates by two atan2s) is made for the closest hit only.
    pub fn nearest(&self, ray: &Ray, t_max: f32) -> Option<(f32, DVec3)> {
        let o = ray.origin.as_dvec3() - self.centre.as_dvec3();
        let d = ray.dir.as_dvec3();
        let r = self.radius as f64;
        let a = d.length_squared();
        if !(a > 0.0) {
            return None;
        }
        let b = 2.0 * o.dot(d);
        let c = o.length_squared() - r * r;
        // Distance² from the centre to the ray's line, computed without
        // subtracting two large numbers.
        let off_line = o - d * (o.dot(d) / a);
        let disc = 4.0 * a * (r * r - off_line.length_squared());
        if disc < 0.0 {
            return None;
        }
        let root = disc.sqrt();
        let q = if b < 0.0 {
            -0.5 * (b - root)
        } else {
            -0.5 * (b + root)
        };
        let (mut t0, mut t1) = (q / a, c / q);
        if t0 > t1 {
            std::mem::swap(&mut t0, &mut t1);
        }
        let t = if t0 > 0.0 { t0 } else { t1 };
        if !(t > 0.0 && t < t_max as f64 && t.is_finite()) {
            return None;
        }
        Some((t as f32, o + d * t))
    }

    /// The hit at `local` (relative to the centre, near the surface): the
    /// point projected onto the sphere, its normal and coordinates.
    fn hit_at(&self, local: DVec3, t: f32) -> SphereHit {
        let n = local.normalize();
        let (p, p_err) = self.placed((n * self.radius as f64).as_vec3());
        let n = n.as_vec3();
        let (uv, dpdu) = self.coordinates(n);
        SphereHit {
            t,
            p,
            p_err,
            n,
            uv,
            dpdu,
        }
    }

    /// Texture coordinates and ∂p/∂u at the point of outward normal `n`.
    pub fn coordinates(&self, n: Vec3) -> (Vec2, Vec3) {
        let l = self.rotation.transpose() * n;
        let phi = angles::atan2(l.y, l.x);
        let phi = if phi < 0.0 {
            phi + 2.0 * std::f32::consts::PI
        } else {
            phi
        };
        let theta = angles::polar_angle(l.z, l.x, l.y);
        let uv = Vec2::new(
            phi / (2.0 * std::f32::consts::PI),
            theta / std::f32::consts::PI,
        );
        let along = Vec3::new(-l.y, l.x, 0.0) * (2.0 * std::f32::consts::PI * self.radius);
        (uv, self.rotation * along)
    }

    /// The outward normal at texture coordinates `uv`.
    pub fn normal_at(&self, uv: Vec2) -> Vec3 {
        let phi = uv.x * 2.0 * std::f32::consts::PI;
        let theta = uv.y * std::f32::consts::PI;
        let (st, ct) = theta.sin_cos();
        let (sp, cp) = phi.sin_cos();
        (self.rotation * Vec3::new(st * cp, st * sp, ct)).normalize()
    }

    /// The point of outward normal `n` with its error bound.
    pub fn point_at(&self, n: Vec3) -> (Vec3, Vec3) {
        self.placed(n * self.radius)
    }

    /// The point `on_sphere` from the centre (on the surface, to rounding),
    /// and a bound on its error: the projection's and the centre's sum's.
    fn placed(&self, on_sphere: Vec3) -> (Vec3, Vec3) {
        let p = self.centre + on_sphere;
        (p, gamma(5) * on_sphere.abs() + gamma(1) * p.abs())
    }
}

/// Spheres in a binary hierarchy of bounding boxes.
#[derive(Clone, Debug, Default)]
pub struct SphereSet {
    /// In the tree's order.
    spheres: Vec<Sphere>,
    /// Each of `spheres`' index as given to `new`.
    ids: Vec<u32>,
    /// Depth-first: an inner node's left child follows it.
    nodes: Vec<Node>,
}

#[derive(Clone, Copy, Debug)]
struct Node {
    bounds: Aabb,
    /// Leaf: the first sphere; inner: the right child.
    first_or_right: u32,
    /// Spheres of a leaf; 0 for an inner node.
    count: u32,
}

/// Spheres a leaf holds at most.
const LEAF: usize = 2;

/// Traversal stack entries: the tree splits at the median, so its depth
/// is at most log2 of the sphere count (u32).
const STACK: usize = 64;

impl SphereSet {
    /// The set of `spheres`; hits name them by their index here.
    pub fn new(spheres: &[Sphere]) -> Self {
        let mut ids: Vec<u32> = (0..spheres.len() as u32).collect();
        let mut nodes = Vec::new();
        if !spheres.is_empty() {
            build(spheres, &mut ids, 0, &mut nodes);
        }
        Self {
            spheres: ids.iter().map(|&i| spheres[i as usize]).collect(),
            ids,
            nodes,
        }
    }

    pub fn is_empty(&self) -> bool {
        self.spheres.is_empty()
    }

    pub fn len(&self) -> usize {
        self.spheres.len()
    }

    pub fn bounds(&self) -> Aabb {
        self.nodes.first().map_or(Aabb::EMPTY, |n| n.bounds)
    }

    /// Each sphere with its index as given to `new`.
    pub fn iter(&self) -> impl Iterator<Item = (u32, &Sphere)> {
        self.ids.iter().copied().zip(&self.spheres)
    }

    pub fn size_bytes(&self) -> usize {
        self.spheres.len() * (std::mem::size_of::<Sphere>() + 4)
            + self.nodes.len() * std::mem::size_of::<Node>()
    }

    /// The nearest hit within (0, t_max): the sphere's index (as given to
    /// `new`) and where.
    pub fn intersect(&self, ray: &Ray, t_max: f32) -> Option<(u32, SphereHit)> {
        let mut best = None;
        let mut t_max = t_max;
        self.visit(ray, |id, s| {
            if let Some((t, local)) = s.nearest(ray, t_max) {
                t_max = t;
                best = Some((id, s, local));
            }
            false
        });
        best.map(|(id, s, local)| (id, s.hit_at(local, t_max)))
    }

    /// Whether a sphere lies on the ray within (0, ray.t_max).
    pub fn occluded(&self, ray: &Ray) -> bool {
        self.visit(ray, |_, s| s.nearest(ray, ray.t_max).is_some())
    }

    /// Calls `test` on the spheres whose boxes the ray meets, until it
    /// returns true (whether it did).
    fn visit<'s>(&'s self, ray: &Ray, mut test: impl FnMut(u32, &'s Sphere) -> bool) -> bool {
        if self.nodes.is_empty() || !(ray.origin.is_finite() && ray.dir.is_finite()) {
            return false;
        }
        let inv = ray.dir.recip();
        let mut stack = [0u32; STACK];
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let at = stack[top];
            let node = &self.nodes[at as usize];
            if !meets(&node.bounds, ray, inv) {
                continue;
            }
            if node.count > 0 {
                let first = node.first_or_right as usize;
                for k in first..first + node.count as usize {
                    if test(self.ids[k], &self.spheres[k]) {
                        return true;
                    }
                }
            } else {
                stack[top] = node.first_or_right;
                stack[top + 1] = at + 1;
                top += 2;
            }
        }
        false
    }
}

/// Whether the ray meets `b` within (0, ray.t_max) (the slab test, its far
/// distance enlarged against rounding).
fn meets(b: &Aabb, ray: &Ray, inv: Vec3) -> bool {
    let t0 = (b.min - ray.origin) * inv;
    let t1 = (b.max - ray.origin) * inv;
    let near = t0.min(t1).max_element().max(0.0);
    let far = t0.max(t1).min_element() * (1.0 + 2.0 * gamma(3));
    near <= far.min(ray.t_max)
}

/// Builds the subtree over `ids[first..]` (spheres split at the median of
/// the widest axis of their centres) into `nodes`, depth-first.
fn build(spheres: &[Sphere], ids: &mut [u32], first: u32, nodes: &mut Vec<Node>) {
    let bounds = ids
        .iter()
        .fold(Aabb::EMPTY, |b, &i| b.union(spheres[i as usize].bounds()));
    let at = nodes.len();
    nodes.push(Node {
        bounds,
        first_or_right: first,
        count: ids.len() as u32,
    });
    if ids.len() <= LEAF {
        return;
    }
    let centres = ids
        .iter()
        .fold(Aabb::EMPTY, |b, &i| b.grow(spheres[i as usize].centre));
    let extent = centres.diagonal();
    let axis = if extent.x >= extent.y && extent.x >= extent.z {
        0
    } else if extent.y >= extent.z {
        1
    } else {
        2
    };
    let mid = ids.len() / 2;
    ids.select_nth_unstable_by(mid, |&a, &b| {
        let (a, b) = (
            spheres[a as usize].centre[axis],
            spheres[b as usize].centre[axis],
        );
        a.total_cmp(&b)
    });
    let (left, right) = ids.split_at_mut(mid);
    build(spheres, left, first, nodes);
    let right_at = nodes.len() as u32;
    build(spheres, right, first + mid as u32, nodes);
    nodes[at].first_or_right = right_at;
    nodes[at].count = 0;
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Uniform numbers in [0, 1) (a hash of a counter).
    fn numbers(seed: u64) -> impl FnMut() -> f32 {
        let mut k = seed;
        move || {
            k = k.wrapping_add(0x9e37_79b9_7f4a_7c15);
            let mut z = k;
            z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
            ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32
        }
    }

    fn unit(a: f32, b: f32) -> Vec3 {
        let z = 1.0 - 2.0 * a;
        let r = (1.0 - z * z).max(0.0).sqrt();
        let phi = 2.0 * std::f32::consts::PI * b;
        Vec3::new(r * phi.cos(), r * phi.sin(), z)
    }

    #[test]
    fn hits_lie_on_the_sphere_and_leave_it_cleanly() {
        let s = Sphere::new(Vec3::new(1e3, -2e3, 5e2), 0.75);
        let mut u = numbers(3);
        for _ in 0..20_000 {
            let [a, b, c, d] = [u(), u(), u(), u()];
            let from = s.centre + Vec3::new(a - 0.5, b - 0.5, c - 0.5) * 400.0 * d;
            let target = s.centre + unit(a, c) * 0.7;
            let ray = Ray::new(from, (target - from).normalize());
            let Some(h) = s.intersect(&ray, f32::INFINITY) else {
                continue;
            };
            let off = ((h.p - s.centre).length() - s.radius).abs();
            assert!(off <= h.p_err.length() * 2.0, "{off} vs {}", h.p_err);
            // A ray leaving outwards misses it; one leaving inwards hits
            // the far side, not the point it left.
            let out = super::super::offset::offset_ray_origin(h.p, h.p_err, h.n, h.n);
            assert!(s
                .intersect(
                    &Ray::new(out, (h.n + ray.dir * 0.1).normalize()),
                    f32::INFINITY
                )
                .is_none());
            // Grazing hits have no inside to speak of.
            if ray.dir.dot(h.n) > -0.01 {
                continue;
            }
            let inwards = ray.dir;
            let inside = super::super::offset::offset_ray_origin(h.p, h.p_err, h.n, inwards);
            let far = s.intersect(&Ray::new(inside, inwards), f32::INFINITY);
            let far = far.unwrap_or_else(|| panic!("no far side: {h:?} {ray:?}"));
            let chord = -2.0 * s.radius * ray.dir.dot(h.n);
            // From the offset origin: off by up to the offset, a few p_err.
            let slack = 8.0 * h.p_err.length() / ray.dir.dot(h.n).abs() + 1e-5 * s.radius;
            assert!((far.t - chord).abs() < slack, "{} vs {chord}", far.t);
        }
    }

    #[test]
    fn coordinates_and_normals_agree() {
        let s = Sphere {
            rotation: Mat3::from_axis_angle(Vec3::new(1.0, 2.0, 3.0).normalize(), 0.7),
            ..Sphere::new(Vec3::ONE, 2.0)
        };
        for (u, v) in [(0.1, 0.2), (0.6, 0.5), (0.95, 0.9)] {
            let n = s.normal_at(Vec2::new(u, v));
            let (uv, dpdu) = s.coordinates(n);
            assert!((uv - Vec2::new(u, v)).length() < 1e-5, "{uv}");
            assert!(dpdu.dot(n).abs() < 1e-4 * dpdu.length());
        }
    }

    #[test]
    fn the_set_finds_the_nearest_of_many() {
        let spheres: Vec<Sphere> = (0..100)
            .map(|i| {
                Sphere::new(
                    Vec3::new((i % 10) as f32 * 3.0, (i / 10) as f32 * 3.0, 0.0),
                    1.0,
                )
            })
            .collect();
        let set = SphereSet::new(&spheres);
        let mut u = numbers(5);
        for _ in 0..2000 {
            let [a, b, c, d] = [u(), u(), u(), u()];
            let ray = Ray::new(
                Vec3::new(a * 30.0 - 1.5, b * 30.0 - 1.5, 10.0),
                Vec3::new(c - 0.5, d - 0.5, -1.0).normalize(),
            );
            let brute = spheres
                .iter()
                .enumerate()
                .filter_map(|(i, s)| s.intersect(&ray, f32::INFINITY).map(|h| (i as u32, h.t)))
                .min_by(|a, b| a.1.total_cmp(&b.1));
            let found = set.intersect(&ray, f32::INFINITY).map(|(i, h)| (i, h.t));
            assert_eq!(found, brute);
            assert_eq!(set.occluded(&ray), brute.is_some());
        }
    }
}
