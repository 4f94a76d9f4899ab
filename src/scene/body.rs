//! A scene's `[[body]]`: an FBX body (its own motion or another file's) or a
//! motion cache, sampled at the scene's frame rate into a deforming collider.

use std::path::Path;
use std::sync::Arc;

use nalgebra::{Isometry3, Translation3, Vector3};

use super::file::BodySpec;
use crate::body::Body;
use crate::io::fbx::{BodyOptions, FbxError, read_body, read_motion};
use crate::io::motion_cache::{MotionCacheError, read_motion_cache};
use crate::mesh::Surface;
use crate::sim::collision::obstacles::MeshCollider;
use crate::sim::motion::Placement;
use crate::sim::vertex_animation::VertexAnimation;

/// Most memory a scene may spend on a body's sampled frames, bytes.
const MAX_SAMPLED_BYTES: f64 = 2e9;

/// The animated body of a scene.
#[derive(Clone, Debug)]
pub struct SceneBody {
    /// Index of its collider in the scene's mesh colliders.
    pub collider: usize,
    /// Its materials (skin, underwear...) by triangle runs, for drawing.
    pub surface: Surface,
    /// Where it came from, for reports.
    pub origin: String,
    /// What it is made of.
    pub loaded: LoadedBody,
}

/// What a body file gave the scene: its meshes, its animation stacks, and
/// how its motion fits.
#[derive(Clone, Debug, Default)]
pub struct LoadedBody {
    /// The meshes in the collider, in file order (one for a motion cache).
    pub parts: Vec<PartSummary>,
    /// Every mesh of the file, kept or not, in file order.
    pub meshes: Vec<String>,
    /// The animation stacks of the file whose motion plays, in file order.
    pub stacks: Vec<String>,
    /// The stack that plays, if any.
    pub stack: Option<String>,
    /// Bones of the motion the body lacks (motion reuse), for reports.
    pub unmatched_bones: Vec<String>,
}

impl LoadedBody {
    /// The file's meshes `parts` / `exclude` left out, in file order.
    pub fn left_out(&self) -> impl Iterator<Item = &str> {
        self.meshes.iter().map(String::as_str).filter(|m| !self.parts.iter().any(|p| p.name == *m))
    }
}

/// One mesh of a scene's body.
#[derive(Clone, Debug, PartialEq)]
pub struct PartSummary {
    /// Its name in the file.
    pub name: String,
    /// How it moves: skinned, rigid or static.
    pub kind: &'static str,
    /// Its vertices in the collider.
    pub vertices: std::ops::Range<usize>,
    /// Its triangles in the collider.
    pub triangles: std::ops::Range<usize>,
}

