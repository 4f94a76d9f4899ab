//! FBX bodies: binary FBX 7.x read with fbxcel-dom, interpreted here into a
//! [`Body`] (mesh, skeleton, skin, animation) in drape's world (Y up, metres).
//!
//! What is read: the first skinned mesh (or the first mesh, as a static body),
//! `Vertices`, `PolygonVertexIndex` (polygons fanned into triangles), UVs and
//! per-polygon materials; the Model hierarchy above the skin's bones with
//! `Lcl Translation / Rotation / Scaling`, `RotationOrder`, `PreRotation`,
//! `PostRotation`, pivots and offsets; Skin → Cluster `Indexes`, `Weights`,
//! `Transform`, `TransformLink` (at most four influences per vertex,
//! normalised); the first AnimationStack's curves (KeyTime in FBX ticks of
//! 1/46 186 158 000 s, KeyValueFloat, constant / linear / cubic keys); and
//! GlobalSettings' axes and UnitScaleFactor.

mod nodes;
mod scene;

use std::path::{Path, PathBuf};

use crate::body::Body;

/// The start of every binary FBX file.
const BINARY_MAGIC: &[u8] = b"Kaydara FBX Binary  \0";
/// Oldest FBX version read (7.0); fbxcel reads 7.x.
const OLDEST_VERSION: u32 = 7000;

/// Why an FBX file cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum FbxError {
    /// The file could not be read.
    #[error("cannot read {path}: {source}")]
    Read {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// ASCII FBX.
    #[error("{path} is an ASCII FBX file, which drape does not read: re-export it as binary FBX 7.4 or later")]
    Ascii {
        /// The file.
        path: PathBuf,
    },
    /// FBX 6 or older.
    #[error("{path} is FBX version {version}, which drape does not read: re-export it as binary FBX 7.4 or later")]
    OldVersion {
        /// The file.
        path: PathBuf,
        /// The version number in the header (e.g. 6100).
        version: u32,
    },
    /// Not an FBX file.
    #[error("{path} is not an FBX file (no binary FBX header)")]
    NotFbx {
        /// The file.
        path: PathBuf,
    },
    /// The binary structure is broken (truncated, corrupt, or an encoding
    /// the reader does not support).
    #[error("{path} is damaged or uses an unsupported encoding: {problem}. Re-export it as binary FBX 7.4")]
    Malformed {
        /// The file.
        path: PathBuf,
        /// What the parser found.
        problem: String,
    },
    /// The content is not what a body needs.
    #[error("{path}: {problem}")]
    Content {
        /// The file.
        path: PathBuf,
        /// What is missing or wrong.
        problem: String,
    },
}

/// Reads a body (and its animation, if any) from a binary FBX file.
pub fn read_fbx(path: &Path) -> Result<Body, FbxError> {
    let bytes = std::fs::read(path).map_err(|source| FbxError::Read { path: path.to_owned(), source })?;
    parse_fbx(&bytes, path)
}

/// Reads a body from the bytes of an FBX file read from `path` (named in errors).
pub fn parse_fbx(bytes: &[u8], path: &Path) -> Result<Body, FbxError> {
    check_header(bytes, path)?;
    let document = load_document(bytes).map_err(|problem| FbxError::Malformed { path: path.to_owned(), problem })?;
    let name = path.file_stem().map_or("body".into(), |s| s.to_string_lossy().into_owned());
    scene::body(&document, name).map_err(|problem| FbxError::Content { path: path.to_owned(), problem })
}

/// Tells binary FBX 7 from ASCII FBX, old versions and other files.
fn check_header(bytes: &[u8], path: &Path) -> Result<(), FbxError> {
    if bytes.starts_with(BINARY_MAGIC) {
        let version = bytes.get(23..27).map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]));
        return match version {
            Some(v) if v >= OLDEST_VERSION => Ok(()),
            Some(version) => Err(FbxError::OldVersion { path: path.to_owned(), version }),
            None => Err(FbxError::Malformed { path: path.to_owned(), problem: "the header is truncated".into() }),
        };
    }
    let head = String::from_utf8_lossy(&bytes[..bytes.len().min(4096)]);
    if head.contains("FBXHeaderExtension") || head.trim_start().starts_with("; FBX") {
        return Err(FbxError::Ascii { path: path.to_owned() });
    }
    Err(FbxError::NotFbx { path: path.to_owned() })
}

/// Parses the document. fbxcel-dom assumes internal consistency in places;
/// a panic inside it on hostile bytes is turned into an error here, so a bad
/// file can never take the program down.
fn load_document(bytes: &[u8]) -> Result<fbxcel_dom::v7400::Document, String> {
    use fbxcel_dom::any::AnyDocument;
    let parsed = std::panic::catch_unwind(|| AnyDocument::from_seekable_reader(std::io::Cursor::new(bytes)));
    match parsed {
        Ok(Ok(AnyDocument::V7400(_, document))) => Ok(*document),
        Ok(Ok(_)) => Err("an FBX version this reader does not know".into()),
        Ok(Err(e)) => Err(e.to_string()),
        Err(_) => Err("the FBX structure is inconsistent".into()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn headers_are_told_apart() {
        let path = Path::new("x.fbx");
        let mut binary = BINARY_MAGIC.to_vec();
        binary.extend([0x1a, 0x00]);
        binary.extend(7400u32.to_le_bytes());
        assert!(check_header(&binary, path).is_ok());
        let mut old = binary.clone();
        old[23..27].copy_from_slice(&6100u32.to_le_bytes());
        assert!(matches!(check_header(&old, path), Err(FbxError::OldVersion { version: 6100, .. })));
        let ascii = b"; FBX 7.4.0 project file\nFBXHeaderExtension:  {\n";
        assert!(matches!(check_header(ascii, path), Err(FbxError::Ascii { .. })));
        assert!(matches!(check_header(b"\x89PNG....", path), Err(FbxError::NotFbx { .. })));
        assert!(matches!(check_header(BINARY_MAGIC, path), Err(FbxError::Malformed { .. })));
    }
}
