//! Checking a whole OBJ sequence, ours or another program's, with the
//! independent checker (`drape check-bake`).
//!
//! Frames are the folder's `.obj` files ordered by the number at the end of
//! their names (`frame_0007.obj`, `cloth000007.obj`); all geometry in a frame
//! is cloth. Colliders come from a scene, if one is given, at time
//! `(n − n₀) / fps` for frame number `n` (the first file is time 0).

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::intersections::{Checker, Intersections};
use crate::io::obj::{FrameMesh, ObjError, read_frame};
use crate::sim::colliders::Collider;
use crate::sim::collision::obstacles::MeshCollider;

/// What a sequence is checked against: the scene's colliders, and its frame
/// rate (to place moving colliders at each frame's time).
#[derive(Clone, Copy, Debug)]
pub struct Obstacles<'a> {
    /// The analytic colliders.
    pub colliders: &'a [Collider],
    /// The mesh colliders (bodies, props).
    pub mesh_colliders: &'a [MeshCollider],
    /// Frames per second of the sequence.
    pub fps: f64,
}

/// Why a sequence could not be checked.
#[derive(Debug, thiserror::Error)]
pub enum SequenceError {
    /// The folder could not be listed.
    #[error("cannot read the folder {path}: {source}")]
    Folder {
        /// The folder.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// No frame files.
    #[error("{path} holds no .obj files to check")]
    NoFrames {
        /// The folder.
        path: PathBuf,
    },
    /// A frame file's name carries no frame number.
    #[error("{path}: the file name does not end in a frame number (expected e.g. frame_0007.obj)")]
    Unnumbered {
        /// The file.
        path: PathBuf,
    },
    /// A frame file could not be read.
    #[error(transparent)]
    Obj(#[from] ObjError),
}

/// What the checker found in one frame file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FrameCheck {
    /// Frame number from the file name.
    pub frame: u64,
    /// File name.
    pub file: String,
    /// Cloth triangles in the frame.
    pub triangles: usize,
    /// What was found.
    pub intersections: Intersections,
}

/// The frame files of `dir`, ordered by frame number.
pub fn frame_files(dir: &Path) -> Result<Vec<(u64, PathBuf)>, SequenceError> {
    let folder_error = |source| SequenceError::Folder { path: dir.to_owned(), source };
    let mut frames = Vec::new();
    for entry in std::fs::read_dir(dir).map_err(folder_error)? {
        let path = entry.map_err(folder_error)?.path();
        if path.extension().and_then(|e| e.to_str()).is_none_or(|e| !e.eq_ignore_ascii_case("obj")) {
            continue;
        }
        let stem = path.file_stem().and_then(|s| s.to_str()).unwrap_or_default();
        let digits = &stem[stem.trim_end_matches(|c: char| c.is_ascii_digit()).len()..];
        match digits.parse::<u64>() {
            Ok(n) => frames.push((n, path)),
            Err(_) => return Err(SequenceError::Unnumbered { path }),
        }
    }
    if frames.is_empty() {
        return Err(SequenceError::NoFrames { path: dir.to_owned() });
    }
    frames.sort();
    Ok(frames)
}

/// Checks every frame of the sequence in `dir` (against `obstacles`, if
/// given), calling `on_frame` with each check and the frame it read.
pub fn check_sequence(
    dir: &Path,
    obstacles: Option<Obstacles>,
    mut on_frame: impl FnMut(&FrameCheck, &FrameMesh),
) -> Result<Vec<FrameCheck>, SequenceError> {
    let files = frame_files(dir)?;
    let first = files[0].0;
    let mut checks = Vec::with_capacity(files.len());
    for (frame, path) in files {
        let mesh = read_frame(&path)?;
        let checker = match obstacles {
            Some(o) => Checker::new(mesh.triangles.clone(), o.colliders, o.mesh_colliders),
            None => Checker::new(mesh.triangles.clone(), &[], &[]),
        };
        let time = obstacles.map_or(0.0, |o| (frame - first) as f64 / o.fps);
        let check = FrameCheck {
            frame,
            file: path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default(),
            triangles: mesh.triangles.len(),
            intersections: checker.check(&mesh.positions, time),
        };
        on_frame(&check, &mesh);
        checks.push(check);
    }
    Ok(checks)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(dir: &Path, name: &str, text: &str) {
        std::fs::write(dir.join(name), text).unwrap();
    }

    /// Two triangles far apart, or the second pierced through the first.
    fn frame(pierce: bool) -> String {
        let y = if pierce { -0.5 } else { 2.0 };
        format!(
            "o a\nv 0 0 0\nv 1 0 0\nv 0 0 1\ng part\no b\nv 0.2 {y} 0.2\nv 0.2 {} 0.2\nv 0.3 {y} 0.4\nf 1 2 3\nf 4 5 6\n",
            y + 1.0
        )
    }

    #[test]
    fn frames_are_ordered_by_number_and_piercings_are_counted() {
        let dir = tempfile::tempdir().unwrap();
        write(dir.path(), "cloth10.obj", &frame(true));
        write(dir.path(), "cloth9.obj", &frame(false));
        write(dir.path(), "notes.txt", "not a frame");
        let checks = check_sequence(dir.path(), None, |_, _| {}).unwrap();
        assert_eq!(checks.iter().map(|c| c.frame).collect::<Vec<_>>(), [9, 10]);
        assert_eq!(checks[0].intersections.pairs(), 0);
        assert_eq!(checks[1].intersections.cloth_pairs, 1);
    }

    #[test]
    fn corners_split_between_groups_are_one_vertex() {
        let dir = tempfile::tempdir().unwrap();
        // Two triangles sharing an edge, in different groups: tobj splits the
        // shared corners, the reader merges them, so they are adjacent (and
        // touching along that edge is not an intersection).
        write(dir.path(), "f_1.obj", "v 0 0 0\nv 1 0 0\nv 0 0 1\nv 1 0.5 1\ng a\nf 1 2 3\ng b\nf 2 4 3\n");
        let checks = check_sequence(dir.path(), None, |_, _| {}).unwrap();
        assert_eq!((checks[0].triangles, checks[0].intersections.pairs()), (2, 0));
    }

    #[test]
    fn bad_folders_and_files_are_named() {
        let dir = tempfile::tempdir().unwrap();
        assert!(matches!(check_sequence(dir.path(), None, |_, _| {}), Err(SequenceError::NoFrames { .. })));
        write(dir.path(), "final.obj", &frame(false));
        let e = check_sequence(dir.path(), None, |_, _| {}).unwrap_err();
        assert!(e.to_string().contains("final.obj") && e.to_string().contains("frame number"), "{e}");
        std::fs::remove_file(dir.path().join("final.obj")).unwrap();
        write(dir.path(), "f_3.obj", "v 0 0 0\nv 1 0 zero\nf 1 2 1\n");
        let e = check_sequence(dir.path(), None, |_, _| {}).unwrap_err();
        assert!(e.to_string().contains("f_3.obj") && e.to_string().contains("line 2"), "{e}");
        let missing = dir.path().join("missing");
        assert!(check_sequence(&missing, None, |_, _| {}).unwrap_err().to_string().contains("missing"));
    }
}
