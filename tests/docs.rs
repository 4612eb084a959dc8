//! The guide against the code: the scene-format reference documents every
//! key the parser takes and no key it refuses (with the types each applies
//! to), the command-line page every flag of `--help`, the README stays a
//! short user's guide, and every picture and CSV under docs/ is linked from
//! a page.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::process::Command;

use prism::integrator::{CommonParams, IntegratorKind};
use prism::load::format::{
    CameraSpec, DirectionalLightSpec, EnvironmentSpec, FilmSpec, LightCommon, MediumSpec,
    PhaseSpec, PointLightSpec, RotateSpec, SceneFile, ShapeCommon, ShapeKind, SkySpec,
    SpotLightSpec, TransformSpec,
};
use prism::schema::keys_of;

use crate::common::{files_under, ticked};

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn read(path: &str) -> String {
    std::fs::read_to_string(root().join(path)).unwrap_or_else(|e| panic!("{path}: {e}"))
}

/// A page's sections by their `## ` heading (the text before the first
/// heading under "").
fn sections(page: &str) -> BTreeMap<String, String> {
    let mut out = BTreeMap::new();
    let mut heading = String::new();
    for line in page.lines() {
        if let Some(h) = line.strip_prefix("## ") {
            heading = h.to_string();
        }
        let text: &mut String = out.entry(heading.clone()).or_default();
        text.push_str(line);
        text.push('\n');
    }
    out
}

fn section<'a>(sections: &'a BTreeMap<String, String>, starts: &str) -> &'a str {
    sections
        .iter()
        .find(|(h, _)| h.starts_with(starts))
        .unwrap_or_else(|| panic!("no section `{starts}` in docs/scene-format.md"))
        .1
}

/// The rows of the key tables of a section (tables whose header has a
/// `key` column): each row's keys (backticked names in the key cell) with
/// its `applies to` cell, or "" in tables without one.
fn rows(text: &str) -> Vec<(Vec<String>, String)> {
    let mut out = Vec::new();
    let mut columns: Option<(usize, Option<usize>)> = None;
    for line in text.lines() {
        if !line.starts_with('|') {
            columns = None;
            continue;
        }
        let cells: Vec<&str> = line.trim_matches('|').split('|').map(str::trim).collect();
        if cells.iter().all(|c| c.starts_with("---")) {
            continue;
        }
        match columns {
            None => {
                columns = cells
                    .iter()
                    .position(|c| *c == "key")
                    .map(|k| (k, cells.iter().position(|c| *c == "applies to")));
            }
            Some((key, applies)) => {
                let names = ticked(cells[key]);
                out.push((names, applies.map_or("", |a| cells[a]).to_string()));
            }
        }
    }
    out
}

/// Checks one table: every key the parser takes is named in the section
/// (backticked), and every key of its key tables is one the parser takes.
fn check_table(name: &str, text: &str, parser: &BTreeSet<&str>) {
    for key in parser {
        assert!(
            text.contains(&format!("`{key}`")),
            "docs/scene-format.md, {name}: the parser takes `{key}`, the reference does not name it"
        );
    }
    for (keys, _) in rows(text) {
        for key in keys {
            assert!(
                parser.contains(key.as_str()),
                "docs/scene-format.md, {name}: documents `{key}`, which the parser refuses \
                 (it takes {parser:?})"
            );
        }
    }
}

/// Checks the `applies to` column of a typed table: "all" for a key every
/// type takes, else the types listed are those whose schema has the key.
fn check_applies_to(name: &str, text: &str, common: &[&str], types: &[(&str, &[&str])]) {
    for (keys, applies) in rows(text) {
        for key in keys.iter().filter(|k| *k != "type") {
            let documented: BTreeSet<String> = if applies == "all" {
                types.iter().map(|(t, _)| t.to_string()).collect()
            } else {
                applies
                    .split(',')
                    .map(|t| t.trim().trim_start_matches("tessellated ").to_string())
                    .collect()
            };
            let actual: BTreeSet<String> = types
                .iter()
                .filter(|(_, keys)| common.contains(&key.as_str()) || keys.contains(&key.as_str()))
                .map(|(t, _)| t.to_string())
                .collect();
            assert_eq!(
                documented, actual,
                "docs/scene-format.md, {name}: `{key}` applies to {actual:?}, the reference says {applies:?}"
            );
        }
    }
}

