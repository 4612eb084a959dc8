//! Robust spawning of rays from surfaces. A hit point computed in floating
//! point lies within a small box of the true surface; offsetting the origin
//! along the normal by that box's extent, then rounding away, guarantees the
//! new ray cannot re-hit the surface it leaves (pbrt-v4's error-bound method,
//! Pharr, Jakob & Humphreys, §6.8). It scales with the scene: no fixed epsilon.

use glam::Vec3;

/// Moves `p` (with absolute error bound `p_err`) off the surface with normal
/// `n`, to the side that direction `w` points into.
pub fn offset_ray_origin(p: Vec3, p_err: Vec3, n: Vec3, w: Vec3) -> Vec3 {
    let d = n.abs().dot(p_err);
    let mut offset = d * n;
    if w.dot(n) < 0.0 {
        offset = -offset;
    }
    let mut po = p + offset;
    for i in 0..3 {
        if offset[i] > 0.0 {
            po[i] = po[i].next_up();
        } else if offset[i] < 0.0 {
            po[i] = po[i].next_down();
        }
    }
    po
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn offset_moves_to_the_requested_side() {
        let p = Vec3::new(1.0, 2.0, 3.0);
        let err = Vec3::splat(1e-6);
        let up = offset_ray_origin(p, err, Vec3::Y, Vec3::new(0.0, 1.0, 0.0));
        let down = offset_ray_origin(p, err, Vec3::Y, Vec3::new(0.0, -1.0, 0.0));
        assert!(up.y > p.y && down.y < p.y);
        // The offset covers the error box: the box's far corner stays behind.
        assert!(up.y - p.y >= 1e-6 && p.y - down.y >= 1e-6);
    }
}
