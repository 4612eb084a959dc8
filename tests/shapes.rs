//! Every shape type of the list (`ShapeKind::ALL`), so a new one is tested
//! as soon as it has an example here (the match is exhaustive: a type
//! added to `shape_kinds!` does not compile until it has one): each loads
//! and stands where its example puts it, a ray down the axis hitting its
//! front at the expected distance with its normal facing the ray.

use crate::common;

use glam::Vec3;
use prism::geometry::Ray;
use prism::load::format::ShapeKind;
use prism::load::load_str;

/// The `[[shape]]` table of a `kind` facing +z at the origin, and where a
/// ray from (0, 0, 5) down −z meets it.
fn example(kind: ShapeKind, dir: &std::path::Path) -> (String, f32) {
    match kind {
        ShapeKind::Obj => {
            let obj = "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nf 1 2 3 4\n";
            std::fs::write(dir.join("quad.obj"), obj).unwrap();
            ("file = \"quad.obj\"".into(), 5.0)
        }
        ShapeKind::Gltf => {
            let mut b = common::assets::GltfBuilder::default();
            let prim = common::assets::quad(&mut b, true);
            let json = b.json(&format!(
                r#""scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0}}],"meshes":[{{"primitives":[{prim}}}]}}]"#
            ));
            let file = common::assets::write_glb(dir, "quad", &json, &b.bin);
            (format!("file = \"{file}\""), 5.0)
        }
        ShapeKind::Quad => (
            "vertices = [[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]]".into(),
            5.0,
        ),
        ShapeKind::Sphere => ("radius = 1".into(), 4.0),
    }
}

#[test]
fn every_shape_type_loads_and_stands_where_it_is_put() {
    let dir = tempfile::tempdir().unwrap();
    for &kind in ShapeKind::ALL {
        let (keys, distance) = example(kind, dir.path());
        let text = format!(
            "[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\n\
             [[shape]]\ntype = \"{}\"\n{keys}\n",
            kind.name()
        );
        let loaded = load_str(&text, dir.path()).unwrap_or_else(|e| panic!("{kind:?}: {e}"));
        let ray = Ray::new(Vec3::new(0.1, 0.05, 5.0), -Vec3::Z);
        let hit = loaded
            .scene
            .intersect(&ray)
            .unwrap_or_else(|| panic!("{kind:?}: the ray misses"));
        assert!(
            (hit.t - distance).abs() < 0.01,
            "{kind:?}: hit at {}, expected {distance}",
            hit.t
        );
        assert!(hit.ng.dot(ray.dir) < 0.0, "{kind:?}: normal {}", hit.ng);
    }
}

/// One schema per type: every key of another shape type that this type
/// does not take is refused, and the error names the key in full with the
/// line it is on.
#[test]
fn every_shape_type_refuses_the_keys_of_the_others() {
    let dir = tempfile::tempdir().unwrap();
    for &kind in ShapeKind::ALL {
        let (keys, _) = example(kind, dir.path());
        for &other in ShapeKind::ALL {
            for &key in other.keys() {
                if kind.keys().contains(&key) {
                    continue;
                }
                let text = format!(
                    "[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\n\
                     [[shape]]\ntype = \"{}\"\n{keys}\n{key} = 1\n",
                    kind.name()
                );
                let e = match load_str(&text, dir.path()) {
                    Ok(_) => panic!("{kind:?} took `{key}` of {other:?}"),
                    Err(e) => e.to_string(),
                };
                assert!(
                    e.contains(&format!("`shape[0].{key}` does not apply"))
                        && e.contains(&format!("line 7, column 1\n  |\n7 | {key} = 1")),
                    "{kind:?} with `{key}`: {e}"
                );
            }
        }
    }
}
