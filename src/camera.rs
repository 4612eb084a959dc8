//! The camera: a pinhole or a thin lens (depth of field) with a perspective
//! projection, or an orthographic projection. Maps continuous raster
//! positions to rays, and, for paths that start at lights, points of the
//! scene back to raster positions with the camera's importance.

use glam::{Vec2, Vec3};

use crate::geometry::Ray;

/// A connection from a point of the scene to the camera.
#[derive(Clone, Copy, Debug)]
pub struct CameraSample {
    /// Continuous raster position (pixels from the top-left corner).
    pub raster: Vec2,
    /// The point on the lens (the camera's position for a pinhole).
    pub p_lens: Vec3,
    /// Unit direction from the point towards `p_lens`.
    pub wi: Vec3,
    /// Distance from the point to `p_lens`.
    pub dist: f32,
    /// Importance over its density, W_e / p: what the connection weighs.
    /// W_e = 1 / (A · A_lens · cos⁴θ) with A the image's area on the plane
    /// at distance 1, so that W_e integrates to 1 over image and lens (per
    /// projected solid angle and area); p = dist² / (A_lens cos θ) converts
    /// the lens point's density to solid angle at the point (pbrt-v4's
    /// PerspectiveCamera). The lens area cancels.
    pub weight: f32,
}

/// How the image plane maps to rays.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Projection {
    /// Rays from the eye: tan(vertical fov / 2).
    Perspective { tan_half_fov: f32 },
    /// Parallel rays: half the height of the view in scene units.
    Orthographic { half_height: f32 },
}

