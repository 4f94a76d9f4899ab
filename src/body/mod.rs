//! Animated bodies: a character's meshes (skinned, moved rigidly by their
//! nodes, or static) on one hierarchy of nodes, and motions that pose it.
//!
//! Pure data and maths (no files): `io::fbx` builds a [`Body`] from an FBX
//! file. Positions come out in drape's world: Y up, metres.

pub mod blend_shape;
pub mod curve;
pub mod motion;
pub mod skeleton;
pub mod skin;
pub mod transform;

use nalgebra::{Matrix4, Vector3};
use rayon::prelude::*;

use self::blend_shape::ShapeChannel;
use self::motion::{Motion, skeleton_height};
use self::skeleton::Skeleton;
use self::skin::Skin;
use crate::mesh::TriMesh;

/// How a part of a body moves.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PartKind {
    /// Bones deform it (a skin).
    Skinned,
    /// It moves rigidly with its node (its node or a parent is animated).
    Rigid,
    /// Nothing moves it.
    Static,
}

impl PartKind {
    /// Lower-case name for reports.
    pub fn label(self) -> &'static str {
        match self {
            PartKind::Skinned => "skinned",
            PartKind::Rigid => "rigid",
            PartKind::Static => "static",
        }
    }
}

/// The polygons of a mesh as its file stores them (before fanning into
/// triangles), to compare with other applications' exports.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Polygons {
    /// Every polygon's points (indices into the part's points), one after another.
    pub corners: Vec<u32>,
    /// Where each polygon starts in `corners`, with the end as the last entry.
    pub starts: Vec<u32>,
}

/// One mesh of a body.
#[derive(Clone, Debug, PartialEq)]
pub struct BodyPart {
    /// The name of its node in the file.
    pub name: String,
    /// Index of its node in the skeleton.
    pub node: usize,
    /// `node_from_geometry`: the node's geometric transform (its geometry alone).
    pub geometric: Matrix4<f64>,
    /// Its first vertex in the body's mesh.
    pub first_vertex: usize,
    /// Its triangles in the body's mesh: the first and how many.
    pub triangles: std::ops::Range<usize>,
    /// Its points in the geometry's frame, file units.
    pub points: Vec<Vector3<f64>>,
    /// Blend-shape channels, applied before skinning.
    pub shapes: Vec<ShapeChannel>,
    /// Its skin, if bones deform it.
    pub skin: Option<Skin>,
    /// How it moves in the file's own animation.
    pub kind: PartKind,
    /// Its polygons as stored.
    pub polygons: Polygons,
}

/// An animation stack of the body's file: name and span.
#[derive(Clone, Debug, PartialEq)]
pub struct StackSummary {
    /// The stack's name.
    pub name: String,
    /// Start on the file's timeline, s.
    pub start_s: f64,
    /// End on the file's timeline, s.
    pub end_s: f64,
}

/// An animated body: every kept mesh of a character, merged.
#[derive(Clone, Debug)]
pub struct Body {
    /// Name (the file stem).
    pub name: String,
    /// What the file is, for reports (`binary FBX 7400 saved by Maya`).
    pub source: String,
    /// The parts' meshes merged, in the bind pose, world space (Y up, m),
    /// with their materials.
    pub mesh: TriMesh,
    /// Every node of the file, parents first.
    pub skeleton: Skeleton,
    /// The meshes, in file order.
    pub parts: Vec<BodyPart>,
    /// The names of every mesh of the file, kept or left out, in file order.
    pub meshes: Vec<String>,
    /// The chosen stack's animation, if it animates anything.
    pub motion: Option<Motion>,
    /// Every animation stack of the file, in file order.
    pub stacks: Vec<StackSummary>,
    /// Maps the file's axes and units to drape's (Y up, metres).
    pub world_from_file: Matrix4<f64>,
    /// The file's up axis, in file coordinates (for heights).
    pub up_in_file: Vector3<f64>,
}

impl Body {
    /// Height of this body's skeleton at bind, file units (see [`Motion::pose`]).
    pub fn skeleton_height(&self) -> f64 {
        skeleton_height(&self.skeleton, &self.up_in_file)
    }

    /// The body posed by `motion` at `t_s` (from the motion's start),
    /// world space, m, into `out` (one position per mesh vertex).
    pub fn pose_into(&self, motion: &Motion, t_s: f64, out: &mut Vec<Vector3<f64>>) {
        self.pose_in_file(motion, t_s, out);
        self.to_world(out);
    }

    /// The body posed by `motion` at `t_s` (from the motion's start), in
    /// the file's own axes and units.
    pub fn pose_in_file(&self, motion: &Motion, t_s: f64, out: &mut Vec<Vector3<f64>>) {
        let locals = motion.pose(&self.skeleton, t_s, self.skeleton_height());
        let world = self.skeleton.world_matrices(&locals);
        let percent = |c: &ShapeChannel| motion.shape_percent(&c.name, c.percent, t_s).unwrap_or(c.percent);
        self.deform(&world, &percent, out);
    }

    /// The body as the file's static values place it (no animation), in
    /// the file's own axes and units.
    pub fn static_in_file(&self, out: &mut Vec<Vector3<f64>>) {
        let world = self.skeleton.world_matrices(&self.skeleton.rest_pose());
        self.deform(&world, &|c: &ShapeChannel| c.percent, out);
    }

    /// The mesh in the bind pose, world space, m: skinned parts where their
    /// bones were bound, the others under their nodes' bind placement.
    pub fn bind_pose(&self) -> Vec<Vector3<f64>> {
        let mut out = Vec::new();
        self.deform(&self.skeleton.bind_matrices(), &|c: &ShapeChannel| c.percent, &mut out);
        self.to_world(&mut out);
        out
    }

    /// Every part deformed by the nodes' `file_from_bone` and its blend
    /// shapes at the channels' percentages, file space.
    fn deform(
        &self,
        file_from_bone: &[Matrix4<f64>],
        percent: &dyn Fn(&ShapeChannel) -> f64,
        out: &mut Vec<Vector3<f64>>,
    ) {
        out.resize(self.mesh.vertex_count(), Vector3::zeros());
        for part in &self.parts {
            let end = (part.first_vertex + part.points.len()).min(out.len());
            let Some(slice) = out.get_mut(part.first_vertex..end) else { continue };
            let mut points = part.points.clone();
            for channel in &part.shapes {
                channel.apply(percent(channel), &mut points);
            }
            let node = file_from_bone.get(part.node).copied().unwrap_or_else(Matrix4::identity);
            let geometry = node * part.geometric;
            match &part.skin {
                Some(skin) => skin.deform(&points, file_from_bone, (&node, &geometry), slice),
                None => slice
                    .par_iter_mut()
                    .zip(&points)
                    .for_each(|(o, p)| *o = geometry.transform_point(&(*p).into()).coords),
            }
        }
    }

    /// File space to world space, in place.
    fn to_world(&self, points: &mut [Vector3<f64>]) {
        let m = self.world_from_file;
        points.par_iter_mut().for_each(|p| *p = m.transform_point(&(*p).into()).coords);
    }
}
