//! The pinhole camera: maps continuous raster positions to rays, and, for
//! paths that start at lights, points of the scene back to raster positions
//! with the camera's importance.

use glam::{Vec2, Vec3};

use crate::geometry::Ray;

/// A connection from a point of the scene to the camera.
#[derive(Clone, Copy, Debug)]
pub struct CameraSample {
    /// Continuous raster position (pixels from the top-left corner).
    pub raster: Vec2,
    /// Unit direction from the point towards the camera.
    pub wi: Vec3,
    /// Distance from the point to the camera.
    pub dist: f32,
    /// Importance over its density, W_e / p: what the connection weighs.
    /// W_e = 1 / (A cos⁴θ) with A the image's area on the plane at distance
    /// 1, so that W_e integrates to 1 over the image (per projected solid
    /// angle); p = dist² / cos θ converts the pinhole's point to the
    /// solid angle at the point (pbrt-v4's PerspectiveCamera).
    pub weight: f32,
}

#[derive(Clone, Debug)]
pub struct Camera {
    pub position: Vec3,
    forward: Vec3,
    right: Vec3,
    up: Vec3,
    /// tan(vertical fov / 2)
    tan_half_fov: f32,
    width: u32,
    height: u32,
}

impl Camera {
    /// A camera at `position` looking at `look_at`; `fov_y_degrees` is the
    /// vertical field of view. Image x grows to the right, y downwards.
    pub fn look_at(
        position: Vec3,
        look_at: Vec3,
        up: Vec3,
        fov_y_degrees: f32,
        width: u32,
        height: u32,
    ) -> Self {
        Self::looking(
            position,
            look_at - position,
            up,
            fov_y_degrees,
            width,
            height,
        )
    }

    /// A camera at `position` looking along `forward` (any length).
    pub fn looking(
        position: Vec3,
        forward: Vec3,
        up: Vec3,
        fov_y_degrees: f32,
        width: u32,
        height: u32,
    ) -> Self {
        let forward = forward.normalize();
        let right = forward.cross(up).normalize();
        let up = right.cross(forward);
        Self {
            position,
            forward,
            right,
            up,
            tan_half_fov: (fov_y_degrees.to_radians() * 0.5).tan(),
            width,
            height,
        }
    }

    /// The ray through raster position (x, y), in pixels from the top-left corner.
    pub fn generate_ray(&self, x: f32, y: f32) -> Ray {
        let aspect = self.width as f32 / self.height as f32;
        let sx = (2.0 * x / self.width as f32 - 1.0) * self.tan_half_fov * aspect;
        let sy = (1.0 - 2.0 * y / self.height as f32) * self.tan_half_fov;
        Ray::new(
            self.position,
            (self.forward + sx * self.right + sy * self.up).normalize(),
        )
    }

    /// Where the point `p` appears on the film, and what a connection from
    /// it to the camera weighs; None when it is behind the camera or
    /// outside the image.
    pub fn sample_wi(&self, p: Vec3) -> Option<CameraSample> {
        let to_camera = self.position - p;
        let dist2 = to_camera.length_squared();
        if !(dist2 > 0.0) {
            return None;
        }
        let dist = dist2.sqrt();
        let wi = to_camera / dist;
        let dir = -wi;
        let cos = dir.dot(self.forward);
        if !(cos > 0.0) {
            return None;
        }
        let aspect = self.width as f32 / self.height as f32;
        let (sx, sy) = (dir.dot(self.right) / cos, dir.dot(self.up) / cos);
        let x = (sx / (self.tan_half_fov * aspect) + 1.0) * 0.5 * self.width as f32;
        let y = (1.0 - sy / self.tan_half_fov) * 0.5 * self.height as f32;
        if !(x >= 0.0 && x < self.width as f32 && y >= 0.0 && y < self.height as f32) {
            return None;
        }
        let area = 4.0 * self.tan_half_fov * self.tan_half_fov * aspect;
        Some(CameraSample {
            raster: Vec2::new(x, y),
            wi,
            dist,
            weight: 1.0 / (area * cos * cos * cos * dist2),
        })
    }

