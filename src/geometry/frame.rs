//! Orthonormal shading frames.

use glam::Vec3;

/// An orthonormal basis with `n` as its z axis.
#[derive(Clone, Copy, Debug)]
pub struct Frame {
    pub s: Vec3,
    pub t: Vec3,
    pub n: Vec3,
}

impl Frame {
    /// Builds a frame around a unit normal without branches on its direction
    /// (Duff et al. 2017, "Building an Orthonormal Basis, Revisited").
    #[inline(always)]
    pub fn from_normal(n: Vec3) -> Self {
        let sign = 1.0f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        Self {
            s: Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
            t: Vec3::new(b, sign + n.y * n.y * a, -n.y),
            n,
        }
    }

    #[inline(always)]
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.s), v.dot(self.t), v.dot(self.n))
    }

    #[inline(always)]
    pub fn to_world(&self, v: Vec3) -> Vec3 {
        self.s * v.x + self.t * v.y + self.n * v.z
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_are_orthonormal_for_every_direction() {
        for n in [
            Vec3::Z,
            -Vec3::Z,
            Vec3::X,
            Vec3::new(0.0, 0.0, -0.999_999),
            Vec3::new(1.0, 2.0, -3.0).normalize(),
        ] {
            let f = Frame::from_normal(n);
            assert!((f.s.length() - 1.0).abs() < 1e-5);
            assert!((f.t.length() - 1.0).abs() < 1e-5);
            assert!(
                f.s.dot(f.t).abs() < 1e-5 && f.s.dot(n).abs() < 1e-5 && f.t.dot(n).abs() < 1e-5
            );
            let v = Vec3::new(0.3, -0.5, 0.8);
            assert!((f.to_world(f.to_local(v)) - v).length() < 1e-5);
        }
    }
}
