//! The film's colorimetry: the XYZ that rendering accumulates from sampled
//! wavelengths converges to the 1 nm Riemann sum of the CIE 1931 CMFs, and
//! D65 white comes out as sRGB white.

use glam::{DVec3, Vec3};
use prism::film::{Film, FilmTile, SpectralLayout};
use prism::sampler::Sampler;
use prism::spectrum::{cie, SampledWavelengths, Spectrum};

#[test]
fn d65_lit_white_reflector_through_the_film() {
    let d65 = Spectrum::Table(cie::d65().clone());
    let exact = cie::spectrum_to_xyz(&d65).as_dvec3();
    let white = exact / exact.y;
    assert!(
        (white - DVec3::new(0.95047, 1.0, 1.08883))
            .abs()
            .max_element()
            < 2e-4,
        "{white}"
    );

    let layout = SpectralLayout {
        min: 380.0,
        max: 780.0,
        count: 40,
    };
    let mut tile = FilmTile::new(0, 0, 1, 1, 1, layout);
    let n = 400_000u64;
    let mut sq = DVec3::ZERO;
    for k in 0..n {
        let mut s = Sampler::for_sample(5, 0, 0, k);
        let wl = SampledWavelengths::sample_visible(s.next_f32());
        let l = d65.sample(&wl);
        let xyz = cie::sampled_to_xyz(l, &wl).as_dvec3();
        sq += xyz * xyz;
        tile.add_sample(0, 0, l, &wl);
    }
    let mut film = Film::new(1, 1, layout);
    film.add_tile(&tile);
    let mean = film.xyz(0, 0).as_dvec3();
    let std_err = ((sq / n as f64 - mean * mean) / (n - 1) as f64)
        .max(DVec3::ZERO)
        .powf(0.5);
    for c in 0..3 {
        assert!(
            (mean[c] - exact[c]).abs() < 4.5 * std_err[c],
            "component {c}: {} ± {}, Riemann sum {}",
            mean[c],
            std_err[c],
            exact[c]
        );
        assert!(std_err[c] < 2e-3 * exact[c], "error bar too wide");
    }
    let rgb = cie::xyz_to_linear_srgb((mean / mean.y).as_vec3());
    assert!((rgb - Vec3::ONE).abs().max_element() < 5e-3, "{rgb}");

    // The spectral buckets hold the mean spectral radiance of each bucket.
    let spectrum = film.spectrum(0, 0);
    for (b, value) in spectrum.iter().enumerate() {
        let (lo, hi) = (
            layout.min + b as f32 * 10.0,
            layout.min + (b + 1) as f32 * 10.0,
        );
        let expected = d65.average(lo, hi);
        assert!(
            (value - expected).abs() < 0.03 * expected,
            "bucket {b} ({lo}–{hi} nm): {value}, expected {expected}"
        );
    }
}

/// A camera looking straight at a two-sided emitter that fills its view,
/// with `film` keys and the emitter's `emission`.
fn emitter_filling_the_view(film: &str, emission: &str) -> prism::load::Loaded {
    crate::common::scene(&format!(
        r#"
        [camera]
        position = [0, 0, -1]
        look_at = [0, 0, 0]
        fov = 30
        [film]
        {film}
        [[shape]]
        type = "quad"
        vertices = [[-2, -2, 0], [-2, 2, 0], [2, 2, 0], [2, -2, 0]]
        emission = {emission}
        two_sided = true
        "#
    ))
}

/// Built-in illuminants are scaled to Y = 1 under CIE 1931 whatever the
/// film's observer (docs/scene-format.md): an emitter seen directly has
/// Y = 1 under CIE 1931 and, under another observer, the Y of the same
/// radiance (D65: 1.0073 under 1964 10°, illuminant A: 0.966).
#[test]
fn illuminants_keep_their_cie_1931_scale_under_every_observer() {
    use prism::spectrum::cie::Observer;
    for (name, table) in [("D65", cie::d65()), ("A", cie::illuminant("A").unwrap())] {
        let spectrum = Spectrum::Table(table.clone());
        let y_1931 = cie::spectrum_to_xyz(&spectrum).y as f64;
        for (observer, key) in [
            (Observer::Cie1931, "cie1931-2"),
            (Observer::Cie1964, "cie1964-10"),
            (Observer::Cie2015_10, "cie2015-10"),
        ] {
            let film = format!("resolution = [4, 4]\nspp = 4096\nobserver = \"{key}\"");
            let loaded = emitter_filling_the_view(&film, &format!("\"{name}\""));
            let film = crate::common::render_film(&loaded, 2);
            let expected = observer.cmfs().spectrum_to_xyz(&spectrum).y as f64 / y_1931;
            let (mut mean, mut var) = (0.0, 0.0);
            for y in 0..4 {
                for x in 0..4 {
                    let (m, v) = film.luminance_and_variance(x, y);
                    mean += m / 16.0;
                    var += v / 256.0;
                }
            }
            assert!(
                (mean - expected).abs() < 5.0 * var.sqrt() + 1e-4,
                "{name} under {key}: Y {mean} ± {}, expected {expected}",
                var.sqrt()
            );
            if observer == Observer::Cie1931 {
                assert!((expected - 1.0).abs() < 1e-6);
            } else {
                // The test tells the two conventions apart.
                assert!((expected - 1.0).abs() > 10.0 * var.sqrt(), "{name} {key}");
            }
        }
    }
}

