//! Property-based fuzzing of the input paths: mangled scene files, random
//! OBJ files, GLB files damaged byte by byte and glTF documents edited
//! member by member must load or fail with an error naming the file, never
//! panic; what loads must render without a non-finite sample (proptest
//! shrinks any failure to a minimal input). Bounded: a few hundred cases
//! each, seconds in CI, where tools/test.sh fixes the seed so that a run is
//! reproducible. For longer runs with fresh seeds:
//! PROPTEST_CASES=100000 cargo test --release --test suite -- fuzz::.

use crate::common;

use proptest::prelude::*;

const VALID: &str = r#"
[camera]
position = [0, 1, -4]
look_at = [0, 0.5, 0]
fov = 40

[film]
resolution = [8, 8]
spp = 1
max_depth = 3
spectral_range = [400, 700]

[spectra]
warm = { blackbody = 3000 }

[materials.white]
type = "diffuse"
reflectance = { rgb = [0.8, 0.7, 0.6] }

[materials.glass]
type = "dielectric"
ior = { abbe = [1.5, 40] }
roughness = 0.1
priority = 1

[materials.gold]
type = "conductor"
metal = "Au"

[[shape]]
type = "quad"
vertices = [[-5, 0, -5], [-5, 0, 5], [5, 0, 5], [5, 0, -5]]
material = "white"

[[shape]]
type = "sphere"
center = [0, 1, 0]
radius = 0.5
tessellate = true
segments = 16
material = "glass"
transform = { scale = 1.5, rotate = { axis = [0, 1, 0], degrees = 30 }, translate = [0, 0.1, 0] }

[[shape]]
type = "quad"
vertices = [[-1, 3, -1], [1, 3, -1], [1, 3, 1], [-1, 3, 1]]
emission = "warm"
emission_scale = 5
"#;

/// Fragments that stress the parser and the loader's checks.
const TOKENS: &[&str] = &[
    "[",
    "]",
    "{",
    "}",
    "=",
    ",",
    "\"",
    "\n",
    " ",
    "-",
    ".",
    "0",
    "1",
    "-1",
    "1e30",
    "-1e-30",
    "nan",
    "inf",
    "-inf",
    "4294967296",
    "true",
    "type",
    "\"obj\"",
    "\"sphere\"",
    "\"dielectric\"",
    "ior",
    "roughness",
    "2",
    "[[shape]]",
    "[film]",
    "spp",
    "resolution",
    "segments",
    "tessellate",
    "radius",
    "file",
    "\"missing.obj\"",
    "[[400, 1], [300, 2]]",
];

fn mangled_scene() -> impl Strategy<Value = String> {
    // Up to four edits: replace a byte range of the valid scene by tokens.
    proptest::collection::vec(
        (
            0..VALID.len(),
            0usize..12,
            proptest::collection::vec(0..TOKENS.len(), 0..4),
        ),
        1..5,
    )
    .prop_map(|edits| {
        let mut text = VALID.to_string();
        for (at, len, tokens) in edits {
            let at = at.min(text.len());
            let end = (at + len).min(text.len());
            if !text.is_char_boundary(at) || !text.is_char_boundary(end) {
                continue;
            }
            let insert: String = tokens.iter().map(|&t| TOKENS[t]).collect();
            text.replace_range(at..end, &insert);
        }
        text
    })
}

fn obj_line() -> impl Strategy<Value = String> {
    let number = prop_oneof![
        (-10.0f64..10.0).prop_map(|v| format!("{v}")),
        Just("nan".to_string()),
        Just("1e39".to_string()),
        Just("-0".to_string()),
        Just("x".to_string()),
    ];
    let index = prop_oneof![
        (-6i64..8).prop_map(|i| i.to_string()),
        Just("1/2/3".to_string()),
        Just("2//1".to_string())
    ];
    prop_oneof![
        proptest::collection::vec(number.clone(), 0..5).prop_map(|n| format!("v {}", n.join(" "))),
        proptest::collection::vec(number, 0..4).prop_map(|n| format!("vn {}", n.join(" "))),
        proptest::collection::vec(index, 0..6).prop_map(|i| format!("f {}", i.join(" "))),
        Just("o thing".to_string()),
        Just("usemtl missing".to_string()),
        Just("mtllib nowhere.mtl".to_string()),
        Just("# comment".to_string()),
        Just(String::new()),
    ]
}

