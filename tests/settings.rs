//! A loaded scene is apart from how it is rendered: one load renders under
//! every integrator and under other film settings, with the same pixels as
//! a fresh load of the file with those settings asked for.

use std::path::Path;

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
        let spec = IntegratorSpec {
            kind,
            ..Default::default()
        };
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
