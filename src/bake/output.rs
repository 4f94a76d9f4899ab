//! The bake folder:
//!
//! ```text
//! frame_0000.obj …     every garment as an object; frame 0 is the initial state;
//!                      the same vertex order in every frame
//! materials.mtl        one material per garment part (+ textures/ when used)
//! <garment>.pc2        the garment's point cache (Blender's Mesh Cache modifier)
//! summary.json         speed, solver effort, strain, contacts (see BakeSummary)
//! .resume/             while the bake is unfinished: what `--resume` needs
//!                      ([`super::resume`])
//! ```
//!
//! Every file is written atomically, and frames are streamed to disk as they
//! are finished, so an interrupted bake leaves only whole files and goes on
//! from its last checkpoint.

use std::path::{Path, PathBuf};

use nalgebra::Vector3;

use super::FrameRecord;
use super::resume::{Checkpoint, ResumeError, ResumeLog};
use super::summary::BakeSummary;
use crate::io::atomic::{WriteError, write_file};
use crate::io::obj::{ObjFrames, ObjSurface};
use crate::io::pc2::Pc2Stream;
use crate::scene::Scene;
use crate::sim::snapshot::Snapshot;

/// Name of the material library in the bake folder.
const MTL_NAME: &str = "materials.mtl";

/// A bake folder being filled.
pub struct BakeFolder<'a> {
    dir: PathBuf,
    scene: &'a Scene,
    /// The working files (`.resume/`).
    log: ResumeLog,
    /// Per garment, its point cache so far.
    caches: Vec<Pc2Stream>,
    /// The frames' OBJ writer, with the garments' UV and face lines.
    obj: ObjFrames<'a>,
    /// Whether a checkpoint was written (a bake that can be resumed).
    resumable: bool,
}

impl<'a> BakeFolder<'a> {
    /// Creates `dir` (and parents) and writes the material library and textures.
    pub fn create(dir: &Path, scene: &'a Scene) -> Result<Self, WriteError> {
        std::fs::create_dir_all(dir).map_err(|source| WriteError { path: dir.to_owned(), source })?;
        if !dir.is_dir() {
            let source =
                std::io::Error::new(std::io::ErrorKind::NotADirectory, "a file is in the way of the output folder");
            return Err(WriteError { path: dir.to_owned(), source });
        }
        let log = ResumeLog::create(dir)?;
        let mut caches = Vec::with_capacity(scene.garments.len());
        for g in &scene.garments {
            let path = log.cache_path(&g.name);
            let stream =
                Pc2Stream::create(&path, g.mesh.vertex_count()).map_err(|source| WriteError { path, source })?;
            caches.push(stream);
        }
        let folder = BakeFolder { dir: dir.to_owned(), scene, log, caches, obj: obj_frames(scene), resumable: false };
        folder.write_materials()?;
        Ok(folder)
    }

    /// Takes up the unfinished bake of `scene` in `dir` after its last
    /// checkpoint (whose scene must have `fingerprint`): returns the folder,
    /// ready for the next frame, the checkpoint and the finished frames'
    /// records. Temporary files a kill left behind are removed.
    pub fn reopen(
        dir: &Path,
        scene: &'a Scene,
        fingerprint: u32,
    ) -> Result<(Self, Checkpoint, Vec<FrameRecord>), ResumeError> {
        let resumed = ResumeLog::reopen(dir, fingerprint)?;
        let samples = resumed.checkpoint.frame + 1;
        let mut caches = Vec::with_capacity(scene.garments.len());
        for g in &scene.garments {
            let path = resumed.log.cache_path(&g.name);
            let stream = Pc2Stream::reopen(&path, g.mesh.vertex_count(), samples)
                .map_err(|e| ResumeError::Damaged { path, problem: e.to_string() })?;
            caches.push(stream);
        }
        remove_temporaries(dir);
        let obj = obj_frames(scene);
        let folder = BakeFolder { dir: dir.to_owned(), scene, log: resumed.log, caches, obj, resumable: true };
        Ok((folder, resumed.checkpoint, resumed.records))
    }

