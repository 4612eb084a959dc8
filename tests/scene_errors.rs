//! Bad scene files get a clear error naming the file and the key, never a
//! panic or a silent default.

use std::path::Path;

use prism::load::{load, load_str};

const CAMERA: &str = "[camera]\nposition = [0, 0, -5]\nlook_at = [0, 0, 0]\n";

fn error(text: &str) -> String {
    match load_str(text, Path::new(env!("CARGO_MANIFEST_DIR"))) {
        Ok(_) => panic!("expected an error for:\n{text}"),
        Err(e) => e.to_string(),
    }
}

fn file_error(name: &str, text: &str) -> String {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(name);
    std::fs::write(&path, text).unwrap();
    match load(&path) {
        Ok(_) => panic!("expected an error for:\n{text}"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn unknown_key_names_key_line_and_file() {
    let e = file_error("typo.toml", &format!("{CAMERA}[film]\nsamples = 4\n"));
    assert!(e.contains("typo.toml"), "{e}");
    assert!(
        e.contains("unknown field `samples`") && e.contains("spp"),
        "{e}"
    );
    assert!(e.contains("line 5"), "{e}");
}

#[test]
fn near_miss_keys_get_a_suggestion() {
    let e = error(&format!("{CAMERA}[film]\nmax_dept = 3\n"));
    assert!(
        e.contains("unknown field `max_dept`") && e.contains("did you mean `max_depth`?"),
        "{e}"
    );
    let e = error(&format!("{CAMERA}[materials.m]\ntype = \"dielectirc\"\n"));
    assert!(e.contains("did you mean `dielectric`?"), "{e}");
}

#[test]
fn wrong_type_names_the_key() {
    let e = error(&format!("{CAMERA}[film]\nspp = \"many\"\n"));
    assert!(e.contains("invalid type") && e.contains("spp"), "{e}");
    let e = error("[camera]\nposition = [0, 0]\nlook_at = [0, 0, 0]\n");
    assert!(e.contains("position") && e.contains("line 2"), "{e}");
}

#[test]
fn malformed_toml_gives_line_and_column() {
    let e = error(&format!("{CAMERA}[film\nspp = 4\n"));
    assert!(e.contains("line 4") && e.contains("column"), "{e}");
}

#[test]
fn missing_files_are_named() {
    let e = error(&format!(
        "{CAMERA}[[shape]]\ntype = \"obj\"\nfile = \"nowhere/missing.obj\"\n"
    ));
    assert!(
        e.contains("shape[0].file") && e.contains("missing.obj") && e.contains("does not exist"),
        "{e}"
    );
    let e = error(&format!(
        "{CAMERA}[materials.m]\ntype = \"diffuse\"\nreflectance = {{ file = \"spectra/missing.csv\" }}\n"
    ));
    assert!(
        e.contains("materials.m.reflectance") && e.contains("missing.csv"),
        "{e}"
    );
    let e = error(&format!(
        "{CAMERA}[[shape]]\ntype = \"obj\"\nfile = \"scenes\"\n"
    ));
    assert!(e.contains("is a directory"), "{e}");
    let dir = tempfile::tempdir().unwrap();
    let e = load(dir.path()).err().unwrap().to_string();
    assert!(e.contains("is a directory"), "{e}");
    let e = load(&dir.path().join("absent.toml"))
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.contains("absent.toml") && e.contains("cannot read"),
        "{e}"
    );
}

#[test]
fn invalid_values_are_rejected() {
    let e = error(&format!("{CAMERA}[film]\nspp = 0\n"));
    assert!(e.contains("film.spp"), "{e}");
    let e = error(&format!("{CAMERA}[film]\nresolution = [0, 10]\n"));
    assert!(e.contains("film.resolution"), "{e}");
    let e = error(&format!("{CAMERA}[film]\nspp = -3\n"));
    assert!(e.contains("spp"), "{e}");
    let e = error(&format!("{CAMERA}[film]\nexposure = nan\n"));
    assert!(e.contains("film.exposure") && e.contains("finite"), "{e}");
    let e = error(&format!(
        "{CAMERA}[[shape]]\ntype = \"sphere\"\nradius = inf\n"
    ));
    assert!(e.contains("shape[0].radius") && e.contains("finite"), "{e}");
    let e = error(&format!(
        "{CAMERA}[materials.m]\ntype = \"diffuse\"\nreflectance = 1.5\n"
    ));
    assert!(
        e.contains("materials.m.reflectance") && e.contains("[0, 1]"),
        "{e}"
    );
    let e = error(&format!(
        "{CAMERA}[materials.m]\ntype = \"diffuse\"\nreflectance = [[500, 0.5], [400, 0.5]]\n"
    ));
    assert!(e.contains("increase"), "{e}");
    let e = error(&format!("{CAMERA}[[shape]]\ntype = \"quad\"\nvertices = [[0,0,0],[1,0,0],[1,1,0],[0,1,0]]\nemission = -1\n"));
    assert!(
        e.contains("shape[0].emission") && e.contains("negative"),
        "{e}"
    );
    let e = error("[camera]\nposition = [0, 0, 0]\nlook_at = [0, 0, 0]\n");
    assert!(e.contains("camera.look_at"), "{e}");
}

#[test]
fn names_must_resolve() {
    let e = error(&format!(
        "{CAMERA}[[shape]]\ntype = \"sphere\"\nradius = 1\nmaterial = \"gold\"\n"
    ));
    assert!(e.contains("shape[0].material") && e.contains("gold"), "{e}");
    let e = error(&format!(
        "{CAMERA}[[shape]]\ntype = \"sphere\"\nradius = 1\nemission = \"D66\"\n"
    ));
    assert!(e.contains("D66") && e.contains("D65"), "{e}");
    let e = error(&format!(
        "{CAMERA}[[shape]]\ntype = \"sphere\"\nradius = 1\nfile = \"x.obj\"\n"
    ));
    assert!(
        e.contains("shape[0].file") && e.contains("does not apply"),
        "{e}"
    );
    let e = error(&format!("{CAMERA}[[shape]]\ntype = \"cube\"\n"));
    assert!(e.contains("unknown variant `cube`"), "{e}");
}

#[test]
fn broken_obj_is_an_error_not_a_panic() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("empty.obj"), "").unwrap();
    std::fs::write(dir.path().join("bad.obj"), "v 0 0 0\nv 1 0 0\nf 1 2 7\n").unwrap();
    for (name, expect) in [("empty.obj", "no faces"), ("bad.obj", "")] {
        let text = format!("{CAMERA}[[shape]]\ntype = \"obj\"\nfile = \"{name}\"\n");
        let e = match load_str(&text, dir.path()) {
            Ok(_) => panic!("{name} loaded"),
            Err(e) => e.to_string(),
        };
        assert!(e.contains(name) && e.contains(expect), "{e}");
    }
}

