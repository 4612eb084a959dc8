//! glTF 2.0 and OBJ/MTL import: every file form, the node hierarchy,
//! attributes, materials, textures, cameras, instancing and overrides, and
//! bad input. Every asset is written here by the test helpers.

use crate::common;

use std::path::Path;
use std::sync::Arc;

use common::assets::{self, GltfBuilder};
use glam::{Vec2, Vec3, Vec4};
use prism::geometry::Ray;
use prism::light::LightSource;
use prism::load::{load, Loaded};
use prism::material::{Ior, Material, ShadingGeometry};
use prism::scene::Scene;
use prism::spectrum::SampledWavelengths;

/// Writes NAME.obj and NAME.mtl into `dir`.
fn write_obj_mtl(dir: &Path, name: &str, obj: &str, mtl: &str) {
    std::fs::write(dir.join(format!("{name}.obj")), obj).unwrap();
    std::fs::write(dir.join(format!("{name}.mtl")), mtl).unwrap();
}

const CAMERA: &str = "[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\nfov = 40\n";

fn scene_in(dir: &Path, text: &str) -> Result<Loaded, String> {
    let path = dir.join("scene.toml");
    std::fs::write(&path, text).unwrap();
    load(&path).map_err(|e| e.to_string())
}

fn scene_error(dir: &Path, text: &str) -> String {
    match scene_in(dir, text) {
        Ok(_) => panic!("the scene should not load"),
        Err(e) => e,
    }
}

fn shape(kind: &str, file: &str, extra: &str) -> String {
    format!("[[shape]]\ntype = \"{kind}\"\nfile = \"{file}\"\n{extra}\n")
}

/// Sorted triangle corners, to compare geometry regardless of order.
fn triangles(scene: &Scene) -> Vec<[[i64; 3]; 3]> {
    let mut t: Vec<[[i64; 3]; 3]> = (0..scene.triangle_count() as u32)
        .map(|i| {
            let mut c = scene
                .triangle(i)
                .map(|p| (p * 1e4).round().as_i64vec3().to_array());
            c.sort();
            c
        })
        .collect();
    t.sort();
    t
}

fn hit(scene: &Scene, origin: Vec3, dir: Vec3) -> prism::scene::SurfaceHit {
    scene
        .intersect(&Ray::new(origin, dir.normalize()))
        .expect("the ray should hit")
}

fn wavelengths() -> SampledWavelengths {
    let mut wl = SampledWavelengths::sample_visible(0.5);
    wl.lambda = Vec4::new(450.0, 530.0, 600.0, 650.0);
    wl
}

/// Reflectance seen at a hit: f·π of a diffuse BSDF for light from above.
fn reflectance_at(scene: &Scene, h: &prism::scene::SurfaceHit) -> Vec4 {
    let geom = ShadingGeometry {
        ng: h.ng,
        ns: h.ns,
        wo: h.ng,
    };
    let b = scene.materials[h.material as usize].bsdf(&geom, h.uv, &mut wavelengths(), Vec4::ONE);
    b.f(h.ng, h.ng, prism::material::TransportMode::Radiance) * std::f32::consts::PI
}

/// A glTF document: one quad mesh under a translated parent node whose
/// child has a matrix (scale 2), so world = T(0, 0, -1) · S(2).
fn hierarchy_json(b: &mut GltfBuilder, normals: bool) -> String {
    let prim = assets::quad(b, normals);
    b.json(&format!(
        r#""scene":0,"scenes":[{{"nodes":[0]}}],
        "nodes":[{{"translation":[0,0,-1],"children":[1]}},
                 {{"matrix":[2,0,0,0, 0,2,0,0, 0,0,2,0, 0,0,0,1],"mesh":0}}],
        "meshes":[{{"name":"panel","primitives":[{prim}}}]}}]"#
    ))
}

