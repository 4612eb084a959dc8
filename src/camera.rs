//! The pinhole camera: maps continuous raster positions to rays.

use glam::Vec3;

use crate::geometry::Ray;

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
    fn cornell_focal_length_gives_its_fov() {
        assert!((fov_from_focal_length(35.0, 25.0) - 39.3077).abs() < 1e-3);
    }
}
