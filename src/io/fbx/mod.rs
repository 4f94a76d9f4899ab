//! FBX bodies and motions, binary or ASCII FBX 7, interpreted the way the
//! FBX SDK evaluates them, into a [`Body`] in drape's world (Y up, metres).
//!
//! Layers, from the bytes up: `binary` and `ascii` read the two encodings
//! into one [`tree::Node`] tree; `document` indexes its objects,
//! connections and property templates in file order; `geometry`,
//! `deformers` and `animation` read meshes, skins and blend shapes, and
//! animation stacks; `scene` assembles the body. The evaluation itself
//! (node transforms with every inherit type, curves, skinning, blend
//! shapes) lives in `crate::body`.
//!
//! FBX 6 and older are refused with a clear message: every application
//! that writes them (Maya, 3ds Max and MotionBuilder before 2011, Blender
//! 2.7's ASCII option) also writes FBX 7, the format of every current
//! exporter, Mixamo's included; FBX 6 stores animation in a different
//! structure (takes of channels) that would need a reader of its own.

mod animation;
mod ascii;
mod binary;
mod deformers;
mod document;
mod geometry;
mod scene;
mod tree;

use std::path::{Path, PathBuf};

use self::document::Document;
pub use self::scene::BodyOptions;
use crate::body::motion::Motion;
use crate::body::skeleton::Skeleton;
use crate::body::{Body, StackSummary};

/// Oldest FBX version read (7.0).
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
    /// FBX 6 or older.
    #[error(
        "{path} is FBX version {version}, which drape does not read: re-export it as FBX 7.4 or later \
         (binary or ASCII)"
    )]
    OldVersion {
        /// The file.
        path: PathBuf,
        /// The version number in the header (e.g. 6100).
        version: u32,
    },
    /// Not an FBX file.
    #[error("{path} is not an FBX file (neither the binary FBX header nor ASCII FBX text)")]
    NotFbx {
        /// The file.
        path: PathBuf,
    },
    /// The structure is broken (truncated, corrupt, an encoding FBX does not define).
    #[error("{path} is damaged: {problem}")]
    Malformed {
        /// The file.
        path: PathBuf,
        /// What the reader found.
        problem: String,
    },
    /// No mesh to make a body of.
    #[error(
        "{path} has no polygon mesh: a body needs one (a file with only a skeleton and animation, such as a \
         motion library or a Mixamo animation without skin, drives a body as its `motion`)"
    )]
    NoMesh {
        /// The file.
        path: PathBuf,
    },
    /// A vertex cache drives a mesh.
    #[error(
        "{path}: mesh '{mesh}' is driven by a vertex cache ({cache}), which drape does not read: export the \
         character with its skin and blend shapes instead, or leave the mesh out with `exclude`"
    )]
    VertexCache {
        /// The file.
        path: PathBuf,
        /// The mesh.
        mesh: String,
        /// The cache file as the FBX names it.
        cache: String,
    },
    /// The content is not what a body or motion needs.
    #[error("{path}: {problem}")]
    Content {
        /// The file.
        path: PathBuf,
        /// What is missing or wrong.
        problem: String,
    },
}

/// The skeleton and animation of an FBX file, with or without a mesh.
#[derive(Clone, Debug)]
pub struct FbxMotion {
    /// Every node of the file, parents first.
    pub skeleton: Skeleton,
    /// The chosen stack's animation, if it animates anything.
    pub motion: Option<Motion>,
    /// Every animation stack, in file order.
    pub stacks: Vec<StackSummary>,
    /// What the file is, for reports.
    pub source: String,
}

/// Reads a body (every mesh, the first animation stack) from an FBX file.
pub fn read_fbx(path: &Path) -> Result<Body, FbxError> {
    read_body(path, &BodyOptions::default())
}

/// Reads a body from an FBX file, with the parts and stack `options` choose.
pub fn read_body(path: &Path, options: &BodyOptions) -> Result<Body, FbxError> {
    let bytes = std::fs::read(path).map_err(|source| FbxError::Read { path: path.to_owned(), source })?;
    parse_body(&bytes, path, options)
}

/// Reads the skeleton and motion (stack `stack`, else the first) of an FBX
/// file, which need not hold a mesh (a motion library, a Mixamo animation
/// downloaded without skin).
pub fn read_motion(path: &Path, stack: Option<&str>) -> Result<FbxMotion, FbxError> {
    let bytes = std::fs::read(path).map_err(|source| FbxError::Read { path: path.to_owned(), source })?;
    let document = load_document(&bytes, path)?;
    let (skeleton, motion, stacks) =
        scene::skeleton_and_motion(&document, stack).map_err(|problem| content(path, problem))?;
    let source = scene::describe(&document, &scene::application(&document));
    Ok(FbxMotion { skeleton, motion, stacks, source })
}

/// Reads a body from the bytes of an FBX file read from `path` (named in errors).
pub fn parse_fbx(bytes: &[u8], path: &Path) -> Result<Body, FbxError> {
    parse_body(bytes, path, &BodyOptions::default())
}

fn parse_body(bytes: &[u8], path: &Path, options: &BodyOptions) -> Result<Body, FbxError> {
    let document = load_document(bytes, path)?;
    let name = path.file_stem().map_or("body".into(), |s| s.to_string_lossy().into_owned());
    scene::body(&document, name, options).map_err(|problem| match problem {
        scene::Problem::NoMesh => FbxError::NoMesh { path: path.to_owned() },
        scene::Problem::VertexCache { mesh, cache } => FbxError::VertexCache { path: path.to_owned(), mesh, cache },
        scene::Problem::Content(problem) => content(path, problem),
    })
}

fn content(path: &Path, problem: String) -> FbxError {
    FbxError::Content { path: path.to_owned(), problem }
}

/// Reads either encoding into a document, refusing versions before 7.
fn load_document(bytes: &[u8], path: &Path) -> Result<Document, FbxError> {
    let malformed = |problem: String| FbxError::Malformed { path: path.to_owned(), problem };
    let (root, version, is_ascii) = if bytes.starts_with(binary::MAGIC) {
        let header = binary::header(bytes).ok_or_else(|| malformed("the header is truncated".into()))?;
        check_version(header.version, path)?;
        (binary::parse(bytes).map_err(malformed)?, header.version, false)
    } else if ascii::looks_like_ascii(bytes) {
        let root = ascii::parse(bytes).map_err(malformed)?;
        let version = ascii::version(&root, bytes).unwrap_or(7400);
        check_version(version, path)?;
        (root, version, true)
    } else {
        return Err(FbxError::NotFbx { path: path.to_owned() });
    };
    Ok(Document::new(root, version, is_ascii))
}

fn check_version(version: u32, path: &Path) -> Result<(), FbxError> {
    match version >= OLDEST_VERSION {
        true => Ok(()),
        false => Err(FbxError::OldVersion { path: path.to_owned(), version }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn headers_are_told_apart() {
        let path = Path::new("x.fbx");
        let old = binary::tests::file(6100, false, &[]);
        assert!(matches!(load_document(&old, path), Err(FbxError::OldVersion { version: 6100, .. })));
        let ascii = b"; FBX 6.1.0 project file\nFBXHeaderExtension:  {\n}\n";
        assert!(matches!(load_document(ascii, path), Err(FbxError::OldVersion { version: 6100, .. })));
        assert!(matches!(load_document(b"\x89PNG....", path), Err(FbxError::NotFbx { .. })));
        assert!(matches!(load_document(binary::MAGIC, path), Err(FbxError::Malformed { .. })));
        let empty = binary::tests::file(7400, false, &[]);
        assert!(load_document(&empty, path).is_ok());
    }
}
