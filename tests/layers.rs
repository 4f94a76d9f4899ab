//! Arrows point down (ARCHITECTURE.md): no module of `src/` imports one that
//! imports it back (directly or round a loop), and no top-level module
//! imports one of a higher layer. Read from the source: each file's `crate::`
//! and `super::` paths outside comments and its test module.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// The layers, bottom first: a module may use its own layer and those below.
const LAYERS: [&[&str]; 5] = [
    &["mesh"],
    &["io", "sim", "body"],
    &["render", "scene", "metrics"],
    &["bench", "bake", "export", "stage", "fabric_lab"],
    &["app", "farm", "untrusted"],
];

/// `crate::a::b` for `src/a/b.rs` or `src/a/b/mod.rs` (`crate` for the roots).
fn module_of(file: &Path) -> String {
    let relative = file.strip_prefix(Path::new(env!("CARGO_MANIFEST_DIR")).join("src")).unwrap();
    let mut parts: Vec<String> = relative.with_extension("").iter().map(|p| p.to_string_lossy().into_owned()).collect();
    if parts.last().is_some_and(|p| p == "mod") {
        parts.pop();
    }
    if parts == ["lib"] || parts == ["main"] {
        parts.clear();
    }
    std::iter::once("crate".to_owned()).chain(parts).collect::<Vec<_>>().join("::")
}

fn rust_files(dir: &Path, out: &mut Vec<std::path::PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap().flatten() {
        let path = entry.path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// The code of `text` without comments and without its test module.
fn code(text: &str) -> String {
    let text = text.split("#[cfg(test)]\nmod tests").next().unwrap_or_default();
    text.lines().filter(|l| !l.trim_start().starts_with("//")).collect::<Vec<_>>().join("\n")
}

/// Every module a file's code names (the longest known module of each path),
/// but its own parents and children.
fn imports(module: &str, text: &str, known: &BTreeSet<String>) -> BTreeSet<String> {
    let here: Vec<&str> = module.split("::").collect();
    let mut found = BTreeSet::new();
    let words: Vec<&str> = text.split(|c: char| !(c.is_alphanumeric() || c == '_' || c == ':')).collect();
    for word in words.iter().filter(|w| w.starts_with("crate::") || w.starts_with("super::")) {
        let mut parts: Vec<&str> = word.split("::").filter(|p| !p.is_empty()).collect();
        let mut base: Vec<&str> = if parts[0] == "crate" { vec!["crate"] } else { here.clone() };
        if parts[0] == "crate" {
            parts.remove(0);
        }
        while parts.first() == Some(&"super") {
            base.pop();
            parts.remove(0);
        }
        let path: Vec<&str> = base.into_iter().chain(parts).collect();
        let target = (1..=path.len()).rev().map(|k| path[..k].join("::")).find(|m| known.contains(m));
        if let Some(target) = target {
            let related = target == module
                || module.starts_with(&format!("{target}::"))
                || target.starts_with(&format!("{module}::"));
            if !related {
                found.insert(target);
            }
        }
    }
    found
}

fn graph() -> BTreeMap<String, BTreeSet<String>> {
    let mut files = Vec::new();
    rust_files(&Path::new(env!("CARGO_MANIFEST_DIR")).join("src"), &mut files);
    let known: BTreeSet<String> = files.iter().map(|f| module_of(f)).collect();
    files
        .iter()
        .map(|f| {
            let module = module_of(f);
            let deps = imports(&module, &code(&std::fs::read_to_string(f).unwrap()), &known);
            (module, deps)
        })
        .collect()
}

/// Modules on a loop of imports (each loop's members, sorted).
fn loops(graph: &BTreeMap<String, BTreeSet<String>>) -> Vec<Vec<String>> {
    let reaches = |from: &str| {
        let mut seen = BTreeSet::new();
        let mut todo: Vec<&str> = graph[from].iter().map(String::as_str).collect();
        while let Some(m) = todo.pop() {
            if seen.insert(m.to_owned()) {
                todo.extend(graph.get(m).into_iter().flatten().map(String::as_str));
            }
        }
        seen
    };
    let reach: BTreeMap<&str, BTreeSet<String>> = graph.keys().map(|m| (m.as_str(), reaches(m))).collect();
    let mut found: BTreeSet<Vec<String>> = BTreeSet::new();
    for (m, r) in &reach {
        if r.contains(*m) {
            found.insert(r.iter().filter(|o| reach[o.as_str()].contains(*m)).cloned().collect());
        }
    }
    found.into_iter().collect()
}

fn layer(top: &str) -> Option<usize> {
    LAYERS.iter().position(|l| l.contains(&top))
}

#[test]
fn no_module_imports_one_that_imports_it_back() {
    let graph = graph();
    assert!(graph.len() > 100, "the modules were found: {}", graph.len());
    assert_eq!(loops(&graph), Vec::<Vec<String>>::new(), "modules on a loop of imports");
}

#[test]
fn imports_point_down_the_layers() {
    let mut upward = Vec::new();
    for (module, deps) in graph() {
        let top = module.split("::").nth(1).unwrap_or_default().to_owned();
        for dep in deps {
            let dep_top = dep.split("::").nth(1).unwrap_or_default();
            if let (Some(from), Some(to)) = (layer(&top), layer(dep_top))
                && to > from
            {
                upward.push(format!("{module} -> {dep}"));
            }
        }
    }
    assert!(upward.is_empty(), "imports that run up the layers: {upward:#?}");
}