#[test]
fn optical_constants_are_not_illuminants() {
    // η, k and IOR tables are unbounded spectra: an illuminant name or a
    // blackbody (normalised to luminance 1) would silently give nonsense.
    let metal = |eta: &str, k: &str| {
        format!("{CAMERA}[materials.m]\ntype = \"conductor\"\neta = {eta}\nk = {k}\n")
    };
    let e = error(&metal("\"D65\"", "{ rgb = [1, 1, 1] }"));
    assert!(
        e.contains("materials.m.eta") && e.contains("illuminant, not an optical constant"),
        "{e}"
    );
    let e = error(&metal("1.5", "{ blackbody = 3000 }"));
    assert!(
        e.contains("materials.m.k") && e.contains("blackbody"),
        "{e}"
    );
    // A spectrum named under [spectra] that is an illuminant, used as η.
    let e = error(&format!(
        "{CAMERA}[spectra]\nlamp = \"D65\"\n[materials.m]\ntype = \"conductor\"\neta = \"lamp\"\nk = 1\n"
    ));
    assert!(e.contains("illuminant, not an optical constant"), "{e}");
    // An RGB k of (1, 1, 1) is k ≈ 1 at every wavelength, not an
    // emission normalised to luminance 1 (which gave k ≈ 0.01).
    let s = load_str(
        &metal("1.5", "{ rgb = [1, 1, 1] }"),
        Path::new(env!("CARGO_MANIFEST_DIR")),
    )
    .unwrap();
    let prism::material::Material::Conductor { k, .. } = &s.scene.materials[0] else {
        panic!("a conductor");
    };
    for lambda in [450.0, 550.0, 650.0] {
        assert!(
            (k.eval(lambda) - 1.0).abs() < 0.05,
            "k({lambda}) = {}",
            k.eval(lambda)
        );
    }
}