    /// The bake folder.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    fn write_materials(&self) -> Result<(), WriteError> {
        let mut textures = Vec::new();
        let mut mtl = String::from("# drape bake materials\n");
        for g in &self.scene.garments {
            let [r, gr, b] = g.appearance().base_color;
            mtl += &format!("newmtl {}\nKd {r:.4} {gr:.4} {b:.4}\n", g.name);
            for m in &g.mesh.surface.materials {
                let [r, gr, b] = m.diffuse;
                mtl += &format!("newmtl {}.{}\nKd {r:.4} {gr:.4} {b:.4}\n", g.name, m.name);
                if let Some(texture) = &m.diffuse_texture {
                    let file = texture.file_name().map(|f| f.to_string_lossy().into_owned()).unwrap_or_default();
                    mtl += &format!("map_Kd textures/{file}\n");
                    textures.push((texture.clone(), file));
                }
            }
        }
        write_file(&self.dir.join(MTL_NAME), |w| std::io::Write::write_all(w, mtl.as_bytes()))?;
        if !textures.is_empty() {
            let folder = self.dir.join("textures");
            std::fs::create_dir_all(&folder).map_err(|source| WriteError { path: folder.clone(), source })?;
            for (source_path, file) in textures {
                let bytes =
                    std::fs::read(&source_path).map_err(|source| WriteError { path: source_path.clone(), source })?;
                write_file(&folder.join(file), |w| std::io::Write::write_all(w, &bytes))?;
            }
        }
        Ok(())
    }

    /// Writes `frame_NNNN.obj` from the cloth's current `positions` (all garments
    /// concatenated) and appends them to the point caches.
    pub fn write_frame(&mut self, frame: usize, time_s: f64, positions: &[Vector3<f64>]) -> Result<(), WriteError> {
        let mut offset = 0;
        for (g, cache) in self.scene.garments.iter().zip(&mut self.caches) {
            let own = &positions[offset..offset + g.mesh.vertex_count()];
            offset += own.len();
            cache.append(own).map_err(|source| WriteError { path: self.log.cache_path(&g.name), source })?;
        }
        let header = format!("drape bake of scene {}, frame {frame}, t = {time_s:.6} s", self.scene.name);
        write_file(&self.dir.join(format!("frame_{frame:04}.obj")), |w| self.obj.write(w, &header, positions))
    }

    /// Appends the `record` of the frame just written to the records.
    pub fn add_record(&mut self, record: &FrameRecord) -> Result<(), WriteError> {
        self.log.append_record(record)
    }

    /// Marks `frame`, the last written, as where `--resume` goes on: puts
    /// the point caches and records on disk and writes the checkpoint with
    /// the simulation's `snapshot` at the end of that frame.
    pub fn checkpoint(&mut self, frame: usize, fingerprint: u32, snapshot: Snapshot) -> Result<(), WriteError> {
        for (g, cache) in self.scene.garments.iter().zip(&self.caches) {
            cache.sync().map_err(|source| WriteError { path: self.log.cache_path(&g.name), source })?;
        }
        self.log.commit(frame, fingerprint, snapshot)?;
        self.resumable = true;
        Ok(())
    }

    /// Writes each garment's point cache and the summary. The working files
    /// are removed, unless the bake is unfinished and can be resumed.
    pub fn finish(self, summary: &BakeSummary) -> Result<(), WriteError> {
        for (g, cache) in self.scene.garments.iter().zip(&self.caches) {
            cache.publish(&self.dir.join(format!("{}.pc2", g.name)))?;
        }
        let json = serde_json::to_string_pretty(summary).unwrap_or_default();
        write_file(&self.dir.join("summary.json"), |w| std::io::Write::write_all(w, json.as_bytes()))?;
        if summary.complete || !self.resumable { self.log.remove() } else { Ok(()) }
    }

    /// Stops writing: the frames written stay, the working files go.
    pub fn abandon(self) -> Result<(), WriteError> {
        self.log.remove()
    }
}

/// The OBJ writer of `scene`'s frames: every garment as an object.
fn obj_frames(scene: &Scene) -> ObjFrames<'_> {
    let objects: Vec<_> = scene
        .garments
        .iter()
        .map(|g| ObjSurface {
            name: &g.name,
            vertex_count: g.mesh.vertex_count(),
            triangles: &g.mesh.triangles,
            surface: &g.mesh.surface,
            material_namespace: &g.name,
        })
        .collect();
    ObjFrames::new(Some(MTL_NAME), &objects)
}

/// Removes the hidden temporary files (`.name.partial`) that a kill in the
/// middle of an atomic write leaves in `dir`.
fn remove_temporaries(dir: &Path) {
    let Ok(entries) = std::fs::read_dir(dir) else { return };
    for entry in entries.flatten() {
        let name = entry.file_name();
        let name = name.to_string_lossy();
        if name.starts_with('.') && name.ends_with(".partial") {
            let _ = std::fs::remove_file(entry.path());
        }
    }
}
