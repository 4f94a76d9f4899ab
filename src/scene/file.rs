//! The scene file format (TOML), as written by people and saved by the editor.
//! Every table refuses unknown keys, so a typo is an error with its line, not a
//! silently ignored setting. Units are in the key names.
//!
//! ```toml
//! description = "A cotton square dropped on a sphere."
//! kind = "demo"                           # or "hard-case": listed apart in the editor
//! [time]
//! fps = 30.0
//! duration_s = 2.0
//! [solver]
//! steps_per_frame = 2
//!
//! [[garment]]
//! name = "cloth"
//! preset = "cotton"                       # built-in name, or a path to a .toml preset
//! mesh = { grid = { size_m = 1.0, resolution = 64 } }
//! translation_m = [0.0, 1.0, 0.0]
//! [[garment.pin]]
//! vertices = [0, 63]                      # and/or region = { min_m = [..], max_m = [..] }
//!
//! [[collider]]
//! name = "ball"
//! shape = { sphere = { radius_m = 0.3 } }
//! position_m = [0.0, 0.5, 0.0]
//! motion = { angular_velocity_deg_per_s = [0.0, 360.0, 0.0], start_s = 1.0 }
//!
//! [camera]                                # optional: renders frame the scene by themselves
//! yaw_deg = 30.0
//! pitch_deg = 20.0
//! ```

use std::path::PathBuf;

use serde::{Deserialize, Serialize};

use crate::sim::collision::CollisionSettings as PipelineSettings;
use crate::sim::inextensibility::StrainLimiting;
use crate::sim::motion::MotionSpec;
use crate::sim::pcg::PreconditionerKind;

/// A whole scene file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneFile {
    /// What the scene is for, in a sentence.
    #[serde(default)]
    pub description: String,
    /// A demonstration (default) or a hard case (a stress test of the
    /// solver, listed apart in the editor).
    #[serde(default, skip_serializing_if = "SceneKind::is_demo")]
    pub kind: SceneKind,
    /// Frame rate and length.
    pub time: TimeSettings,
    /// Linear solver and stepping.
    #[serde(default)]
    pub solver: SolverSettings,
    /// Scene-wide collision settings.
    #[serde(default)]
    pub collision: CollisionSettings,
    /// The cloths.
    #[serde(default, rename = "garment")]
    pub garments: Vec<GarmentSpec>,
    /// The obstacles.
    #[serde(default, rename = "collider")]
    pub colliders: Vec<ColliderSpec>,
    /// Animated bodies (`[[body]]`): the garments dress them.
    #[serde(default, rename = "body", skip_serializing_if = "Vec::is_empty")]
    pub bodies: Vec<BodySpec>,
    /// How renders and the editor's viewport look at the scene.
    #[serde(default, skip_serializing_if = "CameraSpec::is_automatic")]
    pub camera: CameraSpec,
    /// Where the editor exports this scene's frames.
    #[serde(default, skip_serializing_if = "ExportSpec::is_default")]
    pub export: ExportSpec,
}

/// What a scene is for: `kind = "demo"` (the default) or `"hard-case"`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum SceneKind {
    /// Shows what drape does (a garment on a body, a drape).
    #[default]
    Demo,
    /// A stress test of stability or robustness (SCENES.md's hard cases).
    HardCase,
}

impl SceneKind {
    /// Whether this is the default kind (not written to saved files).
    pub fn is_demo(&self) -> bool {
        *self == SceneKind::Demo
    }
}