#[derive(Clone, Debug)]
pub struct Camera {
    pub position: Vec3,
    forward: Vec3,
    right: Vec3,
    up: Vec3,
    projection: Projection,
    /// Radius of the thin lens (0: a pinhole) and the distance along the
    /// view that is in focus (perspective only).
    lens_radius: f32,
    focus_distance: f32,
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
            projection: Projection::Perspective {
                tan_half_fov: (fov_y_degrees.to_radians() * 0.5).tan(),
            },
            lens_radius: 0.0,
            focus_distance: 1.0,
            width,
            height,
        }
    }

    /// The same camera with a thin lens of `radius` focused at `distance`
    /// along the view (perspective only).
    pub fn with_lens(mut self, radius: f32, distance: f32) -> Self {
        self.lens_radius = radius;
        self.focus_distance = distance;
        self
    }

    /// The same view with an orthographic projection `height` scene units high.
    pub fn orthographic(mut self, height: f32) -> Self {
        self.projection = Projection::Orthographic {
            half_height: 0.5 * height,
        };
        self.lens_radius = 0.0;
        self
    }

    pub fn projection(&self) -> Projection {
        self.projection
    }

    /// Whether rays start on a lens of some size (they need `u_lens`).
    pub fn has_lens(&self) -> bool {
        self.lens_radius > 0.0
    }

    /// Whether light paths can connect to the camera (not through the
    /// Dirac directions of an orthographic view).
    pub fn connectible(&self) -> bool {
        matches!(self.projection, Projection::Perspective { .. })
    }

    fn aspect(&self) -> f32 {
        self.width as f32 / self.height as f32
    }

    /// The film position (x, y) as offsets on the image plane: along
    /// `right` and `up`, at distance 1 (perspective) or in scene units.
    fn plane(&self, x: f32, y: f32) -> Vec2 {
        let half = match self.projection {
            Projection::Perspective { tan_half_fov } => tan_half_fov,
            Projection::Orthographic { half_height } => half_height,
        };
        Vec2::new(
            (2.0 * x / self.width as f32 - 1.0) * half * self.aspect(),
            (1.0 - 2.0 * y / self.height as f32) * half,
        )
    }

    /// Raster position of image-plane offsets (the inverse of `plane`).
    fn raster(&self, s: Vec2) -> Vec2 {
        let half = match self.projection {
            Projection::Perspective { tan_half_fov } => tan_half_fov,
            Projection::Orthographic { half_height } => half_height,
        };
        Vec2::new(
            (s.x / (half * self.aspect()) + 1.0) * 0.5 * self.width as f32,
            (1.0 - s.y / half) * 0.5 * self.height as f32,
        )
    }

    fn in_image(&self, r: Vec2) -> bool {
        r.x >= 0.0 && r.x < self.width as f32 && r.y >= 0.0 && r.y < self.height as f32
    }

    /// The point of the lens for a uniform `u_lens` in [0, 1)².
    fn lens_point(&self, u_lens: (f32, f32)) -> Vec3 {
        if !self.has_lens() {
            return self.position;
        }
        let d = concentric_disc(u_lens) * self.lens_radius;
        self.position + d.x * self.right + d.y * self.up
    }

    /// The ray through raster position (x, y), in pixels from the top-left
    /// corner, with the centre of the lens.
    pub fn generate_ray(&self, x: f32, y: f32) -> Ray {
        self.ray(x, y, (0.5, 0.5))
    }

    /// The ray through raster position (x, y) from the lens point picked
    /// by `u_lens` (ignored without a lens).
    pub fn ray(&self, x: f32, y: f32, u_lens: (f32, f32)) -> Ray {
        let s = self.plane(x, y);
        match self.projection {
            Projection::Orthographic { .. } => Ray::new(
                self.position + s.x * self.right + s.y * self.up,
                self.forward,
            ),
            Projection::Perspective { .. } => {
                let d = self.forward + s.x * self.right + s.y * self.up;
                if !self.has_lens() {
                    return Ray::new(self.position, d.normalize());
                }
                // Every lens point sees the same point of the focus plane.
                let focus = self.position + d * self.focus_distance;
                let origin = self.lens_point(u_lens);
                Ray::new(origin, (focus - origin).normalize())
            }
        }
    }

    /// Where a ray from `p_lens` along `dir` meets the image, in raster
    /// coordinates (perspective only).
    fn raster_of(&self, p_lens: Vec3, dir: Vec3) -> Option<Vec2> {
        let cos = dir.dot(self.forward);
        if !(cos > 0.0) {
            return None;
        }
        // The point of the focus plane the ray goes through, seen from the
        // lens centre (for a pinhole, the direction itself).
        let q = if self.has_lens() {
            p_lens + dir * (self.focus_distance / cos) - self.position
        } else {
            dir
        };
        let depth = q.dot(self.forward);
        let r = self.raster(Vec2::new(q.dot(self.right), q.dot(self.up)) / depth);
        self.in_image(r).then_some(r)
    }

    /// A connection from the point `p` to the camera through the lens point
    /// picked by `u_lens`; None when it is behind the camera, outside the
    /// image, or the camera is orthographic.
    pub fn sample_wi(&self, p: Vec3, u_lens: (f32, f32)) -> Option<CameraSample> {
        let Projection::Perspective { tan_half_fov } = self.projection else {
            return None;
        };
        let p_lens = self.lens_point(u_lens);
        let to_camera = p_lens - p;
        let dist2 = to_camera.length_squared();
        if !(dist2 > 0.0) {
            return None;
        }
        let dist = dist2.sqrt();
        let wi = to_camera / dist;
        let dir = -wi;
        let raster = self.raster_of(p_lens, dir)?;
        let cos = dir.dot(self.forward);
        let area = 4.0 * tan_half_fov * tan_half_fov * self.aspect();
        Some(CameraSample {
            raster,
            p_lens,
            wi,
            dist,
            weight: 1.0 / (area * cos * cos * cos * dist2),
        })
    }

    /// Solid-angle density with which `ray` (at a uniform raster position)
    /// leaves `p_lens` along `dir` (unit): 1 / (A cos³θ), zero outside the
    /// image and for an orthographic camera (a Dirac direction).
    pub fn pdf_we(&self, p_lens: Vec3, dir: Vec3) -> f32 {
        let Projection::Perspective { tan_half_fov } = self.projection else {
            return 0.0;
        };
        if self.raster_of(p_lens, dir).is_none() {
            return 0.0;
        }
        let cos = dir.dot(self.forward);
        let area = 4.0 * tan_half_fov * tan_half_fov * self.aspect();
        1.0 / (area * cos * cos * cos)
    }

    /// The width of a pixel's footprint on a plane facing the camera at
    /// `distance`.
    pub fn pixel_footprint(&self, distance: f32) -> f32 {
        match self.projection {
            Projection::Perspective { tan_half_fov } => {
                2.0 * distance * tan_half_fov / self.height as f32
            }
            Projection::Orthographic { half_height } => 2.0 * half_height / self.height as f32,
        }
    }

    /// The same camera for another image size (the vertical field of view,
    /// or height, is kept).
    pub fn with_resolution(mut self, width: u32, height: u32) -> Self {
        self.width = width;
        self.height = height;
        self
    }

    pub fn resolution(&self) -> (u32, u32) {
        (self.width, self.height)
    }
}