/// Spectrum files with several value columns need `column` (a header name
/// or a position from 1); semicolon files with decimal commas read as the
/// same numbers.
#[test]
fn spectrum_columns_are_picked_by_name_or_position() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("two.csv"),
        "nm,dark,light\n400,0.1,0.8\n700,0.2,0.9\n",
    )
    .unwrap();
    std::fs::write(dir.path().join("semi.csv"), "nm;light\n400;0,8\n700;0,9\n").unwrap();
    let load = |reflectance: &str| {
        let text = format!(
            "[camera]\nposition = [0, 0, -5]\nlook_at = [0, 0, 0]\n\
             [materials.m]\ntype = \"diffuse\"\nreflectance = {reflectance}\n"
        );
        let path = dir.path().join("s.toml");
        std::fs::write(&path, text).unwrap();
        prism::load::load(&path)
    };
    let reflectance_at = |loaded: prism::load::Loaded, nm: f32| match &loaded.scene.materials[0] {
        prism::material::Material::Diffuse { reflectance } => reflectance.factor.eval(nm),
        other => panic!("{other:?}"),
    };
    let e = load("{ file = \"two.csv\" }").err().unwrap().to_string();
    assert!(
        e.contains("2 value columns")
            && e.contains("columns: dark, light")
            && e.contains("materials.m.reflectance"),
        "{e}"
    );
    let by_name = reflectance_at(
        load("{ file = \"two.csv\", column = \"light\" }").unwrap(),
        550.0,
    );
    let by_index = reflectance_at(load("{ file = \"two.csv\", column = 2 }").unwrap(), 550.0);
    let semicolons = reflectance_at(load("{ file = \"semi.csv\" }").unwrap(), 550.0);
    assert!((by_name - 0.85).abs() < 1e-6 && by_index == by_name && semicolons == by_name);
    let e = load("{ file = \"two.csv\", column = \"medium\" }")
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("no column named `medium`"), "{e}");
}

/// A white balance on the daylight locus renders that daylight neutral,
/// and `{ daylight = 6504 }` is the standard D65 to the table's precision.
#[test]
fn daylight_by_temperature_emits_and_white_balances() {
    let scene = |emission: &str, balance: &str| {
        let film = format!("resolution = [2, 2]\nspp = 256\nwhite_balance = {balance}");
        emitter_filling_the_view(&film, emission)
    };
    let mean_rgb = |loaded: &prism::load::Loaded| {
        let film = crate::common::render_film(loaded, 1);
        let xyz = (0..4).map(|i| film.xyz(i % 2, i / 2)).sum::<Vec3>() / 4.0;
        loaded.settings.film.colour.rgb(xyz)
    };
    let rgb = mean_rgb(&scene("{ daylight = 4500 }", "{ daylight = 4500 }"));
    assert!(
        (rgb.max_element() - rgb.min_element()) < 1e-3 * rgb.max_element(),
        "{rgb}"
    );
    let warm = mean_rgb(&scene("{ daylight = 4500 }", "\"D65\""));
    assert!(warm.x > 1.1 * warm.z, "{warm}");
    let d65 = mean_rgb(&scene("\"D65\"", "\"D65\""));
    let made = mean_rgb(&scene("{ daylight = 6504 }", "\"D65\""));
    assert!((d65 - made).abs().max_element() < 2e-3, "{d65} {made}");
    let e = prism::load::load_str(
        "[camera]\nposition = [0, 0, -5]\nlook_at = [0, 0, 0]\n[film]\nwhite_balance = { daylight = 3000 }\n",
        std::path::Path::new("."),
    )
    .err()
    .unwrap()
    .to_string();
    assert!(e.contains("4000–25000 K"), "{e}");
}

