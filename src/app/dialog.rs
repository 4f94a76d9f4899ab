//! File dialogs (drawn by egui_file, so they work the same on every
//! platform, under Xvfb and in UI tests): what a dialog is for, which files
//! it offers, and paths written relative to the scene's folder. What
//! choosing a file does to the editor is `browse.rs`.

use std::path::{Path, PathBuf};

use egui_file::FileDialog;

/// What a file dialog chooses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Purpose {
    /// A scene file to open.
    OpenScene,
    /// Where to save the scene.
    SaveScene,
    /// The selected garment's OBJ.
    Garment,
    /// The first body's FBX or motion cache.
    Body,
    /// Another file's motion for the first body.
    Motion,
    /// A fabric preset file to load.
    LoadFabric,
    /// Where to save the fabric parameters.
    SaveFabric,
    /// The export folder.
    ExportFolder,
}

impl Purpose {
    /// The dialog's title.
    fn title(self) -> &'static str {
        match self {
            Purpose::OpenScene => "Open a scene",
            Purpose::SaveScene => "Save the scene as",
            Purpose::Garment => "Garment OBJ",
            Purpose::Body => "Body: FBX or motion cache",
            Purpose::Motion => "Motion from another FBX",
            Purpose::LoadFabric => "Load fabric parameters",
            Purpose::SaveFabric => "Save fabric parameters as",
            Purpose::ExportFolder => "Export folder",
        }
    }

    /// File name extensions offered (lower case); empty for folders.
    pub fn extensions(self) -> &'static [&'static str] {
        match self {
            Purpose::OpenScene | Purpose::SaveScene | Purpose::LoadFabric | Purpose::SaveFabric => &["toml"],
            Purpose::Garment => &["obj"],
            Purpose::Body => &["fbx", "motion"],
            Purpose::Motion => &["fbx"],
            Purpose::ExportFolder => &[],
        }
    }
}

/// An open file dialog and what it is for.
pub struct Browse {
    /// What it is for.
    pub purpose: Purpose,
    /// The dialog (egui_file).
    pub dialog: FileDialog,
}

impl Browse {
    /// Opens a dialog for `purpose`, starting at `start` (a file or folder).
    pub fn open(purpose: Purpose, start: &Path) -> Browse {
        let extensions = purpose.extensions();
        let mut dialog = match purpose {
            Purpose::ExportFolder => FileDialog::select_folder(),
            Purpose::SaveScene | Purpose::SaveFabric => FileDialog::save_file(),
            _ => FileDialog::open_file(),
        }
        .title(purpose.title())
        .initial_path(start)
        .default_size([640.0, 420.0]);
        if !extensions.is_empty() {
            dialog = dialog.show_files_filter(Box::new(move |path: &Path| has_extension(path, extensions)));
        }
        dialog.open();
        Browse { purpose, dialog }
    }
}

/// `path` relative to `folder` (with `..` where it lies outside), so that a
/// saved scene still finds it when the project folder moves; absolute when
/// the two share no root (another drive).
pub fn relative_to(path: &Path, folder: &Path) -> PathBuf {
    let absolute = |p: &Path| normalised(&std::path::absolute(p).unwrap_or_else(|_| p.to_owned()));
    let (path, folder) = (absolute(path), absolute(folder));
    let shared = path.components().zip(folder.components()).take_while(|(a, b)| a == b).count();
    if shared == 0 {
        return path;
    }
    let up = folder.components().count() - shared;
    std::iter::repeat_n(std::path::Component::ParentDir.as_os_str(), up)
        .chain(path.components().skip(shared).map(|c| c.as_os_str()))
        .collect()
}

/// `path` without `.` and `..` components (lexically).
fn normalised(path: &Path) -> PathBuf {
    let mut out = PathBuf::new();
    for part in path.components() {
        match part {
            std::path::Component::CurDir => {}
            std::path::Component::ParentDir => {
                out.pop();
            }
            other => out.push(other),
        }
    }
    out
}

/// True when `path`'s extension is one of `extensions` (any case).
fn has_extension(path: &Path, extensions: &[&str]) -> bool {
    path.extension().is_some_and(|e| extensions.iter().any(|x| e.eq_ignore_ascii_case(x)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chosen_files_are_written_relative_to_the_scene_folder() {
        let scene_folder = Path::new("/work/assets/scenes");
        let inside = Path::new("/work/assets/scenes/../scenes/cloth/skirt.obj");
        assert_eq!(relative_to(inside, scene_folder), Path::new("cloth/skirt.obj"));
        let beside = Path::new("/work/assets/garments/skirt.obj");
        assert_eq!(relative_to(beside, scene_folder), Path::new("../garments/skirt.obj"));
    }

    #[test]
    fn dialogs_offer_only_the_files_their_purpose_reads() {
        assert!(has_extension(Path::new("walk.FBX"), Purpose::Body.extensions()));
        assert!(has_extension(Path::new("walk.motion"), Purpose::Body.extensions()));
        assert!(!has_extension(Path::new("skirt.obj"), Purpose::Body.extensions()));
        assert!(has_extension(Path::new("skirt.obj"), Purpose::Garment.extensions()));
        assert!(!has_extension(Path::new("README"), Purpose::OpenScene.extensions()));
    }
}
