//! Property-based fuzzing of the input paths: mangled scene files and
//! random OBJ files and damaged GLB files must load or fail with an error, never panic (proptest
//! shrinks any failure to a minimal input). Bounded: a few hundred cases
//! each, seconds in CI. For longer runs: PROPTEST_CASES=100000 cargo test --test fuzz.

mod common;

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

proptest! {
    #![proptest_config(ProptestConfig {
        cases: std::env::var("PROPTEST_CASES").ok().and_then(|c| c.parse().ok()).unwrap_or(400),
        failure_persistence: None,
        ..ProptestConfig::default()
    })]

    #[test]
    fn mangled_scenes_load_or_fail_cleanly(text in mangled_scene()) {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
        if let Err(e) = prism::scene::load_str(&text, dir) {
            prop_assert!(!e.message.is_empty());
        }
    }

    #[test]
    fn random_obj_files_load_or_fail_cleanly(lines in proptest::collection::vec(obj_line(), 0..24)) {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("m.obj"), lines.join("\n")).unwrap();
        let scene = "[camera]\nposition = [0, 0, -5]\nlook_at = [0, 0, 0]\n[film]\nresolution = [4, 4]\nspp = 1\n\
                     [[shape]]\ntype = \"obj\"\nfile = \"m.obj\"\nemission = 1\n";
        match prism::scene::load_str(scene, dir.path()) {
            Ok(s) => {
                // What loads also renders without a non-finite sample.
                let (_, stats) = prism::render::render(&s, &prism::render::RenderOptions { threads: Some(1), ..Default::default() });
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
    #![proptest_config(ProptestConfig {
        cases: std::env::var("PROPTEST_CASES").ok().and_then(|c| c.parse().ok()).unwrap_or(300),
        ..ProptestConfig::default()
    })]

    #[test]
    fn damaged_glb_files_load_or_fail_cleanly(
        cut in 0.0f64..1.2,
        flips in proptest::collection::vec((0.0f64..1.0, any::<u8>()), 0..6),
    ) {
        let mut glb = sample_glb();
        for (at, byte) in flips {
            let i = ((at * glb.len() as f64) as usize).min(glb.len() - 1);
            glb[i] = byte;
        }
        let keep = ((cut * glb.len() as f64) as usize).min(glb.len());
        glb.truncate(keep);
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("m.glb"), &glb).unwrap();
        let scene = "[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\n[film]\nresolution = [4, 4]\nspp = 1\n\
                     [[shape]]\ntype = \"gltf\"\nfile = \"m.glb\"\n";
        match prism::scene::load_str(scene, dir.path()) {
            Ok(s) => {
                let (_, stats) = prism::render::render(&s, &prism::render::RenderOptions { threads: Some(1), ..Default::default() });
                prop_assert_eq!(stats.non_finite, 0);
            }
            Err(e) => prop_assert!(e.message.contains("m.glb"), "{}", e.message),
        }
    }
}