/// `cases` cases unless PROPTEST_CASES says otherwise; no failure files
/// (a failure prints its minimal input, and CI's seed is fixed).
fn config(cases: u32) -> ProptestConfig {
    ProptestConfig {
        cases: std::env::var("PROPTEST_CASES")
            .ok()
            .and_then(|c| c.parse().ok())
            .unwrap_or(cases),
        failure_persistence: None,
        ..ProptestConfig::default()
    }
}

proptest! {
    #![proptest_config(config(400))]

    #[test]
    fn mangled_scenes_load_or_fail_cleanly(text in mangled_scene()) {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
        match prism::load::load_str(&text, dir) {
            Ok(s) => {
                // What loads also renders (one sample a pixel, on films
                // small enough for a test) without a non-finite sample.
                if s.settings.film.width as u64 * s.settings.film.height as u64 <= 1 << 16 {
                    let options = prism::render::RenderOptions {
                        threads: Some(1),
                        ..prism::render::RenderOptions::with_spp(&s.settings.film, 1)
                    };
                    let (film, stats) = prism::render::render(&s.scene, &s.settings, &options).unwrap();
                    prop_assert_eq!(stats.non_finite, 0);
                    prop_assert!(film.linear_srgb().iter().all(|c| c.is_finite()));
                }
            }
            Err(e) => {
                prop_assert!(!e.message.is_empty());
                prop_assert!(e.to_string().starts_with("<scene>: "), "{}", e);
            }
        }
    }

    #[test]
    fn random_obj_files_load_or_fail_cleanly(lines in proptest::collection::vec(obj_line(), 0..24)) {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("m.obj"), lines.join("\n")).unwrap();
        let scene = "[camera]\nposition = [0, 0, -5]\nlook_at = [0, 0, 0]\n[film]\nresolution = [4, 4]\nspp = 1\n\
                     [[shape]]\ntype = \"obj\"\nfile = \"m.obj\"\nemission = 1\n";
        match prism::load::load_str(scene, dir.path()) {
            Ok(s) => {
                // What loads also renders without a non-finite sample.
                let (_, stats) = prism::render::render(&s.scene, &s.settings, &prism::render::RenderOptions { threads: Some(1), ..s.settings.options() }).unwrap();
                prop_assert_eq!(stats.non_finite, 0);
            }
            Err(e) => prop_assert!(e.message.contains("m.obj"), "{}", e.message),
        }
    }
}

/// A valid textured GLB (a quad with a base colour texture and a normal
/// map) to damage.
fn sample_glb() -> Vec<u8> {
    use common::assets::{self, GltfBuilder};
    let mut b = GltfBuilder::default();
    let prim = assets::quad(&mut b, true);
    let view = b.image_view(&assets::png(1, 1, &[200, 100, 50, 255]));
    let json = b.json(&format!(
        r#""scenes":[{{"nodes":[0]}}],"nodes":[{{"children":[1],"scale":[2,2,2]}},{{"mesh":0}}],
        "meshes":[{{"name":"m","primitives":[{prim},"material":0}}]}}],
        "images":[{{"bufferView":{view},"mimeType":"image/png"}}],"textures":[{{"source":0}}],
        "materials":[{{"normalTexture":{{"index":0}},"emissiveFactor":[1,1,1],
          "pbrMetallicRoughness":{{"baseColorTexture":{{"index":0}}}}}}]"#
    ));
    assets::glb_bytes(&json, &b.bin)
}

proptest! {
    #![proptest_config(config(300))]

    #[test]
    fn damaged_glb_files_load_or_fail_cleanly(
        cut in 0.0f64..1.2,
        flips in proptest::collection::vec((0.0f64..1.0, any::<u8>()), 0..6),
    ) {
        glb_loads_or_fails_cleanly(&damaged_glb(cut, &flips), CAMERA_AT_Z5)?;
    }
}

const CAMERA_AT_Z5: &str = "[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\n";
const CAMERA_FROM_FILE: &str = "[camera]\nfrom_file = \"m.glb\"\n";

/// The sample GLB with bytes overwritten (positions as fractions of its
/// length) and cut at `cut` × its length.
fn damaged_glb(cut: f64, flips: &[(f64, u8)]) -> Vec<u8> {
    let mut glb = sample_glb();
    for &(at, byte) in flips {
        let i = ((at * glb.len() as f64) as usize).min(glb.len() - 1);
        glb[i] = byte;
    }
    let keep = ((cut * glb.len() as f64) as usize).min(glb.len());
    glb.truncate(keep);
    glb
}

