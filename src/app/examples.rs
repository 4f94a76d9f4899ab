//! The example scenes shipped in `assets/scenes/`, for File ▸ Examples:
//! the demos apart from the hard cases (`kind = "hard-case"`), each with its
//! description.

use std::path::{Path, PathBuf};

use crate::scene::file::{SceneFile, SceneKind};

/// Where the examples are, relative to the working folder.
const EXAMPLES: &str = "assets/scenes";

/// One example scene.
#[derive(Clone, Debug, PartialEq)]
pub struct Example {
    /// Its scene file.
    pub path: PathBuf,
    /// The file's stem, e.g. `skirt_walk`.
    pub name: String,
    /// The scene's `description`.
    pub description: String,
    /// Demo or hard case.
    pub kind: SceneKind,
}

/// The examples folder: in the working folder, else where drape was built.
pub fn examples_folder() -> PathBuf {
    let here = PathBuf::from(EXAMPLES);
    if here.is_dir() { here } else { Path::new(env!("CARGO_MANIFEST_DIR")).join(EXAMPLES) }
}

/// The scene files in `folder` (not its subfolders), by name; files that do
/// not read as scenes are left out (opening one says why).
pub fn examples_in(folder: &Path) -> Vec<Example> {
    let entries = std::fs::read_dir(folder).into_iter().flatten().flatten();
    let mut examples: Vec<Example> = entries.filter_map(|entry| example(entry.path())).collect();
    examples.sort_by(|a, b| a.name.cmp(&b.name));
    examples
}

fn example(path: PathBuf) -> Option<Example> {
    if path.extension()? != "toml" {
        return None;
    }
    let file: SceneFile = toml::from_str(&std::fs::read_to_string(&path).ok()?).ok()?;
    let name = path.file_stem()?.to_string_lossy().into_owned();
    Some(Example { path, name, description: file.description, kind: file.kind })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_shipped_examples_split_into_demos_and_the_hard_cases_of_scenes_md() {
        let examples = examples_in(&examples_folder());
        let named =
            |kind| -> Vec<&str> { examples.iter().filter(|e| e.kind == kind).map(|e| e.name.as_str()).collect() };
        let hard = [
            "bad_mesh",
            "fast_body",
            "large_step",
            "needles",
            "pinch_drag",
            "projectile",
            "pull_through_funnel",
            "sleeve_elbow",
            "spin_sphere",
            "spin_sphere_grip",
            "stiff",
            "twist",
        ];
        assert_eq!(named(SceneKind::HardCase), hard);
        assert!(named(SceneKind::Demo).contains(&"skirt_walk"));
        assert!(examples.iter().all(|e| !e.description.is_empty()), "every example says what it is");
    }
}
