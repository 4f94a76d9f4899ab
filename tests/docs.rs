//! The reference pages stay true to the code: every key of the scene file
//! (each field of the structs in `src/scene/file.rs`, by its name in the
//! file) is documented in `docs/scenes.md`, and the example scene there is
//! one drape reads.

use std::path::Path;

fn repo(path: &str) -> String {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(path);
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// The keys a scene file can hold: the fields of every struct in
/// `file.rs`, renamed as serde renames them.
fn scene_keys() -> Vec<String> {
    let source = repo("src/scene/file.rs");
    let mut keys = Vec::new();
    let mut rename = None;
    let mut in_struct = false;
    for line in source.lines().map(str::trim) {
        if line.starts_with("pub struct ") && line.ends_with('{') {
            in_struct = true;
        } else if line == "}" {
            in_struct = false;
        } else if let Some(attribute) = line.strip_prefix("#[serde(").filter(|_| in_struct) {
            if let Some(start) = attribute.find("rename = \"") {
                let name = &attribute[start + 10..];
                rename = name.split('"').next().map(str::to_owned);
            }
        } else if let Some(field) = line.strip_prefix("pub ").filter(|_| in_struct) {
            let name = field.split(':').next().unwrap_or_default().trim().to_owned();
            keys.push(rename.take().unwrap_or(name));
        }
    }
    keys.sort();
    keys.dedup();
    keys
}

#[test]
fn every_scene_key_is_documented() {
    let doc = repo("docs/scenes.md");
    let keys = scene_keys();
    assert!(keys.len() > 40, "the struct fields were found: {keys:?}");
    let missing: Vec<&String> = keys
        .iter()
        .filter(|k| {
            let forms = [format!("`{k}`"), format!("{k} ="), format!("[{k}]"), format!(".{k}]")];
            !forms.iter().any(|form| doc.contains(form.as_str()))
        })
        .collect();
    assert!(missing.is_empty(), "docs/scenes.md does not document: {missing:?}");
}

#[test]
fn the_example_scene_of_the_reference_is_a_valid_scene() {
    let doc = repo("docs/scenes.md");
    let example = doc.split("```toml\n").nth(1).and_then(|rest| rest.split("```").next()).expect("a toml block");
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/scenes");
    drape::scene::Scene::parse(example, "example", &dir, "docs/scenes.md").unwrap_or_else(|e| panic!("{e}"));
}