#[test]
fn gltf_external_embedded_and_glb_give_the_same_geometry() {
    let dir = tempfile::tempdir().unwrap();
    let mut b = GltfBuilder::default();
    let json = hierarchy_json(&mut b, true);
    let files = [
        assets::write_gltf_external(dir.path(), "quad", &json, &b.bin),
        assets::write_gltf_embedded(dir.path(), "quad", &json, &b.bin),
        assets::write_glb(dir.path(), "quad", &json, &b.bin),
    ];
    let scenes: Vec<Loaded> = files
        .iter()
        .map(|f| scene_in(dir.path(), &format!("{CAMERA}{}", shape("gltf", f, ""))).unwrap())
        .collect();
    let reference = triangles(&scenes[0].scene);
    assert_eq!(reference.len(), 2);
    for s in &scenes[1..] {
        assert_eq!(triangles(&s.scene), reference);
    }
    // TRS parent · matrix child: corners at (±2, ±2, -1).
    let loaded = &scenes[0];
    let s = &loaded.scene;
    let h = hit(s, Vec3::new(1.9, 1.9, 5.0), -Vec3::Z);
    assert!((h.p.z + 1.0).abs() < 1e-5, "{}", h.p);
    assert!(s
        .intersect(&Ray::new(Vec3::new(2.1, 0.0, 5.0), -Vec3::Z))
        .is_none());
    // Texture coordinates: v = 0 at the top (+y), u = 0 at the left.
    let h = hit(s, Vec3::new(-1.0, 1.0, 5.0), -Vec3::Z);
    assert!((h.uv - Vec2::new(0.25, 0.25)).length() < 1e-5, "{}", h.uv);
    // Geometry only: the one warning is that nothing emits.
    assert!(
        loaded
            .report
            .warnings
            .iter()
            .all(|w| w.contains("no light")),
        "{:?}",
        loaded.report.warnings
    );
    // A rotation quaternion of length 3 (exporters round; broken files
    // scale) rotates like the unit one instead of scaling by 9.
    let turned = json.replace(
        r#""translation":[0,0,-1]"#,
        r#""translation":[0,0,-1],"rotation":[0,0,2.1213203,2.1213203]"#,
    );
    let f = assets::write_glb(dir.path(), "turned", &turned, &b.bin);
    let s = scene_in(dir.path(), &format!("{CAMERA}{}", shape("gltf", &f, ""))).unwrap();
    let reach = |x: f32| {
        s.scene
            .intersect(&Ray::new(Vec3::new(x, 0.0, 5.0), -Vec3::Z))
            .is_some()
    };
    // Turned 90° about z the quad still spans ±2.
    assert!(reach(1.9) && !reach(2.1));
    // Coordinates beyond single precision's comfortable range are refused.
    let far = json.replace(r#""translation":[0,0,-1]"#, r#""translation":[0,0,1e13]"#);
    let f = assets::write_glb(dir.path(), "far", &far, &b.bin);
    let e = scene_error(dir.path(), &format!("{CAMERA}{}", shape("gltf", &f, "")));
    assert!(e.contains("far.glb") && e.contains("beyond"), "{e}");
}

#[test]
fn gltf_non_indexed_primitives_and_missing_normals() {
    let dir = tempfile::tempdir().unwrap();
    let mut b = GltfBuilder::default();
    // The quad's two triangles written out vertex by vertex, no normals.
    let corners = [
        [-1.0, -1.0, 0.0],
        [1.0, -1.0, 0.0],
        [1.0, 1.0, 0.0],
        [-1.0, -1.0, 0.0],
        [1.0, 1.0, 0.0],
        [-1.0, 1.0, 0.0f32],
    ];
    let p = b.floats(corners.as_flattened(), "VEC3");
    let json = b.json(&format!(
        r#""scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":{p}}}}}]}}]"#
    ));
    let f = assets::write_glb(dir.path(), "flat", &json, &b.bin);
    let s = scene_in(dir.path(), &format!("{CAMERA}{}", shape("gltf", &f, ""))).unwrap();
    assert_eq!(s.scene.triangle_count(), 2);
    // No normals: flat shading (glTF requires flat normals then).
    let h = hit(&s.scene, Vec3::new(0.3, -0.2, 5.0), -Vec3::Z);
    assert_eq!(h.ns, h.ng);
    assert_eq!(h.ng, Vec3::Z);
}

#[test]
fn gltf_sparse_accessor_replaces_elements() {
    let dir = tempfile::tempdir().unwrap();
    let mut b = GltfBuilder::default();
    let prim = assets::quad(&mut b, true);
    // Vertex 2 (the +x +y corner, uv (1, 0)) gets uv (0.5, 0.25).
    let uv = b.sparse_vec2(1, 4, &[2], &[0.5, 0.25]);
    let prim = prim.replace(r#""TEXCOORD_0":1"#, &format!(r#""TEXCOORD_0":{uv}"#));
    let json = b.json(&format!(
        r#""scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0}}],"meshes":[{{"primitives":[{prim}}}]}}]"#
    ));
    let f = assets::write_glb(dir.path(), "sparse", &json, &b.bin);
    let s = scene_in(dir.path(), &format!("{CAMERA}{}", shape("gltf", &f, ""))).unwrap();
    // Geometry only: the one warning is that nothing emits.
    assert!(
        s.report.warnings.iter().all(|w| w.contains("no light")),
        "{:?}",
        s.report.warnings
    );
    let near = |p: Vec3| hit(&s.scene, p + Vec3::Z * 5.0, -Vec3::Z).uv;
    assert!((near(Vec3::new(0.999, 0.999, 0.0)) - Vec2::new(0.5, 0.25)).length() < 0.01);
    // Untouched corners keep the base values.
    assert!((near(Vec3::new(-0.999, -0.999, 0.0)) - Vec2::new(0.0, 1.0)).length() < 0.01);
}

#[test]
fn gltf_materials_map_to_spectral_materials() {
    let dir = tempfile::tempdir().unwrap();
    let mut b = GltfBuilder::default();
    let prims: Vec<String> = (0..4)
        .map(|m| format!("{}, \"material\":{m}}}", assets::quad(&mut b, true)))
        .collect();
    let json = b.json(&format!(
        r#""extensionsUsed":["KHR_materials_transmission","KHR_materials_ior","KHR_materials_dispersion","KHR_materials_emissive_strength","KHR_materials_clearcoat","KHR_materials_iridescence","KHR_materials_specular","KHR_materials_anisotropy"],
        "scenes":[{{"nodes":[0,1,2,3]}}],
        "nodes":[{{"mesh":0}},{{"mesh":1,"translation":[3,0,0]}},{{"mesh":2,"translation":[6,0,0]}},{{"mesh":3,"translation":[9,0,0]}}],
        "meshes":[{{"name":"a","primitives":[{}]}},{{"name":"b","primitives":[{}]}},{{"name":"c","primitives":[{}]}},{{"name":"d","primitives":[{}]}}],
        "materials":[
          {{"name":"gold","pbrMetallicRoughness":{{"baseColorFactor":[1,0.8,0.3,1],"metallicFactor":1,"roughnessFactor":0.25}},
            "extensions":{{"KHR_materials_clearcoat":{{"clearcoatFactor":0.8,"clearcoatRoughnessFactor":0.1,"clearcoatTexture":{{"index":0}}}},
              "KHR_materials_iridescence":{{"iridescenceFactor":1,"iridescenceIor":1.4,"iridescenceThicknessMaximum":420}},
              "KHR_materials_specular":{{"specularFactor":0.5,"specularColorFactor":[1,0.5,0.25]}},
              "KHR_materials_sheen":{{"sheenColorFactor":[0.5,0.5,0.5],"sheenRoughnessFactor":0.3}}}}}},
          {{"name":"glass","pbrMetallicRoughness":{{"metallicFactor":0,"roughnessFactor":0}},
            "extensions":{{"KHR_materials_transmission":{{"transmissionFactor":1}},"KHR_materials_ior":{{"ior":1.6}},"KHR_materials_dispersion":{{"dispersion":0.5}}}}}},
          {{"name":"lamp","emissiveFactor":[1,0.5,0.25],"doubleSided":true,
            "extensions":{{"KHR_materials_emissive_strength":{{"emissiveStrength":4}},"KHR_materials_anisotropy":{{"anisotropyStrength":1}}}}}},
          {{"name":"plastic","pbrMetallicRoughness":{{"baseColorFactor":[0.2,0.4,0.8,1],"metallicFactor":0,"roughnessFactor":0.5}},"alphaMode":"BLEND"}}
        ]"#,
        prims[0], prims[1], prims[2], prims[3]
    ));
    let f = assets::write_glb(dir.path(), "materials", &json, &b.bin);
    let s = scene_in(dir.path(), &format!("{CAMERA}{}", shape("gltf", &f, ""))).unwrap();
    let at = |x: f32| {
        let h = hit(&s.scene, Vec3::new(x, 0.1, 5.0), -Vec3::Z);
        (h, &s.scene.materials[h.material as usize])
    };
    match at(0.0).1 {
        Material::Pbr(m) => {
            assert_eq!((m.metallic, m.roughness, m.ior), (1.0, 0.25, 1.5));
            let l = &m.layers;
            let c = l.clearcoat.as_ref().expect("clear coat mapped");
            assert_eq!((c.weight, c.roughness), (0.8, 0.1));
            // The file has no texture 0: said, and the factor alone used.
            assert!(c.texture.is_none());
            assert!(
                s.report
                    .warnings
                    .iter()
                    .any(|w| w.contains("clearcoatTexture names texture 0")),
                "{:?}",
                s.report.warnings
            );
            let i = l.iridescence.as_ref().expect("iridescence mapped");
            assert_eq!((i.weight, i.ior, i.thickness), (1.0, 1.4, [100.0, 420.0]));
            let s = l.specular.as_ref().expect("specular mapped");
            assert_eq!(s.weight, 0.5);
            assert!(
                s.colour.factor.eval(450.0) < s.colour.factor.eval(650.0),
                "reddish specular colour"
            );
            let sh = l.sheen.as_ref().expect("sheen mapped");
            assert_eq!(sh.roughness, 0.3);
        }
        other => panic!("gold: {other:?}"),
    }
    match at(3.0).1 {
        Material::Dielectric { ior, alpha, .. } => {
            assert_eq!(*alpha, 0.0);
            // KHR_materials_dispersion: Abbe number 20 / dispersion = 40.
            assert!((ior.eval(587.56) - 1.6).abs() < 1e-3, "{ior:?}");
            assert!(
                (ior.abbe_number() - 40.0).abs() < 0.5,
                "{}",
                ior.abbe_number()
            );
            assert!(
                matches!(
                    ior,
                    Ior::Cauchy { .. } | Ior::Sellmeier { .. } | Ior::Table(_)
                ) || ior.is_dispersive()
            );
        }
        other => panic!("glass: {other:?}"),
    }
    // Emission: factor × strength, double-sided; luminance of rgb (1, .5, .25)
    // relative to D65 white, times 4.
    let (h, _) = at(6.0);
    let light = h.light.expect("the lamp is a light");
    let wl = wavelengths();
    let light = s.scene.lights.get(light);
    let front = light.l(h.uv, h.ng, &wl);
    let back = light.l(h.uv, -h.ng, &wl);
    assert_eq!(front, back);
    assert!(front.x < front.w, "reddish: {front}");
    let prism::light::Light::Area(area) = light else {
        panic!("the lamp is an area light");
    };
    let y = prism::spectrum::cie::spectrum_to_xyz(&area.emitter().spectrum).y;
    let expected = 4.0 * (0.2126 + 0.7152 * 0.5 + 0.0722 * 0.25);
    assert!(
        (y - expected).abs() < 0.03 * expected,
        "Y {y} vs {expected}"
    );
    match at(9.0).1 {
        Material::Pbr(m) => assert_eq!((m.metallic, m.roughness), (0.0, 0.5)),
        other => panic!("plastic: {other:?}"),
    }
    // What is not mapped is reported once, in one warning.
    let ignored: Vec<&String> = s
        .report
        .warnings
        .iter()
        .filter(|w| w.contains("ignored"))
        .collect();
    assert_eq!(ignored.len(), 1, "{:?}", s.report.warnings);
    assert!(
        ignored[0].contains("KHR_materials_anisotropy") && !ignored[0].contains("clearcoatTexture"),
        "{}",
        ignored[0]
    );
    assert!(
        !ignored[0].contains("KHR_materials_clearcoat,"),
        "{}",
        ignored[0]
    );
    // BLEND is mapped (a cut-out), so not in the list.
    assert!(!ignored[0].contains("alphaMode"), "{}", ignored[0]);
    assert!(!ignored[0].contains("KHR_materials_ior"), "{}", ignored[0]);
}

/// A 2×2 texture: red, green / blue, white (sRGB bytes).
const CHECKER: [u8; 16] = [
    255, 0, 0, 255, 0, 255, 0, 255, //
    0, 0, 255, 255, 255, 255, 255, 255,
];

#[test]
fn gltf_textures_embedded_with_sampler_and_transform() {
    let dir = tempfile::tempdir().unwrap();
    let mut b = GltfBuilder::default();
    let prim = assets::quad(&mut b, true);
    let view = b.image_view(&assets::png(2, 2, &CHECKER));
    let json = b.json(&format!(
        r#""extensionsUsed":["KHR_texture_transform"],
        "scenes":[{{"nodes":[0,1]}}],"nodes":[{{"mesh":0}},{{"mesh":1,"translation":[3,0,0]}}],
        "meshes":[{{"primitives":[{prim},"material":0}}]}},{{"primitives":[{prim},"material":1}}]}}],
        "samplers":[{{"magFilter":9728,"wrapS":33071,"wrapT":33071}}],
        "images":[{{"bufferView":{view},"mimeType":"image/png"}}],
        "textures":[{{"source":0,"sampler":0}}],
        "materials":[
          {{"pbrMetallicRoughness":{{"baseColorTexture":{{"index":0}},"metallicFactor":0}}}},
          {{"pbrMetallicRoughness":{{"baseColorTexture":{{"index":0,
              "extensions":{{"KHR_texture_transform":{{"offset":[0.5,0],"scale":[0.5,1]}}}}}},"metallicFactor":0}}}}
        ]"#
    ));
    let f = assets::write_glb(dir.path(), "textured", &json, &b.bin);
    let s = scene_in(dir.path(), &format!("{CAMERA}{}", shape("gltf", &f, ""))).unwrap();
    // Quadrants of the first quad: top-left red, top-right green,
    // bottom-left blue, bottom-right white (nearest filtering).
    let colour = |x: f32, y: f32| {
        let h = hit(&s.scene, Vec3::new(x, y, 5.0), -Vec3::Z);
        let Material::Pbr(m) = &s.scene.materials[h.material as usize] else {
            panic!("not pbr")
        };
        m.base_color.sample(h.uv, &wavelengths())
    };
    let red = colour(-0.5, 0.5);
    assert!(red.w > 0.8 && red.x < 0.1, "red {red}");
    let green = colour(0.5, 0.5);
    assert!(
        green.y > 0.6 && green.x < 0.2 && green.w < 0.2,
        "green {green}"
    );
    let blue = colour(-0.5, -0.5);
    assert!(blue.x > 0.6 && blue.w < 0.1, "blue {blue}");
    let white = colour(0.5, -0.5);
    assert!(white.min_element() > 0.95, "white {white}");
    // The transform maps u to 0.5 + u/2: the whole second quad's top row is green.
    let c = colour(3.0 - 0.9, 0.5);
    assert!(c.y > 0.6 && c.w < 0.2, "transformed {c}");
    // One image, decoded once, shared by both materials.
    let tex = |i: usize| match &s.scene.materials[i] {
        Material::Pbr(m) => m.base_color.texture.as_ref().unwrap().texture.clone(),
        _ => panic!(),
    };
    let (a, b) = (
        hit(&s.scene, Vec3::new(0.0, 0.0, 5.0), -Vec3::Z),
        hit(&s.scene, Vec3::new(3.0, 0.0, 5.0), -Vec3::Z),
    );
    assert!(Arc::ptr_eq(
        &tex(a.material as usize),
        &tex(b.material as usize)
    ));
}

