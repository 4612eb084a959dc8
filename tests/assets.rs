//! What exporters really write, from the files of tests/data/assets/ (made
//! by tools/gen_asset_cases.py): required extensions, quantised and
//! Draco-compressed geometry, roughness and texture sets, OBJ illumination
//! models, several material libraries, missing normals, BMP and TGA.

use std::path::{Path, PathBuf};

use glam::{Vec2, Vec3, Vec4};
use prism::geometry::Ray;
use prism::load::{load_str, Loaded};
use prism::material::{Ior, Material, ShadingGeometry, TransportMode};
use prism::scene::{Scene, SurfaceHit};
use prism::spectrum::SampledWavelengths;

fn assets() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/assets")
}

/// A scene of one asset file seen from +z.
fn load_asset(file: &str) -> Result<Loaded, String> {
    let kind = if file.ends_with(".obj") {
        "obj"
    } else {
        "gltf"
    };
    let text = format!(
        "[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\nfov = 40\n\
         [film]\nresolution = [16, 16]\nspp = 1\n\
         [environment]\nradiance = 1\n\
         [[shape]]\ntype = \"{kind}\"\nfile = \"{file}\"\n"
    );
    load_str(&text, &assets()).map_err(|e| e.to_string())
}

fn asset(file: &str) -> Loaded {
    load_asset(file).unwrap_or_else(|e| panic!("{file}: {e}"))
}

fn hit(scene: &Scene, origin: Vec3, target: Vec3) -> Option<SurfaceHit> {
    scene.intersect(&Ray::new(origin, (target - origin).normalize()))
}

fn wavelengths() -> SampledWavelengths {
    let mut wl = SampledWavelengths::sample_visible(0.5);
    wl.lambda = Vec4::new(450.0, 530.0, 600.0, 650.0);
    wl
}

/// The material at a hit, by the scene's own lookup.
fn material<'a>(scene: &'a Scene, h: &SurfaceHit) -> &'a Material {
    &scene.materials[h.material as usize]
}

/// Diffuse-like reflectance at a hit: f·π for light from above.
fn reflectance_at(scene: &Scene, h: &SurfaceHit) -> Vec4 {
    let geom = ShadingGeometry {
        ng: h.ng,
        ns: h.ns,
        wo: h.ng,
    };
    let b = material(scene, h).bsdf(&geom, h.uv, &mut wavelengths(), Vec4::ONE);
    b.f(h.ng, h.ng, TransportMode::Radiance) * std::f32::consts::PI
}

#[test]
fn required_extensions_that_prism_maps_load_and_others_are_refused_by_name() {
    let s = asset("requires_mapped.gltf");
    assert_eq!(s.scene.triangle_count(), 2);
    let Err(e) = load_asset("requires_meshopt.gltf") else {
        panic!("a file requiring EXT_meshopt_compression should be refused")
    };
    assert!(
        e.contains("requires extensions that prism does not support")
            && e.contains("EXT_meshopt_compression")
            && e.contains("KHR_materials_unlit")
            && !e.contains("KHR_materials_sheen"),
        "{e}"
    );
}

/// Rays from all around at the unit sphere: hit distance, shading normal
/// and texture coordinates of each of `others` against the float file's.
/// 16-bit positions (quantised, or Draco's 16 bits) are within 2 / 65535 of
/// the float ones; 8-bit normals within 1/127; 16-bit uvs within 1e-4.
#[test]
fn quantised_and_draco_compressed_spheres_match_their_float_twin() {
    let float = asset("sphere_float.gltf");
    for (file, t_tol, n_tol) in [
        ("sphere_quantized.gltf", 1e-4, 0.02),
        ("sphere_draco.gltf", 1e-4, 0.02),
    ] {
        let other = asset(file);
        assert_eq!(
            other.scene.triangle_count(),
            float.scene.triangle_count(),
            "{file}"
        );
        let mut compared = 0;
        for i in 0..200 {
            // A spiral of directions over the sphere, off the seams.
            let z = 1.0 - (i as f32 + 0.5) / 100.0;
            let phi = i as f32 * 2.399_963;
            let r = (1.0 - z * z).sqrt();
            let dir = Vec3::new(r * phi.cos(), z, r * phi.sin());
            let origin = dir * 3.0;
            let (a, b) = (
                hit(&float.scene, origin, Vec3::ZERO).expect("float sphere"),
                hit(&other.scene, origin, Vec3::ZERO)
                    .unwrap_or_else(|| panic!("{file}: ray {i} misses")),
            );
            assert!(
                (a.t - b.t).abs() < t_tol + 1e-4,
                "{file} ray {i}: t {} vs {}",
                a.t,
                b.t
            );
            assert!(
                a.ns.dot(b.ns) > 1.0 - n_tol,
                "{file} ray {i}: normal {} vs {}",
                a.ns,
                b.ns
            );
            // The u seam (u = 0 and 1 at phi = 0) aside.
            if (a.uv.x - b.uv.x).abs() < 0.5 {
                assert!(
                    (a.uv - b.uv).abs().max_element() < 1e-3,
                    "{file} ray {i}: uv {} vs {}",
                    a.uv,
                    b.uv
                );
                compared += 1;
            }
        }
        assert!(compared > 150);
    }
}