/// An animated body: a deforming collider that garments can attach to.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BodySpec {
    /// Name, for reports and `attach = "..."` pins.
    #[serde(default = "default_body_name")]
    pub name: String,
    /// The body: an FBX (binary or ASCII) with its meshes, skins and
    /// animation, or a `.motion` cache made by `drape import-motion`;
    /// relative to the scene file.
    pub file: PathBuf,
    /// Keep only the FBX's meshes of these names (default: every mesh).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub parts: Option<Vec<String>>,
    /// Leave out the FBX's meshes of these names (eyes, hair...).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub exclude: Vec<String>,
    /// Drive the FBX body with this FBX file's motion instead of its own
    /// (motion reuse: bones are matched by name); it may hold no mesh (a
    /// motion library, a Mixamo animation downloaded without skin).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub motion: Option<PathBuf>,
    /// The animation stack to play, by name (of `motion` when given);
    /// default: the file's first.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stack: Option<String>,
    /// Seconds into the motion when it starts playing.
    #[serde(default)]
    pub start_s: f64,
    /// The body starts in its bind pose (the pose garments are fitted to) and
    /// moves into the motion's first pose over this long before the motion
    /// plays, s (FBX bodies).
    #[serde(default)]
    pub blend_in_s: f64,
    /// Playback rate of the motion (2 plays it twice as fast), unitless.
    #[serde(default = "default_speed")]
    pub speed: f64,
    /// Repeat the motion after its end (a cycle such as an in-place walk);
    /// otherwise the body holds its last pose.
    #[serde(default)]
    pub cycle: bool,
    /// Where the body stands, m.
    #[serde(default)]
    pub position_m: [f64; 3],
    /// Its rotation about X, Y, Z (fixed axes), degrees.
    #[serde(default)]
    pub rotation_deg: [f64; 3],
    /// Friction coefficient overriding the fabric's, unitless.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub friction: Option<f64>,
}

/// Where the editor exports a scene's frames (`[export]`).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExportSpec {
    /// The folder last exported to, relative to the scene file.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub folder: Option<PathBuf>,
}

impl ExportSpec {
    /// True when nothing is set (not written to the file).
    pub fn is_default(&self) -> bool {
        *self == ExportSpec::default()
    }
}

impl BodySpec {
    /// A body read from `file` (relative to the scene's folder), every
    /// other setting at its default.
    pub fn new(file: PathBuf) -> BodySpec {
        BodySpec {
            name: default_body_name(),
            file,
            parts: None,
            exclude: Vec::new(),
            motion: None,
            stack: None,
            start_s: 0.0,
            blend_in_s: 0.0,
            speed: default_speed(),
            cycle: false,
            position_m: [0.0; 3],
            rotation_deg: [0.0; 3],
            friction: None,
        }
    }
}

fn default_speed() -> f64 {
    1.0
}

fn default_body_name() -> String {
    "body".into()
}

/// The camera orbit of renders and of the editor's first view. Every key is
/// optional: by default the camera frames the scene's first frame from a
/// three-quarter view.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraSpec {
    /// Angle about the vertical axis from +Z towards +X, degrees.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub yaw_deg: Option<f64>,
    /// Elevation above the horizontal (positive looks down), degrees.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pitch_deg: Option<f64>,
    /// Vertical field of view, degrees.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fov_deg: Option<f64>,
    /// Distance from the target, m (default: what frames the scene).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub distance_m: Option<f64>,
    /// Point looked at, m (default: the centre of the scene's bounds).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub target_m: Option<[f64; 3]>,
    /// When given, the camera circles the scene once in this period (a
    /// turntable), s.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub turntable_period_s: Option<f64>,
}

impl CameraSpec {
    /// Whether nothing is set (the camera frames the scene by itself).
    pub fn is_automatic(&self) -> bool {
        *self == CameraSpec::default()
    }
}

/// Frame rate and frame range. Frame 0 is the initial state; frames
/// `1..=round(duration × fps)` are simulated.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TimeSettings {
    /// Frames per second of the output.
    #[serde(default = "default_fps")]
    pub fps: f64,
    /// Length of the animation, s.
    pub duration_s: f64,
}

fn default_fps() -> f64 {
    30.0
}

