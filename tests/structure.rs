//! The code's shape, checked against ARCHITECTURE.md: top-level modules
//! import only from lower layers (its "Layers" table), and no function in
//! src/ is over 120 lines nor any file over 600, except those its "Size
//! exceptions" table names with a reason.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use crate::common::{files_under, ticked};

const MAX_FUNCTION_LINES: usize = 120;
const MAX_FILE_LINES: usize = 600;

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// The lines of ARCHITECTURE.md's section `title` (a `## ` heading).
fn section(title: &str) -> Vec<String> {
    let text = std::fs::read_to_string(root().join("ARCHITECTURE.md")).unwrap();
    let heading = format!("## {title}");
    text.lines()
        .skip_while(|l| l.trim() != heading)
        .skip(1)
        .take_while(|l| !l.starts_with("## "))
        .map(str::to_string)
        .collect()
}

/// Each module of the Layers table with its layer number.
fn layers() -> BTreeMap<String, u32> {
    let mut out = BTreeMap::new();
    for line in section("Layers") {
        let cells: Vec<&str> = line.split('|').map(str::trim).collect();
        let Some(layer) = cells.get(1).and_then(|c| c.parse::<u32>().ok()) else {
            continue;
        };
        for module in ticked(cells[2]) {
            assert!(
                out.insert(module.clone(), layer).is_none(),
                "{module} listed twice"
            );
        }
    }
    assert!(out.len() > 10, "no Layers table found: {out:?}");
    out
}

fn rust_files(dir: &Path) -> Vec<PathBuf> {
    files_under(dir)
        .into_iter()
        .filter(|p| p.extension().is_some_and(|e| e == "rs"))
        .collect()
}

/// The top-level module a file of src/ belongs to (None for the binary's
/// main.rs and lib.rs).
fn module_of(file: &Path) -> Option<String> {
    let relative = file.strip_prefix(root().join("src")).unwrap();
    let first = relative.components().next()?.as_os_str().to_str()?;
    let name = first.trim_end_matches(".rs");
    (name != "main" && name != "lib").then(|| name.to_string())
}

/// Code lines of a file: comments dropped (a doc comment may name any
/// module).
fn code_lines(text: &str) -> impl Iterator<Item = (usize, &str)> {
    text.lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.split("//").next().unwrap_or("")))
}

#[test]
fn modules_import_only_from_lower_layers() {
    let layers = layers();
    let mut seen = BTreeSet::new();
    let mut wrong = Vec::new();
    for file in rust_files(&root().join("src")) {
        let Some(module) = module_of(&file) else {
            continue;
        };
        seen.insert(module.clone());
        let Some(&own) = layers.get(&module) else {
            wrong.push(format!("{module} is not in ARCHITECTURE.md's Layers table"));
            continue;
        };
        let text = std::fs::read_to_string(&file).unwrap();
        for (n, line) in code_lines(&text) {
            for part in line.split("crate::").skip(1) {
                let target: String = part
                    .chars()
                    .take_while(|c| c.is_alphanumeric() || *c == '_')
                    .collect();
                if target == module || target.is_empty() {
                    continue;
                }
                match layers.get(&target) {
                    Some(&layer) if layer < own => {}
                    Some(&layer) => wrong.push(format!(
                        "{}:{n}: {module} (layer {own}) imports {target} (layer {layer})",
                        file.display()
                    )),
                    None => wrong.push(format!(
                        "{}:{n}: {target} is not in the Layers table",
                        file.display()
                    )),
                }
            }
        }
    }
    let listed: BTreeSet<String> = layers.keys().cloned().collect();
    for gone in listed.difference(&seen) {
        wrong.push(format!("the Layers table lists {gone}, which src/ lacks"));
    }
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
}

/// The Size exceptions table: `src/…/file.rs` or `src/…/file.rs::function`.
fn size_exceptions() -> BTreeSet<String> {
    section("Size exceptions")
        .iter()
        .filter(|l| l.starts_with('|'))
        .filter_map(|l| ticked(l.split('|').nth(1)?).into_iter().next())
        .collect()
}