/// A scene made of `glb` (as m.glb) loads and renders without a non-finite
/// sample, or fails with an error naming the file.
fn glb_loads_or_fails_cleanly(glb: &[u8], camera: &str) -> Result<(), TestCaseError> {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("m.glb"), glb).unwrap();
    let scene = format!(
        "{camera}[film]\nresolution = [4, 4]\nspp = 1\n[[shape]]\ntype = \"gltf\"\nfile = \"m.glb\"\n"
    );
    match prism::load::load_str(&scene, dir.path()) {
        Ok(s) => {
            let options = prism::render::RenderOptions {
                threads: Some(1),
                ..s.settings.options()
            };
            let (_, stats) = prism::render::render(&s.scene, &s.settings, &options).unwrap();
            prop_assert_eq!(stats.non_finite, 0);
        }
        Err(e) => prop_assert!(e.message.contains("m.glb"), "{}", e.message),
    }
    Ok(())
}

/// Inputs the fuzzers once failed on (CI's random seed found the first: an
/// image in a buffer view whose mimeType key was damaged).
#[test]
fn former_fuzz_failures() {
    glb_loads_or_fails_cleanly(
        &damaged_glb(1.0390177166470316, &[(0.6668312343802721, 35)]),
        CAMERA_AT_Z5,
    )
    .unwrap();
    for (at, op, value) in [
        (0.9196027576617477, 199, 248), // camera 4.3e9 from the origin
        (0.9177092176390352, 232, 166), // camera 1e30 from the origin
        (0.7601865315678636, 106, 24),  // rotation quaternion of length 4.3e9
        (0.3373827378980993, 52, 210),  // negative field of view
    ] {
        let (mut doc, bin) = rich_gltf();
        edit(&mut doc, at, op, value);
        let glb = common::assets::glb_bytes(&doc.to_string(), &bin);
        glb_loads_or_fails_cleanly(&glb, CAMERA_FROM_FILE).unwrap();
    }
}

/// A glTF document using most of what the importer reads: a node tree with
/// matrix and TRS, a camera, a sampler, an embedded image used by several
/// texture slots with KHR_texture_transform, a textured PBR material and a
/// transmissive, dispersive one.
fn rich_gltf() -> (serde_json::Value, Vec<u8>) {
    use common::assets::{self, GltfBuilder};
    let mut b = GltfBuilder::default();
    let prim = assets::quad(&mut b, true);
    let tangents = b.floats(&[1.0, 0.0, 0.0, 1.0].repeat(4), "VEC4");
    let view = b.image_view(&assets::png(2, 1, &[200, 100, 50, 255, 10, 20, 30, 255]));
    let prim_t = prim.replace(
        r#""attributes":{"#,
        &format!(r#""attributes":{{"TANGENT":{tangents},"#),
    );
    // The pane's texture coordinates: a sparse accessor over the tile's.
    let uv = b.sparse_vec2(1, 4, &[2], &[0.5, 0.5]);
    let prim = prim.replace(r#""TEXCOORD_0":1"#, &format!(r#""TEXCOORD_0":{uv}"#));
    assert!(prim.contains(&format!(r#""TEXCOORD_0":{uv}"#)));
    let json = b.json(&format!(
        r#""extensionsUsed":["KHR_texture_transform","KHR_materials_transmission","KHR_materials_ior",
            "KHR_materials_dispersion","KHR_materials_emissive_strength"],
        "scene":0,"scenes":[{{"nodes":[0,3]}}],
        "nodes":[{{"children":[1,2],"translation":[0,0,-1],"rotation":[0,0,0.3826834,0.9238795],"scale":[2,2,2]}},
                 {{"mesh":0}},
                 {{"mesh":1,"matrix":[1,0,0,0,0,1,0,0,0,0,1,0,0,0,0.5,1]}},
                 {{"camera":0,"translation":[0,0,5]}}],
        "cameras":[{{"type":"perspective","perspective":{{"yfov":0.8,"znear":0.1,"aspectRatio":1.0}}}}],
        "meshes":[{{"name":"tile","primitives":[{prim_t},"material":0}}]}},
                  {{"name":"pane","primitives":[{prim},"material":1,"mode":4}}]}}],
        "samplers":[{{"magFilter":9728,"wrapS":33648,"wrapT":33071}}],
        "images":[{{"bufferView":{view},"mimeType":"image/png"}}],
        "textures":[{{"source":0,"sampler":0}},{{"source":0}}],
        "materials":[{{"normalTexture":{{"index":1,"scale":0.5}},"emissiveFactor":[1,0.5,0.2],
            "emissiveTexture":{{"index":0}},"doubleSided":true,
            "extensions":{{"KHR_materials_emissive_strength":{{"emissiveStrength":3}}}},
            "pbrMetallicRoughness":{{"baseColorFactor":[1,1,1,1],"metallicFactor":0.2,"roughnessFactor":0.6,
              "baseColorTexture":{{"index":0,"extensions":{{"KHR_texture_transform":{{"offset":[0.5,0],"rotation":0.3,"scale":[2,2]}}}}}},
              "metallicRoughnessTexture":{{"index":1}}}}}},
          {{"extensions":{{"KHR_materials_transmission":{{"transmissionFactor":1}},"KHR_materials_ior":{{"ior":1.6}},
              "KHR_materials_dispersion":{{"dispersion":0.5}}}},
            "pbrMetallicRoughness":{{"metallicFactor":0,"roughnessFactor":0.1}}}}]"#
    ));
    (
        serde_json::from_str(&json).expect("the sample is valid JSON"),
        b.bin,
    )
}

