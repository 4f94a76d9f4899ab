//! Baked cloth into the formats other tools read, with the body it was
//! simulated on: USD (`.usda`: Maya, Houdini, Unreal, Omniverse, Blender),
//! glTF 2.0 (`.glb`: browsers, three.js, Blender) and MDD point caches
//! (Marvelous Designer, Houdini, Modo), from a finished bake folder or
//! from the frames the editor holds.
//!
//! Every file is written to a temporary and renamed when whole: an export
//! that fails or is cancelled leaves nothing behind.

pub mod content;
pub mod gltf;
pub mod usd;

use std::ops::RangeInclusive;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};

use self::content::{Content, Role};
use crate::bake::summary::BakeSummary;
use crate::io::atomic::{WriteError, write_file};
use crate::io::mdd;
use crate::scene::{Scene, SceneError};
use crate::stage::baked::{BakedFrames, BakedFramesError};

/// A format drape exports to.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Format {
    /// USD, as a `.usda` text layer.
    Usd,
    /// glTF 2.0, as a binary `.glb`.
    Gltf,
    /// MDD point caches, one `.mdd` per garment.
    Mdd,
}

impl Format {
    /// Every format, by the name the command line and the editor use.
    pub const ALL: [(Format, &'static str); 3] = [(Format::Usd, "usd"), (Format::Gltf, "gltf"), (Format::Mdd, "mdd")];

    /// The format called `name` (`usd`, `gltf`, `mdd`).
    pub fn named(name: &str) -> Option<Format> {
        Format::ALL.iter().find(|(_, n)| n.eq_ignore_ascii_case(name.trim())).map(|(f, _)| *f)
    }

    /// Its name.
    pub fn name(self) -> &'static str {
        Format::ALL.iter().find(|(f, _)| *f == self).map_or("", |(_, n)| n)
    }
}

/// What to export and where.
#[derive(Clone, Debug, PartialEq)]
pub struct ExportRequest {
    /// The format.
    pub format: Format,
    /// The file (USD, glTF) or folder (MDD) to write; default: in the bake
    /// folder, named after the scene.
    pub out: Option<PathBuf>,
    /// The frames to export (default: all).
    pub frames: Option<RangeInclusive<usize>>,
    /// Export the bodies (every mesh) too.
    pub body: bool,
    /// glTF: a morph target every this many frames, the weights animated
    /// linearly between them (1: every frame).
    pub every: usize,
    /// glTF: positions and normals as 16-bit integers (KHR_mesh_quantization).
    pub quantize: bool,
}

impl ExportRequest {
    /// Everything, every frame, in `format`, to the default place.
    pub fn new(format: Format) -> ExportRequest {
        ExportRequest { format, out: None, frames: None, body: true, every: 1, quantize: false }
    }
}

/// Why an export failed.
#[derive(Debug, thiserror::Error)]
pub enum ExportError {
    /// The folder is not a bake drape can export.
    #[error("{dir} is not a bake folder drape can export: {problem}")]
    NotABake {
        /// The folder.
        dir: PathBuf,
        /// What is missing.
        problem: String,
    },
    /// The scene of the bake cannot be read.
    #[error(transparent)]
    Scene(#[from] Box<SceneError>),
    /// The bake's point caches cannot be read.
    #[error(transparent)]
    Frames(#[from] BakedFramesError),
    /// Frames outside the bake were asked for.
    #[error("frames {first}..{last} are outside the bake, which has frames 0..{available}")]
    OutsideBake {
        /// First frame asked for.
        first: usize,
        /// Last frame asked for.
        last: usize,
        /// Last frame of the bake.
        available: usize,
    },
    /// A value the format cannot hold.
    #[error("{0}")]
    Invalid(String),
    /// The output could not be written.
    #[error(transparent)]
    Write(#[from] WriteError),
    /// Stopped on request; nothing was written.
    #[error("the export was cancelled; nothing was written")]
    Cancelled,
}

/// How an export went: the files written and their sizes, bytes.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ExportReport {
    /// Each file written and its size.
    pub files: Vec<(PathBuf, u64)>,
}

/// Reads a finished bake folder: its scene (from its summary, or `scene`)
/// and its frames.
pub fn open_bake(dir: &Path, scene: Option<&Path>) -> Result<(Scene, BakedFrames), ExportError> {
    let not = |problem: String| ExportError::NotABake { dir: dir.to_owned(), problem };
    if !dir.is_dir() {
        return Err(not("no such folder".into()));
    }
    let text = std::fs::read_to_string(dir.join("summary.json"))
        .map_err(|e| not(format!("summary.json cannot be read ({e}); bake the scene with drape bake")))?;
    let summary: BakeSummary =
        serde_json::from_str(&text).map_err(|e| not(format!("summary.json is not a bake summary ({e})")))?;
    if !summary.complete {
        return Err(not("the bake is unfinished: finish it with drape bake SCENE --out DIR --resume".into()));
    }
    let scene_path = match (scene, &summary.scene_file) {
        (Some(path), _) => path.to_owned(),
        (None, Some(file)) => PathBuf::from(file),
        (None, None) => return Err(not("its summary names no scene file: give it with --scene".into())),
    };
    let scene = Scene::load(&scene_path).map_err(Box::new)?;
    let frames = BakedFrames::open(dir, &scene)?;
    Ok((scene, frames))
}

/// The bake frames `range` asks for (all of `count` by default).
pub fn frame_numbers(range: Option<&RangeInclusive<usize>>, count: usize) -> Result<Vec<usize>, ExportError> {
    let last = count.saturating_sub(1);
    match range {
        None => Ok((0..count).collect()),
        Some(r) if *r.end() <= last && r.start() <= r.end() => Ok(r.clone().collect()),
        Some(r) => Err(ExportError::OutsideBake { first: *r.start(), last: *r.end(), available: last }),
    }
}

/// Exports `frames` of `scene` as `request` says; `default_dir` holds the
/// files when the request names none; `progress` hears the work done of
/// the total (meshes × frames); `stop` cancels.
pub fn export(
    scene: &Scene,
    frames: &BakedFrames,
    request: &ExportRequest,
    default_dir: &Path,
    progress: &dyn Fn(usize, usize),
    stop: &AtomicBool,
) -> Result<ExportReport, ExportError> {
    let numbers = frame_numbers(request.frames.as_ref(), frames.frame_count())?;
    if numbers.is_empty() {
        return Err(ExportError::Invalid("the bake has no frames to export".into()));
    }
    if request.every == 0 {
        return Err(ExportError::Invalid("--every 0: a morph target every 0 frames is no frame at all".into()));
    }
    let content = Content::new(scene, frames, numbers, request.body && request.format != Format::Mdd);
    let work = Work { total: content.meshes.len() * content.frame_numbers.len(), progress, stop };
    let file_name = |extension: &str| default_dir.join(format!("{}.{extension}", scene.name));
    match request.format {
        Format::Usd => {
            let out = request.out.clone().unwrap_or_else(|| file_name("usda"));
            write_one(&out, |w| usd::write(&content, &out, w, &work))
        }
        Format::Gltf => {
            let out = request.out.clone().unwrap_or_else(|| file_name("glb"));
            let options = gltf::Options { every: request.every, quantize: request.quantize };
            write_one(&out, |w| gltf::write(&content, options, w, &work))
        }
        Format::Mdd => write_mdd(&content, request.out.as_deref().unwrap_or(default_dir), &work),
    }
}

/// Progress and cancellation shared by the writers.
pub struct Work<'a> {
    total: usize,
    progress: &'a dyn Fn(usize, usize),
    stop: &'a AtomicBool,
}

impl Work<'_> {
    /// Reports `done` units of work; an error once cancelled.
    pub fn done(&self, done: usize) -> std::io::Result<()> {
        (self.progress)(done.min(self.total), self.total);
        match self.stop.load(Ordering::Relaxed) {
            true => Err(std::io::Error::new(std::io::ErrorKind::Interrupted, "cancelled")),
            false => Ok(()),
        }
    }
}

/// Writes one file atomically with `write`; a cancel is reported as one.
fn write_one(
    out: &Path,
    write: impl FnOnce(&mut std::io::BufWriter<std::fs::File>) -> std::io::Result<()>,
) -> Result<ExportReport, ExportError> {
    if let Some(parent) = out.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(parent).map_err(|source| WriteError { path: parent.to_owned(), source })?;
    }
    match write_file(out, write) {
        Ok(()) => Ok(ExportReport { files: vec![(out.to_owned(), file_size(out))] }),
        Err(e) if e.source.kind() == std::io::ErrorKind::Interrupted => Err(ExportError::Cancelled),
        Err(e) if e.source.kind() == std::io::ErrorKind::InvalidData => Err(ExportError::Invalid(e.source.to_string())),
        Err(e) => Err(e.into()),
    }
}

fn file_size(path: &Path) -> u64 {
    std::fs::metadata(path).map_or(0, |m| m.len())
}

/// One MDD file per garment, `<garment>.mdd` in `dir`.
fn write_mdd(content: &Content<'_>, dir: &Path, work: &Work<'_>) -> Result<ExportReport, ExportError> {
    let mut report = ExportReport::default();
    let mut done = 0;
    let mut positions = Vec::new();
    for (index, mesh) in content.meshes.iter().enumerate().filter(|(_, m)| m.role == Role::Garment) {
        let out = dir.join(format!("{}.mdd", mesh.name));
        let file = write_one(&out, |w| {
            mdd::write_header(w, content.frame_numbers.len(), mesh.vertex_count, content.fps)?;
            for &frame in &content.frame_numbers {
                content.positions(index, frame, &mut positions);
                let points: Vec<[f32; 3]> = positions.iter().map(|p| [p.x as f32, p.y as f32, p.z as f32]).collect();
                mdd::write_frame(w, &points)?;
                done += 1;
                work.done(done)?;
            }
            Ok(())
        })?;
        report.files.extend(file.files);
    }
    Ok(report)
}