/// How each frame is stepped and solved.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SolverSettings {
    /// Solver steps per frame; when absent, the fewest steps that respect every
    /// garment's `time_step_s`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub steps_per_frame: Option<u32>,
    /// Relative residual at which the conjugate-gradient solve stops.
    #[serde(default = "default_tolerance")]
    pub tolerance: f64,
    /// The local error estimate (backward Euler's, root mean square over the
    /// particles) a step longer than `1/steps_per_frame` of a frame may
    /// have, as a fraction of the error the nominal step makes in free fall:
    /// while the cloth is that calm, steps double up to a whole frame
    /// ([`crate::sim::adaptive`]). 0 keeps every step nominal.
    #[serde(default = "default_long_step_error")]
    pub long_step_error: f64,
    /// Iteration cap of the conjugate-gradient solve.
    #[serde(default = "default_max_iterations")]
    pub max_iterations: u32,
    /// Preconditioner of the conjugate-gradient solve: `cholesky` (default; a
    /// sparse factor kept across steps while it works), `multigrid` (linear
    /// memory, for very large meshes) or `block_jacobi`.
    #[serde(default)]
    pub preconditioner: PreconditionerKind,
    /// How fabrics' strain limits are enforced: `projection` (default; fast
    /// projection, PAPER eq. 6), `clamp` (per-edge clamping, cheap, slow to
    /// converge on fine meshes) or `off` (the stretch springs alone).
    #[serde(default)]
    pub strain_limiting: StrainLimiting,
}

fn default_tolerance() -> f64 {
    1e-3
}

fn default_long_step_error() -> f64 {
    0.5
}

fn default_max_iterations() -> u32 {
    500
}

impl Default for SolverSettings {
    fn default() -> Self {
        SolverSettings {
            steps_per_frame: None,
            tolerance: default_tolerance(),
            long_step_error: default_long_step_error(),
            max_iterations: default_max_iterations(),
            preconditioner: PreconditionerKind::default(),
            strain_limiting: StrainLimiting::default(),
        }
    }
}

/// Scene-wide collision settings (PAPER Fig. 10c). Thickness and friction
/// override the garments' fabric values; the rest tune the collision pipeline.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CollisionSettings {
    /// Distance the cloth keeps from colliders and from itself, m.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub thickness_m: Option<f64>,
    /// Friction coefficient between cloth and colliders and between layers.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub friction: Option<f64>,
    /// Detect → respond passes per step before impact zones take over.
    #[serde(default = "default_passes")]
    pub passes: u32,
    /// Fraction of the contacts' total shortfall a pass must take away for
    /// the next one to respond, 0 ≤ p < 1 (0 turns this off).
    #[serde(default = "default_pass_progress")]
    pub pass_progress: f64,
    /// Decay factor `a` of a contact's influence when it is not seen again
    /// (eq. 16), 0 < a < 1.
    #[serde(default = "default_decay")]
    pub influence_decay: f64,
    /// Influence at which a contact joins the constraint set solved together.
    #[serde(default = "default_threshold")]
    pub influence_threshold: f64,
    /// Sweeps over the constraint set per pass.
    #[serde(default = "default_sweeps")]
    pub constraint_sweeps: u32,
    /// Rounds of rigid impact zones before a step gives up.
    #[serde(default = "default_zone_rounds")]
    pub zone_rounds: u32,
    /// Test each vertex and edge from one owning triangle only (PAPER
    /// Algorithm 1); `false` is for measuring what that saves.
    #[serde(default = "default_representative")]
    pub representative_triangles: bool,
    /// Stiffness of the springs that push resting self-contacts apart in the
    /// implicit solve, N/m (0 turns them off).
    #[serde(default = "default_repulsion_stiffness")]
    pub repulsion_stiffness_n_per_m: f64,
    /// Stiffness of the springs that push the cloth off the analytic
    /// colliders' sharp features (edges, corners, tips) it rests on in the
    /// implicit solve, N/m (0 turns them off).
    #[serde(default = "default_feature_repulsion_stiffness")]
    pub feature_repulsion_stiffness_n_per_m: f64,
    /// Stiffness of the springs that hold the cloth on the tips of props
    /// narrower than its edges it rests on as on a point (a needle), in
    /// the implicit solve, N/m (0 turns them off).
    #[serde(default = "default_tip_repulsion_stiffness")]
    pub tip_repulsion_stiffness_n_per_m: f64,
    /// How near the thickness a contact rests, and how far past it its
    /// spring pushes, as a fraction of the thickness, 0 < b < 1.
    #[serde(default = "default_repulsion_band")]
    pub repulsion_band: f64,
}