/// Pointers to every value in a JSON document, depth first.
fn json_paths(v: &serde_json::Value, at: String, out: &mut Vec<String>) {
    match v {
        serde_json::Value::Object(m) => {
            for (k, x) in m {
                let p = format!("{at}/{k}");
                out.push(p.clone());
                json_paths(x, p, out);
            }
        }
        serde_json::Value::Array(a) => {
            for (i, x) in a.iter().enumerate() {
                let p = format!("{at}/{i}");
                out.push(p.clone());
                json_paths(x, p, out);
            }
        }
        _ => {}
    }
}

/// Values a damaged or hostile file might hold instead of the right one.
fn hostile_value(k: u8) -> serde_json::Value {
    use serde_json::json;
    match k % 16 {
        0 => json!(null),
        1 => json!(true),
        2 => json!(-1),
        3 => json!(0),
        4 => json!(1),
        5 => json!(7),
        6 => json!(1e30),
        7 => json!(-0.5),
        8 => json!(4294967295u64),
        9 => json!("x"),
        10 => json!("perspective"),
        11 => json!([]),
        12 => json!({}),
        13 => json!([0, 0, 0]),
        14 => json!([1, 1, 1, 1]),
        _ => json!(5123),
    }
}

/// One edit of the document: delete a member or element, replace it with
/// a hostile value, or duplicate an array element.
fn edit(doc: &mut serde_json::Value, at: f64, op: u8, value: u8) {
    let mut paths = Vec::new();
    json_paths(doc, String::new(), &mut paths);
    if paths.is_empty() {
        return;
    }
    let path = &paths[((at * paths.len() as f64) as usize).min(paths.len() - 1)];
    let (parent, key) = path.rsplit_once('/').unwrap();
    let Some(parent) = doc.pointer_mut(parent) else {
        return;
    };
    match (op % 3, parent) {
        (0, serde_json::Value::Object(m)) => {
            m.remove(key);
        }
        (0, serde_json::Value::Array(a)) => {
            a.remove(key.parse::<usize>().unwrap());
        }
        (2, serde_json::Value::Array(a)) => {
            let x = a[key.parse::<usize>().unwrap()].clone();
            a.push(x);
        }
        (_, parent) => {
            if let Some(slot) = parent.pointer_mut(&format!("/{key}")) {
                *slot = hostile_value(value);
            }
        }
    }
}

proptest! {
    #![proptest_config(config(300))]

    #[test]
    fn edited_gltf_documents_load_or_fail_cleanly(
        edits in proptest::collection::vec((0.0f64..1.0, any::<u8>(), any::<u8>()), 1..5),
    ) {
        let (mut doc, bin) = rich_gltf();
        for (at, op, value) in edits {
            edit(&mut doc, at, op, value);
        }
        let glb = common::assets::glb_bytes(&doc.to_string(), &bin);
        glb_loads_or_fails_cleanly(&glb, CAMERA_FROM_FILE)?;
    }
}

