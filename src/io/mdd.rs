//! MDD point caches (NewTek's format, read by Marvelous Designer, Houdini,
//! Modo, LightWave and Blender's MDD add-on): every number big-endian.
//!
//! ```text
//! i32 frames | i32 points | f32 time of each frame, s | frames × points × [f32; 3]
//! ```
//!
//! The times start at 0 and step by 1/fps, as Blender's exporter writes them.

use std::io::Write;

/// Why bytes are not a valid MDD cache.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum MddError {
    /// The counts do not match the size.
    #[error("MDD header announces {frames} frames of {points} points ({expected} bytes) but the file has {actual}")]
    SizeMismatch {
        /// Frames announced.
        frames: i64,
        /// Points announced.
        points: i64,
        /// Bytes the header implies.
        expected: u64,
        /// Bytes present.
        actual: u64,
    },
}

/// Writes the MDD header: `frames` frames of `points` points at `fps`.
pub fn write_header(out: &mut impl Write, frames: usize, points: usize, fps: f64) -> std::io::Result<()> {
    let count = |n: usize| i32::try_from(n).map_err(|_| std::io::Error::other(format!("{n} is too many for MDD")));
    out.write_all(&count(frames)?.to_be_bytes())?;
    out.write_all(&count(points)?.to_be_bytes())?;
    for f in 0..frames {
        out.write_all(&((f as f64 / fps) as f32).to_be_bytes())?;
    }
    Ok(())
}

/// Writes one frame's positions (after the header and the frames before it).
pub fn write_frame(out: &mut impl Write, positions: &[[f32; 3]]) -> std::io::Result<()> {
    let mut bytes = Vec::with_capacity(12 * positions.len());
    for p in positions {
        for c in p {
            bytes.extend(c.to_be_bytes());
        }
    }
    out.write_all(&bytes)
}

/// An MDD cache in memory: its frame times, s, and frames of positions.
#[derive(Clone, Debug, PartialEq)]
pub struct Mdd {
    /// Time of each frame, s.
    pub times: Vec<f32>,
    /// Each frame's positions.
    pub frames: Vec<Vec<[f32; 3]>>,
}

/// Parses MDD bytes, checking the counts against the size before allocating.
pub fn read_mdd(bytes: &[u8]) -> Result<Mdd, MddError> {
    let word = |at: usize| bytes.get(at..at + 4).map(|b| [b[0], b[1], b[2], b[3]]);
    let (frames, points) =
        (word(0).map_or(-1, i32::from_be_bytes) as i64, word(4).map_or(-1, i32::from_be_bytes) as i64);
    let expected = 8 + 4 * frames as i128 + 12 * frames as i128 * points as i128;
    if frames < 0 || points < 0 || expected != bytes.len() as i128 {
        let expected = expected.max(0) as u64;
        return Err(MddError::SizeMismatch { frames, points, expected, actual: bytes.len() as u64 });
    }
    let floats: Vec<f32> = bytes[8..].chunks_exact(4).map(|c| f32::from_be_bytes([c[0], c[1], c[2], c[3]])).collect();
    let (times, positions) = floats.split_at(frames as usize);
    let points = points as usize;
    let frames = positions
        .chunks_exact(3)
        .map(|p| [p[0], p[1], p[2]])
        .collect::<Vec<_>>()
        .chunks(points.max(1))
        .take(frames as usize)
        .map(<[_]>::to_vec)
        .collect();
    Ok(Mdd { times: times.to_vec(), frames })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_layout_is_big_endian_counts_times_then_positions() {
        let frames = [vec![[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]], vec![[-1.0, 0.5, 0.25], [0.0, -0.0, 7.0]]];
        let mut bytes = Vec::new();
        write_header(&mut bytes, 2, 2, 30.0).unwrap();
        frames.iter().for_each(|f| write_frame(&mut bytes, f).unwrap());
        assert_eq!(bytes.len(), 8 + 2 * 4 + 2 * 2 * 12);
        assert_eq!(&bytes[..8], &[0, 0, 0, 2, 0, 0, 0, 2]);
        assert_eq!(&bytes[8..12], &0.0f32.to_be_bytes());
        assert_eq!(&bytes[12..16], &(1.0f32 / 30.0).to_be_bytes());
        assert_eq!(&bytes[16..20], &1.0f32.to_be_bytes());
        let read = read_mdd(&bytes).unwrap();
        assert_eq!((read.times.len(), read.frames), (2, frames.to_vec()));
        assert!(matches!(read_mdd(&bytes[..bytes.len() - 1]), Err(MddError::SizeMismatch { .. })));
        assert!(read_mdd(&[0, 0]).is_err());
    }
}
