//! Rays, bounding boxes, the watertight ray/triangle test, robust ray
//! origins and the bounding volume hierarchy.

pub mod angles;
pub mod bvh;
pub mod frame;
pub mod huge_pages;
pub mod lanes;
pub mod offset;
pub mod sphere;
pub mod triangle;
pub mod triangle4;

use glam::Vec3;

pub use bvh::Bvh;
pub use frame::Frame;

#[derive(Clone, Copy, Debug)]
pub struct Ray {
    pub origin: Vec3,
    /// Not necessarily normalised: shadow rays span origin → target with t ∈ (0, 1).
    pub dir: Vec3,
    pub t_max: f32,
    /// The ray starts in free space (where a medium scatters), not on a
    /// surface: a hit at any t > 0 counts. A ray from a surface ignores
    /// hits within the triangle test's rounding bound of its origin,
    /// which would be the surface it leaves; from a point near a surface
    /// that bound would hide the surface itself.
    pub in_free_space: bool,
}

/// Shadow rays stop this fraction short of their (already offset) target.
const SHADOW_EPSILON: f32 = 1e-6;

impl Ray {
    pub fn new(origin: Vec3, dir: Vec3) -> Self {
        Self {
            origin,
            dir,
            t_max: f32::INFINITY,
            in_free_space: false,
        }
    }

    /// The same ray, marked as starting in free space or not (see
    /// `in_free_space`).
    pub fn starting_in_free_space(self, in_free_space: bool) -> Self {
        Self {
            in_free_space,
            ..self
        }
    }

    /// The segment from `origin` to just short of `target`, for visibility
    /// tests (`dir` is not normalised: t runs from 0 to 1).
    pub fn towards(origin: Vec3, target: Vec3) -> Self {
        Self {
            origin,
            dir: target - origin,
            t_max: 1.0 - SHADOW_EPSILON,
            in_free_space: false,
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    pub min: Vec3,
    pub max: Vec3,
}

impl Aabb {
    pub const EMPTY: Aabb = Aabb {
        min: Vec3::splat(f32::INFINITY),
        max: Vec3::splat(f32::NEG_INFINITY),
    };

    pub fn of_points(points: &[Vec3]) -> Self {
        points.iter().fold(Self::EMPTY, |b, &p| b.grow(p))
    }

    pub fn grow(self, p: Vec3) -> Self {
        Self {
            min: lesser(self.min, p),
            max: greater(self.max, p),
        }
    }

    pub fn union(self, o: Aabb) -> Self {
        Self {
            min: lesser(self.min, o.min),
            max: greater(self.max, o.max),
        }
    }

    pub fn centroid(&self) -> Vec3 {
        0.5 * (self.min + self.max)
    }

    pub fn diagonal(&self) -> Vec3 {
        (self.max - self.min).max(Vec3::ZERO)
    }

    pub fn surface_area(&self) -> f32 {
        let d = self.diagonal();
        2.0 * (d.x * d.y + d.y * d.z + d.z * d.x)
    }
}

/// Per component, the smaller: one `minss` each. Boxes hold no NaN (every
/// vertex is checked finite), so `f32::min`'s NaN handling, three
/// instructions a component, only slowed the BVH build's binning.
#[inline]
fn lesser(a: Vec3, b: Vec3) -> Vec3 {
    let pick = |a: f32, b: f32| if a < b { a } else { b };
    Vec3::new(pick(a.x, b.x), pick(a.y, b.y), pick(a.z, b.z))
}

/// Per component, the larger (see `lesser`).
#[inline]
fn greater(a: Vec3, b: Vec3) -> Vec3 {
    let pick = |a: f32, b: f32| if a > b { a } else { b };
    Vec3::new(pick(a.x, b.x), pick(a.y, b.y), pick(a.z, b.z))
}

/// γ(n) = nε/(1 − nε): the bound on relative error of n rounded operations.
pub const fn gamma(n: i32) -> f32 {
    let e = f32::EPSILON * 0.5 * n as f32;
    e / (1.0 - e)
}