/// Shirley–Chiu's concentric map of [0, 1)² onto the unit disc (uniform,
/// with little distortion).
fn concentric_disc(u: (f32, f32)) -> Vec2 {
    let (a, b) = (2.0 * u.0 - 1.0, 2.0 * u.1 - 1.0);
    if a == 0.0 && b == 0.0 {
        return Vec2::ZERO;
    }
    let q = std::f32::consts::FRAC_PI_4;
    let (r, theta) = if a.abs() > b.abs() {
        (a, q * (b / a))
    } else {
        (b, 2.0 * q - q * (a / b))
    };
    Vec2::new(r * theta.cos(), r * theta.sin())
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
            let s = c.sample_wi(p, (0.5, 0.5)).expect("in view");
            assert!(
                (s.raster - Vec2::new(x, y)).length() < 1e-2,
                "{x},{y}: {}",
                s.raster
            );
            assert!((s.wi + r.dir).length() < 1e-5 && (s.dist - 7.5).abs() < 1e-4);
        }
        assert!(
            c.sample_wi(Vec3::new(1.0, 2.0, -10.0), (0.5, 0.5))
                .is_none(),
            "behind"
        );
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
                let s = c.sample_wi(p, (0.5, 0.5)).expect("in view");
                let cos_plane = s.wi.z.abs();
                sum +=
                    (s.weight * cos_plane) as f64 * (4.0 * half_w * half_h) as f64 / (n * n) as f64;
            }
        }
        assert!((sum - 1.0).abs() < 1e-3, "{sum}");
    }

    #[test]
    fn lens_rays_meet_on_the_focus_plane_and_map_back_to_their_raster() {
        let c = Camera::look_at(Vec3::new(0.5, 1.0, -4.0), Vec3::ZERO, Vec3::Y, 40.0, 80, 60)
            .with_lens(0.3, 3.0);
        let forward = (Vec3::ZERO - Vec3::new(0.5, 1.0, -4.0)).normalize();
        for (x, y) in [(40.0, 30.0), (3.5, 50.2), (77.0, 4.0)] {
            let centre = c.generate_ray(x, y);
            let t = 3.0 / centre.dir.dot(forward);
            let focus = centre.origin + centre.dir * t;
            for u in [(0.1, 0.9), (0.7, 0.2), (0.95, 0.5)] {
                let r = c.ray(x, y, u);
                assert!((r.origin - c.position).length() <= 0.3 + 1e-5);
                let t = (focus - r.origin).dot(r.dir);
                assert!(
                    (r.origin + r.dir * t - focus).length() < 1e-4,
                    "misses the focus point"
                );
                // A point on this ray maps back to (x, y) through the same lens point.
                let p = r.origin + r.dir * 7.0;
                let s = c.sample_wi(p, u).expect("in view");
                assert!((s.raster - Vec2::new(x, y)).length() < 1e-2, "{}", s.raster);
                assert!((s.p_lens - r.origin).length() < 1e-5);
            }
        }
    }

    #[test]
    fn orthographic_rays_are_parallel_and_sized_in_scene_units() {
        let c = Camera::look_at(
            Vec3::new(0.0, 0.0, -5.0),
            Vec3::ZERO,
            Vec3::Y,
            40.0,
            100,
            50,
        )
        .orthographic(2.0);
        let a = c.generate_ray(0.0, 25.0);
        let b = c.generate_ray(100.0, 25.0);
        assert_eq!(a.dir, b.dir);
        // 2 units high, 4 wide.
        assert!(((a.origin - b.origin).length() - 4.0).abs() < 1e-5);
        assert!(c.sample_wi(Vec3::ZERO, (0.5, 0.5)).is_none() && !c.connectible());
    }

    #[test]
    fn cornell_focal_length_gives_its_fov() {
        assert!((fov_from_focal_length(35.0, 25.0) - 39.3077).abs() < 1e-3);
    }
}
