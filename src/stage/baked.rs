//! The frames of a bake folder, read back from its point caches (one
//! `<garment>.pc2` per garment, in the scene's vertex order).

use std::path::{Path, PathBuf};

use nalgebra::Vector3;

use crate::io::pc2::{Pc2Error, PointCache, read_pc2};
use crate::scene::Scene;

/// Why a bake folder's frames cannot be read.
#[derive(Debug, thiserror::Error)]
pub enum BakedFramesError {
    /// A point cache is missing or unreadable.
    #[error("cannot read {path}: {source}")]
    Read {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// A point cache is malformed.
    #[error("{path}: {source}")]
    Malformed {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        source: Pc2Error,
    },
    /// A point cache does not belong to this scene's garment.
    #[error(
        "{path} has {found} points per frame but garment '{garment}' of the scene has {expected} vertices: the bake is not of this scene"
    )]
    WrongGarment {
        /// The file.
        path: PathBuf,
        /// The garment.
        garment: String,
        /// Its vertex count.
        expected: usize,
        /// The cache's.
        found: usize,
    },
}

/// Every garment's baked positions.
pub struct BakedFrames {
    caches: Vec<PointCache>,
    fps: f64,
}

impl BakedFrames {
    /// Reads `dir`'s point caches for the garments of `scene`.
    pub fn open(dir: &Path, scene: &Scene) -> Result<BakedFrames, BakedFramesError> {
        let mut caches = Vec::new();
        for garment in &scene.garments {
            let path = dir.join(format!("{}.pc2", garment.name));
            let bytes = std::fs::read(&path).map_err(|source| BakedFramesError::Read { path: path.clone(), source })?;
            let cache =
                read_pc2(&bytes).map_err(|source| BakedFramesError::Malformed { path: path.clone(), source })?;
            let expected = garment.mesh.vertex_count();
            if cache.points != expected {
                let garment = garment.name.clone();
                return Err(BakedFramesError::WrongGarment { path, garment, expected, found: cache.points });
            }
            caches.push(cache);
        }
        Ok(BakedFrames { caches, fps: scene.fps })
    }

    /// Frames held in memory (each every garment's positions, concatenated
    /// in scene order, m), as the editor has them, stored as the caches would.
    pub fn from_positions(scene: &Scene, frames: &[&[Vector3<f64>]]) -> BakedFrames {
        let mut caches = Vec::with_capacity(scene.garments.len());
        let mut offset = 0;
        for garment in &scene.garments {
            let points = garment.mesh.vertex_count();
            let samples = frames
                .iter()
                .map(|f| {
                    let slice = f.get(offset..offset + points).unwrap_or_default();
                    slice.iter().map(|p| [p.x as f32, p.y as f32, p.z as f32]).collect()
                })
                .collect();
            caches.push(PointCache { start_frame: 0.0, sample_rate: 1.0, points, samples });
            offset += points;
        }
        BakedFrames { caches, fps: scene.fps }
    }

    /// Number of frames every garment has.
    pub fn frame_count(&self) -> usize {
        self.caches.iter().map(|c| c.samples.len()).min().unwrap_or(0)
    }

    /// Time of `frame`, s.
    pub fn time(&self, frame: usize) -> f64 {
        frame as f64 / self.fps
    }

    /// Garment `garment`'s positions at `frame`, m, as the cache stores them.
    pub fn garment(&self, garment: usize, frame: usize) -> Option<&[[f32; 3]]> {
        self.caches.get(garment)?.samples.get(frame).map(Vec::as_slice)
    }

    /// Every garment's positions at `frame`, concatenated in scene order, m.
    pub fn positions(&self, frame: usize) -> Vec<Vector3<f64>> {
        self.caches
            .iter()
            .filter_map(|c| c.samples.get(frame))
            .flatten()
            .map(|p| Vector3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2])))
            .collect()
    }
}
