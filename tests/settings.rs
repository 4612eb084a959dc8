//! A loaded scene is apart from how it is rendered: one load renders under
//! every integrator and under other film settings, with the same pixels as
//! a fresh load of the file with those settings asked for.

use std::path::Path;

use crate::common;

use prism::film::Film;
use prism::integrator::{Integrator, IntegratorKind, IntegratorSpec};
use prism::load::{load_with, Loaded, Overrides};
use prism::render::{render, RenderError, RenderOptions, RenderSettings};

fn cornell(overrides: Overrides) -> Loaded {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-box.toml");
    load_with(
        &path,
        &Overrides {
            resolution: Some((24, 24)),
            ..overrides
        },
    )
    .unwrap_or_else(|e| panic!("{e}"))
}

fn film(loaded: &Loaded, settings: &RenderSettings) -> Film {
    let options = RenderOptions {
        threads: Some(2),
        ..RenderOptions::with_spp(&settings.film, 4)
    };
    let (film, stats) = render(&loaded.scene, settings, &options).unwrap();
    assert_eq!(stats.non_finite, 0);
    film
}

/// Every pixel's sums and spectrum, bit for bit.
fn assert_same(a: &Film, b: &Film, what: &str) {
    assert_eq!((a.width, a.height), (b.width, b.height), "{what}");
    for y in 0..a.height {
        for x in 0..a.width {
            assert_eq!(a.sums(x, y), b.sums(x, y), "{what}: pixel ({x}, {y})");
            assert_eq!(a.spectrum(x, y), b.spectrum(x, y), "{what}: ({x}, {y})");
        }
    }
}

#[test]
fn one_load_renders_under_every_integrator() {
    let loaded = cornell(Overrides::default());
    for &kind in IntegratorKind::ALL {
        let spec = IntegratorSpec::of(kind);
        let settings = RenderSettings {
            integrator: Integrator::from_spec(&spec).unwrap(),
            ..loaded.settings.clone()
        };
        let image = film(&loaded, &settings);
        let fresh = cornell(Overrides {
            integrator: Some(kind),
            ..Default::default()
        });
        assert_eq!(fresh.settings.integrator, settings.integrator);
        assert_same(&image, &film(&fresh, &fresh.settings), kind.name());
        let (w, h) = (image.width, image.height);
        let mean = (0..h)
            .flat_map(|y| (0..w).map(move |x| (x, y)))
            .map(|(x, y)| image.xyz(x, y).y as f64)
            .sum::<f64>()
            / (w * h) as f64;
        assert!(mean > 0.01, "{}: mean luminance {mean}", kind.name());
    }
}

#[test]
fn one_load_renders_under_other_film_settings() {
    let loaded = cornell(Overrides::default());
    let mut settings = loaded.settings.clone();
    settings.film.layout.count = 8;
    let fresh = cornell(Overrides {
        spectral_buckets: Some(8),
        ..Default::default()
    });
    assert_eq!(fresh.settings.film, settings.film);
    assert_same(
        &film(&loaded, &settings),
        &film(&fresh, &fresh.settings),
        "8 buckets",
    );
    // A film of another size than the camera's is refused, not stretched.
    settings.film.width = 30;
    let options = RenderOptions::with_spp(&settings.film, 1);
    assert!(matches!(
        render(&loaded.scene, &settings, &options),
        Err(RenderError::Resolution { .. })
    ));
}

#[test]
fn one_photon_mapper_sizes_each_scene_by_its_own_photons() {
    // Photon mapping measures each scene's photons stored per photon
    // emitted, for its default photon count: what it learnt of one scene
    // must not carry over to another. A closed room stores several per
    // photon, a lamp over a floor in the open less than one.
    let room = common::scene(&format!(
        "{}\n[film]\nresolution = [512, 512]\n",
        "[camera]\nposition = [0.1, -0.2, 0.05]\nlook_at = [0, 0, 1]\n\
         [integrator]\ntype = \"sppm\"\n\
         [[shape]]\ntype = \"sphere\"\nradius = 1\nflip_normals = true\nemission = 1\n"
    ));
    let floor = common::scene(
        "[camera]\nposition = [0, 2, -3]\nlook_at = [0, 0, 0]\n\
         [film]\nresolution = [512, 512]\n[integrator]\ntype = \"sppm\"\n\
         [[shape]]\ntype = \"quad\"\nvertices = [[-2, 0, -2], [-2, 0, 2], [2, 0, 2], [2, 0, -2]]\n\
         [[light]]\ntype = \"point\"\nposition = [0, 1, 0]\nintensity = 5\n",
    );
    let photons = |integrator: &Integrator, loaded: &Loaded| match integrator {
        Integrator::Sppm(p) => p.photons_per_iteration(&loaded.scene),
        other => panic!("photon mapping, not {}", other.name()),
    };
    let shared = room.settings.integrator.clone();
    let in_room = photons(&shared, &room);
    let on_floor = photons(&floor.settings.integrator, &floor);
    assert_ne!(in_room, on_floor, "the scenes should differ for this test");
    assert_eq!(photons(&shared, &floor), on_floor);
    assert_eq!(photons(&shared, &room), in_room);
}

/// One schema per integrator: a key of another integrator is refused,
/// naming the integrator it belongs to; `--integrator` drops it with a
/// warning instead.
#[test]
fn every_integrator_refuses_the_keys_of_the_others() {
    let dir = tempfile::tempdir().unwrap();
    let camera = "[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\n";
    let (mut checked, mut moved_checked) = (0, 0);
    for &kind in IntegratorKind::ALL {
        for &other in IntegratorKind::ALL {
            for &key in other.own_keys() {
                if kind.own_keys().contains(&key) {
                    continue;
                }
                let value = valid_value(key);
                let text = format!(
                    "{camera}[integrator]\ntype = \"{}\"\n{key} = {value}\n",
                    other.name()
                );
                let file = dir.path().join("s.toml");
                std::fs::write(&file, &text).unwrap();
                let moved = prism::load::load_with(
                    &file,
                    &Overrides {
                        integrator: Some(kind),
                        ..Default::default()
                    },
                );
                if let Ok(moved) = moved {
                    assert_eq!(moved.settings.integrator.kind(), kind);
                    assert!(
                        moved.report.warnings.iter().any(|w| w.contains(&format!(
                            "`integrator.{key}` does not apply to `{}`",
                            kind.name()
                        ))),
                        "{:?}",
                        moved.report.warnings
                    );
                    moved_checked += 1;
                }
                let text = text.replace(other.name(), kind.name());
                let e = match prism::load::load_str(&text, dir.path()) {
                    Ok(_) => panic!("{kind:?} took `{key}` of {other:?}"),
                    Err(e) => e.to_string(),
                };
                // A key several integrators share names them all.
                let owners = e
                    .split(&format!("`integrator.{key}` applies to "))
                    .nth(1)
                    .and_then(|rest| rest.split(", not to ").next())
                    .unwrap_or("");
                assert!(
                    owners.contains(&format!("`{}`", other.name()))
                        && e.contains(&format!(", not to `{}`", kind.name()))
                        && e.contains(&format!("6 | {key} = {value}")),
                    "{e}"
                );
                checked += 1;
            }
        }
    }
    // Every key moves, with a value its owner takes.
    assert!(
        checked >= 6 && moved_checked == checked,
        "{checked} keys checked, {moved_checked} moved"
    );
}

/// A value that the integrator owning `key` accepts.
fn valid_value(key: &str) -> &'static str {
    match key {
        "strategy" => "\"mis\"",
        "split_dispersion" | "split_glass" | "look_ahead" | "reuse" => "true",
        _ => "1",
    }
}