/// Functions of a file with their lengths in lines: from the `fn` line to
/// the closing brace at its indentation.
fn functions(text: &str) -> Vec<(String, usize)> {
    let lines: Vec<&str> = text.lines().collect();
    let mut out = Vec::new();
    for (i, line) in lines.iter().enumerate() {
        let trimmed = line.trim_start();
        let indent = &line[..line.len() - trimmed.len()];
        let signature = trimmed
            .trim_start_matches("pub(crate) ")
            .trim_start_matches("pub(super) ")
            .trim_start_matches("pub ")
            .trim_start_matches("const ")
            .trim_start_matches("unsafe ");
        let Some(rest) = signature.strip_prefix("fn ") else {
            continue;
        };
        let name: String = rest
            .chars()
            .take_while(|c| c.is_alphanumeric() || *c == '_')
            .collect();
        // A declaration without a body (a trait's) ends with `;` before any `{`.
        let body = lines[i..]
            .iter()
            .find_map(|l| {
                let l = l.split("//").next().unwrap_or("");
                if l.contains('{') {
                    Some(true)
                } else if l.trim_end().ends_with(';') {
                    Some(false)
                } else {
                    None
                }
            })
            .unwrap_or(false);
        if !body {
            continue;
        }
        let close = format!("{indent}}}");
        if let Some(end) = lines[i..].iter().position(|l| *l == close) {
            out.push((name, end + 1));
        }
    }
    out
}

#[test]
fn functions_and_files_stay_short() {
    let exceptions = size_exceptions();
    let mut used = BTreeSet::new();
    let mut long = Vec::new();
    for file in rust_files(&root().join("src")) {
        let name = file
            .strip_prefix(root())
            .unwrap()
            .to_string_lossy()
            .into_owned();
        let text = std::fs::read_to_string(&file).unwrap();
        let lines = text.lines().count();
        if lines > MAX_FILE_LINES {
            if exceptions.contains(&name) {
                used.insert(name.clone());
            } else {
                long.push(format!("{name}: {lines} lines"));
            }
        }
        for (function, length) in functions(&text) {
            let key = format!("{name}::{function}");
            if length > MAX_FUNCTION_LINES {
                if exceptions.contains(&key) {
                    used.insert(key);
                } else {
                    long.push(format!("{key}: {length} lines"));
                }
            }
        }
    }
    for stale in exceptions.difference(&used) {
        long.push(format!(
            "{stale} is named in ARCHITECTURE.md's Size exceptions but is within the limits (or gone)"
        ));
    }
    assert!(
        long.is_empty(),
        "over {MAX_FUNCTION_LINES} lines a function or {MAX_FILE_LINES} a file, and not named in ARCHITECTURE.md's Size exceptions:\n{}",
        long.join("\n")
    );
}

#[test]
fn the_function_scanner_measures_a_known_function() {
    let text =
        "fn a() {\n    let x = 1;\n}\n\nimpl T {\n    pub fn b(&self) {\n        x\n    }\n}\n";
    assert_eq!(
        functions(text),
        [("a".to_string(), 3), ("b".to_string(), 3)]
    );
}

/// The integration tests are one crate (`autotests = false`): a file of
/// tests/ that tests/suite.rs does not name as a module would never be
/// compiled or run.
#[test]
fn every_test_file_is_a_module_of_the_suite() {
    let suite = std::fs::read_to_string(root().join("tests/suite.rs")).unwrap();
    let declared: BTreeSet<String> = suite
        .lines()
        .filter_map(|l| l.strip_prefix("mod ")?.strip_suffix(';'))
        .map(str::to_string)
        .collect();
    for file in std::fs::read_dir(root().join("tests")).unwrap() {
        let path = file.unwrap().path();
        let Some(stem) = path.file_stem().and_then(|s| s.to_str()) else {
            continue;
        };
        if path.extension().is_some_and(|e| e == "rs") && stem != "suite" {
            assert!(
                declared.contains(stem),
                "tests/{stem}.rs is not a module of tests/suite.rs: it would never run"
            );
        }
    }
}
