//! The sweep folder on disk: writing it from a sweep, its manifest, and
//! what state each variant is in (module doc of [`super`] has the layout).

use std::path::{Path, PathBuf};

use super::FarmError;
use super::sweep::{Sweep, plain};
use super::variant::{key, resolve};
use crate::io::atomic::write_file;

/// The manifest's file name.
pub const MANIFEST: &str = "manifest.csv";
/// A complete bake's folder, inside a variant's folder.
pub const BAKE: &str = "bake";
/// A bake in progress (resumed by the next task), inside a variant's folder.
pub const PARTIAL: &str = "bake.partial";
/// Why a variant's simulation stopped, inside its folder.
pub const FAILED: &str = "failed.txt";
/// The key a folder was written or baked for.
pub const KEY: &str = "key";

/// One row of the manifest.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Entry {
    /// Variant number, from 0.
    pub index: usize,
    /// Its folder, relative to the sweep folder.
    pub folder: String,
    /// Its key (SHA-256, hex).
    pub key: String,
    /// Frames to bake (empty: the scene's range).
    pub frames: Option<usize>,
    /// Whether the task also measures the error against the reference.
    pub reference: bool,
    /// Short label, e.g. `preset silk · friction 0.2`.
    pub label: String,
    /// The values it sets, `key=value` joined by `; `.
    pub settings: String,
}

impl Entry {
    /// The variant's folder.
    pub fn dir(&self, sweep_dir: &Path) -> PathBuf {
        sweep_dir.join(&self.folder)
    }
}

/// Where a variant stands.
#[derive(Clone, Debug, PartialEq)]
pub enum VariantState {
    /// Its bake is complete, for its current key.
    Finished,
    /// Its simulation stopped: the message (with the frame).
    Failed(String),
    /// A bake was started and not finished (running, or to be resumed).
    Started,
    /// Nothing done yet.
    Pending,
}

impl VariantState {
    /// One word for tables.
    pub fn word(&self) -> &'static str {
        match self {
            VariantState::Finished => "finished",
            VariantState::Failed(_) => "failed",
            VariantState::Started => "started",
            VariantState::Pending => "pending",
        }
    }
}

/// Writes the sweep folder `dir` for `sweep`: each variant's resolved scene
/// and key, the manifest and a copy of the sweep file. A variant whose key
/// is unchanged keeps its bake; one whose key changed loses its old results.
/// Nothing is written unless every variant resolves.
pub fn write_sweep(sweep: &Sweep, dir: &Path) -> Result<Vec<Entry>, FarmError> {
    let mut resolved = Vec::with_capacity(sweep.variants.len());
    for (index, variant) in sweep.variants.iter().enumerate() {
        let bad = |problem: String| FarmError::Variant { index, label: variant.label(), problem };
        let scene = resolve(&sweep.base, &variant.settings).map_err(bad)?;
        let key = key(&scene, sweep.frames, sweep.reference).map_err(|e| bad(e.to_string()))?;
        let settings: Vec<String> = variant.settings.iter().map(|(k, v)| format!("{k}={}", plain(v))).collect();
        let entry = Entry {
            index,
            folder: format!("v{index:04}"),
            key,
            frames: sweep.frames,
            reference: sweep.reference,
            label: variant.label(),
            settings: settings.join("; "),
        };
        resolved.push((entry, scene.scene_text));
    }
    std::fs::create_dir_all(dir).map_err(|e| FarmError::io(dir, e))?;
    for (entry, scene_text) in &resolved {
        write_variant(&entry.dir(dir), &entry.key, scene_text)?;
    }
    let entries: Vec<Entry> = resolved.into_iter().map(|(entry, _)| entry).collect();
    write_manifest(dir, &entries)?;
    let sweep_text = std::fs::read(&sweep.path).map_err(|e| FarmError::io(&sweep.path, e))?;
    write(&dir.join("sweep.toml"), &sweep_text)?;
    Ok(entries)
}

/// Writes one variant's folder; old results of another key go.
fn write_variant(folder: &Path, key: &str, scene_text: &str) -> Result<(), FarmError> {
    let old_key = std::fs::read_to_string(folder.join(KEY)).ok();
    if old_key.as_deref() != Some(key) {
        for stale in [BAKE, PARTIAL] {
            let path = folder.join(stale);
            if path.exists() {
                std::fs::remove_dir_all(&path).map_err(|e| FarmError::io(&path, e))?;
            }
        }
        let failed = folder.join(FAILED);
        if failed.exists() {
            std::fs::remove_file(&failed).map_err(|e| FarmError::io(&failed, e))?;
        }
    }
    std::fs::create_dir_all(folder).map_err(|e| FarmError::io(folder, e))?;
    write(&folder.join("scene.toml"), scene_text.as_bytes())?;
    write(&folder.join(KEY), key.as_bytes())
}

fn write(path: &Path, bytes: &[u8]) -> Result<(), FarmError> {
    write_file(path, |out| std::io::Write::write_all(out, bytes)).map_err(|e| FarmError::io(path, e.source))
}

fn write_manifest(dir: &Path, entries: &[Entry]) -> Result<(), FarmError> {
    let path = dir.join(MANIFEST);
    let mut csv = csv::Writer::from_writer(Vec::new());
    for entry in entries {
        csv.serialize(entry).map_err(|e| FarmError::Folder { dir: dir.to_owned(), problem: e.to_string() })?;
    }
    let bytes = csv.into_inner().map_err(|e| FarmError::Folder { dir: dir.to_owned(), problem: e.to_string() })?;
    write(&path, &bytes)
}

/// The manifest of the sweep folder `dir`.
pub fn read_manifest(dir: &Path) -> Result<Vec<Entry>, FarmError> {
    let path = dir.join(MANIFEST);
    let bad = |problem: String| FarmError::Folder { dir: dir.to_owned(), problem };
    let text = std::fs::read(&path).map_err(|e| match e.kind() {
        std::io::ErrorKind::NotFound => {
            bad(format!("no {MANIFEST}: not a sweep folder (`drape sweep SPEC --out DIR` writes one)"))
        }
        _ => FarmError::io(&path, e),
    })?;
    let mut reader = csv::Reader::from_reader(text.as_slice());
    let entries: Result<Vec<Entry>, _> = reader.deserialize().collect();
    let entries = entries.map_err(|e| bad(format!("{MANIFEST}: {e}")))?;
    if entries
        .iter()
        .enumerate()
        .any(|(k, e)| e.index != k || e.folder.contains(['/', '\\']) || e.folder.starts_with('.'))
    {
        return Err(bad(format!("{MANIFEST}: rows out of order or folders outside the sweep")));
    }
    Ok(entries)
}

/// Where the variant `entry` of the sweep folder `dir` stands.
pub fn state(dir: &Path, entry: &Entry) -> VariantState {
    let folder = entry.dir(dir);
    let baked_key = std::fs::read_to_string(folder.join(BAKE).join(KEY)).ok();
    if baked_key.as_deref() == Some(entry.key.as_str()) {
        return VariantState::Finished;
    }
    if let Ok(reason) = std::fs::read_to_string(folder.join(FAILED)) {
        return VariantState::Failed(reason.trim().to_owned());
    }
    if folder.join(PARTIAL).exists() { VariantState::Started } else { VariantState::Pending }
}