#[test]
fn max_depth_moved_to_the_integrator() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    let s = load_str(&format!("{CAMERA}[film]\nmax_depth = 3\n"), dir).unwrap();
    assert!(s
        .report
        .warnings
        .iter()
        .any(|w| w.contains("integrator.max_depth")));
    let prism::integrator::Integrator::Path(p) = &s.settings.integrator else {
        panic!("the default integrator is the path tracer");
    };
    assert_eq!(p.max_depth, 3);
    let e = error(&format!(
        "{CAMERA}[film]\nmax_depth = 3\n[integrator]\nmax_depth = 4\n"
    ));
    assert!(e.contains("both given"), "{e}");
    let e = error(&format!(
        "{CAMERA}[integrator]\ntype = \"light\"\nstrategy = \"nee\"\n"
    ));
    assert!(
        e.contains("integrator.strategy") && e.contains("applies to `path`, not to `light`"),
        "{e}"
    );
    let e = error(&format!(
        "{CAMERA}[integrator]\ntype = \"bdpt\"\nstrategy = \"mis\"\n"
    ));
    assert!(e.contains("not to `bdpt`"), "{e}");
    let e = error(&format!(
        "{CAMERA}[integrator]\ntype = \"sppm\"\nsplit = 4\n"
    ));
    assert!(
        e.contains("integrator.split") && e.contains("applies to `path`"),
        "{e}"
    );
    for bad in [0, 257] {
        let e = error(&format!("{CAMERA}[integrator]\nsplit = {bad}\n"));
        assert!(
            e.contains("integrator.split") && e.contains("between 1 and 256"),
            "{e}"
        );
    }
    let e = error(&format!("{CAMERA}[integrator]\ntype = \"mlt\"\n"));
    assert!(e.contains("unknown variant `mlt`"), "{e}");
}

#[test]
fn a_scene_without_light_is_warned_about() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    let dark = load_str(
        &format!("{CAMERA}[[shape]]\ntype = \"sphere\"\nradius = 1\n"),
        dir,
    )
    .unwrap();
    assert!(
        dark.report.warnings.iter().any(|w| w.contains("no light")),
        "{:?}",
        dark.report.warnings
    );
    // Built-in spheres have no degenerate triangles to drop.
    assert_eq!(dark.scene.degenerate_triangles, 0);
    let lit = load_str(
        &format!("{CAMERA}[[shape]]\ntype = \"sphere\"\nradius = 1\nemission = 1\n"),
        dir,
    )
    .unwrap();
    assert!(lit.report.warnings.is_empty(), "{:?}", lit.report.warnings);
}

