//! One light of each kind, for tests that must cover every light: the
//! match is exhaustive, so a kind added to `lights!` does not compile
//! until it has an example here.

use std::sync::Arc;

use glam::Vec3;

use super::{
    AreaLight, Cone, DirectionalLight, Emitter, EnvironmentMap, Light, LightKind, LightSource,
    PointLight, SceneSphere, Sky, SkyModel, SphereLight, Sun, UniformEnvironment, SKY_BANDS,
};
use crate::geometry::sphere::Sphere;
use crate::spectrum::Spectrum;

impl LightKind {
    /// A typical light of the kind above the origin (a scene within 5 of
    /// it, for the lights at infinity); `kind()` of it is `self`.
    pub fn example(self) -> Light {
        let emitter = || {
            Arc::new(Emitter {
                spectrum: Spectrum::Blackbody {
                    kelvin: 4000.0,
                    scale: 1.0,
                },
                texture: None,
            })
        };
        let sky = || Arc::new(SkyModel::new(0.6, 3.0, [0.3; SKY_BANDS]));
        let towards_sun = Vec3::new(0.3, 0.6, 0.2).normalize();
        let light = match self {
            LightKind::Area => Light::Area(AreaLight::new(
                [
                    Vec3::new(-0.5, 2.0, -0.5),
                    Vec3::new(0.5, 2.0, -0.5),
                    Vec3::new(0.0, 2.0, 0.5),
                ],
                None,
                emitter(),
                true,
            )),
            LightKind::Point => Light::Point(PointLight::new(
                Vec3::new(0.2, 2.0, 0.1),
                Spectrum::Constant(3.0),
                Some(Cone {
                    axis: -Vec3::Y,
                    cos_falloff_start: 0.9,
                    cos_falloff_end: 0.7,
                }),
            )),
            LightKind::Directional => Light::Directional(DirectionalLight::new(
                Vec3::new(0.1, -1.0, 0.2).normalize(),
                Spectrum::Constant(2.0),
            )),
            LightKind::Environment => {
                Light::Environment(UniformEnvironment::new(Spectrum::Constant(0.5)))
            }
            LightKind::EnvironmentMap => {
                let (w, h) = (16, 8);
                let rgb: Vec<Vec3> = (0..w * h)
                    .map(|i| {
                        Vec3::new(
                            0.2 + (i % w) as f32 / w as f32,
                            0.5,
                            1.0 - (i / w) as f32 / h as f32,
                        )
                    })
                    .collect();
                Light::EnvironmentMap(EnvironmentMap::new(w, h, &rgb, 1.0, 30.0))
            }
            LightKind::Sky => Light::Sky(Sky::new(sky(), towards_sun, 1.0)),
            LightKind::Sun => Light::Sun(Sun::new(sky(), towards_sun, 0.53, 1.0)),
            LightKind::Sphere => Light::Sphere(SphereLight::new(
                Sphere::new(Vec3::new(0.0, 2.0, 0.5), 0.4),
                emitter(),
                false,
                false,
            )),
        };
        light.with_scene_bounds(SceneSphere {
            centre: Vec3::ZERO,
            radius: 5.0,
        })
    }
}