/// The fuzzer starts from a document that loads, with no warning.
#[test]
fn rich_gltf_sample_loads() {
    let (doc, bin) = rich_gltf();
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("m.glb"),
        common::assets::glb_bytes(&doc.to_string(), &bin),
    )
    .unwrap();
    let scene = "[camera]\nfrom_file = \"m.glb\"\n[film]\nresolution = [4, 4]\nspp = 1\n\
                 [[shape]]\ntype = \"gltf\"\nfile = \"m.glb\"\n";
    let s = prism::load::load_str(scene, dir.path()).unwrap_or_else(|e| panic!("{}", e.message));
    assert!(s.report.warnings.is_empty(), "{:?}", s.report.warnings);
}

// Resource bombs, special files and integer ranges (issue 19's classes).
// Every case runs under a 64 MiB memory budget, so a forged size that got
// past the checks would fail the case instead of taking the machine.

const BUDGET: u64 = 64 << 20;

/// A baseline JPEG of `w` × `h` from the image crate's encoder.
fn jpeg(w: u32, h: u32) -> Vec<u8> {
    let img = image::RgbImage::from_fn(w, h, |x, y| image::Rgb([x as u8 * 9, y as u8 * 5, 77]));
    let mut out = std::io::Cursor::new(Vec::new());
    img.write_to(&mut out, image::ImageFormat::Jpeg).unwrap();
    out.into_inner()
}

/// Loads a one-quad scene textured with `file`, within the test budget.
fn load_textured(dir: &std::path::Path, file: &str) -> Result<prism::load::Loaded, String> {
    let scene = format!(
        "[camera]\nposition = [0, 0, -5]\nlook_at = [0, 0, 0]\n[film]\nresolution = [4, 4]\n\
         [materials.t]\ntype = \"diffuse\"\ntexture = \"{file}\"\n\
         [[shape]]\ntype = \"quad\"\nvertices = [[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]]\nmaterial = \"t\"\n"
    );
    let (result, _) = prism::memory::tallying(Some(BUDGET), || prism::load::load_str(&scene, dir));
    result.map_err(|e| e.message)
}

proptest! {
    #![proptest_config(config(200))]

    /// Images that declare any size: refused by the budget before their
    /// texels exist, or decoded; never a panic or an abort.
    #[test]
    fn forged_image_sizes_load_or_are_refused(
        width in prop_oneof![1u32..64, 1u32..=u32::MAX],
        height in prop_oneof![1u32..64, 1u32..=u32::MAX],
        colour in prop::sample::select(vec![0u8, 2, 3, 4, 6]),
        depth in prop::sample::select(vec![1u8, 8, 16]),
        rows in 0usize..64,
    ) {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("t.png"), common::assets::forged_png(width, height, colour, depth, rows)).unwrap();
        match load_textured(dir.path(), "t.png") {
            Ok(s) => prop_assert!(s.scene.image_bytes <= BUDGET),
            Err(e) => prop_assert!(e.contains("t.png"), "{}", e),
        }
    }

    /// JPEGs whose frame header declares another size, or cut short: a
    /// cut file that still decodes is named in a warning.
    #[test]
    fn forged_and_truncated_jpegs_load_or_are_refused(
        width in prop_oneof![1u16..64, any::<u16>()],
        height in prop_oneof![1u16..64, any::<u16>()],
        cut in 0.0f64..1.0,
    ) {
        let mut bytes = jpeg(24, 16);
        let sof = bytes.windows(2).position(|w| w == [0xFF, 0xC0]).unwrap();
        bytes[sof + 5..sof + 7].copy_from_slice(&height.to_be_bytes());
        bytes[sof + 7..sof + 9].copy_from_slice(&width.to_be_bytes());
        let keep = sof + 9 + ((bytes.len() - sof - 9) as f64 * cut) as usize;
        bytes.truncate(keep);
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("t.jpg"), &bytes).unwrap();
        match load_textured(dir.path(), "t.jpg") {
            Ok(s) => prop_assert!(
                s.report.warnings.iter().any(|w| w.contains("t.jpg") && w.contains("truncated")),
                "{:?}", s.report.warnings
            ),
            Err(e) => prop_assert!(e.contains("t.jpg"), "{}", e),
        }
    }

    /// EXR files whose data window declares any size are read within the
    /// budget or refused: `prism info` and `merge` read files this way.
    #[test]
    fn forged_exr_sizes_are_read_or_refused(
        window in proptest::array::uniform4(prop_oneof![-4i32..64, any::<i32>()]),
    ) {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("f.spectral.exr");
        std::fs::write(&path, small_spectral_exr()).unwrap();
        let mut bytes = std::fs::read(&path).unwrap();
        let key = b"dataWindow\0box2i\0";
        let at = bytes.windows(key.len()).position(|w| w == key).unwrap() + key.len() + 4;
        for (k, v) in window.iter().enumerate() {
            bytes[at + 4 * k..at + 4 * k + 4].copy_from_slice(&v.to_le_bytes());
        }
        std::fs::write(&path, &bytes).unwrap();
        let (read, _) = prism::memory::tallying(Some(BUDGET), || {
            prism::film::spectral_exr::read(&path)
        });
        if let Ok(img) = read {
            prop_assert!((img.width * img.height) as u64 * 4 * 8 <= BUDGET);
        }
    }

    /// Sample ranges anywhere in u32, up to its last index: they finish,
    /// and every pixel gets exactly the range's samples.
    #[test]
    fn sample_ranges_near_the_end_of_u32_finish(
        back in 1u32..200,
        len in 1u32..40,
    ) {
        let scene = prism::load::load_str(
            &VALID.replace("resolution = [8, 8]", "resolution = [1, 1]"),
            std::path::Path::new("."),
        ).unwrap();
        // END is exclusive: the last range ends at u32::MAX itself.
        let end = u32::MAX - (back - 1);
        let start = end - len;
        let options = prism::render::RenderOptions {
            threads: Some(1),
            progress: false,
            samples: start..end,
            adaptive: false,
            ..scene.settings.options()
        };
        let (film, stats) = prism::render::render(&scene.scene, &scene.settings, &options).unwrap();
        prop_assert_eq!(film.sums(0, 0).samples, (end - start) as u64);
        prop_assert_eq!(stats.samples, (end - start) as u64);
    }
}