#[test]
fn gltf_external_textures_with_srgb_and_missing_file_warning() {
    let dir = tempfile::tempdir().unwrap();
    // 50% sRGB grey: linear 0.214.
    std::fs::write(
        dir.path().join("grey.png"),
        assets::png(1, 1, &[128, 128, 128, 255]),
    )
    .unwrap();
    let mut b = GltfBuilder::default();
    let prim = assets::quad(&mut b, true);
    let json = b.json(&format!(
        r#""scenes":[{{"nodes":[0,1]}}],"nodes":[{{"mesh":0}},{{"mesh":1,"translation":[3,0,0]}}],
        "meshes":[{{"primitives":[{prim},"material":0}}]}},{{"primitives":[{prim},"material":1}}]}}],
        "images":[{{"uri":"grey.png"}},{{"uri":"missing.png"}}],
        "textures":[{{"source":0}},{{"source":1}}],
        "materials":[
          {{"pbrMetallicRoughness":{{"baseColorTexture":{{"index":0}},"metallicFactor":0}}}},
          {{"pbrMetallicRoughness":{{"baseColorFactor":[0.5,0.5,0.5,1],"baseColorTexture":{{"index":1}},"metallicFactor":0}}}}
        ]"#
    ));
    let f = assets::write_gltf_external(dir.path(), "grey", &json, &b.bin);
    let s = scene_in(dir.path(), &format!("{CAMERA}{}", shape("gltf", &f, ""))).unwrap();
    let h = hit(&s.scene, Vec3::new(0.2, 0.3, 5.0), -Vec3::Z);
    let Material::Pbr(m) = &s.scene.materials[h.material as usize] else {
        panic!()
    };
    let v = m.base_color.sample(h.uv, &wavelengths());
    for c in v.to_array() {
        assert!((c - 0.2158).abs() < 0.01, "sRGB 128 decodes to 0.216: {v}");
    }
    // The missing image: a warning naming it; the factor alone is used.
    assert!(
        s.report.warnings.iter().any(|w| w.contains("missing.png")),
        "{:?}",
        s.report.warnings
    );
    let h = hit(&s.scene, Vec3::new(3.0, 0.0, 5.0), -Vec3::Z);
    let Material::Pbr(m) = &s.scene.materials[h.material as usize] else {
        panic!()
    };
    assert!(m.base_color.texture.is_none());
    let v = m.base_color.sample(h.uv, &wavelengths());
    assert!((v.x - 0.5).abs() < 0.02, "{v}");
}

