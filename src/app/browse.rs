//! What choosing a file does in the editor: from a file dialog
//! ([`super::dialog`]) or dropped on the window.

use std::path::{Path, PathBuf};

use super::dialog::{Purpose, relative_to};
use super::editor::Editor;

/// Uses a file dropped on the window for what it is: a scene opens, an OBJ
/// replaces the selected garment's mesh, an FBX or motion cache the body;
/// anything else is refused with a message.
pub fn dropped(editor: &mut Editor, path: PathBuf) {
    let extension = path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase()).unwrap_or_default();
    let purpose = match extension.as_str() {
        "toml" => Purpose::OpenScene,
        "obj" => Purpose::Garment,
        "fbx" | "motion" => Purpose::Body,
        _ => {
            let problem = "not a scene, garment OBJ, body FBX or motion cache";
            return editor.tell(format!("{}: {problem}", path.display()), true);
        }
    };
    choose(editor, purpose, path);
}

/// Draws the editor's open dialog, if any, and carries out the choice.
pub fn show(ctx: &egui::Context, editor: &mut Editor) {
    let Some(browse) = &mut editor.browse else { return };
    let chosen = browse.dialog.show(ctx).selected().then(|| browse.dialog.path().map(Path::to_owned)).flatten();
    let purpose = browse.purpose;
    if !browse.dialog.visible() {
        editor.browse = None;
    }
    if let Some(path) = chosen {
        editor.browse = None;
        choose(editor, purpose, path);
    }
}

/// What choosing `path` (as the dialog or the window gives it: absolute or
/// relative to the working folder) for `purpose` does. Files the scene refers
/// to are written relative to the scene's folder.
pub fn choose(editor: &mut Editor, purpose: Purpose, path: PathBuf) {
    let path = match purpose {
        Purpose::Garment | Purpose::Body | Purpose::Motion | Purpose::LoadFabric => {
            relative_to(&path, &editor.base_dir())
        }
        _ => path,
    };
    let shown = path.display().to_string();
    match purpose {
        Purpose::OpenScene => {
            editor.paths.scene = shown;
            editor.open_scene(path);
        }
        Purpose::SaveScene => {
            editor.paths.scene = shown;
            editor.save_scene(&path);
        }
        Purpose::Garment => {
            editor.paths.garment = shown;
            editor.use_garment_mesh(path);
        }
        Purpose::Body => {
            editor.paths.body = shown;
            editor.use_body(path);
        }
        Purpose::Motion => {
            editor.paths.motion = shown;
            editor.use_motion(path);
        }
        Purpose::LoadFabric => {
            editor.paths.fabric = shown.clone();
            editor.choose_preset(&shown);
        }
        Purpose::SaveFabric => {
            editor.paths.fabric = shown;
            editor.save_fabric(&path);
        }
        Purpose::ExportFolder => editor.paths.export = shown,
    }
}
