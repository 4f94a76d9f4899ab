//! The binary motion cache (PAPER Fig. 5): a body skinned frame by frame, so
//! that simulating against it is a copy per frame, not a skinning pass.
//!
//! Layout, little-endian:
//!
//! ```text
//! magic "DRAPEMOT" | version u32 | vertices u32 | triangles u32 | frames u32
//! | fps f64 | flags u32 (bit 0: the motion cycles) | crc32 u32 of all that follows
//! | triangles: 3 × u32 each | frames: vertices × 3 × f32 each (Y up, m)
//! ```
//!
//! Counts are checked against the file size before anything is allocated, and
//! the checksum catches any flipped byte.

use std::io::Write;
use std::path::{Path, PathBuf};

use nalgebra::Vector3;

use super::atomic::{WriteError, write_file};
use crate::sim::vertex_animation::VertexAnimation;

const MAGIC: &[u8; 8] = b"DRAPEMOT";
const VERSION: u32 = 1;
const HEADER_BYTES: usize = 8 + 4 * 4 + 8 + 4 + 4;

/// A baked body motion: its triangles and every frame's vertex positions.
#[derive(Clone, Debug, PartialEq)]
pub struct MotionCache {
    /// The body's triangles.
    pub triangles: Vec<[u32; 3]>,
    /// The frames, with their rate and whether they cycle.
    pub animation: VertexAnimation,
}