/// Clear glass as exporters write it: roughness 1 by default, 0 in the
/// metallic-roughness texture's green channel on the left texel, 1 on the
/// right: smooth on the left, frosted on the right.
#[test]
fn transmissive_gltf_takes_its_roughness_from_the_texture() {
    let s = asset("glass_roughness_texture.gltf");
    let mut wl = wavelengths();
    let specular = |x: f32, wl: &mut SampledWavelengths| {
        let h = hit(&s.scene, Vec3::new(x, 0.0, 3.0), Vec3::new(x, 0.0, 0.0)).unwrap();
        assert!(matches!(
            material(&s.scene, &h),
            Material::Dielectric { .. }
        ));
        let geom = ShadingGeometry {
            ng: h.ng,
            ns: h.ns,
            wo: h.ng,
        };
        material(&s.scene, &h)
            .bsdf(&geom, h.uv, wl, Vec4::splat(1.5))
            .is_specular()
    };
    assert!(specular(-0.5, &mut wl), "the left texel has roughness 0");
    assert!(!specular(0.5, &mut wl), "the right texel has roughness 1");
}

/// A material whose textures ask for TEXCOORD_1 reads that set; the normal
/// texture and an extension's texture keep their KHR_texture_transform.
#[test]
fn textures_read_the_coordinate_set_they_ask_for_with_their_transforms() {
    let s = asset("texture_sets.gltf");
    assert!(s.report.warnings.is_empty(), "{:?}", s.report.warnings);
    let h = hit(
        &s.scene,
        Vec3::new(-0.3, 0.2, 3.0),
        Vec3::new(-0.3, 0.2, 0.0),
    )
    .unwrap();
    assert_eq!(h.uv, Vec2::new(0.75, 0.5), "TEXCOORD_1 of every vertex");
    // Through TEXCOORD_1 the base colour is the image's right texel (green).
    let r = reflectance_at(&s.scene, &h);
    assert!(r.y > 2.0 * r.x && r.y > 2.0 * r.w, "green expected: {r}");
    let Material::Pbr(m) = material(&s.scene, &h) else {
        panic!("glTF BRDF expected")
    };
    let expected = [0.5, 0.0, 0.5, 0.0, 1.0, 0.0];
    assert_eq!(
        m.normal_map.as_ref().unwrap().texture.transform,
        Some(expected)
    );
    let sheen = m.layers.sheen.as_ref().unwrap();
    assert_eq!(
        sheen.colour.texture.as_ref().unwrap().transform,
        Some(expected)
    );
}

/// MTL illumination models as renderers read them: Maya's `illum 4` with
/// `Ni 1.00` is no glass (its colour and BMP or TGA texture stay), 3 and 5
/// are Fresnel mirrors (Kd where Ks is black), 6 and 7 glass, 10 noted.
#[test]
fn mtl_illumination_models_map_as_renderers_read_them() {
    let s = asset("illum.obj");
    let at = |k: usize| {
        let x = 3.0 * k as f32 + 0.5;
        hit(&s.scene, Vec3::new(x, 0.5, 3.0), Vec3::new(x, 0.5, 0.0)).unwrap()
    };
    let brick = reflectance_at(&s.scene, &at(0));
    // Wavelengths 450, 530, 600 and 650 nm.
    assert!(
        brick.w > 0.4 && brick.x < 0.1,
        "the BMP's brick red: {brick}"
    );
    let tile = reflectance_at(&s.scene, &at(1));
    assert!(
        tile.x > 0.2 && tile.x > 4.0 * tile.w,
        "the TGA's blue: {tile}"
    );
    for k in [0, 1] {
        assert!(matches!(
            material(&s.scene, &at(k)),
            Material::Diffuse { .. }
        ));
    }
    for k in [2, 3] {
        let Material::Pbr(m) = material(&s.scene, &at(k)) else {
            panic!("illum {}: a metal expected", [5, 3][k - 2])
        };
        assert_eq!(m.metallic, 1.0);
    }
    // illum 3 without Ks takes Kd as the mirror's colour, not black.
    let Material::Pbr(m) = material(&s.scene, &at(3)) else {
        unreachable!()
    };
    let c = m.base_color.factor.sample(&wavelengths());
    assert!(c.min_element() > 0.3, "{c}");
    for (k, n) in [(4, 1.6), (5, 1.5)] {
        let Material::Dielectric {
            ior: Ior::Constant(ior),
            ..
        } = material(&s.scene, &at(k))
        else {
            panic!("illum {}: glass expected", [7, 6][k - 4])
        };
        assert_eq!(*ior, n);
    }
    let notes = s.report.warnings.join("\n");
    for expected in [
        "illum 4 without an index Ni above 1 (not glass: shaded as illum 2) (material `maya_brick`)",
        "illum 6 with Ni ≤ 1 (glass of index 1.5) (material `glass_index_one`)",
        "illum 10 (shaded as illum 2) (material `shadow_matte`)",
    ] {
        assert!(notes.contains(expected), "missing {expected:?} in\n{notes}");
    }
}