#[test]
fn gltf_emission_texture_is_seen_in_a_render() {
    let dir = tempfile::tempdir().unwrap();
    // Left half white, right half black.
    let texels = [255, 255, 255, 255, 0, 0, 0, 255];
    let mut b = GltfBuilder::default();
    let prim = assets::quad(&mut b, true);
    let view = b.image_view(&assets::png(2, 1, &texels));
    let json = b.json(&format!(
        r#""scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0,"scale":[3,3,1]}}],
        "meshes":[{{"primitives":[{prim},"material":0}}]}}],
        "samplers":[{{"magFilter":9728}}],
        "images":[{{"bufferView":{view},"mimeType":"image/png"}}],
        "textures":[{{"source":0,"sampler":0}}],
        "materials":[{{"emissiveFactor":[1,1,1],"emissiveTexture":{{"index":0}},
          "pbrMetallicRoughness":{{"baseColorFactor":[0,0,0,1],"metallicFactor":0}}}}]"#
    ));
    let f = assets::write_glb(dir.path(), "sign", &json, &b.bin);
    let s = scene_in(
        dir.path(),
        &format!(
            "{CAMERA}[film]\nresolution = [16, 8]\nspp = 16\nmax_depth = 0\nspectral = false\n{}",
            shape("gltf", &f, "")
        ),
    )
    .unwrap();
    let film = common::render_film(&s, 2);
    // rgb (1, 1, 1) emission has luminance 1; the white texel reflects ~1.
    // The quad fills the view but for 1.4 pixels at each side.
    let (left, _) = common::region_mean(&film, 2, 1, 7, 7);
    let (right, _) = common::region_mean(&film, 9, 1, 14, 7);
    assert!((left - 1.0).abs() < 0.02, "left {left}");
    assert!(right < 0.01, "right {right}");
}

#[test]
fn gltf_camera_is_used_when_the_scene_asks() {
    let dir = tempfile::tempdir().unwrap();
    let mut b = GltfBuilder::default();
    let prim = assets::quad(&mut b, true);
    // A camera at (0, 0, 10) turned 90° about y: it looks along -x.
    let (s, c) = (
        std::f32::consts::FRAC_1_SQRT_2,
        std::f32::consts::FRAC_1_SQRT_2,
    );
    let json = b.json(&format!(
        r#""scenes":[{{"nodes":[0,1]}}],
        "nodes":[{{"mesh":0}},{{"name":"cam node","camera":0,"translation":[0,0,10],"rotation":[0,{s},0,{c}]}}],
        "cameras":[{{"name":"overview","type":"perspective","perspective":{{"yfov":0.5,"znear":0.1}}}}],
        "meshes":[{{"primitives":[{prim}}}]}}]"#
    ));
    let f = assets::write_glb(dir.path(), "cam", &json, &b.bin);
    let text = format!(
        "[camera]\nfrom_file = \"{f}\"\nname = \"overview\"\n[film]\nresolution = [20, 10]\n{}",
        shape("gltf", &f, "")
    );
    let scene = scene_in(dir.path(), &text).unwrap();
    let ray = scene.scene.camera.generate_ray(10.0, 5.0);
    assert!((ray.origin - Vec3::new(0.0, 0.0, 10.0)).length() < 1e-5);
    assert!((ray.dir - -Vec3::X).length() < 1e-4, "{}", ray.dir);
    // Vertical field of view 0.5 rad: the top edge ray is 0.25 rad up.
    let top = scene.scene.camera.generate_ray(10.0, 0.0);
    assert!((top.dir.y.asin() - 0.25).abs() < 1e-3, "{}", top.dir);
    // An unknown camera name is an error listing the cameras there are.
    let e = scene_error(dir.path(), &text.replace("overview", "closeup"));
    assert!(e.contains("closeup") && e.contains("overview"), "{e}");
}

#[test]
fn instances_overrides_and_mesh_selection() {
    let dir = tempfile::tempdir().unwrap();
    let mut b = GltfBuilder::default();
    let prim = assets::quad(&mut b, true);
    let json = b.json(&format!(
        r#""scenes":[{{"nodes":[0,1]}}],"nodes":[{{"mesh":0}},{{"mesh":1,"translation":[0,0,-3]}}],
        "meshes":[{{"name":"front","primitives":[{prim},"material":0}}]}},{{"name":"back","primitives":[{prim},"material":0}}]}}],
        "materials":[{{"name":"paint","pbrMetallicRoughness":{{"metallicFactor":0}}}}]"#
    ));
    let f = assets::write_glb(dir.path(), "two", &json, &b.bin);
    let text = format!(
        "{CAMERA}[materials.red]\ntype = \"diffuse\"\nreflectance = {{ rgb = [0.8, 0.1, 0.1] }}\n{}{}{}",
        shape("gltf", &f, "materials = { paint = \"red\" }"),
        shape("gltf", &f, "mesh = \"back\"\ntransform = { translate = [5, 0, 0] }"),
        shape("gltf", &f, "mesh = \"front\"\ntransform = { translate = [-5, 0, 0] }"),
    );
    let s = scene_in(dir.path(), &text).unwrap();
    // 2 meshes + 1 + 1 instances, 2 triangles each.
    assert_eq!(s.scene.triangle_count(), 8);
    let h = hit(&s.scene, Vec3::new(0.0, 0.0, 5.0), -Vec3::Z);
    assert!(matches!(
        s.scene.materials[h.material as usize],
        Material::Diffuse { .. }
    ));
    let h = hit(&s.scene, Vec3::new(5.0, 0.0, 5.0), -Vec3::Z);
    assert!((h.p.z + 3.0).abs() < 1e-5, "the back mesh only: {}", h.p);
    assert!(matches!(
        s.scene.materials[h.material as usize],
        Material::Pbr(_)
    ));
    let h = hit(&s.scene, Vec3::new(-5.0, 0.0, 5.0), -Vec3::Z);
    assert!(h.p.z.abs() < 1e-5);
    // The file's material is added once however many instances use it.
    let pbr = s
        .scene
        .materials
        .iter()
        .filter(|m| matches!(m, Material::Pbr(_)))
        .count();
    assert_eq!(pbr, 1);
    // Names that do not exist are errors that list what does.
    let e = scene_error(
        dir.path(),
        &format!("{CAMERA}{}", shape("gltf", &f, "mesh = \"side\"")),
    );
    assert!(
        e.contains("side") && e.contains("front") && e.contains("back"),
        "{e}"
    );
    let e = scene_error(
        dir.path(),
        &format!(
            "{CAMERA}[materials.red]\ntype = \"diffuse\"\n{}",
            shape("gltf", &f, "materials = { wood = \"red\" }")
        ),
    );
    assert!(e.contains("wood") && e.contains("paint"), "{e}");
}

#[test]
fn normal_maps_bend_the_shading_normal_in_tangent_space() {
    let dir = tempfile::tempdir().unwrap();
    // A normal tilted 30° towards +u (tangent space x).
    let (sin, cos) = 30f32.to_radians().sin_cos();
    let enc = |v: f32| ((v * 0.5 + 0.5) * 255.0).round() as u8;
    let texel = [enc(sin), enc(0.0), enc(cos), 255];
    let mut b = GltfBuilder::default();
    let prim = assets::quad(&mut b, true);
    let view = b.image_view(&assets::png(1, 1, &texel));
    let json = b.json(&format!(
        r#""scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0}}],
        "meshes":[{{"primitives":[{prim},"material":0}}]}}],
        "images":[{{"bufferView":{view},"mimeType":"image/png"}}],"textures":[{{"source":0}}],
        "materials":[{{"normalTexture":{{"index":0}},"pbrMetallicRoughness":{{"metallicFactor":0}}}}]"#
    ));
    let f = assets::write_glb(dir.path(), "bumpy", &json, &b.bin);
    // Also mirrored: the map must still tilt towards +u, which now runs along -x.
    for (transform, u_dir) in [
        ("", Vec3::X),
        ("transform = { scale = [-1, 1, 1] }", -Vec3::X),
    ] {
        let s = scene_in(
            dir.path(),
            &format!("{CAMERA}{}", shape("gltf", &f, transform)),
        )
        .unwrap();
        let h = hit(&s.scene, Vec3::new(0.3, 0.2, 5.0), -Vec3::Z);
        assert!(
            h.tangent.truncate().dot(u_dir) > 0.99,
            "generated tangent {}",
            h.tangent
        );
        let n = s.scene.materials[h.material as usize].shading_normal(h.ns, h.tangent, h.uv);
        let expected = (u_dir * sin + Vec3::Z * cos).normalize();
        assert!(
            (n - expected).length() < 0.02,
            "{n} vs {expected} ({transform})"
        );
    }
}