/// Why a cache cannot be read.
#[derive(Debug, thiserror::Error)]
pub enum MotionCacheError {
    /// The file could not be read.
    #[error("cannot read motion cache {path}: {source}")]
    Read {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// Not a cache, a newer version, a size that does not match, a bad checksum.
    #[error("motion cache {path}: {problem}")]
    Invalid {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        problem: String,
    },
}

fn u32_at(bytes: &[u8], at: usize) -> u32 {
    u32::from_le_bytes([bytes[at], bytes[at + 1], bytes[at + 2], bytes[at + 3]])
}

/// Writes `cache` to `path` atomically.
pub fn write_motion_cache(path: &Path, cache: &MotionCache) -> Result<(), WriteError> {
    let a = &cache.animation;
    let mut body = Vec::with_capacity(cache.triangles.len() * 12 + a.frames.len() * a.vertex_count() * 12);
    for t in &cache.triangles {
        for v in t {
            body.extend(v.to_le_bytes());
        }
    }
    for frame in &a.frames {
        for p in frame {
            for c in p.iter() {
                body.extend((*c as f32).to_le_bytes());
            }
        }
    }
    let mut header = Vec::with_capacity(HEADER_BYTES);
    header.extend(MAGIC);
    for n in [VERSION, a.vertex_count() as u32, cache.triangles.len() as u32, a.frames.len() as u32] {
        header.extend(n.to_le_bytes());
    }
    header.extend(a.fps.to_le_bytes());
    header.extend(u32::from(a.cycle).to_le_bytes());
    header.extend(crc32fast::hash(&body).to_le_bytes());
    write_file(path, |out| {
        out.write_all(&header)?;
        out.write_all(&body)
    })
}

/// Reads and verifies a cache.
pub fn read_motion_cache(path: &Path) -> Result<MotionCache, MotionCacheError> {
    let bytes = std::fs::read(path).map_err(|source| MotionCacheError::Read { path: path.to_owned(), source })?;
    parse(&bytes).map_err(|problem| MotionCacheError::Invalid { path: path.to_owned(), problem })
}

/// Parses cache bytes (checks the header, the size and the checksum).
pub fn parse(bytes: &[u8]) -> Result<MotionCache, String> {
    if bytes.len() < HEADER_BYTES || &bytes[..8] != MAGIC {
        return Err("not a drape motion cache (no DRAPEMOT header)".into());
    }
    let version = u32_at(bytes, 8);
    if version != VERSION {
        return Err(format!(
            "version {version}; this drape reads version {VERSION}: bake it again with drape import-motion"
        ));
    }
    let (vertices, triangles, frames) = (u32_at(bytes, 12) as u64, u32_at(bytes, 16) as u64, u32_at(bytes, 20) as u64);
    let fps = f64::from_le_bytes(bytes[24..32].try_into().map_err(|_| "truncated header")?);
    let flags = u32_at(bytes, 32);
    let checksum = u32_at(bytes, 36);
    let expected = HEADER_BYTES as u64 + triangles * 12 + frames * vertices * 12;
    if bytes.len() as u64 != expected {
        return Err(format!(
            "the header announces {frames} frames of {vertices} vertices and {triangles} triangles ({expected} bytes) \
             but the file has {} bytes: it is truncated or damaged",
            bytes.len()
        ));
    }
    let body = &bytes[HEADER_BYTES..];
    if crc32fast::hash(body) != checksum {
        return Err("the checksum does not match: the file is damaged".into());
    }
    if !(fps.is_finite() && fps > 0.0) {
        return Err(format!("frame rate {fps} is not a positive number"));
    }
    let words: Vec<u32> = body[..triangles as usize * 12].chunks_exact(4).map(|w| u32_at(w, 0)).collect();
    let triangle_list: Vec<[u32; 3]> = words.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect();
    if let Some(bad) = triangle_list.iter().position(|t| t.iter().any(|&v| u64::from(v) >= vertices)) {
        return Err(format!("triangle {bad} refers to a vertex beyond the {vertices} the cache has"));
    }
    let floats = &body[triangles as usize * 12..];
    let frames: Vec<Vec<Vector3<f64>>> = floats
        .chunks_exact((vertices as usize * 12).max(1))
        .take(frames as usize)
        .map(|frame| {
            frame
                .chunks_exact(12)
                .map(|p| {
                    let c = |k: usize| f64::from(f32::from_le_bytes([p[k], p[k + 1], p[k + 2], p[k + 3]]));
                    Vector3::new(c(0), c(4), c(8))
                })
                .collect()
        })
        .collect();
    if frames.iter().flatten().any(|p| !p.iter().all(|c| c.is_finite())) {
        return Err("a vertex position is not finite".into());
    }
    let animation = VertexAnimation { fps, start_s: 0.0, frames, cycle: flags & 1 != 0, lead_in: 0 };
    Ok(MotionCache { triangles: triangle_list, animation })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> MotionCache {
        let frames = (0..3).map(|f| vec![Vector3::new(0.0, f as f64 * 0.5, 0.0), Vector3::x(), Vector3::z()]).collect();
        MotionCache {
            triangles: vec![[0, 1, 2]],
            animation: VertexAnimation { fps: 30.0, start_s: 0.0, frames, cycle: true, lead_in: 0 },
        }
    }

    #[test]
    fn a_cache_round_trips_exactly() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("walk.motion");
        write_motion_cache(&path, &sample()).unwrap();
        assert_eq!(read_motion_cache(&path).unwrap(), sample());
    }

    #[test]
    fn a_flipped_byte_or_a_cut_is_detected() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("walk.motion");
        write_motion_cache(&path, &sample()).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        for at in [HEADER_BYTES + 3, bytes.len() - 1] {
            let mut flipped = bytes.clone();
            flipped[at] ^= 0x10;
            assert!(parse(&flipped).unwrap_err().contains("checksum"), "byte {at}");
        }
        assert!(parse(&bytes[..bytes.len() - 5]).unwrap_err().contains("truncated"));
        assert!(parse(b"DRAPEMOT").unwrap_err().contains("DRAPEMOT"));
        let mut huge = bytes.clone();
        huge[20..24].copy_from_slice(&u32::MAX.to_le_bytes());
        assert!(parse(&huge).unwrap_err().contains("truncated"), "counts are checked against the size first");
    }
}