/// Why a body could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum BodyError {
    /// The FBX body or motion file.
    #[error(transparent)]
    Fbx(#[from] FbxError),
    /// The motion cache.
    #[error(transparent)]
    Cache(#[from] MotionCacheError),
    /// A setting that does not fit the file.
    #[error("{0}")]
    Invalid(String),
}

/// The collider and drawing data of `spec`, sampled at `fps` over
/// `duration_s` of scene time; paths relative to `base_dir`.
pub fn load_body(
    spec: &BodySpec,
    base_dir: &Path,
    fps: f64,
    duration_s: f64,
) -> Result<(MeshCollider, Surface, LoadedBody), BodyError> {
    let path = base_dir.join(&spec.file);
    let placement = Placement {
        rest_pose: Isometry3::from_parts(
            Translation3::from(Vector3::from(spec.position_m)),
            super::rotation(spec.rotation_deg),
        ),
        motion: None,
    };
    let is_cache = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("motion"));
    let (triangles, animation, bind, surface, loaded) = if is_cache {
        let fbx_only = spec.parts.is_some() || !spec.exclude.is_empty() || spec.stack.is_some();
        if spec.motion.is_some() || spec.blend_in_s > 0.0 || spec.speed != 1.0 || fbx_only {
            let why = "a motion cache is already posed: `motion`, `stack`, `parts`, `exclude`, `blend_in_s` and \
                       `speed` apply to FBX bodies";
            return Err(BodyError::Invalid(why.into()));
        }
        let cache = read_motion_cache(&path)?;
        let mut animation = cache.animation;
        animation.start_s = -spec.start_s;
        animation.cycle = spec.cycle;
        let vertices = 0..animation.frames.first().map_or(0, Vec::len);
        let part = PartSummary { name: "cache".into(), kind: "cached", vertices, triangles: 0..cache.triangles.len() };
        (
            cache.triangles,
            Some(animation),
            Vec::new(),
            Surface::default(),
            LoadedBody { parts: vec![part], ..Default::default() },
        )
    } else {
        let options = BodyOptions {
            parts: spec.parts.clone(),
            exclude: spec.exclude.clone(),
            stack: spec.stack.clone().filter(|_| spec.motion.is_none()),
        };
        let body = read_body(&path, &options)?;
        let (motion, stacks) = match &spec.motion {
            Some(other) => {
                let source = read_motion(&base_dir.join(other), spec.stack.as_deref())?;
                let motion = source.motion.ok_or_else(|| {
                    BodyError::Invalid(format!("{} has no animation to reuse", base_dir.join(other).display()))
                })?;
                (Some(motion), source.stacks)
            }
            None => (body.motion.clone(), body.stacks.clone()),
        };
        let unmatched = motion.as_ref().map(|m| m.bone_match(&body.skeleton).missing_in_skeleton).unwrap_or_default();
        let motion_name = motion.as_ref().map(|m| m.name.clone());
        let animation = match motion {
            Some(m) => Some(sample(&body, &m, spec, fps, duration_s)?),
            None => None,
        };
        let parts = body
            .parts
            .iter()
            .map(|p| PartSummary {
                name: p.name.clone(),
                kind: p.kind.label(),
                vertices: p.first_vertex..p.first_vertex + p.points.len(),
                triangles: p.triangles.clone(),
            })
            .collect();
        let loaded = LoadedBody {
            parts,
            meshes: body.meshes.clone(),
            stacks: stacks.into_iter().map(|s| s.name).collect(),
            stack: motion_name,
            unmatched_bones: unmatched,
        };
        (body.mesh.triangles, animation, body.mesh.positions, body.mesh.surface, loaded)
    };
    let vertices = match &animation {
        Some(a) => a.frames.first().cloned().unwrap_or_default(),
        None => bind,
    };
    if let Some(bad) = triangles.iter().flatten().find(|&&v| v as usize >= vertices.len()) {
        return Err(BodyError::Invalid(format!(
            "triangle vertex {bad} is beyond the body's {} vertices",
            vertices.len()
        )));
    }
    let collider = MeshCollider {
        name: spec.name.clone(),
        vertices,
        triangles,
        placement,
        friction: spec.friction,
        animation: animation.map(Arc::new),
    };
    Ok((collider, surface, loaded))
}

/// The body posed at every frame of the scene (and one past the end): from
/// the bind pose into the motion's first pose over `blend_in_s` (eased), then
/// the motion from `start_s` at `speed`. A cycling motion is posed over one
/// cycle only, after the blend, and repeats from there however long the
/// scene: a cycle's last key leads to its first one frame later (cycles are
/// exported without repeating their first pose at the end).
fn sample(
    body: &Body,
    motion: &crate::body::motion::Motion,
    spec: &BodySpec,
    fps: f64,
    duration_s: f64,
) -> Result<VertexAnimation, BodyError> {
    let length = motion.duration_s();
    let cycles = spec.cycle && length > 0.0;
    let lead_in = if cycles { (spec.blend_in_s * fps).ceil() as usize } else { 0 };
    let frames = if cycles {
        lead_in + (((length + 1.0 / fps) / spec.speed) * fps).round().max(1.0) as usize
    } else {
        (duration_s * fps).ceil() as usize + 1
    };
    let bytes = frames as f64 * body.mesh.vertex_count() as f64 * std::mem::size_of::<Vector3<f64>>() as f64;
    if bytes > MAX_SAMPLED_BYTES {
        return Err(BodyError::Invalid(format!(
            "{frames} frames of {} vertices would take {:.1} GB: shorten the scene, lower its frame rate, \
             or bake the motion with drape import-motion",
            body.mesh.vertex_count(),
            bytes / 1e9
        )));
    }
    let bind = body.bind_pose();
    let mut first = Vec::new();
    body.pose_into(motion, spec.start_s.clamp(0.0, length.max(0.0)), &mut first);
    let mut posed = Vec::new();
    let frames = (0..frames)
        .map(|f| {
            let scene_t = f as f64 / fps;
            if scene_t < spec.blend_in_s {
                let s = scene_t / spec.blend_in_s;
                let w = s * s * (3.0 - 2.0 * s);
                return bind.iter().zip(&first).map(|(a, b)| a * (1.0 - w) + b * w).collect();
            }
            let mut t = spec.start_s + (scene_t - spec.blend_in_s) * spec.speed;
            if cycles {
                t = t.rem_euclid(length + 1.0 / fps);
            }
            body.pose_into(motion, t.clamp(0.0, length.max(0.0)), &mut posed);
            posed.clone()
        })
        .collect();
    Ok(VertexAnimation { fps, start_s: 0.0, frames, cycle: cycles, lead_in })
}