fn default_passes() -> u32 {
    PipelineSettings::default().passes
}
fn default_pass_progress() -> f64 {
    PipelineSettings::default().pass_progress
}
fn default_decay() -> f64 {
    PipelineSettings::default().influence_decay
}
fn default_threshold() -> f64 {
    PipelineSettings::default().influence_threshold
}
fn default_sweeps() -> u32 {
    PipelineSettings::default().constraint_sweeps
}
fn default_zone_rounds() -> u32 {
    PipelineSettings::default().zone_rounds
}
fn default_representative() -> bool {
    PipelineSettings::default().representative_triangles
}
fn default_repulsion_stiffness() -> f64 {
    PipelineSettings::default().repulsion_stiffness
}
fn default_feature_repulsion_stiffness() -> f64 {
    PipelineSettings::default().feature_repulsion_stiffness
}
fn default_tip_repulsion_stiffness() -> f64 {
    PipelineSettings::default().tip_repulsion_stiffness
}
fn default_repulsion_band() -> f64 {
    PipelineSettings::default().repulsion_band
}

impl Default for CollisionSettings {
    fn default() -> Self {
        let p = PipelineSettings::default();
        CollisionSettings {
            thickness_m: None,
            friction: None,
            passes: p.passes,
            pass_progress: p.pass_progress,
            influence_decay: p.influence_decay,
            influence_threshold: p.influence_threshold,
            constraint_sweeps: p.constraint_sweeps,
            zone_rounds: p.zone_rounds,
            representative_triangles: p.representative_triangles,
            repulsion_stiffness_n_per_m: p.repulsion_stiffness,
            feature_repulsion_stiffness_n_per_m: p.feature_repulsion_stiffness,
            tip_repulsion_stiffness_n_per_m: p.tip_repulsion_stiffness,
            repulsion_band: p.repulsion_band,
        }
    }
}

impl CollisionSettings {
    /// The pipeline's constants.
    pub fn pipeline(&self) -> PipelineSettings {
        PipelineSettings {
            passes: self.passes,
            pass_progress: self.pass_progress,
            influence_decay: self.influence_decay,
            influence_threshold: self.influence_threshold,
            constraint_sweeps: self.constraint_sweeps,
            zone_rounds: self.zone_rounds,
            representative_triangles: self.representative_triangles,
            repulsion_stiffness: self.repulsion_stiffness_n_per_m,
            feature_repulsion_stiffness: self.feature_repulsion_stiffness_n_per_m,
            tip_repulsion_stiffness: self.tip_repulsion_stiffness_n_per_m,
            repulsion_band: self.repulsion_band,
        }
    }
}

/// One cloth.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GarmentSpec {
    /// Name, used for export files.
    pub name: String,
    /// Fabric preset: built-in name or path to a preset file.
    pub preset: String,
    /// Values replacing the preset's `[fabric]` entries.
    #[serde(default, skip_serializing_if = "toml::Table::is_empty")]
    pub fabric: toml::Table,
    /// Where the mesh comes from.
    pub mesh: MeshSpec,
    /// Translation applied after rotation and scale, m.
    #[serde(default)]
    pub translation_m: [f64; 3],
    /// Rotation about X, then Y, then Z (fixed axes), degrees.
    #[serde(default)]
    pub rotation_deg: [f64; 3],
    /// Uniform scale applied first (e.g. 0.01 for a mesh in centimetres).
    #[serde(default = "default_scale")]
    pub scale: f64,
    /// Whether the garment collides with itself (folds, layers).
    #[serde(default = "default_self_collision")]
    pub self_collision: bool,
    /// Held vertices.
    #[serde(default, rename = "pin", skip_serializing_if = "Vec::is_empty")]
    pub pins: Vec<PinSpec>,
}