fn set(keys: &[&'static str]) -> BTreeSet<&'static str> {
    keys.iter().copied().collect()
}

#[test]
fn the_scene_reference_documents_every_key_the_parser_takes_and_no_other() {
    let page = read("docs/scene-format.md");
    let s = sections(&page);
    for key in keys_of::<SceneFile>() {
        let table = match *key {
            "shape" | "light" => format!("`[[{key}]]`"),
            "units" => "`units".to_string(),
            _ => format!("`[{key}"),
        };
        assert!(
            page.contains(&table),
            "the top-level `{key}` is not documented"
        );
    }
    check_table(
        "[camera]",
        section(&s, "`[camera]`"),
        &set(keys_of::<CameraSpec>()),
    );
    check_table(
        "[film]",
        section(&s, "`[film]`"),
        &set(keys_of::<FilmSpec>()),
    );

    let integrator = section(&s, "`[integrator]`");
    let mut keys = set(keys_of::<CommonParams>());
    keys.insert("type");
    let kinds: Vec<(&str, &[&str])> = IntegratorKind::ALL
        .iter()
        .map(|k| (k.name(), k.own_keys()))
        .collect();
    keys.extend(kinds.iter().flat_map(|(_, k)| k.iter().copied()));
    check_table("[integrator]", integrator, &keys);
    check_applies_to(
        "[integrator]",
        integrator,
        keys_of::<CommonParams>(),
        &kinds,
    );

    let shape = section(&s, "`[[shape]]`");
    let mut keys = set(keys_of::<ShapeCommon>());
    keys.insert("type");
    let kinds: Vec<(&str, &[&str])> = ShapeKind::ALL
        .iter()
        .map(|k| (k.name(), k.keys()))
        .collect();
    keys.extend(kinds.iter().flat_map(|(_, k)| k.iter().copied()));
    check_table("[[shape]]", shape, &keys);
    check_applies_to("[[shape]]", shape, keys_of::<ShapeCommon>(), &kinds);
    for key in keys_of::<TransformSpec>()
        .iter()
        .chain(keys_of::<RotateSpec>())
    {
        assert!(
            shape.contains(&format!("{key} =")),
            "`transform.{key}` is not documented"
        );
    }

    let light = section(&s, "`[[light]]`");
    let kinds: [(&str, &[&str]); 3] = [
        ("point", keys_of::<PointLightSpec>()),
        ("spot", keys_of::<SpotLightSpec>()),
        ("directional", keys_of::<DirectionalLightSpec>()),
    ];
    let mut keys = set(keys_of::<LightCommon>());
    keys.insert("type");
    keys.extend(kinds.iter().flat_map(|(_, k)| k.iter().copied()));
    check_table("[[light]]", light, &keys);
    check_applies_to("[[light]]", light, keys_of::<LightCommon>(), &kinds);
    for (kind, _) in kinds {
        assert!(light.contains(&format!("\"{kind}\"")), "light type {kind}");
    }

    check_table(
        "[environment]",
        section(&s, "`[environment]`"),
        &set(keys_of::<EnvironmentSpec>()),
    );
    check_table(
        "sky",
        section(&s, "The sky and sun"),
        &set(keys_of::<SkySpec>()),
    );

    let materials = section(&s, "`[materials.NAME]`");
    let mut keys = set(keys_of::<MediumSpec>());
    keys.extend(keys_of::<PhaseSpec>());
    for key in &keys {
        assert!(
            materials.contains(&format!("`{key}`")) || materials.contains(&format!("{key} =")),
            "medium key `{key}`"
        );
    }
    check_materials(materials);
}

/// The names a parser error lists after "expected one of", on that line.
fn expected_one_of(error: &str) -> BTreeSet<String> {
    let (_, list) = error
        .split_once("expected one of")
        .unwrap_or_else(|| panic!("{error}"));
    ticked(list.lines().next().unwrap()).into_iter().collect()
}

/// Material types are variants with keys of their own: the parser's keys
/// of each are read from its error for an unknown key.
fn check_materials(text: &str) {
    let parser_keys = |kind: &str| -> BTreeSet<String> {
        let scene = format!(
            "[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\n\
             [materials.m]\ntype = \"{kind}\"\nnot_a_key = 1\n"
        );
        let e = match prism::load::load_str(&scene, root()) {
            Ok(_) => panic!("{kind} took `not_a_key`"),
            Err(e) => e.to_string(),
        };
        expected_one_of(&e)
    };
    // The rows by type: a row with a type in its first cell starts a type.
    let mut documented: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    let mut kind = String::new();
    let mut in_table = false;
    for line in text.lines() {
        if !line.starts_with('|') {
            in_table = false;
            continue;
        }
        let cells: Vec<&str> = line.trim_matches('|').split('|').map(str::trim).collect();
        if cells.len() >= 2 && cells[0] == "type" && cells[1] == "key" {
            in_table = true;
            continue;
        }
        if !in_table || cells[0].starts_with("---") {
            continue;
        }
        if let Some(k) = cells[0]
            .strip_prefix("`\"")
            .and_then(|k| k.strip_suffix("\"`"))
        {
            kind = k.to_string();
        }
        if kind.is_empty() {
            continue;
        }
        let keys = ticked(cells[1]);
        documented.entry(kind.clone()).or_default().extend(keys);
    }
    assert!(documented.len() >= 4, "{documented:?}");
    for (kind, keys) in &documented {
        assert_eq!(
            keys,
            &parser_keys(kind),
            "docs/scene-format.md, materials of type {kind:?}: documented keys against the parser's"
        );
    }
    // Every type the parser knows, from its error for an unknown type.
    let scene = "[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\n\
                 [materials.m]\ntype = \"not_a_type\"\n";
    let e = prism::load::load_str(scene, root())
        .err()
        .unwrap()
        .to_string();
    assert_eq!(
        expected_one_of(&e),
        documented.keys().cloned().collect(),
        "material types: the parser's against the reference's"
    );
}

/// The long flags of a subcommand's `--help`.
fn flags(subcommand: &str) -> BTreeSet<String> {
    let out = Command::new(env!("CARGO_BIN_EXE_prism"))
        .args([subcommand, "--help"])
        .output()
        .unwrap();
    assert!(out.status.success());
    String::from_utf8(out.stdout)
        .unwrap()
        .lines()
        .map(str::trim_start)
        .filter(|l| l.starts_with('-'))
        .flat_map(|l| {
            l.split([' ', ',', '='])
                .map(str::to_string)
                .collect::<Vec<_>>()
        })
        .filter(|w| w.starts_with("--") && w.len() > 2)
        .collect()
}

#[test]
fn the_command_line_page_documents_every_flag_and_no_other() {
    let page = read("docs/command-line.md");
    let words: BTreeSet<&str> = page
        .split(|c: char| !(c.is_ascii_alphanumeric() || c == '-'))
        .collect();
    let mut all = BTreeSet::new();
    for sub in ["render", "merge", "bench", "info", "spectrum"] {
        for flag in flags(sub) {
            if flag == "--help" {
                continue;
            }
            assert!(
                words.contains(flag.as_str()),
                "docs/command-line.md does not document `prism {sub} {flag}`"
            );
            all.insert(flag);
        }
        assert!(page.contains(&format!("prism {sub}")), "prism {sub}");
    }
    for word in words {
        if word.starts_with("--") && word.len() > 2 && !word.starts_with("---") {
            assert!(
                all.contains(word) || word == "--help",
                "docs/command-line.md names `{word}`, which no subcommand takes"
            );
        }
    }
}

#[test]
fn the_readme_is_a_short_guide_with_the_two_set_up_commands() {
    let readme = read("README.md");
    let lines = readme.lines().count();
    assert!(lines <= 300, "README.md has {lines} lines");
    assert!(readme.contains("\ncargo run --release -- render scenes/cornell-box.toml\n"));
    assert!(readme.contains("\ntools/test.sh\n"));
}

#[test]
fn every_picture_and_table_under_docs_is_linked_from_a_page() {
    let docs = root().join("docs");
    let pages: Vec<(PathBuf, String)> = files_under(&docs)
        .into_iter()
        .chain([root().join("README.md"), root().join("ARCHITECTURE.md")])
        .filter(|p| p.extension().is_some_and(|e| e == "md"))
        .map(|p| {
            let text = std::fs::read_to_string(&p).unwrap();
            (p, text)
        })
        .collect();
    // What the pages cite: names, and globs such as `run*.{png,csv}`.
    let tokens: Vec<&str> = pages
        .iter()
        .flat_map(|(_, text)| text.split(|c: char| c.is_whitespace() || "`()[]:;\"'".contains(c)))
        .filter(|t| t.contains('.'))
        .collect();
    for file in files_under(&docs) {
        if file.extension().is_some_and(|e| e == "md") {
            continue;
        }
        let name = file.file_name().unwrap().to_str().unwrap();
        let cited = tokens.iter().any(|t| {
            let t = t.trim_end_matches(['.', ',']);
            let base = t.rsplit('/').next().unwrap();
            expand(base).iter().any(|pattern| matches(pattern, name))
        });
        assert!(cited, "{} is cited by no page", file.display());
    }
    // And every link of a page leads to a file.
    for (page, text) in &pages {
        for link in text.split("](").skip(1) {
            let target = link.split([')', '#']).next().unwrap();
            if target.is_empty() || target.contains("://") || target.starts_with('<') {
                continue;
            }
            let path = page.parent().unwrap().join(target);
            assert!(path.exists(), "{}: broken link {target}", page.display());
        }
    }
}

/// A glob's alternatives: `a{,-b}.{png,csv}` is four patterns.
fn expand(glob: &str) -> Vec<String> {
    let Some(open) = glob.find('{') else {
        return vec![glob.to_string()];
    };
    let Some(close) = glob[open..].find('}').map(|c| open + c) else {
        return vec![glob.to_string()];
    };
    glob[open + 1..close]
        .split(',')
        .flat_map(|alt| expand(&format!("{}{alt}{}", &glob[..open], &glob[close + 1..])))
        .collect()
}

/// Whether `name` matches `pattern`, where `*` stands for any run of
/// characters.
fn matches(pattern: &str, name: &str) -> bool {
    match pattern.split_once('*') {
        None => pattern == name,
        Some((head, tail)) => {
            name.starts_with(head) && (head.len()..=name.len()).any(|i| matches(tail, &name[i..]))
        }
    }
}

/// The shell blocks marked `<!-- runnable -->` in README.md and docs/,
/// each a script (Python blocks so marked run in `python/tests`).
fn runnable_blocks() -> Vec<(String, String)> {
    let mut out = Vec::new();
    let pages = files_under(&root().join("docs"))
        .into_iter()
        .chain([root().join("README.md")])
        .filter(|p| p.extension().is_some_and(|e| e == "md"));
    for page in pages {
        let text = std::fs::read_to_string(&page).unwrap();
        for block in text.split("<!-- runnable -->\n").skip(1) {
            if block.starts_with("```python\n") {
                // Run by the Python suite (python/tests/test_docs.py).
                continue;
            }
            let body = block
                .strip_prefix("```sh\n")
                .and_then(|b| b.split_once("\n```"))
                .unwrap_or_else(|| panic!("{}: a runnable block must be ```sh", page.display()))
                .0;
            out.push((page.display().to_string(), body.to_string()));
        }
    }
    out
}

/// Every runnable block runs as written, from the repository's root, with
/// `prism` (or `target/release/prism`) the binary under test and each
/// render made small (`--resolution 48x32` in place of the block's).
#[test]
fn the_runnable_examples_run_as_written() {
    let blocks = runnable_blocks();
    assert!(blocks.len() >= 3, "{} runnable blocks", blocks.len());
    let dir = tempfile::tempdir().unwrap();
    for name in ["scenes", "spectra", "tools"] {
        std::os::unix::fs::symlink(root().join(name), dir.path().join(name)).unwrap();
    }
    let small = r#"prism() {
  local args=() skip=0
  for a in "$@"; do
    if [ $skip = 1 ]; then skip=0; continue; fi
    if [ "$a" = --resolution ]; then skip=1; continue; fi
    args+=("$a")
  done
  if [ "${args[0]}" = render ]; then args+=(--resolution 48x32); fi
  "$PRISM_UNDER_TEST" "${args[@]}"
}
"#;
    for (page, body) in blocks {
        let script = format!("{small}{}", body.replace("target/release/prism", "prism"));
        let out = Command::new("bash")
            .args(["-euo", "pipefail", "-c", &script])
            .current_dir(dir.path())
            .env("PRISM_UNDER_TEST", env!("CARGO_BIN_EXE_prism"))
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{page}: the block\n{body}\nfailed:\n{}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
}