#[test]
fn broken_gltf_files_are_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let mut b = GltfBuilder::default();
    let json = hierarchy_json(&mut b, true);
    let check = |file: &str, expect: &[&str]| {
        let e = scene_error(dir.path(), &format!("{CAMERA}{}", shape("gltf", file, "")));
        assert!(e.contains(file), "names the file: {e}");
        for x in expect {
            assert!(e.contains(x), "{x}: {e}");
        }
    };
    // Missing external buffer.
    let f = assets::write_gltf_external(dir.path(), "lost", &json, &b.bin);
    std::fs::remove_file(dir.path().join("lost.bin")).unwrap();
    check(&f, &["lost.bin"]);
    // Truncated GLB, at several lengths, and an empty one.
    let glb = assets::glb_bytes(&json, &b.bin);
    for cut in [0, 7, 20, glb.len() / 2, glb.len() - 9] {
        std::fs::write(dir.path().join("cut.glb"), &glb[..cut]).unwrap();
        check("cut.glb", &[]);
    }
    // An index past the vertices.
    let mut bad = GltfBuilder::default();
    let p = bad.floats(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0], "VEC3");
    let i = bad.indices(&[0, 1, 7]);
    let j = bad.json(&format!(
        r#""scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0}}],"meshes":[{{"name":"m","primitives":[{{"attributes":{{"POSITION":{p}}},"indices":{i}}}]}}]"#
    ));
    let f = assets::write_glb(dir.path(), "index", &j, &bad.bin);
    check(&f, &["index 7", "out of range"]);
    // NaN in a vertex.
    let mut nan = GltfBuilder::default();
    let p = nan.floats(&[0.0, 0.0, 0.0, f32::NAN, 0.0, 0.0, 0.0, 1.0, 0.0], "VEC3");
    let j = nan.json(&format!(
        r#""scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0}}],"meshes":[{{"primitives":[{{"attributes":{{"POSITION":{p}}}}}]}}]"#
    ));
    let f = assets::write_glb(dir.path(), "nan", &j, &nan.bin);
    check(&f, &["not finite"]);
    // An accessor reaching past its buffer (the buffer declares fewer bytes).
    let short = j.replace("\"count\":3", "\"count\":30");
    let f = assets::write_glb(dir.path(), "short", &short, &nan.bin);
    check(&f, &[]);
    // Not JSON at all, and a node cycle.
    std::fs::write(dir.path().join("junk.gltf"), "{ nope").unwrap();
    check("junk.gltf", &["glTF"]);
    let cyc = json.replace(r#""mesh":0}"#, r#""mesh":0,"children":[0]}"#);
    let f = assets::write_glb(dir.path(), "cycle", &cyc, &b.bin);
    check(&f, &[]);
    // Breaches the gltf crate does not validate but would panic on: an
    // image in a buffer view without its MIME type, an image without any
    // source, a camera whose type names a projection it lacks.
    let mut img = GltfBuilder::default();
    let prim = assets::quad(&mut img, true);
    let view = img.image_view(&assets::png(1, 1, &[200, 100, 50, 255]));
    let with_image = |image: &str, camera: &str| {
        img.json(&format!(
            r#""scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0}}],"cameras":[{camera}],
            "meshes":[{{"primitives":[{prim},"material":0}}]}}],
            "images":[{image}],"textures":[{{"source":0}}],
            "materials":[{{"pbrMetallicRoughness":{{"baseColorTexture":{{"index":0}}}}}}]"#
        ))
    };
    let perspective = r#"{"type":"perspective","perspective":{"yfov":0.7,"znear":0.1}}"#;
    let cases = [
        (
            "nomime",
            with_image(&format!(r#"{{"bufferView":{view}}}"#), perspective),
            "mimeType",
        ),
        ("nosource", with_image("{}", perspective), "neither"),
        (
            "camtype",
            with_image(
                &format!(r#"{{"bufferView":{view},"mimeType":"image/png"}}"#),
                r#"{"type":"perspective","orthographic":{"xmag":1,"ymag":1,"znear":0.1,"zfar":9}}"#,
            ),
            "cameras[0]",
        ),
    ];
    // The crate's own validation would index a missing POSITION accessor.
    let far = json.replacen(r#""POSITION":0"#, r#""POSITION":99"#, 1);
    assert_ne!(far, json);
    let f = assets::write_glb(dir.path(), "posindex", &far, &b.bin);
    check(&f, &["POSITION", "99"]);
    for (name, json, expect) in cases {
        let f = assets::write_glb(dir.path(), name, &json, &img.bin);
        check(&f, &[expect]);
    }
}

const OBJ: &str = "\
mtllib scene.mtl
o floor
v -1 0 -1
v 1 0 -1
v 1 0 1
v -1 0 1
vt 0 0
vt 1 0
vt 1 1
vt 0 1
usemtl checker
f -4/-4 -1/-1 -2/-2 -3/-3
g lamp
v -0.5 1 -0.5
v 0.5 1 -0.5
v 0.7 1 0
v 0.5 1 0.5
v -0.5 1 0.5
usemtl glow
f 5 6 7 8 9
g ball
usemtl glass
f 1 2 5
usemtl mirror
f 2 3 6
usemtl nosuch
f 3 4 7
usemtl veil
f 4 1 8
";

const MTL: &str = "\
newmtl checker
Kd 1 1 1
map_Kd checker.png
newmtl glow
Kd 0 0 0
Ke 2 2 2
newmtl glass
Kd 0.5 0.5 0.5
Ni 1.33
Ns 1000
d 0.5
newmtl mirror
illum 3
Ks 0.9 0.9 0.9
Ns 100000
newmtl veil
Kd 0.5 0.5 0.5
d 0.3
";

#[test]
fn obj_with_mtl_polygons_groups_and_textures() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("scene.obj"), OBJ).unwrap();
    std::fs::write(dir.path().join("scene.mtl"), MTL).unwrap();
    std::fs::write(dir.path().join("checker.png"), assets::png(2, 2, &CHECKER)).unwrap();
    let s = scene_in(
        dir.path(),
        &format!("{CAMERA}{}", shape("obj", "scene.obj", "")),
    )
    .unwrap();
    // Quad (2) + pentagon (3) + four triangles.
    assert_eq!(s.scene.triangle_count(), 9);
    // The floor's texture, through negative indices and OBJ's upward v:
    // vt v = 0 (the image's bottom row: blue, white) lies at z = -1.
    // Rays start under the lamp and above the slanted triangles.
    let h = hit(&s.scene, Vec3::new(-0.5, 0.3, -0.5), -Vec3::Y);
    let r = reflectance_at(&s.scene, &h);
    assert!(r.x > 0.6 && r.w < 0.1, "blue at (-0.5, -0.5): {r}");
    let h = hit(&s.scene, Vec3::new(0.5, 0.3, 0.5), -Vec3::Y);
    let r = reflectance_at(&s.scene, &h);
    assert!(r.y > 0.6 && r.x < 0.2, "green at (0.5, 0.5): {r}");
    // The pentagon emits Ke.
    let h = hit(&s.scene, Vec3::new(0.0, 2.0, 0.0), -Vec3::Y);
    assert!(h.light.is_some(), "Ke makes a light");
    // d < 1 with Ni → dielectric with Ni; illum 3 → metal.
    let kinds: Vec<&Material> = s.scene.materials.iter().collect();
    assert!(kinds.iter().any(|m| matches!(m, Material::Dielectric { ior: Ior::Constant(n), .. } if (*n - 1.33).abs() < 1e-6)));
    assert!(kinds
        .iter()
        .any(|m| matches!(m, Material::Pbr(p) if p.metallic == 1.0)));
    // Dissolve without an index is a cut-out now, not an ignored feature.
    assert!(
        !s.report.warnings.iter().any(|w| w.contains("dissolve")),
        "{:?}",
        s.report.warnings
    );
    // The undefined material `nosuch` (face 3 4 7) gets the scene default,
    // diffuse 0.5: seen by a ray onto the face along its normal.
    let corners = [
        Vec3::new(1.0, 0.0, 1.0),
        Vec3::new(-1.0, 0.0, 1.0),
        Vec3::new(0.7, 1.0, 0.0),
    ];
    let centre = (corners[0] + corners[1] + corners[2]) / 3.0;
    let n = (corners[1] - corners[0])
        .cross(corners[2] - corners[0])
        .normalize();
    let h = hit(&s.scene, centre + 0.01 * n, -n);
    assert!(matches!(
        s.scene.materials[h.material as usize],
        Material::Diffuse { .. }
    ));
    let r = reflectance_at(&s.scene, &h);
    assert!((r - Vec4::splat(0.5)).abs().max_element() < 1e-5, "{r}");
}

#[test]
fn obj_missing_or_broken_mtl_is_a_warning() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("scene.obj"), OBJ).unwrap();
    // Loads scene.obj and checks that a warning names `what`.
    let load_warning = |what: &str| {
        let s = scene_in(
            dir.path(),
            &format!("{CAMERA}{}", shape("obj", "scene.obj", "")),
        )
        .unwrap();
        assert!(
            s.report.warnings.iter().any(|w| w.contains(what)),
            "{what}: {:?}",
            s.report.warnings
        );
        s
    };
    let s = load_warning("scene.mtl");
    assert_eq!(s.scene.triangle_count(), 9);
    assert!(s
        .scene
        .materials
        .iter()
        .all(|m| matches!(m, Material::Diffuse { .. })));
    // A broken library, and a missing texture: warnings, the rest loads.
    std::fs::write(dir.path().join("scene.mtl"), "newmtl checker\nKd 1 x\n").unwrap();
    load_warning("scene.mtl");
    std::fs::write(dir.path().join("scene.mtl"), MTL).unwrap();
    load_warning("checker.png");
    // The scene's material overrides the file's, all at once or by name.
    let text = format!(
        "{CAMERA}[materials.grey]\ntype = \"diffuse\"\n{}",
        shape("obj", "scene.obj", "materials = { glass = \"grey\" }")
    );
    let s = scene_in(dir.path(), &text).unwrap();
    assert!(!s
        .scene
        .materials
        .iter()
        .any(|m| matches!(m, Material::Dielectric { .. })));
}