    /// Solid-angle density with which `generate_ray` (at a uniform raster
    /// position) sends a ray along `dir` (unit): 1 / (A cos³θ), zero
    /// outside the image.
    pub fn pdf_we(&self, dir: Vec3) -> f32 {
        let cos = dir.dot(self.forward);
        if !(cos > 0.0) {
            return 0.0;
        }
        let aspect = self.width as f32 / self.height as f32;
        let (sx, sy) = (dir.dot(self.right) / cos, dir.dot(self.up) / cos);
        if sx.abs() > self.tan_half_fov * aspect || sy.abs() > self.tan_half_fov {
            return 0.0;
        }
        let area = 4.0 * self.tan_half_fov * self.tan_half_fov * aspect;
        1.0 / (area * cos * cos * cos)
    }

    /// The width of a pixel's footprint on a plane facing the camera at
    /// `distance`.
    pub fn pixel_footprint(&self, distance: f32) -> f32 {
        2.0 * distance * self.tan_half_fov / self.height as f32
    }

    /// The same camera for another image size (the vertical field of view is kept).
    pub fn with_resolution(mut self, width: u32, height: u32) -> Self {
        self.width = width;
        self.height = height;
        self
    }

    pub fn resolution(&self) -> (u32, u32) {
        (self.width, self.height)
    }
}

/// Vertical field of view (degrees) of a lens of `focal_length` over a film
/// of height `film_height` (same units).
pub fn fov_from_focal_length(focal_length: f32, film_height: f32) -> f32 {
    (2.0 * (0.5 * film_height / focal_length).atan()).to_degrees()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn centre_and_corners() {
        let c = Camera::look_at(Vec3::ZERO, Vec3::Z, Vec3::Y, 90.0, 200, 100);
        let r = c.generate_ray(100.0, 50.0);
        assert!((r.dir - Vec3::Z).length() < 1e-6);
        // Top edge at 45°: y component equals z.
        let top = c.generate_ray(100.0, 0.0).dir;
        assert!((top.y - top.z).abs() < 1e-6 && top.y > 0.0);
        // Right of the image is the camera's right: for +z forward, +y up that is −x.
        assert!(c.generate_ray(200.0, 50.0).dir.x < 0.0);
    }

    #[test]
    fn points_map_back_to_the_raster_positions_of_their_rays() {
        let c = Camera::look_at(
            Vec3::new(1.0, 2.0, -3.0),
            Vec3::ZERO,
            Vec3::Y,
            50.0,
            320,
            200,
        );
        for (x, y) in [(0.5, 0.5), (160.0, 100.0), (319.2, 12.7), (3.3, 199.9)] {
            let r = c.generate_ray(x, y);
            let p = r.origin + r.dir * 7.5;
            let s = c.sample_wi(p).expect("in view");
            assert!(
                (s.raster - Vec2::new(x, y)).length() < 1e-2,
                "{x},{y}: {}",
                s.raster
            );
            assert!((s.wi + r.dir).length() < 1e-5 && (s.dist - 7.5).abs() < 1e-4);
        }
        assert!(c.sample_wi(Vec3::new(1.0, 2.0, -10.0)).is_none(), "behind");
    }

    #[test]
    fn importance_integrates_to_one_over_the_image() {
        // Points on a plane facing the camera at distance d: the image covers
        // the plane's area A·d² (A = the image's area at distance 1), and
        // ∫ W_e cos θ dω over the image is ∫ weight · cos θ_plane dA = 1.
        let c = Camera::look_at(Vec3::ZERO, Vec3::Z, Vec3::Y, 60.0, 64, 48);
        let d = 2.0f32;
        let half_h = (30f32).to_radians().tan() * d;
        let half_w = half_h * 64.0 / 48.0;
        let n = 400;
        let mut sum = 0.0f64;
        for i in 0..n {
            for j in 0..n {
                let p = Vec3::new(
                    -half_w + (i as f32 + 0.5) / n as f32 * 2.0 * half_w,
                    -half_h + (j as f32 + 0.5) / n as f32 * 2.0 * half_h,
                    d,
                );
                let s = c.sample_wi(p).expect("in view");
                let cos_plane = s.wi.z.abs();
                sum +=
                    (s.weight * cos_plane) as f64 * (4.0 * half_w * half_h) as f64 / (n * n) as f64;
            }
        }
        assert!((sum - 1.0).abs() < 1e-3, "{sum}");
    }

    #[test]
    fn cornell_focal_length_gives_its_fov() {
        assert!((fov_from_focal_length(35.0, 25.0) - 39.3077).abs() < 1e-3);
    }
}
