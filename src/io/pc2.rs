//! PC2 point caches (the format of Blender's Mesh Cache modifier and 3ds Max's
//! Point Cache): a 32-byte header then every frame's vertex positions as
//! little-endian f32 triples.
//!
//! ```text
//! char[12] "POINTCACHE2\0" | i32 version = 1 | i32 points | f32 start frame
//! f32 sample rate (frames per sample) | i32 samples | samples × points × [f32; 3]
//! ```

use std::io::Write;

/// File signature.
const MAGIC: &[u8; 12] = b"POINTCACHE2\0";
/// Header size, bytes.
const HEADER_BYTES: usize = 32;

/// A point cache in memory.
#[derive(Clone, Debug, PartialEq)]
pub struct PointCache {
    /// Frame number of the first sample.
    pub start_frame: f32,
    /// Frames between samples.
    pub sample_rate: f32,
    /// Vertices per sample.
    pub points: usize,
    /// Samples, each `points` positions, m.
    pub samples: Vec<Vec<[f32; 3]>>,
}

/// Why bytes are not a valid PC2 cache.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum Pc2Error {
    /// Too short for a header, or the wrong signature.
    #[error("not a PC2 point cache (missing 'POINTCACHE2' header)")]
    NotPc2,
    /// The header's counts do not match the file size.
    #[error("PC2 header announces {samples} samples of {points} points ({expected} bytes) but the file has {actual}")]
    SizeMismatch {
        /// Samples announced.
        samples: i64,
        /// Points announced.
        points: i64,
        /// Bytes the header implies.
        expected: u64,
        /// Bytes present.
        actual: u64,
    },
}

/// Writes `cache` as PC2.
pub fn write_pc2(out: &mut impl Write, cache: &PointCache) -> std::io::Result<()> {
    out.write_all(MAGIC)?;
    out.write_all(&1i32.to_le_bytes())?;
    out.write_all(&(cache.points as i32).to_le_bytes())?;
    out.write_all(&cache.start_frame.to_le_bytes())?;
    out.write_all(&cache.sample_rate.to_le_bytes())?;
    out.write_all(&(cache.samples.len() as i32).to_le_bytes())?;
    for sample in &cache.samples {
        for p in sample {
            for c in p {
                out.write_all(&c.to_le_bytes())?;
            }
        }
    }
    Ok(())
}

/// Parses PC2 bytes, checking the header's counts against the size before
/// allocating.
pub fn read_pc2(bytes: &[u8]) -> Result<PointCache, Pc2Error> {
    if bytes.len() < HEADER_BYTES || &bytes[..12] != MAGIC {
        return Err(Pc2Error::NotPc2);
    }
    let word = |at: usize| [bytes[at], bytes[at + 1], bytes[at + 2], bytes[at + 3]];
    let points = i32::from_le_bytes(word(16)) as i64;
    let samples = i32::from_le_bytes(word(28)) as i64;
    let expected = HEADER_BYTES as i128 + 12 * points as i128 * samples as i128;
    if points < 0 || samples < 0 || expected != bytes.len() as i128 {
        return Err(Pc2Error::SizeMismatch {
            samples,
            points,
            expected: expected.max(0) as u64,
            actual: bytes.len() as u64,
        });
    }
    let floats: Vec<f32> =
        bytes[HEADER_BYTES..].chunks_exact(4).map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect();
    let frames = floats.chunks_exact(3).map(|p| [p[0], p[1], p[2]]).collect::<Vec<_>>();
    Ok(PointCache {
        start_frame: f32::from_le_bytes(word(20)),
        sample_rate: f32::from_le_bytes(word(24)),
        points: points as usize,
        samples: frames.chunks(points.max(1) as usize).take(samples as usize).map(<[_]>::to_vec).collect(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cache() -> PointCache {
        PointCache {
            start_frame: 0.0,
            sample_rate: 1.0,
            points: 2,
            samples: vec![vec![[0.0, 1.0, 2.0], [3.0, 4.0, 5.0]], vec![[0.5, 1.5, 2.5], [3.5, -4.5, 5.5]]],
        }
    }

    #[test]
    fn round_trip_is_exact_and_the_layout_is_blenders() {
        let mut bytes = Vec::new();
        write_pc2(&mut bytes, &cache()).unwrap();
        assert_eq!(bytes.len(), 32 + 2 * 2 * 12);
        assert_eq!(&bytes[..12], b"POINTCACHE2\0");
        assert_eq!(read_pc2(&bytes).unwrap(), cache());
    }

    #[test]
    fn truncated_and_foreign_files_are_refused() {
        let mut bytes = Vec::new();
        write_pc2(&mut bytes, &cache()).unwrap();
        assert!(matches!(read_pc2(&bytes[..bytes.len() - 1]), Err(Pc2Error::SizeMismatch { .. })));
        assert_eq!(read_pc2(b"hello"), Err(Pc2Error::NotPc2));
        let mut huge = bytes.clone();
        huge[28..32].copy_from_slice(&i32::MAX.to_le_bytes());
        assert!(matches!(read_pc2(&huge), Err(Pc2Error::SizeMismatch { .. })));
    }
}