#[test]
fn toml_diffuse_texture() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("checker.png"), assets::png(2, 2, &CHECKER)).unwrap();
    std::fs::write(
        dir.path().join("q.obj"),
        "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nf 1/1 2/2 3/3 4/4\n",
    )
    .unwrap();
    let text = format!(
        "{CAMERA}[materials.tex]\ntype = \"diffuse\"\nreflectance = 0.5\ntexture = \"checker.png\"\n{}",
        shape("obj", "q.obj", "material = \"tex\"")
    );
    let s = scene_in(dir.path(), &text).unwrap();
    // Top-left texel (red) times 0.5.
    let h = hit(&s.scene, Vec3::new(-0.5, 0.5, 5.0), -Vec3::Z);
    let r = reflectance_at(&s.scene, &h);
    assert!(r.w > 0.4 && r.w < 0.51 && r.x < 0.05, "{r}");
    // JPEG too: a uniform sRGB 200 grey (linear 0.578), lossy but flat.
    let grey = image::RgbImage::from_pixel(8, 8, image::Rgb([200, 200, 200]));
    grey.save(dir.path().join("grey.jpg")).unwrap();
    let s = scene_in(dir.path(), &text.replace("checker.png", "grey.jpg")).unwrap();
    let h = hit(&s.scene, Vec3::new(0.1, 0.2, 5.0), -Vec3::Z);
    let r = reflectance_at(&s.scene, &h);
    for c in r.to_array() {
        assert!((c - 0.5 * 0.578).abs() < 0.01, "{r}");
    }
    let e = scene_error(dir.path(), &text.replace("checker.png", "nothere.png"));
    assert!(
        e.contains("nothere.png") && e.contains("materials.tex.texture"),
        "{e}"
    );
}

#[test]
fn gltf_volume_attenuation_becomes_an_absorbing_medium_and_mtl_tf_on_glass_too() {
    let dir = tempfile::tempdir().unwrap();
    let mut b = GltfBuilder::default();
    let prim = format!("{}, \"material\":0}}", assets::quad(&mut b, true));
    let json = b.json(&format!(
        r#""extensionsUsed":["KHR_materials_transmission","KHR_materials_volume"],
        "scenes":[{{"nodes":[0]}}],
        "nodes":[{{"mesh":0}}],
        "meshes":[{{"name":"a","primitives":[{prim}]}}],
        "materials":[
          {{"name":"amber","pbrMetallicRoughness":{{"baseColorFactor":[1,0.9,0.6,1],"metallicFactor":0,"roughnessFactor":0}},
            "extensions":{{"KHR_materials_transmission":{{"transmissionFactor":1}},
              "KHR_materials_volume":{{"attenuationColor":[0.9,0.5,0.2],"attenuationDistance":0.25,"thicknessFactor":0.1}}}}}}
        ]"#
    ));
    let f = assets::write_glb(dir.path(), "amber", &json, &b.bin);
    // Scene units of centimetres: the medium is per scene unit.
    let s = scene_in(
        dir.path(),
        &format!("units = 0.01\n{CAMERA}{}", shape("gltf", &f, "")),
    )
    .unwrap();
    let h = hit(&s.scene, Vec3::new(0.0, 0.1, 5.0), -Vec3::Z);
    let m = s.scene.materials[h.material as usize]
        .medium()
        .expect("the volume's attenuation fills the glass");
    assert!(!m.scatters());
    let colour = prism::spectrum::Spectrum::rgb_reflectance(Vec3::new(0.9, 0.5, 0.2));
    for l in [450.0, 550.0, 650.0] {
        let expected = -colour.eval(l).ln() / 0.25 * 0.01;
        let got = m.sigma_a.eval(l);
        assert!(
            (got - expected).abs() < 1e-3 * expected,
            "{l} nm: {got} vs {expected}"
        );
    }
    assert!(
        m.sigma_a.eval(450.0) > 4.0 * m.sigma_a.eval(650.0),
        "amber absorbs blue"
    );
    assert!(
        s.report.warnings.iter().any(|w| w.contains("thickness")),
        "thicknessFactor is said to be ignored: {:?}",
        s.report.warnings
    );

    // OBJ: Tf on glass is a filter (per unit of path), elsewhere ignored.
    write_obj_mtl(
        dir.path(),
        "tf",
        "mtllib tf.mtl\nv -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nusemtl green_glass\nf 1 2 3 4\n",
        "newmtl green_glass\nillum 7\nNi 1.5\nTf 0.3 0.9 0.3\n",
    );
    let s = scene_in(
        dir.path(),
        &format!("{CAMERA}{}", shape("obj", "tf.obj", "")),
    )
    .unwrap();
    let h = hit(&s.scene, Vec3::new(0.0, 0.1, 5.0), -Vec3::Z);
    let m = s.scene.materials[h.material as usize]
        .medium()
        .expect("Tf fills the glass");
    assert!(
        m.sigma_a.eval(530.0) < 0.3 * m.sigma_a.eval(450.0),
        "green glass"
    );
    assert!(
        !s.report.warnings.iter().any(|w| w.contains("Tf")),
        "{:?}",
        s.report.warnings
    );
}