/// A 6×4 spectral EXR of prism's, to forge.
fn small_spectral_exr() -> Vec<u8> {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("s.spectral.exr");
    let n = 6 * 4;
    let img = prism::film::spectral_exr::SpectralImage {
        width: 6,
        height: 4,
        wavelengths: vec![500.0, 600.0],
        names: vec![
            prism::film::spectral_exr::channel_name(500.0),
            prism::film::spectral_exr::channel_name(600.0),
        ],
        spectral: vec![vec![0.5; n], vec![0.25; n]],
        other: [("R", 0.1), ("G", 0.2), ("B", 0.3)]
            .into_iter()
            .map(|(k, v)| (k.to_string(), vec![v; n]))
            .collect(),
        attributes: Default::default(),
    };
    prism::film::spectral_exr::write_image(img, &path).unwrap();
    std::fs::read(path).unwrap()
}

/// A FIFO in place of each kind of input file: refused at once (a read
/// would block forever), naming the file.
#[test]
fn special_files_in_place_of_any_input_are_refused_without_blocking() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let fifo = |name: &str| {
        let ok = std::process::Command::new("mkfifo")
            .arg(d.join(name))
            .status()
            .is_ok_and(|s| s.success());
        assert!(ok, "mkfifo {name}");
    };
    for name in ["scene.toml", "m.obj", "t.png", "s.csv", "sky.exr", "b.bin"] {
        fifo(name);
    }
    std::fs::write(
        d.join("lib.obj"),
        "mtllib fifo.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    )
    .unwrap();
    fifo("fifo.mtl");
    std::fs::write(
        d.join("m.gltf"),
        r#"{"asset":{"version":"2.0"},"buffers":[{"uri":"b.bin","byteLength":12}],"bufferViews":[{"buffer":0,"byteLength":12}],
            "accessors":[{"bufferView":0,"componentType":5126,"count":1,"type":"VEC3","min":[0,0,0],"max":[0,0,0]}],
            "meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],"nodes":[{"mesh":0}],"scenes":[{"nodes":[0]}]}"#,
    )
    .unwrap();
    let camera =
        "[camera]\nposition = [0, 0, -5]\nlook_at = [0, 0, 0]\n[film]\nresolution = [4, 4]\n";
    let quad =
        "[[shape]]\ntype = \"quad\"\nvertices = [[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]]\n";
    let cases = [
        ("m.obj", format!("{camera}[[shape]]\ntype = \"obj\"\nfile = \"m.obj\"\n")),
        ("fifo.mtl", format!("{camera}[[shape]]\ntype = \"obj\"\nfile = \"lib.obj\"\n")),
        ("b.bin", format!("{camera}[[shape]]\ntype = \"gltf\"\nfile = \"m.gltf\"\n")),
        ("t.png", format!("{camera}[materials.t]\ntype = \"diffuse\"\ntexture = \"t.png\"\n{quad}material = \"t\"\n")),
        ("s.csv", format!("{camera}[spectra]\nlamp = {{ file = \"s.csv\" }}\n{quad}emission = \"lamp\"\n")),
        ("sky.exr", format!("{camera}[environment]\nfile = \"sky.exr\"\n{quad}")),
    ];
    // Each load's error, or its warnings (a material library is optional:
    // one that cannot be read is named in a warning).
    let message = |r: Result<prism::load::Loaded, prism::load::SceneError>| match r {
        Ok(s) => s.report.warnings.join("; "),
        Err(e) => e.to_string(),
    };
    let (sender, receiver) = std::sync::mpsc::channel();
    let base = d.to_path_buf();
    std::thread::spawn(move || {
        for (file, scene) in cases {
            sender
                .send((file, message(prism::load::load_str(&scene, &base))))
                .unwrap();
        }
        let r = prism::load::load(&base.join("scene.toml"));
        sender.send(("scene.toml", message(r))).unwrap();
    });
    for _ in 0..7 {
        let (file, e) = receiver
            .recv_timeout(std::time::Duration::from_secs(20))
            .expect("a load blocked on a FIFO");
        assert!(
            e.contains(file) && e.contains("not a regular file"),
            "{file}: {e}"
        );
    }
}

