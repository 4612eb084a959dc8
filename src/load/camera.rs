//! The camera: from position and look-at, or from a glTF file.

use std::path::Path;

use glam::Vec3;

use super::{list, Loader, MAX_COORDINATE};
use crate::camera::{fov_from_focal_length, Camera};
use crate::film::FilmSettings;
use crate::load::format::{CameraKind, CameraSpec, SceneFile, ShapeKind};
use crate::load::SceneError;

impl Loader {
    pub(super) fn camera(&self, file: &SceneFile, s: &FilmSettings) -> Result<Camera, SceneError> {
        let c = &file.camera;
        if let Some(rel) = &c.from_file {
            return self.asset_camera(rel, file, s);
        }
        if c.name.is_some() {
            return Err(self.error("`camera.name` needs `camera.from_file`"));
        }
        let (Some(position), Some(look_at)) = (c.position, c.look_at) else {
            return Err(self.error(
                "`camera` needs `position` and `look_at` (or `from_file` with a glTF camera)",
            ));
        };
        let fov = match (c.fov, c.focal_length) {
            (Some(_), Some(_)) => {
                return Err(self.error("`camera`: give either `fov` or `focal_length`, not both"))
            }
            (Some(fov), None) => fov,
            (None, Some(f)) => {
                if f <= 0.0 || c.film_height <= 0.0 {
                    return Err(self
                        .error("`camera.focal_length` and `camera.film_height` must be positive"));
                }
                fov_from_focal_length(f, c.film_height)
            }
            (None, None) => 40.0,
        };
        if !(fov > 0.0 && fov < 180.0) {
            return Err(self.error(format!(
                "`camera.fov` must be between 0 and 180 degrees, found {fov}"
            )));
        }
        let (pos, at, up) = (Vec3::from(position), Vec3::from(look_at), Vec3::from(c.up));
        let forward = at - pos;
        if forward.length_squared() == 0.0 {
            return Err(self.error("`camera.look_at` must differ from `camera.position`"));
        }
        if pos.abs().max_element() > MAX_COORDINATE {
            return Err(self.error(format!(
                "`camera.position` {pos} lies beyond ±{MAX_COORDINATE:e}, the range of prism's single-precision geometry"
            )));
        }
        if forward.normalize().cross(up).length_squared() < 1e-12 {
            return Err(self.error("`camera.up` must not be parallel to the viewing direction"));
        }
        let camera = Camera::look_at(pos, at, up, fov, s.width, s.height);
        let lens = self.lens(c)?;
        if lens.is_none() && c.focus_distance.is_some() {
            return Err(
                self.error("`camera.focus_distance` needs a lens: `aperture_radius` or `f_number`")
            );
        }
        match c.kind {
            CameraKind::Perspective => {
                if c.width.is_some() {
                    return Err(self.error(
                        "`camera.width` applies to an orthographic camera (`type = \"orthographic\"`)",
                    ));
                }
                let Some((key, radius)) = lens else {
                    return Ok(camera);
                };
                if !(radius >= 0.0 && radius.is_finite()) {
                    return Err(self.error(format!(
                        "`camera.{key}` gives a lens radius of {radius}: it must be finite and not negative"
                    )));
                }
                let focus = c.focus_distance.unwrap_or(forward.length());
                if !(focus > 0.0 && focus.is_finite()) {
                    return Err(self.error(format!(
                        "`camera.focus_distance` must be positive, found {focus}"
                    )));
                }
                Ok(camera.with_lens(radius, focus))
            }
            CameraKind::Orthographic => {
                if lens.is_some() {
                    return Err(self.error(
                        "an orthographic camera has no lens: drop `aperture_radius`/`f_number`",
                    ));
                }
                if c.fov.is_some() || c.focal_length.is_some() {
                    return Err(self.error(
                        "an orthographic camera takes `width`, not `fov` or `focal_length`",
                    ));
                }
                let Some(width) = c.width else {
                    return Err(self.error(
                        "an orthographic camera needs `camera.width` (the view's width in scene units)",
                    ));
                };
                if !(width > 0.0 && width.is_finite()) {
                    return Err(
                        self.error(format!("`camera.width` must be positive, found {width}"))
                    );
                }
                Ok(camera.orthographic(width * s.height as f32 / s.width as f32))
            }
        }
    }