#[test]
fn photon_mapping_keys_are_checked_and_dropped_when_the_command_line_chooses_another_integrator() {
    let e = error(&format!(
        "{CAMERA}[integrator]\ntype = \"path\"\nphotons = 1000\n"
    ));
    assert!(
        e.contains("integrator.photons") && e.contains("sppm"),
        "{e}"
    );
    let e = error(&format!(
        "{CAMERA}[integrator]\ntype = \"sppm\"\nalpha = 1.5\n"
    ));
    assert!(e.contains("integrator.alpha"), "{e}");
    let e = error(&format!(
        "{CAMERA}[integrator]\ntype = \"sppm\"\nradius = -1\n"
    ));
    assert!(e.contains("integrator.radius"), "{e}");
    // --integrator path on a photon-mapped scene: its photon keys are
    // ignored, with a warning naming each.
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("s.toml");
    std::fs::write(
        &file,
        format!("{CAMERA}[integrator]\ntype = \"sppm\"\nphotons = 1000\nradius = 0.1\n"),
    )
    .unwrap();
    let s = prism::load::load_with(
        &file,
        &prism::load::Overrides {
            integrator: Some(prism::integrator::IntegratorKind::Path),
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(s.settings.integrator.name(), "path");
    for key in ["photons", "radius"] {
        assert!(
            s.report
                .warnings
                .iter()
                .any(|w| w.contains(&format!("integrator.{key}")) && w.contains("ignored")),
            "{:?}",
            s.report.warnings
        );
    }
}

#[test]
fn bad_colour_settings_name_the_key() {
    let light = "[[shape]]\ntype = \"sphere\"\nradius = 1\nemission = 1\n";
    let film = |keys: &str| error(&format!("{CAMERA}[film]\n{keys}\n{light}"));
    let e = film("colour_space = \"adobe-rgb\"");
    assert!(
        e.contains("colour_space") && e.contains("acescg") && e.contains("adobe-rgb"),
        "{e}"
    );
    let e = film("observer = \"cie1931\"");
    assert!(e.contains("observer") && e.contains("cie1931-2"), "{e}");
    let e = film("png_bits = 12");
    assert!(e.contains("film.png_bits") && e.contains("8 or 16"), "{e}");
    let e = film("gamut = \"compress\"");
    assert!(e.contains("gamut") && e.contains("map"), "{e}");
    let e = film("display = \"rec2020\"");
    assert!(e.contains("display") && e.contains("display-p3"), "{e}");
    let e = film("white_balance = 3200");
    assert!(
        e.contains("film.white_balance") && e.contains("temperature"),
        "{e}"
    );
    let e = film("white_balance = { temperature = 300 }");
    assert!(e.contains("1000–40000 K"), "{e}");
    let e = film("white_balance = { kelvin = 3200 }");
    assert!(e.contains("film.white_balance"), "{e}");
    let e = film("white_balance = \"D66\"");
    assert!(e.contains("film.white_balance") && e.contains("D66"), "{e}");
    // A scene's own spectrum is a white too.
    let ok = format!(
        "{CAMERA}[film]\nwhite_balance = \"warm\"\n[spectra]\nwarm = {{ blackbody = 2700 }}\n{light}"
    );
    load_str(&ok, Path::new(env!("CARGO_MANIFEST_DIR"))).unwrap();
}

#[test]
fn unknown_spectrum_names_list_the_names_there_are_and_suggest_one() {
    let light = "[[shape]]\ntype = \"sphere\"\nradius = 1\nemission = \"D6\"\n";
    let e = error(&format!(
        "{CAMERA}[spectra]\nwarm = {{ blackbody = 2700 }}\n{light}"
    ));
    assert!(
        e.contains("unknown spectrum `D6`") && e.contains("warm") && e.contains("FL11"),
        "{e}"
    );
    assert!(e.contains("did you mean `D65`?"), "{e}");
    let e = error(&format!(
        "{CAMERA}[spectra]\nwarm = {{ blackbody = 2700 }}\n{}",
        light.replace("D6", "wram")
    ));
    assert!(e.contains("did you mean `warm`?"), "{e}");
    // A long name is not quoted whole.
    let long = "x".repeat(5000);
    let e = error(&format!("{CAMERA}{}", light.replace("D6", &long)));
    assert!(e.len() < 600, "{} characters", e.len());
}

#[test]
fn a_misspelt_key_in_a_tagged_table_is_pointed_at_not_its_header() {
    let e = error(&format!(
        "{CAMERA}[materials.m]\ntype = \"diffuse\"\nreflectanse = 0.5\n\
         [[shape]]\ntype = \"sphere\"\nradius = 1\nemission = 1\n"
    ));
    assert!(e.contains("line 6, column 1"), "{e}");
    assert!(e.contains("6 | reflectanse = 0.5\n  | ^^^^^^^^^^^"), "{e}");
    assert!(e.contains("did you mean `reflectance`?"), "{e}");
}

#[test]
fn arrays_of_the_wrong_length_are_errors() {
    let light = "[[shape]]\ntype = \"sphere\"\nradius = 1\nemission = 1\n";
    let e = error(&format!(
        "{CAMERA}[film]\nresolution = [16, 16, 16]\n{light}"
    ));
    assert!(
        e.contains("line 5") && e.contains("invalid length 3, expected an array of 2"),
        "{e}"
    );
    let e = error(&format!(
        "[camera]\nposition = [0, 0, -5, 1]\nlook_at = [0, 0, 0]\n{light}"
    ));
    assert!(
        e.contains("line 2") && e.contains("invalid length 4"),
        "{e}"
    );
    let e = error(&format!(
        "{CAMERA}[[shape]]\ntype = \"quad\"\nvertices = [[0, 0, 0], [1, 0, 0], [1, 1, 0]]\nemission = 1\n"
    ));
    assert!(e.contains("four corners"), "{e}");
    let e = error(&format!(
        "{CAMERA}[[shape]]\ntype = \"sphere\"\nradius = 1\nemission = 1\ntransform = {{ rotate = {{ axis = [0, 1], degrees = 30 }} }}\n"
    ));
    assert!(e.contains("invalid length 2"), "{e}");
}

#[test]
fn bad_media_name_the_key() {
    let medium = |m: &str| {
        error(&format!(
            "{CAMERA}[materials.fog]\ntype = \"interface\"\nmedium = {m}\n[[light]]\ntype = \"point\"\nposition = [0, 1, 0]\nintensity = 1\n"
        ))
    };
    let e = medium("{ scattering = 1, phase = { hg = 1.0 } }");
    assert!(
        e.contains("materials.fog.medium.phase.hg") && e.contains("(-1, 1)"),
        "{e}"
    );
    let e =
        medium("{ absorption = 1, attenuation_color = [0.5, 0.5, 0.5], attenuation_distance = 1 }");
    assert!(
        e.contains("materials.fog.medium") && e.contains("not both"),
        "{e}"
    );
    let e = medium("{ attenuation_color = [0.5, 0.5, 0.5] }");
    assert!(e.contains("go together"), "{e}");
    let e = medium("{ attenuation_color = [0.5, 0, 0.5], attenuation_distance = 1 }");
    assert!(
        e.contains("attenuation_color") && e.contains("(0, 1]"),
        "{e}"
    );
    let e = medium("{ absorption = -1 }");
    assert!(
        e.contains("materials.fog.medium.absorption") && e.contains("negative"),
        "{e}"
    );
    let e = medium("{ absorption = \"D65\" }");
    assert!(e.contains("illuminant"), "{e}");
    let e = medium("{ scatering = 1 }");
    assert!(e.contains("scatering"), "{e}");
    // An interface needs its medium.
    let e = error(&format!("{CAMERA}[materials.fog]\ntype = \"interface\"\n"));
    assert!(e.contains("medium"), "{e}");
    let e = error(&format!("units = 0\n{CAMERA}"));
    assert!(e.contains("`units`"), "{e}");
    let e = error(&format!("units = 1e10\n{CAMERA}[medium]\nabsorption = 1\n"));
    assert!(
        e.contains("`medium.absorption`") && e.contains("units"),
        "{e}"
    );
}

#[test]
fn spd_spectrum_files_load_and_a_doubtful_unit_is_warned_about() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("lamp.spd"),
        "# Lambda (A) intensity\n380.0 0.5\n550.0 1.0\n780.0 0.5\n",
    )
    .unwrap();
    let path = dir.path().join("scene.toml");
    std::fs::write(
        &path,
        format!("{CAMERA}[[shape]]\ntype = \"sphere\"\nradius = 1\nemission = {{ file = \"lamp.spd\" }}\n"),
    )
    .unwrap();
    let s = load(&path).unwrap_or_else(|e| panic!("{e}"));
    let w = s.report.warnings.join("\n");
    assert!(w.contains("lamp.spd") && w.contains("read as nm"), "{w}");
}