/// A number at an extreme: zero, tiny, huge, beyond f32, negative, not one.
fn extreme_number() -> impl Strategy<Value = String> {
    prop_oneof![
        Just("0".to_string()),
        Just("-1".to_string()),
        Just("1e-30".to_string()),
        Just("1e-45".to_string()),
        Just("1e30".to_string()),
        Just("1e38".to_string()),
        Just("3.5e38".to_string()),
        Just("1e300".to_string()),
        Just("nan".to_string()),
        Just("inf".to_string()),
        Just("-inf".to_string()),
        (0.0f64..4.0).prop_map(|v| format!("{v}")),
    ]
}

proptest! {
    #![proptest_config(config(200))]

    /// MTL values at their extremes load with warnings, or fail naming the
    /// file; what loads renders finite.
    #[test]
    fn mtl_values_at_extremes_load_or_fail_cleanly(
        values in proptest::collection::vec(
            (prop_oneof![Just("Kd"), Just("Ks"), Just("Ke"), Just("Ka"), Just("d"), Just("Tr"),
                         Just("Ni"), Just("Ns"), Just("Tf"), Just("illum")],
             extreme_number()),
            1..6,
        )
    ) {
        let dir = tempfile::tempdir().unwrap();
        let obj = "mtllib m.mtl\nv -1 -1 0\nv 1 -1 0\nv 0 1 0\nusemtl a\nf 1 2 3\n";
        std::fs::write(dir.path().join("m.obj"), obj).unwrap();
        let mut mtl = "newmtl a\n".to_string();
        for (key, v) in &values {
            let v = if ["Kd", "Ks", "Ke", "Ka", "Tf"].contains(key) { format!("{v} {v} {v}") } else { v.clone() };
            mtl.push_str(&format!("{key} {v}\n"));
        }
        std::fs::write(dir.path().join("m.mtl"), &mtl).unwrap();
        let scene = "[camera]\nposition = [0, 0, -5]\nlook_at = [0, 0, 0]\n[film]\nresolution = [4, 4]\nspp = 1\n\
                     [environment]\nradiance = 1\n[[shape]]\ntype = \"obj\"\nfile = \"m.obj\"\n";
        match prism::load::load_str(scene, dir.path()) {
            Ok(s) => {
                let options = prism::render::RenderOptions { threads: Some(1), ..s.settings.options() };
                let (film, stats) = prism::render::render(&s.scene, &s.settings, &options).unwrap();
                prop_assert_eq!(stats.non_finite, 0, "{}", mtl);
                prop_assert!(film.linear_srgb().iter().all(|c| c.is_finite()), "{}", mtl);
            }
            Err(e) => prop_assert!(e.message.contains("m.mtl") || e.message.contains("m.obj"), "{}", e.message),
        }
    }

    /// Integrator keys at their extremes are refused naming the key, or
    /// render a small film finitely and in bounded time.
    #[test]
    fn integrator_keys_at_extremes_load_or_fail_cleanly(
        kind in prop_oneof![Just("path"), Just("light"), Just("bdpt"), Just("sppm")],
        key in prop_oneof![Just("max_depth"), Just("rr_depth"), Just("photons"), Just("radius"),
                           Just("alpha"), Just("spectral_radius"), Just("split")],
        value in prop_oneof![extreme_number(), Just("4294967295".to_string()), Just("65537".to_string())],
    ) {
        let scene = format!(
            "[camera]\nposition = [0, 0, -5]\nlook_at = [0, 0, 0]\n[film]\nresolution = [4, 4]\nspp = 1\n\
             [integrator]\ntype = \"{kind}\"\n{key} = {value}\n\
             [[shape]]\ntype = \"sphere\"\nradius = 1\nemission = 1\n"
        );
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
        match prism::load::load_str(&scene, dir) {
            Ok(s) => {
                // Keep photon mapping's iteration small where the key
                // allowed a large one: what is checked is the refusal.
                if key == "photons" || key.ends_with("depth") {
                    return Ok(());
                }
                let options = prism::render::RenderOptions { threads: Some(1), ..s.settings.options() };
                let (film, stats) = prism::render::render(&s.scene, &s.settings, &options).unwrap();
                prop_assert_eq!(stats.non_finite, 0, "{}", scene);
                prop_assert!(film.linear_srgb().iter().all(|c| c.is_finite()));
            }
            Err(e) => prop_assert!(e.message.contains(&format!("integrator.{key}")) || e.message.contains(key), "{}", e.message),
        }
    }
}

