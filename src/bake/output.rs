//! The bake folder:
//!
//! ```text
//! frame_0000.obj …     every garment as an object; frame 0 is the initial state;
//!                      the same vertex order in every frame
//! materials.mtl        one material per garment part (+ textures/ when used)
//! <garment>.pc2        the garment's point cache (Blender's Mesh Cache modifier)
//! summary.json         speed, solver effort, strain, contacts (see BakeSummary)
//! ```
//!
//! Every file is written atomically, so an interrupted bake leaves only whole
//! files.

use std::path::{Path, PathBuf};

use nalgebra::Vector3;

use super::summary::BakeSummary;
use crate::io::atomic::{WriteError, write_file};
use crate::io::obj::{ObjObject, write_obj};
use crate::io::pc2::{PointCache, write_pc2};
use crate::scene::Scene;

/// Name of the material library in the bake folder.
const MTL_NAME: &str = "materials.mtl";

/// A bake folder being filled.
pub struct BakeFolder<'a> {
    dir: PathBuf,
    scene: &'a Scene,
    /// Per garment, every written frame's positions (f32), for the point caches.
    caches: Vec<Vec<Vec<[f32; 3]>>>,
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
        let folder = BakeFolder { dir: dir.to_owned(), scene, caches: vec![Vec::new(); scene.garments.len()] };
        folder.write_materials()?;
        Ok(folder)
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
    /// concatenated) and keeps them for the point caches.
    pub fn write_frame(&mut self, frame: usize, time_s: f64, positions: &[Vector3<f64>]) -> Result<(), WriteError> {
        let mut offset = 0;
        let mut objects = Vec::with_capacity(self.scene.garments.len());
        for (g, cache) in self.scene.garments.iter().zip(&mut self.caches) {
            let own = &positions[offset..offset + g.mesh.vertex_count()];
            offset += own.len();
            cache.push(own.iter().map(|p| [p.x as f32, p.y as f32, p.z as f32]).collect());
            objects.push(ObjObject {
                name: &g.name,
                positions: own,
                triangles: &g.mesh.triangles,
                surface: &g.mesh.surface,
                material_namespace: &g.name,
            });
        }
        let header = format!("drape bake of scene {}, frame {frame}, t = {time_s:.6} s", self.scene.name);
        write_file(&self.dir.join(format!("frame_{frame:04}.obj")), |w| write_obj(w, &header, Some(MTL_NAME), &objects))
    }

    /// Writes each garment's point cache and the summary.
    pub fn finish(self, summary: &BakeSummary) -> Result<(), WriteError> {
        for (g, samples) in self.scene.garments.iter().zip(self.caches) {
            let cache = PointCache { start_frame: 0.0, sample_rate: 1.0, points: g.mesh.vertex_count(), samples };
            write_file(&self.dir.join(format!("{}.pc2", g.name)), |w| write_pc2(w, &cache))?;
        }
        let json = serde_json::to_string_pretty(summary).unwrap_or_default();
        write_file(&self.dir.join("summary.json"), |w| std::io::Write::write_all(w, json.as_bytes()))
    }
}