#[test]
fn a_spectral_range_too_narrow_for_its_buckets_is_refused_before_rendering() {
    let e = error(&format!(
        "{CAMERA}[film]\nspectral_range = [500, 500.00003]\n"
    ));
    assert!(
        e.contains("film.spectral_range") && e.contains("too narrow"),
        "{e}"
    );
}

#[test]
fn special_files_as_inputs_are_refused_not_read() {
    let dir = tempfile::tempdir().unwrap();
    let fifo = dir.path().join("pipe.obj");
    let made = std::process::Command::new("mkfifo").arg(&fifo).status();
    if !made.is_ok_and(|s| s.success()) {
        eprintln!("no mkfifo here: skipped");
        return;
    }
    // A FIFO as a mesh, as a spectrum file and as the scene itself: each
    // would block a read forever.
    let scene = dir.path().join("s.toml");
    for shape in [
        "[[shape]]\ntype = \"obj\"\nfile = \"pipe.obj\"\n",
        "[[shape]]\ntype = \"sphere\"\nradius = 1\nemission = { file = \"pipe.obj\" }\n",
        "[[shape]]\ntype = \"sphere\"\nradius = 1\nemission = { file = \"/dev/zero\" }\n",
    ] {
        std::fs::write(&scene, format!("{CAMERA}{shape}")).unwrap();
        let e = load(&scene).err().expect("refused").to_string();
        assert!(e.contains("not a regular file"), "{e}");
    }
    let e = load(&fifo).err().expect("refused").to_string();
    assert!(e.contains("not a regular file"), "{e}");
}

