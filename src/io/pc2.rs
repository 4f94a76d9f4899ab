//! PC2 point caches (the format of Blender's Mesh Cache modifier and 3ds Max's
//! Point Cache): a 32-byte header then every frame's vertex positions as
//! little-endian f32 triples.
//!
//! ```text
//! char[12] "POINTCACHE2\0" | i32 version = 1 | i32 points | f32 start frame
//! f32 sample rate (frames per sample) | i32 samples | samples × points × [f32; 3]
//! ```

use std::fs::{File, OpenOptions};
use std::io::{Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use nalgebra::Vector3;

use crate::io::atomic::{WriteError, write_file};

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
    write_header(out, cache.points, cache.start_frame, cache.sample_rate, cache.samples.len())?;
    for sample in &cache.samples {
        for p in sample {
            for c in p {
                out.write_all(&c.to_le_bytes())?;
            }
        }
    }
    Ok(())
}

/// Writes the 32-byte header.
fn write_header(
    out: &mut impl Write,
    points: usize,
    start_frame: f32,
    sample_rate: f32,
    samples: usize,
) -> std::io::Result<()> {
    out.write_all(MAGIC)?;
    out.write_all(&1i32.to_le_bytes())?;
    out.write_all(&(points as i32).to_le_bytes())?;
    out.write_all(&start_frame.to_le_bytes())?;
    out.write_all(&sample_rate.to_le_bytes())?;
    out.write_all(&(samples as i32).to_le_bytes())
}

/// A point cache written one sample at a time to a working file, so a long
/// bake keeps no frames in memory and loses none it finished; the finished
/// cache is published under its real name with [`Pc2Stream::publish`]. The
/// working file's header says 0 samples until then.
#[derive(Debug)]
pub struct Pc2Stream {
    file: File,
    path: PathBuf,
    points: usize,
    samples: usize,
}

impl Pc2Stream {
    /// Starts a working cache of `points` vertices per sample at `path`,
    /// starting at frame 0, one sample per frame.
    pub fn create(path: &Path, points: usize) -> std::io::Result<Self> {
        let mut file = File::create(path)?;
        write_header(&mut file, points, 0.0, 1.0, 0)?;
        Ok(Pc2Stream { file, path: path.to_owned(), points, samples: 0 })
    }

    /// Reopens the working cache at `path` to go on after its first
    /// `samples` samples of `points` vertices, dropping anything after them.
    pub fn reopen(path: &Path, points: usize, samples: usize) -> std::io::Result<Self> {
        let mut file = OpenOptions::new().read(true).write(true).open(path)?;
        let mut header = [0u8; HEADER_BYTES];
        file.read_exact(&mut header)?;
        let stored_points = i32::from_le_bytes([header[16], header[17], header[18], header[19]]);
        let needed = (HEADER_BYTES + samples * points * 12) as u64;
        let actual = file.metadata()?.len();
        let problem = if &header[..12] != MAGIC || stored_points as i64 != points as i64 {
            Some(format!("not a working cache of {points} points"))
        } else if actual < needed {
            Some(format!("holds {actual} bytes, fewer than the {needed} of {samples} samples"))
        } else {
            None
        };
        if let Some(problem) = problem {
            return Err(std::io::Error::new(std::io::ErrorKind::InvalidData, problem));
        }
        file.set_len(needed)?;
        file.seek(SeekFrom::End(0))?;
        Ok(Pc2Stream { file, path: path.to_owned(), points, samples })
    }

    /// Appends one sample (`points` positions, m, stored as f32).
    pub fn append(&mut self, positions: &[Vector3<f64>]) -> std::io::Result<()> {
        debug_assert_eq!(positions.len(), self.points);
        let bytes: Vec<u8> =
            positions.iter().flat_map(|p| [p.x as f32, p.y as f32, p.z as f32]).flat_map(f32::to_le_bytes).collect();
        self.file.write_all(&bytes)?;
        self.samples += 1;
        Ok(())
    }

    /// Forces the samples written so far to the disk.
    pub fn sync(&self) -> std::io::Result<()> {
        self.file.sync_data()
    }

    /// Writes the cache so far to `to` as a complete PC2 file (atomically),
    /// leaving the working file as it is.
    pub fn publish(&self, to: &Path) -> Result<(), WriteError> {
        let mut body = File::open(&self.path).map_err(|source| WriteError { path: self.path.clone(), source })?;
        write_file(to, |out| {
            write_header(out, self.points, 0.0, 1.0, self.samples)?;
            body.seek(SeekFrom::Start(HEADER_BYTES as u64))?;
            let copied = std::io::copy(&mut (&mut body).take((self.samples * self.points * 12) as u64), out)?;
            if copied != (self.samples * self.points * 12) as u64 {
                return Err(std::io::Error::new(std::io::ErrorKind::UnexpectedEof, "the working cache is shorter"));
            }
            Ok(())
        })
    }
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
    fn a_stream_reopened_after_a_cut_publishes_what_writing_it_whole_does() {
        let dir = tempfile::tempdir().unwrap();
        let (working, published) = (dir.path().join("work.pc2"), dir.path().join("cloth.pc2"));
        let sample = |k: usize| -> Vec<Vector3<f64>> {
            cache().samples[k].iter().map(|p| Vector3::new(p[0] as f64, p[1] as f64, p[2] as f64)).collect()
        };
        let mut stream = Pc2Stream::create(&working, 2).unwrap();
        stream.append(&sample(0)).unwrap();
        stream.append(&sample(1)).unwrap();
        drop(stream);
        // A crash after the second sample, resumed after the first: the
        // second is dropped and written again.
        let mut stream = Pc2Stream::reopen(&working, 2, 1).unwrap();
        stream.append(&sample(1)).unwrap();
        stream.publish(&published).unwrap();
        assert_eq!(read_pc2(&std::fs::read(&published).unwrap()).unwrap(), cache());
        let err = Pc2Stream::reopen(&working, 2, 3).unwrap_err();
        assert!(err.to_string().contains("fewer than"), "{err}");
        assert!(Pc2Stream::reopen(&working, 5, 1).is_err(), "another point count is refused");
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
