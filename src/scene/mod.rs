//! Scenes: read a scene file, resolve its presets, meshes, pins and colliders,
//! check every value, and build the simulator.

pub mod body;
pub mod file;
pub mod preset;
mod resolve;
pub mod summary;

use std::path::{Path, PathBuf};

use nalgebra::{Isometry3, Similarity3, Translation3, UnitQuaternion, Vector3};

use self::body::{BodyError, SceneBody, load_body};
use self::file::{BodySpec, CameraSpec, ColliderSpec, GarmentSpec, MeshSpec, PinSpec, SceneFile, ShapeSpec};
use self::preset::{Appearance, Preset, PresetError};
use self::resolve::{Resolver, rotation};
use crate::io::obj::{ObjError, read_obj};
use crate::mesh::validate::MeshReport;
use crate::mesh::{TriMesh, generate};
use crate::sim::adaptive::AdaptiveSettings;
use crate::sim::cloth::Cloth;
use crate::sim::colliders::{Collider, Shape};
use crate::sim::collision::CollisionSettings;
use crate::sim::collision::geometry::closest_on_triangle;
use crate::sim::collision::obstacles::MeshCollider;
use crate::sim::fabric::Fabric;
use crate::sim::inextensibility::StrainLimiting;
use crate::sim::motion::{Placement, RigidMotion};
use crate::sim::pcg::PcgSettings;
use crate::sim::step::{Settings, triangle_frame};
use crate::sim::{Pin, PinTarget, SimError, Simulator};

/// Largest grid or tube resolution a scene may ask for (vertices per side).
const MAX_RESOLUTION: usize = 2048;

/// A scene ready to simulate: every value checked, every file loaded, every
/// mesh in world space.
#[derive(Clone, Debug)]
pub struct Scene {
    /// Name (the file stem).
    pub name: String,
    /// Where it was read from, if from a file.
    pub source: Option<PathBuf>,
    /// The file as read (for saving it again).
    pub file: SceneFile,
    /// Output frames per second.
    pub fps: f64,
    /// Frames simulated after the initial frame 0.
    pub frame_count: usize,
    /// Solver steps per frame: the nominal step is `1/steps_per_frame` of a
    /// frame.
    pub steps_per_frame: u32,
    /// The local error estimate a step longer than the nominal one may
    /// have, as a fraction of the nominal step's error in free fall (0:
    /// every step nominal).
    pub long_step_error: f64,
    /// Linear solver settings.
    pub solver: PcgSettings,
    /// How strain limits are enforced.
    pub strain_limiting: StrainLimiting,
    /// The cloths.
    pub garments: Vec<Garment>,
    /// The analytic obstacles.
    pub colliders: Vec<Collider>,
    /// The triangle-mesh obstacles (the body's among them).
    pub mesh_colliders: Vec<MeshCollider>,
    /// The animated bodies.
    pub bodies: Vec<SceneBody>,
    /// The collision pipeline's constants.
    pub collision: CollisionSettings,
}

/// One cloth of a scene.
#[derive(Clone, Debug)]
pub struct Garment {
    /// Name (used for export files).
    pub name: String,
    /// Preset it was built from, with provenance and appearance.
    pub preset: Preset,
    /// Effective fabric (preset, overrides and scene collision settings).
    pub fabric: Fabric,
    /// World-space rest mesh.
    pub mesh: TriMesh,
    /// What mesh validation found and repaired.
    pub report: MeshReport,
    /// Non-fatal loading problems.
    pub warnings: Vec<String>,
    /// Pins, by vertex index within this garment.
    pub pins: Vec<Pin>,
    /// Whether it collides with itself.
    pub self_collision: bool,
    /// Where the mesh came from, for reports.
    pub origin: String,
}

impl Garment {
    /// Render and export appearance.
    pub fn appearance(&self) -> &Appearance {
        &self.preset.appearance
    }
}

/// Why a scene could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// The file could not be read.
    #[error("cannot read scene file {path}: {source}")]
    Read {
        /// File path.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The TOML is malformed or has unknown or missing keys.
    #[error("scene {origin}: {message}")]
    Parse {
        /// File path.
        origin: String,
        /// The parser's message, with line and column.
        message: String,
    },
    /// A garment's preset is unusable.
    #[error("scene {origin}: garment '{garment}': {source}")]
    Preset {
        /// File path.
        origin: String,
        /// Garment name.
        garment: String,
        /// The preset problem.
        source: PresetError,
    },
    /// A garment's OBJ is unusable.
    #[error("scene {origin}: garment '{garment}': {source}")]
    Obj {
        /// File path.
        origin: String,
        /// Garment name.
        garment: String,
        /// The OBJ problem.
        source: ObjError,
    },
    /// The body file is unusable.
    #[error("scene {origin}: body '{body}': {source}")]
    Body {
        /// File path.
        origin: String,
        /// Body name.
        body: String,
        /// The body problem (it names its file).
        source: Box<BodyError>,
    },
    /// A value is out of range or inconsistent.
    #[error("scene {origin}: {what}: {problem}")]
    Invalid {
        /// File path.
        origin: String,
        /// Which setting.
        what: String,
        /// What is wrong, with the accepted range.
        problem: String,
    },
}

