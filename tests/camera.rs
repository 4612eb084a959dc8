//! Cameras: a thin lens against thin-lens optics (a point at the focus
//! distance stays sharp, elsewhere it spreads over the circle of
//! confusion R·|D − F|/D), lens cameras rendered alike by paths from the
//! camera and from the lights, an orthographic view that keeps sizes at
//! every distance, and clear errors.

use crate::common;

use std::path::Path;

use prism::film::Film;

/// Luminance-weighted centroid and mean squared distance from it, in
/// pixels (pixel centres at half-integers).
fn spot(film: &Film) -> ((f64, f64), f64, f64) {
    let (mut w, mut sx, mut sy) = (0.0, 0.0, 0.0);
    let mut pixels = Vec::new();
    for y in 0..film.height {
        for x in 0..film.width {
            let l = film.xyz(x, y).y as f64;
            let (px, py) = (x as f64 + 0.5, y as f64 + 0.5);
            w += l;
            sx += l * px;
            sy += l * py;
            pixels.push((px, py, l));
        }
    }
    let (cx, cy) = (sx / w, sy / w);
    let r2 = pixels
        .iter()
        .map(|(x, y, l)| l * ((x - cx).powi(2) + (y - cy).powi(2)))
        .sum::<f64>()
        / w;
    ((cx, cy), r2, w)
}

/// A small square emitter of half-size `a` facing a lens camera on its
/// axis at distance `d`: fov 20°, 64², lens radius `radius` focused at `focus`.
fn lens_scene(d: f32, a: f32, radius: f32, focus: f32, kind: &str) -> prism::load::Loaded {
    common::scene(&format!(
        "[camera]\nposition = [0, 0, 0]\nlook_at = [0, 0, 1]\nfov = 20\n\
         aperture_radius = {radius}\nfocus_distance = {focus}\n\
         [film]\nresolution = [64, 64]\nspp = 256\n\
         [integrator]\ntype = \"{kind}\"\nmax_depth = 0\n\
         [[shape]]\ntype = \"quad\"\nvertices = [[{a}, {a}, {d}], [{a}, -{a}, {d}], [-{a}, -{a}, {d}], [-{a}, {a}, {d}]]\n\
         emission = 1\n"
    ))
}

#[test]
fn a_thin_lens_blurs_by_the_circle_of_confusion_and_keeps_the_focus_plane_sharp() {
    let (radius, focus, a) = (0.4f64, 5.0f64, 0.01f64);
    let footprint = 2.0 * focus * 10f64.to_radians().tan() / 64.0;
    for d in [5.0f64, 2.5, 10.0] {
        let s = lens_scene(d as f32, a as f32, radius as f32, focus as f32, "light");
        let film = common::render_film(&s, 2);
        let ((cx, cy), r2, _) = spot(&film);
        // Circle of confusion on the focus plane, and the square's own
        // image there, in pixels; a splat lands on a whole pixel (1/12 px²
        // a side).
        let coc = radius * (d - focus).abs() / d / footprint;
        let half = a * focus / d / footprint;
        let expected = coc * coc / 2.0 + 2.0 * half * half / 3.0 + 1.0 / 6.0;
        eprintln!(
            "D = {d}: spot rms radius {:.3} px, expected {:.3} (circle of confusion {coc:.2} px)",
            r2.sqrt(),
            expected.sqrt()
        );
        assert!(
            (cx - 32.0).abs() < 0.05 && (cy - 32.0).abs() < 0.05,
            "centre {cx}, {cy}"
        );
        if d == focus {
            // Sharp: the spot is a point on the corner of four pixels, so
            // its light falls on those four (rms √½ px), no further.
            assert!(
                r2.sqrt() < 0.75,
                "the focus plane is sharp: {} px",
                r2.sqrt()
            );
        } else {
            assert!(coc > 5.0, "the test must see the blur: {coc} px");
            assert!(
                (r2.sqrt() / expected.sqrt() - 1.0).abs() < 0.03,
                "D = {d}: rms radius {} px, expected {} px",
                r2.sqrt(),
                expected.sqrt()
            );
        }
    }
}

/// The GLASS_METAL_SHADING scene through a lens focused on its middle: the
/// path tracer (camera rays from the lens), the light tracer and bdpt
/// (connections to sampled lens points, with the lens's importance) agree.
#[test]
fn lens_cameras_render_alike_from_the_camera_and_from_the_lights() {
    let text = common::agree::GLASS_METAL_SHADING.replace(
        "fov = 45\n",
        "fov = 45\naperture_radius = 0.15\nfocus_distance = 3.5\n",
    );
    assert!(text.contains("aperture_radius"));
    for kind in ["light", "bdpt"] {
        common::agree::assert_integrators_agree(&text, kind, &format!("{kind} through a lens"));
    }
}

#[test]
fn an_orthographic_view_keeps_sizes_at_every_distance() {
    // A 4-unit wide view on 64 pixels: 16 pixels a unit, at any distance.
    for d in [3.0f32, 9.0] {
        let s = common::scene(&format!(
            "[camera]\ntype = \"orthographic\"\nwidth = 4\nposition = [0, 0, -10]\nlook_at = [0, 0, 0]\n\
             [film]\nresolution = [64, 48]\nspp = 64\n\
             [integrator]\nmax_depth = 0\n\
             [[shape]]\ntype = \"quad\"\nvertices = [[0.5, 0.5, {d}], [0.5, -0.5, {d}], [-0.5, -0.5, {d}], [-0.5, 0.5, {d}]]\n\
             emission = 1\n"
        ));
        let film = common::render_film(&s, 2);
        // Radiance 1 (luminance 1 for a constant spectrum) over the square's
        // image: the sum over pixels is its area in pixels.
        let (_, _, total) = spot(&film);
        assert!(
            (total - 256.0).abs() < 0.01 * 256.0,
            "distance {d}: {total} px², expected 256"
        );
    }
}

#[test]
fn bad_cameras_are_clear_errors() {
    let error = |camera: &str, rest: &str| match prism::load::load_str(
        &format!("[camera]\nposition = [0, 0, -5]\nlook_at = [0, 0, 0]\n{camera}\n{rest}"),
        Path::new(env!("CARGO_MANIFEST_DIR")),
    ) {
        Ok(_) => panic!("expected an error for {camera}"),
        Err(e) => e.to_string(),
    };
    let e = error("type = \"orthographic\"", "");
    assert!(e.contains("camera.width"), "{e}");
    let e = error(
        "type = \"orthographic\"\nwidth = 2",
        "[integrator]\ntype = \"light\"",
    );
    assert!(e.contains("orthographic") && e.contains("light"), "{e}");
    let e = error(
        "type = \"orthographic\"\nwidth = 2\naperture_radius = 0.1",
        "",
    );
    assert!(e.contains("no lens"), "{e}");
    let e = error("f_number = 2.8", "");
    assert!(
        e.contains("camera.f_number") && e.contains("focal_length"),
        "{e}"
    );
    let e = error("focus_distance = 3", "");
    assert!(
        e.contains("camera.focus_distance") && e.contains("lens"),
        "{e}"
    );
    let e = error("aperture_radius = -1", "");
    assert!(e.contains("aperture_radius"), "{e}");
    let e = error("width = 3", "");
    assert!(
        e.contains("camera.width") && e.contains("orthographic"),
        "{e}"
    );
    let e = error("type = \"fisheye\"", "");
    assert!(e.contains("fisheye"), "{e}");
}
