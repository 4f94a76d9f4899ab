//! Every reader of drape on bytes from anywhere: the entry points of the
//! fuzz targets (`fuzz/`) and of the bounded property tests and corpus runs
//! of the test command. The property they all check: any byte string gives
//! `Ok` or an error that names the problem, never a panic, and no reader
//! allocates more than its input can justify (counts from headers are
//! checked against the size first).

use std::path::Path;

use crate::bake::resume;
use crate::io::{fbx, motion_cache, obj, pc2};
use crate::scene::Scene;
use crate::scene::preset::Preset;

/// A file format drape reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// A garment OBJ.
    Obj,
    /// A binary FBX body.
    Fbx,
    /// A scene file (TOML).
    Scene,
    /// A fabric preset (TOML).
    Preset,
    /// A motion cache.
    MotionCache,
    /// A PC2 point cache.
    Pc2,
    /// A bake's resume checkpoint (`.resume/checkpoint.bin`).
    Checkpoint,
}

impl Format {
    /// Every format, with the name of its fuzz target and corpus folder.
    pub const ALL: [(Format, &'static str); 7] = [
        (Format::Obj, "obj"),
        (Format::Fbx, "fbx"),
        (Format::Scene, "scene"),
        (Format::Preset, "preset"),
        (Format::MotionCache, "motion_cache"),
        (Format::Pc2, "pc2"),
        (Format::Checkpoint, "checkpoint"),
    ];
}

/// The name hostile bytes are read under (errors name it; nothing is read
/// from beside it).
const ORIGIN: &str = "/nonexistent/untrusted";

/// Reads `bytes` as `format`: `Ok` or the error message, as a user would see it.
pub fn read(format: Format, bytes: &[u8]) -> Result<(), String> {
    let text = || std::str::from_utf8(bytes).map_err(|e| format!("{ORIGIN}: not UTF-8 ({e})"));
    match format {
        Format::Obj => obj::parse_obj(bytes, Path::new(ORIGIN)).map(drop).map_err(|e| e.to_string()),
        Format::Fbx => fbx::parse_fbx(bytes, Path::new(ORIGIN)).map(drop).map_err(|e| e.to_string()),
        Format::Scene => {
            Scene::parse(text()?, "untrusted", Path::new(ORIGIN), ORIGIN).map(drop).map_err(|e| e.to_string())
        }
        Format::Preset => Preset::parse(text()?, ORIGIN, &toml::Table::new()).map(drop).map_err(|e| e.to_string()),
        Format::MotionCache => motion_cache::parse(bytes).map(drop),
        Format::Pc2 => pc2::read_pc2(bytes).map(drop).map_err(|e| e.to_string()),
        Format::Checkpoint => read_checkpoint(bytes),
    }
}

/// A checkpoint read as `--resume` reads one, its state checked against a
/// simulation of its own size. The payload is also decoded without the
/// header and checksum, so a fuzzer's mutations reach the decoder.
fn read_checkpoint(bytes: &[u8]) -> Result<(), String> {
    let check = |c: resume::Checkpoint| {
        let s = &c.snapshot;
        s.check(s.positions.len(), 1, s.factor.is_some()).map_err(|e| e.to_string())
    };
    let unwrapped = resume::decode_payload(bytes).and_then(check);
    resume::decode(bytes).and_then(check).or(unwrapped)
}