fn default_self_collision() -> bool {
    true
}

fn default_scale() -> f64 {
    1.0
}

/// A garment mesh: a file or a generated shape.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum MeshSpec {
    /// An OBJ file, relative to the scene file.
    Obj(PathBuf),
    /// A square grid cloth in the XZ plane (see [`crate::mesh::generate::grid`]).
    Grid {
        /// Side length, m.
        size_m: f64,
        /// Vertices per side.
        resolution: usize,
    },
    /// An open tube along X (see [`crate::mesh::generate::tube`]).
    Tube {
        /// Radius, m.
        radius_m: f64,
        /// Length, m.
        length_m: f64,
        /// Vertices around each ring.
        around: usize,
        /// Number of rings.
        along: usize,
    },
}

/// A group of pinned vertices, optionally moving together.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PinSpec {
    /// Vertex indices (0-based, in the mesh's vertex order after welding).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub vertices: Vec<u32>,
    /// Every vertex inside this box of the mesh's own coordinates (before the
    /// garment transform).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub region: Option<Region>,
    /// Motion of the pinned vertices; the pivot defaults to their centroid.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub motion: Option<MotionSpec>,
    /// Name of a mesh collider to glue the vertices to: each is held at the
    /// point of that mesh closest to it at the start (barycentric on its
    /// triangle) and follows the mesh as it moves. Excludes `motion`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub attach: Option<String>,
}

/// An axis-aligned box, m.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Region {
    /// Lower corner, m.
    pub min_m: [f64; 3],
    /// Upper corner, m.
    pub max_m: [f64; 3],
}

/// One obstacle.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ColliderSpec {
    /// Name, for reports.
    pub name: String,
    /// The solid.
    pub shape: ShapeSpec,
    /// Centre of the shape at time 0, m (for a plane: a point on it).
    #[serde(default)]
    pub position_m: [f64; 3],
    /// Rotation about X, then Y, then Z (fixed axes), degrees.
    #[serde(default)]
    pub rotation_deg: [f64; 3],
    /// Friction coefficient overriding the fabric's.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub friction: Option<f64>,
    /// Kinematic motion; the pivot defaults to `position_m`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub motion: Option<MotionSpec>,
}

/// Collider shapes, each centred on the collider's position with its axis
/// along local Y.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum ShapeSpec {
    /// The half-space below the local XZ plane (a ground when unrotated).
    Plane,
    /// A ball.
    Sphere {
        /// Radius, m.
        radius_m: f64,
    },
    /// A box.
    Box {
        /// Full size along X, Y, Z, m.
        size_m: [f64; 3],
    },
    /// A capped cylinder.
    Cylinder {
        /// Radius, m.
        radius_m: f64,
        /// Height, m.
        height_m: f64,
    },
    /// A cone, apex up.
    Cone {
        /// Base radius, m.
        radius_m: f64,
        /// Height, m.
        height_m: f64,
    },
    /// An upright prism on an equilateral triangle.
    Prism {
        /// Side of the triangle, m.
        side_m: f64,
        /// Height, m.
        height_m: f64,
    },
    /// A rigid triangle mesh from an OBJ file (relative to the scene file),
    /// placed by the collider's position and rotation.
    Mesh {
        /// OBJ file.
        obj: PathBuf,
        /// Uniform scale applied first (e.g. 0.01 for centimetres).
        #[serde(default = "default_scale")]
        scale: f64,
    },
}
