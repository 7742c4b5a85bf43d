//! The crate's layers: every `crate::` path in `rust/src` points to its own layer or to a
//! lower one, never up (lib.rs, which re-exports the public API, is the top).
//!
//! Run alone with `cargo test --test layers`; it reads the sources, so it also catches an
//! import added without a build.

use std::path::{Path, PathBuf};

/// The layers from the bottom up: the first component of a module path under `rust/src`.
const LAYERS: &[&[&str]] = &[
    &["error"],
    &["threads"],
    &["options", "sparse"],
    &["element"],
    &["mesh"],
    &["topology"],
    &["assembly"],
    &["analysis"],
    &["solve"],
];

fn layer(module: &str) -> Option<usize> {
    LAYERS.iter().position(|l| l.contains(&module))
}

fn sources(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            sources(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// Every `crate::NAME` in the code of `text` (comments and doc links left out; NAME: the
/// first path component after `crate::`, every name of a `crate::{A, B::c}` group).
fn crate_paths(text: &str) -> Vec<String> {
    let code: String = text
        .lines()
        .filter(|l| !l.trim_start().starts_with("//"))
        .map(|l| format!("{l}\n"))
        .collect();
    let word = |s: &str| -> String { s.chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect() };
    let mut names = vec![];
    for (i, m) in code.match_indices("crate::") {
        let rest = &code[i + m.len()..];
        match rest.strip_prefix('{') {
            Some(group) => {
                let group = &group[..group.find('}').unwrap_or(group.len())];
                names.extend(group.split(',').map(|item| word(item.trim())).filter(|w| !w.is_empty()));
            }
            None => names.push(word(rest)),
        }
    }
    names
}

#[test]
fn no_module_imports_from_a_higher_layer() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("rust/src");
    let mut files = vec![];
    sources(&root, &mut files);
    files.sort();
    let mut violations = vec![];
    for file in &files {
        let relative = file.strip_prefix(&root).unwrap();
        let first = relative.components().next().unwrap().as_os_str().to_str().unwrap();
        let own = first.trim_end_matches(".rs");
        if own == "lib" {
            continue;
        }
        let Some(own_layer) = layer(own) else {
            panic!("{} is in no layer: add it to LAYERS", relative.display());
        };
        let text = std::fs::read_to_string(file).unwrap();
        for name in crate_paths(&text) {
            // names re-exported by lib.rs (types and functions) resolve to their module's layer
            let target = layer(&name).or_else(|| reexported_layer(&name));
            match target {
                Some(l) if l <= own_layer => {}
                Some(l) => violations.push(format!(
                    "{} (layer {own_layer}) uses crate::{name} (layer {l})",
                    relative.display()
                )),
                None => violations.push(format!("{}: crate::{name} is in no layer", relative.display())),
            }
        }
    }
    assert!(violations.is_empty(), "imports from a higher layer:\n{}", violations.join("\n"));
}

/// The layer of an item that `lib.rs` re-exports, from its `pub use MODULE::...` lines.
fn reexported_layer(name: &str) -> Option<usize> {
    let lib = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("rust/src/lib.rs")).unwrap();
    let mut statement = String::new();
    for line in lib.lines().map(str::trim) {
        if line.starts_with("pub use ") || !statement.is_empty() {
            statement.push_str(line);
            statement.push(' ');
            if !line.ends_with(';') {
                continue;
            }
            let module = statement["pub use ".len()..].split("::").next().unwrap_or("").to_string();
            let items = &statement[statement.find("::").map_or(0, |i| i + 2)..];
            let holds = items
                .split(|c: char| !(c.is_alphanumeric() || c == '_'))
                .any(|word| word == name);
            statement.clear();
            if holds {
                return layer(&module);
            }
        }
    }
    None
}

#[test]
fn the_check_sees_an_upward_import() {
    // a self-test of the parser: the names of a `use` line and of a path in code
    assert_eq!(crate_paths("use crate::mesh::MeshView; crate::assembly::install::<S, _>"), ["mesh", "assembly"]);
    assert_eq!(crate_paths("use crate::{laplacian, sparse::Csr};\n/// [`crate::analysis`]"), ["laplacian", "sparse"]);
    assert_eq!(layer("element"), Some(3));
    assert!(layer("analysis") > layer("assembly"));
    assert_eq!(reexported_layer("MeshView"), layer("mesh"));
    assert_eq!(reexported_layer("laplacian"), layer("assembly"));
}