/// `mtllib` with two files, the second with an escaped space and in a
/// folder of its own, whose texture is found relative to it.
#[test]
fn mtllib_names_several_files_and_escaped_spaces() {
    let s = asset("libraries.obj");
    assert!(s.report.warnings.is_empty(), "{:?}", s.report.warnings);
    let red = hit(&s.scene, Vec3::new(0.5, 0.5, 3.0), Vec3::new(0.5, 0.5, 0.0)).unwrap();
    let r = reflectance_at(&s.scene, &red);
    assert!(r.w > 0.5 && r.x < 0.2, "red from first.mtl: {r}");
    let green = hit(&s.scene, Vec3::new(3.5, 0.5, 3.0), Vec3::new(3.5, 0.5, 0.0)).unwrap();
    let g = reflectance_at(&s.scene, &green);
    assert!(
        g.y > 0.5 && g.w < 0.2,
        "green texture of `second lib.mtl`: {g}"
    );
}

/// Faces naming `vn` lines that do not exist: one warning with the line,
/// and smooth normals computed from the geometry.
#[test]
fn obj_normals_that_do_not_exist_are_computed_with_a_warning() {
    let s = asset("missing_normals.obj");
    let warnings: Vec<&String> = s
        .report
        .warnings
        .iter()
        .filter(|w| w.contains("normal index"))
        .collect();
    assert_eq!(warnings.len(), 1, "{:?}", s.report.warnings);
    assert!(
        warnings[0].contains(
            "missing_normals.obj: line 8: normal index 7 is out of range (the file has 2)"
        ),
        "{}",
        warnings[0]
    );
    // The pyramid's apex normal is the mean of its four faces': +z.
    let h = hit(
        &s.scene,
        Vec3::new(0.5, 0.52, 3.0),
        Vec3::new(0.5, 0.52, 0.0),
    )
    .unwrap();
    assert!(h.ns.z > 0.99, "smooth normal near the apex: {}", h.ns);
    assert!(
        h.ns.dot(h.ng) < 0.999,
        "interpolated, not flat: {} vs {}",
        h.ns,
        h.ng
    );
}

/// glTF's `doubleSided = false`: the camera does not see a single-sided
/// surface's back face (the top right quad shows the sky behind it); the
/// mirrored quad keeps its front face, and the double-sided one is seen
/// from behind. Path tracing, bdpt and light tracing (whose light paths
/// reach the camera by connections) agree; the light tracer sees no sky.
#[test]
fn single_sided_gltf_surfaces_are_not_seen_from_behind() {
    for integrator in ["path", "bdpt", "light"] {
        let text = format!(
            "[camera]\nposition = [0, -1.5, 9]\nlook_at = [0, -1.5, 0]\nfov = 40\n\
             [film]\nresolution = [32, 32]\nspp = 64\n\
             [integrator]\ntype = \"{integrator}\"\n\
             [environment]\nradiance = 1\n\
             [[shape]]\ntype = \"gltf\"\nfile = \"single_sided.gltf\"\n"
        );
        let s = load_str(&text, &assets()).unwrap();
        let film = crate::common::render_film(&s, 2);
        // Quad centres at pixels (9, 9), (23, 9), (9, 23) and (23, 23).
        let at = |x: u32, y: u32| crate::common::region_mean(&film, x - 1, y - 1, x + 2, y + 2);
        let sky = at(16, 30);
        let sky_expected = if integrator == "light" { 0.0 } else { 1.0 };
        assert!(
            (sky.0 - sky_expected).abs() < 0.02,
            "{integrator}: the sky reads {sky:?}"
        );
        let hidden = at(23, 9);
        assert!(
            (hidden.0 - sky.0).abs() < 0.02,
            "{integrator}: a single-sided quad seen from behind should show the sky: {hidden:?}"
        );
        for (x, y, what) in [
            (9, 9, "front"),
            (9, 23, "mirrored"),
            (23, 23, "double-sided"),
        ] {
            let seen = at(x, y);
            assert!(
                seen.0 < 0.5 && seen.0 > 0.03,
                "{integrator}: the {what} quad should be seen (albedo 0.2): {seen:?}"
            );
        }
    }
}