/// Durations at their extremes are a command-line error, never a panic.
#[test]
fn durations_at_extremes_are_errors_not_panics() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("s.toml"),
        "[camera]\nposition = [0, 0, -5]\nlook_at = [0, 0, 0]\n[film]\nresolution = [4, 4]\nspp = 1\n",
    )
    .unwrap();
    for flag in ["--time", "--log-every", "--preview-every"] {
        for value in [
            "0",
            "-1",
            "nan",
            "inf",
            "1e30",
            "1e300h",
            "99999999999999999999h",
            "18446744073709551616s",
            "5x",
            "",
        ] {
            let out = std::process::Command::new(env!("CARGO_BIN_EXE_prism"))
                .args(["render", "s.toml", "-q", flag, value])
                .current_dir(dir.path())
                .output()
                .unwrap();
            let err = String::from_utf8_lossy(&out.stderr);
            assert_eq!(out.status.code(), Some(2), "{flag} {value:?}: {err}");
        }
    }
}

proptest! {
    #![proptest_config(config(150))]

    /// Environment maps of forged bytes (Radiance HDR headers declaring
    /// any size, texels of any exponent up to 255) load and render finite,
    /// or are refused naming `environment.file`.
    #[test]
    fn forged_environment_maps_load_or_are_refused(
        w in prop_oneof![1u32..8, Just(16384u32), Just(1u32 << 30)],
        h in prop_oneof![1u32..8, Just(16384u32), Just(1u32 << 30)],
        texels in proptest::collection::vec(any::<u8>(), 0..256),
    ) {
        let dir = tempfile::tempdir().unwrap();
        let mut bytes = format!("#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y {h} +X {w}\n").into_bytes();
        bytes.extend_from_slice(&texels);
        std::fs::write(dir.path().join("map.hdr"), &bytes).unwrap();
        let scene = "[camera]\nposition = [0, 0, -5]\nlook_at = [0, 0, 0]\n[film]\nresolution = [4, 4]\nspp = 1\n\
                     [environment]\nfile = \"map.hdr\"\n[[shape]]\ntype = \"sphere\"\nradius = 1\n";
        let loaded = prism::memory::tallying(Some(1 << 30), || prism::load::load_str(scene, dir.path())).0;
        match loaded {
            Ok(s) => {
                let options = prism::render::RenderOptions { threads: Some(1), ..s.settings.options() };
                let (film, stats) = prism::render::render(&s.scene, &s.settings, &options).unwrap();
                prop_assert_eq!(stats.non_finite, 0);
                prop_assert!(film.linear_srgb().iter().all(|c| c.is_finite()));
            }
            Err(e) => prop_assert!(e.message.contains("environment.file"), "{}", e.message),
        }
    }
}