/// Photometric inputs and the absolute film: an emitter of 100 cd/m² reads
/// Y = 100; a white Lambertian floor under 1000 lux reads 1000/π cd/m²,
/// and under a 1000 lm point light 2 m above it (1000/4π cd, so 1000/16π
/// lux) 1000/(16π²).
#[test]
fn photometric_units_in_and_out() {
    let render_y = |body: &str, spp: u32| {
        let loaded = crate::common::scene(&format!(
            r#"
            [camera]
            position = [0, 1, 0]
            look_at = [0, 0, 0]
            up = [0, 0, 1]
            fov = 10
            [film]
            resolution = [4, 4]
            spp = {spp}
            photometric = true
            colour_space = "xyz"
            [integrator]
            max_depth = 1
            [materials.white]
            type = "diffuse"
            reflectance = 1
            {body}
            "#
        ));
        let film = crate::common::render_film(&loaded, 2);
        // The output's Y per unit of the film's: 683 lm/W × Σ ȳ.
        let k = loaded.settings.film.colour.rgb(Vec3::Y).y as f64;
        assert!((k / (683.0 * cie::cmfs().y_integral as f64) - 1.0).abs() < 1e-6);
        let (mut mean, mut var) = (0.0, 0.0);
        for y in 0..4 {
            for x in 0..4 {
                let (m, v) = film.luminance_and_variance(x, y);
                mean += m * k / 16.0;
                var += v * k * k / 256.0;
            }
        }
        (mean, var.sqrt())
    };
    let floor = r#"
        [[shape]]
        type = "quad"
        vertices = [[-5, 0, -5], [-5, 0, 5], [5, 0, 5], [5, 0, -5]]
        material = "white"
    "#;
    let (y, e) = render_y(
        r#"[[shape]]
        type = "quad"
        vertices = [[-5, 0, -5], [-5, 0, 5], [5, 0, 5], [5, 0, -5]]
        emission = "A"
        luminance = 100
        two_sided = true"#,
        64,
    );
    assert!((y - 100.0).abs() < 5.0 * e + 1e-3, "emitter: {y} ± {e}");
    let (y, e) = render_y(
        &format!("{floor}\n[[light]]\ntype = \"directional\"\ndirection = [0, -1, 0]\nirradiance = \"D65\"\nlux = 1000\n"),
        64,
    );
    let expected = 1000.0 / std::f64::consts::PI;
    assert!(
        (y - expected).abs() < 5.0 * e + 1e-2,
        "under 1000 lux: {y} ± {e}, expected {expected}"
    );
    let (y, e) = render_y(
        &format!("{floor}\n[[light]]\ntype = \"point\"\nposition = [0, 2, 0]\npower = \"D65\"\nlumens = 1000\n"),
        64,
    );
    // The floor seen is 0.17 wide at 2 m: cos³ falls 1% at its edge.
    let expected = 1000.0 / (16.0 * std::f64::consts::PI.powi(2));
    assert!(
        (y - expected).abs() < 0.01 * expected + 5.0 * e,
        "under 1000 lm: {y} ± {e}, expected {expected}"
    );
}

/// `[measured.NAME]`: a measured set (CGATS) becomes one diffuse material a
/// sample, `NAME.SAMPLE`, with the sample's reflectance.
#[test]
fn a_measured_set_becomes_one_material_a_sample() {
    let dir = tempfile::tempdir().unwrap();
    let cgats =
        "CGATS.17\nBEGIN_DATA_FORMAT\nSAMPLE_ID SAMPLE_NAME SPECTRAL_NM400 SPECTRAL_NM700\n\
                 END_DATA_FORMAT\nBEGIN_DATA\n1 \"dark skin\" 5.0 40.0\n2 A2 80 90\nEND_DATA\n";
    std::fs::write(dir.path().join("checker.txt"), cgats).unwrap();
    let scene = |extra: &str| {
        let path = dir.path().join("s.toml");
        std::fs::write(
            &path,
            format!(
                "[camera]\nposition = [0, 0, -5]\nlook_at = [0, 0, 0]\n\
                 [measured.cc]\nfile = \"checker.txt\"\n{extra}\n\
                 [[shape]]\ntype = \"quad\"\nvertices = [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]]\n\
                 material = \"cc.dark skin\"\n"
            ),
        )
        .unwrap();
        prism::load::load(&path)
    };
    let loaded = scene("").unwrap();
    let reflectances: Vec<f32> = loaded
        .scene
        .materials
        .iter()
        .filter_map(|m| match m {
            prism::material::Material::Diffuse { reflectance } => {
                Some(reflectance.factor.eval(550.0))
            }
            _ => None,
        })
        .collect();
    // The two samples (percent read as such), then the default material.
    assert_eq!(reflectances.len(), 3, "{reflectances:?}");
    assert!(
        (reflectances[0] - 0.85).abs() < 1e-6 && (reflectances[1] - 0.225).abs() < 1e-6,
        "{reflectances:?}"
    );
    let e = scene("[materials.\"cc.A2\"]\ntype = \"diffuse\"")
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("`cc.A2` is also defined"), "{e}");
}