impl Scene {
    /// Reads and resolves a scene file; relative paths in it are relative to
    /// its folder.
    pub fn load(path: &Path) -> Result<Scene, SceneError> {
        Scene::load_edited(path, |_| {})
    }

    /// Reads a scene file, lets `edit` change it, then resolves it (benchmarks
    /// and tests vary one setting of a standard scene this way).
    pub fn load_edited(path: &Path, edit: impl FnOnce(&mut SceneFile)) -> Result<Scene, SceneError> {
        let text =
            std::fs::read_to_string(path).map_err(|source| SceneError::Read { path: path.to_owned(), source })?;
        let mut file = parse_file(&text, &path.display().to_string())?;
        edit(&mut file);
        Scene::resolve(file, path)
    }

    /// Resolves a scene file as if it were at `path` (relative paths in it
    /// are relative to that folder): the editor's scene after edits.
    pub fn resolve(file: SceneFile, path: &Path) -> Result<Scene, SceneError> {
        let origin = path.display().to_string();
        let name = path.file_stem().map_or("scene".into(), |s| s.to_string_lossy().into_owned());
        let mut scene =
            Resolver { base_dir: path.parent().unwrap_or(Path::new("")), origin: &origin }.scene(file, &name)?;
        scene.source = Some(path.to_owned());
        Ok(scene)
    }

    /// The scene file with every garment's current fabric and the solver's
    /// effort written out in full, so that opening it again gives the same
    /// simulation.
    pub fn to_file(&self) -> SceneFile {
        let mut file = self.file.clone();
        file.solver.steps_per_frame = Some(self.steps_per_frame);
        file.solver.tolerance = self.solver.tolerance;
        file.solver.long_step_error = self.long_step_error;
        for (spec, garment) in file.garments.iter_mut().zip(&self.garments) {
            if let Ok(table) = toml::Table::try_from(&garment.fabric) {
                spec.fabric = table;
            }
        }
        file
    }

    /// Parses and resolves scene text; `origin` names it in errors.
    pub fn parse(text: &str, name: &str, base_dir: &Path, origin: &str) -> Result<Scene, SceneError> {
        Resolver { base_dir, origin }.scene(parse_file(text, origin)?, name)
    }

    /// Its colliders and frame rate, for checking a sequence of its frames.
    pub fn obstacles(&self) -> crate::metrics::sequence::Obstacles<'_> {
        crate::metrics::sequence::Obstacles {
            colliders: &self.colliders,
            mesh_colliders: &self.mesh_colliders,
            fps: self.fps,
        }
    }

    /// Duration of one frame, s.
    pub fn frame_duration(&self) -> f64 {
        1.0 / self.fps
    }

    /// Duration of one nominal solver step, s.
    pub fn step_duration(&self) -> f64 {
        self.frame_duration() / self.steps_per_frame as f64
    }

    /// How its steps are retried, shortened and lengthened.
    pub fn adaptive_settings(&self) -> AdaptiveSettings {
        AdaptiveSettings { long_step_error: self.long_step_error, ..AdaptiveSettings::default() }
    }

    /// Builds the cloth of every garment, in order (particle indices follow).
    pub fn cloth(&self) -> Cloth {
        Cloth::new(self.garments.iter().map(|g| (&g.mesh, g.fabric.clone())))
    }

    /// A simulator at the scene's initial state.
    pub fn simulator(&self) -> Result<Simulator, SimError> {
        let mut pins = Vec::new();
        let mut offset = 0;
        for garment in &self.garments {
            pins.extend(garment.pins.iter().map(|p| Pin { vertex: p.vertex + offset, target: p.target.clone() }));
            offset += garment.mesh.vertex_count() as u32;
        }
        let settings = Settings {
            solver: self.solver,
            collision: self.collision.clone(),
            self_collision: self.garments.iter().map(|g| g.self_collision).collect(),
            strain_limiting: self.strain_limiting,
        };
        Simulator::new(self.cloth(), pins, self.colliders.clone(), self.mesh_colliders.clone(), settings)
    }
}

fn parse_file(text: &str, origin: &str) -> Result<SceneFile, SceneError> {
    toml::from_str(text).map_err(|e| SceneError::Parse { origin: origin.to_owned(), message: e.to_string() })
}