    /// The lens the camera table asks for: the key that gave it and the
    /// aperture radius (scene units), or None for a pinhole.
    fn lens(&self, c: &CameraSpec) -> Result<Option<(&'static str, f32)>, SceneError> {
        Ok(match (c.aperture_radius, c.f_number) {
            (Some(_), Some(_)) => {
                return Err(
                    self.error("`camera`: give either `aperture_radius` or `f_number`, not both")
                )
            }
            (Some(r), None) => Some(("aperture_radius", r)),
            (None, Some(n)) => {
                let Some(f) = c.focal_length else {
                    return Err(self.error(
                        "`camera.f_number` needs `camera.focal_length` (the aperture is focal length / f-number)",
                    ));
                };
                if !(n > 0.0) {
                    return Err(
                        self.error(format!("`camera.f_number` must be positive, found {n}"))
                    );
                }
                // Millimetres to scene units taken as metres.
                Some(("f_number", 0.5 * f / n / 1000.0))
            }
            (None, None) => None,
        })
    }

    /// The camera of a glTF file: the one called `camera.name`, or the first.
    pub(super) fn asset_camera(
        &self,
        rel: &Path,
        file: &SceneFile,
        s: &FilmSettings,
    ) -> Result<Camera, SceneError> {
        let c = &file.camera;
        if c.position.is_some()
            || c.look_at.is_some()
            || c.fov.is_some()
            || c.focal_length.is_some()
            || c.width.is_some()
            || c.kind != CameraKind::Perspective
            || c.aperture_radius.is_some()
            || c.f_number.is_some()
            || c.focus_distance.is_some()
        {
            return Err(self.error(
                "`camera.from_file` takes the whole camera from the file: drop position, look_at, fov, focal_length, type, width and the lens keys",
            ));
        }
        let path = self.input_file(rel, "camera.from_file")?;
        if !path.is_file() {
            return Err(self.error(format!(
                "`camera.from_file`: {} does not exist or is not a file",
                path.display()
            )));
        }
        let asset = self.asset(&path, ShapeKind::Gltf, true, "camera.from_file")?;
        let names: Vec<&String> = asset.cameras.iter().map(|c| &c.name).collect();
        let found = match &c.name {
            Some(name) => asset.cameras.iter().find(|cam| &cam.name == name),
            None => asset.cameras.first(),
        };
        let Some(cam) = found else {
            return Err(self.error(format!(
                "`camera.from_file`: {} has no {} (cameras: {})",
                path.display(),
                c.name
                    .as_ref()
                    .map_or("perspective camera".to_string(), |n| format!(
                        "camera `{n}`"
                    )),
                list(names.into_iter())
            )));
        };
        let finite = cam.position.is_finite() && cam.forward.is_finite() && cam.up.is_finite();
        if !finite || !(cam.forward.cross(cam.up).length_squared() >= 1e-12) {
            return Err(self.error(format!(
                "`camera.from_file`: {}: camera `{}` has a degenerate transform",
                path.display(),
                cam.name
            )));
        }
        if cam.position.abs().max_element() > MAX_COORDINATE {
            return Err(self.error(format!(
                "`camera.from_file`: {}: camera `{}` at {} lies beyond ±{MAX_COORDINATE:e}, the range of prism's single-precision geometry",
                path.display(),
                cam.name,
                cam.position
            )));
        }
        if !(cam.yfov > 0.0 && cam.yfov < 180.0) {
            return Err(self.error(format!(
                "`camera.from_file`: {}: camera `{}` has a field of view of {} degrees",
                path.display(),
                cam.name,
                cam.yfov
            )));
        }
        // Looking along the direction, not at position + forward: far from
        // the origin that sum rounds back to the position.
        Ok(Camera::looking(
            cam.position,
            cam.forward,
            cam.up,
            cam.yfov,
            s.width,
            s.height,
        ))
    }
}