#[test]
fn emission_beyond_f32_arithmetic_is_refused() {
    for shape in [
        "[[shape]]\ntype = \"sphere\"\nradius = 1\nemission = 1e38\n",
        "[[shape]]\ntype = \"sphere\"\nradius = 1\nemission = 1e20\nemission_scale = 1e20\n",
        "[[light]]\ntype = \"point\"\nposition = [0, 2, 0]\nintensity = 1e35\n",
    ] {
        let e = error(&format!("{CAMERA}{shape}"));
        assert!(
            e.contains("f32 arithmetic") && e.contains("film.exposure"),
            "{e}"
        );
    }
    // Bright but representable: fine.
    let text = format!("{CAMERA}[[shape]]\ntype = \"sphere\"\nradius = 1\nemission = 1e12\n");
    assert!(load_str(&text, Path::new(".")).is_ok());
}

#[test]
fn a_newcomers_mistakes_show_the_form_expected_and_where_a_file_was_looked_for() {
    let e = error(&format!("{CAMERA}[film]\nresolution = \"512x512\"\n"));
    assert!(
        e.contains("line 5") && e.contains("an array of 2 numbers, written [a, b]"),
        "{e}"
    );
    let dir = tempfile::tempdir().unwrap();
    let text =
        format!("{CAMERA}[materials.m]\ntype = \"diffuse\"\ntexture = \"textures/wood.png\"\n");
    let e = match load_str(&text, dir.path()) {
        Ok(_) => panic!("a missing texture loaded"),
        Err(e) => e.to_string(),
    };
    let looked = dir.path().join("textures/wood.png");
    assert!(
        e.contains("`materials.m.texture`: textures/wood.png does not exist")
            && e.contains(&format!("looked for {}", looked.display()))
            && e.contains("relative paths start at the scene file's folder"),
        "{e}"
    );
}