#[test]
fn a_concave_obj_face_keeps_its_hole() {
    // One 66-vertex face: a ring (radii 0.5 and 0.3) joined to its hole by
    // a bridge, as exporters write faces with holes. A fan fills the hole.
    let mut obj = String::new();
    let mut ring = Vec::new();
    for i in 0..=32 {
        let t = i as f32 * std::f32::consts::TAU / 32.0;
        ring.push((0.5 * t.cos(), 0.5 * t.sin()));
    }
    for i in (0..=32).rev() {
        let t = i as f32 * std::f32::consts::TAU / 32.0;
        ring.push((0.3 * t.cos(), 0.3 * t.sin()));
    }
    for (x, y) in &ring {
        obj.push_str(&format!("v {x} {y} 0\n"));
    }
    obj.push('f');
    for i in 1..=ring.len() {
        obj.push_str(&format!(" {i}"));
    }
    obj.push('\n');
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("ring.obj"), obj).unwrap();
    let s = scene_in(
        dir.path(),
        &format!("{CAMERA}{}", shape("obj", "ring.obj", "")),
    )
    .unwrap();
    assert_eq!(s.scene.triangle_count(), 64);
    let hits = |x: f32, y: f32| {
        s.scene
            .intersect(&Ray::new(Vec3::new(x, y, 5.0), -Vec3::Z))
            .is_some()
    };
    // The ring is there all round; the hole is empty.
    for k in 0..16 {
        let t = k as f32 * std::f32::consts::TAU / 16.0 + 0.1;
        assert!(hits(0.4 * t.cos(), 0.4 * t.sin()), "ring at angle {t}");
        assert!(!hits(0.2 * t.cos(), 0.2 * t.sin()), "hole at angle {t}");
    }
}

#[test]
fn mtl_textures_with_windows_paths_and_other_case_are_found_and_only_used_materials_warn() {
    let dir = tempfile::tempdir().unwrap();
    let (models, textures) = (dir.path().join("models"), dir.path().join("Textures"));
    std::fs::create_dir_all(&models).unwrap();
    std::fs::create_dir_all(&textures).unwrap();
    std::fs::write(textures.join("Wall.PNG"), assets::png(2, 2, &CHECKER)).unwrap();
    std::fs::write(models.join("local.png"), assets::png(2, 2, &CHECKER)).unwrap();
    std::fs::write(
        models.join("room.obj"),
        "mtllib room.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n\
         usemtl wall\nf 1/1 2/2 3/3\nusemtl near\nf 1/1 3/3 4/4\nusemtl lamp\nf 2/2 3/3 4/4\n",
    )
    .unwrap();
    std::fs::write(
        models.join("room.mtl"),
        "newmtl wall\nKd 1 1 1\nmap_Kd ..\\textures\\wall.png\n\
         newmtl near\nKd 1 1 1\nmap_Kd .\\local.png\n\
         newmtl lamp\nKa 20 20 20\nKd 0 0 0\n\
         newmtl unused\nKd 1 1 1\nmap_Kd missing.png\nmap_Ks gloss.png\n",
    )
    .unwrap();
    let s = scene_in(
        dir.path(),
        &format!("{CAMERA}{}", shape("obj", "models/room.obj", "")),
    )
    .unwrap();
    let textured = s
        .scene
        .materials
        .iter()
        .filter(|m| matches!(m, Material::Diffuse { reflectance } if reflectance.texture.is_some()))
        .count();
    assert_eq!(textured, 2, "both textures found");
    let all = s.report.warnings.join("\n");
    assert!(all.contains("wall.png") && all.contains("case"), "{all}");
    assert!(
        !all.contains("local.png"),
        "found as written (Windows separator): {all}"
    );
    assert!(all.contains("`lamp`") && all.contains("Ka"), "{all}");
    assert!(
        !all.contains("missing.png") && !all.contains("map_Ks"),
        "a material no face uses says nothing: {all}"
    );
}

#[test]
fn gltf_transmission_follows_the_textured_metalness_per_texel() {
    // Transmission 1, metallicFactor left at its default 1, and a
    // metallicRoughnessTexture: metal 0 on the left half, 1 on the right.
    let dir = tempfile::tempdir().unwrap();
    let mut b = GltfBuilder::default();
    let prim = assets::quad(&mut b, true);
    let (glass, metal) = ([0u8, 0, 0, 255], [0u8, 0, 255, 255]);
    let texels: Vec<u8> = [glass, metal, glass, metal].concat();
    let view = b.image_view(&assets::png(2, 2, &texels));
    let json = b.json(&format!(
        r#""extensionsUsed":["KHR_materials_transmission"],
        "scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0}}],
        "meshes":[{{"primitives":[{prim},"material":0}}]}}],
        "samplers":[{{"magFilter":9728}}],
        "images":[{{"bufferView":{view},"mimeType":"image/png"}}],
        "textures":[{{"source":0,"sampler":0}}],
        "materials":[
          {{"pbrMetallicRoughness":{{"baseColorFactor":[0.7,0.8,1,1],"metallicRoughnessTexture":{{"index":0}}}},
            "extensions":{{"KHR_materials_transmission":{{"transmissionFactor":1}}}}}}
        ]"#
    ));
    let f = assets::write_glb(dir.path(), "half_metal", &json, &b.bin);
    let s = scene_in(dir.path(), &format!("{CAMERA}{}", shape("gltf", &f, ""))).unwrap();
    let flags_at = |x: f32| {
        let h = hit(&s.scene, Vec3::new(x, 0.1, 5.0), -Vec3::Z);
        let m = &s.scene.materials[h.material as usize];
        let geom = ShadingGeometry {
            ng: h.ng,
            ns: h.ns,
            wo: Vec3::Z,
        };
        m.bsdf(&geom, h.uv, &mut wavelengths(), Vec4::splat(1.5))
            .flags()
    };
    use prism::material::BsdfFlags;
    assert!(
        flags_at(-0.5).contains(BsdfFlags::TRANSMISSION),
        "glass where metal is 0"
    );
    assert!(
        !flags_at(0.5).contains(BsdfFlags::TRANSMISSION),
        "metal where metal is 1"
    );
    // The glass half sits on the IOR stack as a dielectric.
    let h = hit(&s.scene, Vec3::new(-0.5, 0.1, 5.0), -Vec3::Z);
    assert!(s.scene.materials[h.material as usize].bounds_volume());
}

#[test]
fn gltf_alpha_mask_and_blend_and_mtl_dissolve_cut_surfaces_out() {
    let dir = tempfile::tempdir().unwrap();
    let mut b = GltfBuilder::default();
    let prim = assets::quad(&mut b, true);
    // Alpha 0 on the left half, 1 on the right.
    let texels: Vec<u8> = [[255u8, 255, 255, 0], [255, 255, 255, 255]]
        .concat()
        .repeat(2);
    let view = b.image_view(&assets::png(2, 2, &texels));
    let json = b.json(&format!(
        r#""scenes":[{{"nodes":[0,1]}}],"nodes":[{{"mesh":0}},{{"mesh":1,"translation":[3,0,0]}}],
        "meshes":[{{"primitives":[{prim},"material":0}}]}},{{"primitives":[{prim},"material":1}}]}}],
        "samplers":[{{"magFilter":9728}}],
        "images":[{{"bufferView":{view},"mimeType":"image/png"}}],
        "textures":[{{"source":0,"sampler":0}}],
        "materials":[
          {{"pbrMetallicRoughness":{{"baseColorTexture":{{"index":0}},"metallicFactor":0}},"alphaMode":"MASK","alphaCutoff":0.5}},
          {{"pbrMetallicRoughness":{{"baseColorFactor":[1,1,1,0.3],"metallicFactor":0}},"alphaMode":"BLEND"}}
        ]"#
    ));
    let f = assets::write_glb(dir.path(), "cutouts", &json, &b.bin);
    let s = scene_in(dir.path(), &format!("{CAMERA}{}", shape("gltf", &f, ""))).unwrap();
    let down = |x: f32, y: f32| Ray::new(Vec3::new(x, y, 5.0), -Vec3::Z);
    // MASK: the left half is not there, for closest hits and shadow rays.
    for y in [-0.7f32, 0.0, 0.6] {
        assert!(
            s.scene.intersect(&down(-0.5, y)).is_none(),
            "masked out at y {y}"
        );
        assert!(!s.scene.occluded(&down(-0.5, y)));
        assert!(s.scene.intersect(&down(0.5, y)).is_some(), "kept at y {y}");
        assert!(s.scene.occluded(&down(0.5, y)));
    }
    // BLEND: present with probability 0.3, decided per ray.
    let n = 4000;
    let hits = (0..n)
        .filter(|i| {
            let (x, y) = (
                3.0 + 1.8 * ((*i as f32 * 0.618_034).fract() - 0.5),
                1.8 * ((*i as f32 * 0.414_214).fract() - 0.5),
            );
            s.scene.intersect(&down(x, y)).is_some()
        })
        .count() as f64
        / n as f64;
    let sigma = (0.3f64 * 0.7 / n as f64).sqrt();
    assert!(
        (hits - 0.3).abs() < 5.0 * sigma,
        "blend coverage {hits} against 0.3 ± {sigma}"
    );
    assert!(
        !s.report.warnings.iter().any(|w| w.contains("alphaMode")),
        "{:?}",
        s.report.warnings
    );

    // MTL: dissolve on a diffuse surface, and a grey map_d without alpha.
    // A grey image (no alpha channel): black on the left, white on the right.
    image::GrayImage::from_raw(2, 2, vec![0, 255, 0, 255])
        .unwrap()
        .save(dir.path().join("matte.png"))
        .unwrap();
    std::fs::write(
        dir.path().join("cards.obj"),
        "mtllib cards.mtl\nv -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nvt 0 1\nvt 1 1\nvt 1 0\nvt 0 0\n\
         usemtl leaf\nf 1/1 2/2 3/3 4/4\n",
    )
    .unwrap();
    std::fs::write(
        dir.path().join("cards.mtl"),
        "newmtl leaf\nKd 0.2 0.6 0.2\nmap_d matte.png\n",
    )
    .unwrap();
    let s = scene_in(
        dir.path(),
        &format!("{CAMERA}{}", shape("obj", "cards.obj", "")),
    )
    .unwrap();
    assert!(
        s.scene.intersect(&down(-0.5, 0.0)).is_none(),
        "black in the matte: absent"
    );
    assert!(
        s.scene.intersect(&down(0.5, 0.0)).is_some(),
        "white in the matte: present"
    );
    assert!(
        !s.report.warnings.iter().any(|w| w.contains("map_d")),
        "{:?}",
        s.report.warnings
    );
}

#[test]
fn stochastic_transparency_passes_the_expected_share_of_light() {
    // A black card of dissolve 0.3 (an MTL cut-out) in front of a white
    // emitter: 70 % of the emitter's radiance gets through, on average.
    let dir = tempfile::tempdir().unwrap();
    write_obj_mtl(
        dir.path(),
        "card",
        "mtllib card.mtl\nv -3 -3 0\nv 3 -3 0\nv 3 3 0\nv -3 3 0\nusemtl veil\nf 1 2 3 4\n",
        "newmtl veil\nKd 0 0 0\nd 0.3\n",
    );
    let s = scene_in(
        dir.path(),
        &format!(
            "{CAMERA}[film]\nresolution = [8, 8]\nspp = 64\n{}\
             [[shape]]\ntype = \"quad\"\nvertices = [[-9, -9, -3], [9, -9, -3], [9, 9, -3], [-9, 9, -3]]\nemission = 1\n",
            shape("obj", "card.obj", "")
        ),
    )
    .unwrap();
    let film = common::render_film(&s, 2);
    let (mut mean, mut var) = (0.0, 0.0);
    for y in 0..8 {
        for x in 0..8 {
            let (m, v) = film.luminance_and_variance(x, y);
            mean += m / 64.0;
            var += v / 4096.0;
        }
    }
    let sigma = var.sqrt();
    assert!(
        (mean - 0.7).abs() < 5.0 * sigma,
        "{mean} ± {sigma}, expected 0.7"
    );
    assert!(sigma < 0.01, "{sigma}");
}

#[test]
fn gltf_extension_textures_vary_the_layers_over_the_surface() {
    // A thin film whose thickness texture is 0 on the left (100 nm) and 1
    // on the right (600 nm): the reflected colour differs between halves.
    // The second material shifts the texture by half its width with
    // KHR_texture_transform, which swaps the halves.
    let dir = tempfile::tempdir().unwrap();
    let mut b = GltfBuilder::default();
    let prim = assets::quad(&mut b, true);
    let texels: Vec<u8> = [[0u8, 0, 0, 255], [0, 255, 0, 255]].concat().repeat(2);
    let view = b.image_view(&assets::png(2, 2, &texels));
    let json = b.json(&format!(
        r#""extensionsUsed":["KHR_materials_iridescence","KHR_texture_transform"],
        "scenes":[{{"nodes":[0,1]}}],"nodes":[{{"mesh":0}},{{"mesh":1,"translation":[3,0,0]}}],
        "meshes":[{{"primitives":[{prim},"material":0}}]}},{{"primitives":[{prim},"material":1}}]}}],
        "samplers":[{{"magFilter":9728}}],
        "images":[{{"bufferView":{view},"mimeType":"image/png"}}],
        "textures":[{{"source":0,"sampler":0}}],
        "materials":[
          {{"pbrMetallicRoughness":{{"baseColorFactor":[0.02,0.02,0.02,1],"metallicFactor":0,"roughnessFactor":0.3}},
            "extensions":{{"KHR_materials_iridescence":{{"iridescenceFactor":1,"iridescenceIor":1.4,
              "iridescenceThicknessMinimum":100,"iridescenceThicknessMaximum":600,"iridescenceThicknessTexture":{{"index":0}}}}}}}},
          {{"pbrMetallicRoughness":{{"baseColorFactor":[0.02,0.02,0.02,1],"metallicFactor":0,"roughnessFactor":0.3}},
            "extensions":{{"KHR_materials_iridescence":{{"iridescenceFactor":1,"iridescenceIor":1.4,
              "iridescenceThicknessMinimum":100,"iridescenceThicknessMaximum":600,"iridescenceThicknessTexture":{{"index":0,
                "extensions":{{"KHR_texture_transform":{{"offset":[0.5,0]}}}}}}}}}}}}
        ]"#
    ));
    let f = assets::write_glb(dir.path(), "film", &json, &b.bin);
    let s = scene_in(dir.path(), &format!("{CAMERA}{}", shape("gltf", &f, ""))).unwrap();
    let reflected = |x: f32| {
        let h = hit(&s.scene, Vec3::new(x, 0.1, 5.0), -Vec3::Z);
        let geom = ShadingGeometry {
            ng: h.ng,
            ns: h.ns,
            wo: Vec3::new(0.3, 0.0, 1.0).normalize(),
        };
        let b = s.scene.materials[h.material as usize].bsdf(
            &geom,
            h.uv,
            &mut wavelengths(),
            Vec4::splat(1.0),
        );
        b.f(
            geom.wo,
            Vec3::new(-0.3, 0.0, 1.0).normalize(),
            prism::material::TransportMode::Radiance,
        )
    };
    let (thin, thick) = (reflected(-0.5), reflected(0.5));
    let hue = |f: Vec4| f / f.element_sum();
    assert!(
        (hue(thin) - hue(thick)).abs().max_element() > 0.02,
        "{thin} vs {thick}"
    );
    // Shifted by half: thick on the left, thin on the right.
    assert_eq!(reflected(3.0 - 0.5), thick);
    assert_eq!(reflected(3.0 + 0.5), thin);
}
