//! Animated bodies: a skinned mesh on a skeleton, and motions that pose it.
//!
//! Pure data and maths (no files): `io::fbx` builds a [`Body`] from an FBX
//! file. Positions come out in drape's world: Y up, metres.

pub mod curve;
pub mod motion;
pub mod skeleton;
pub mod skin;
pub mod transform;

use nalgebra::{Matrix4, Vector3};

use self::motion::{Motion, skeleton_height};
use self::skeleton::Skeleton;
use self::skin::Skin;
use crate::mesh::TriMesh;

/// A skinned body.
#[derive(Clone, Debug)]
pub struct Body {
    /// Name (the file stem).
    pub name: String,
    /// The mesh in the bind pose, world space (Y up, m), with its materials.
    pub mesh: TriMesh,
    /// The bones (the file's hierarchy above and including the skin's bones).
    pub skeleton: Skeleton,
    /// How the mesh follows the bones.
    pub skin: Skin,
    /// The file's own animation, if it has one.
    pub motion: Option<Motion>,
    /// Maps the file's axes and units to drape's (Y up, metres).
    pub world_from_file: Matrix4<f64>,
    /// The file's up axis, in file coordinates (for heights).
    pub up_in_file: Vector3<f64>,
}

impl Body {
    /// Height of this body's skeleton at rest, file units (see [`Motion::pose`]).
    pub fn skeleton_height(&self) -> f64 {
        skeleton_height(&self.skeleton, &self.up_in_file)
    }

    /// The skinned mesh posed by `motion` at `t_s` (from the motion's start),
    /// world space, m, into `out` (one position per mesh vertex).
    pub fn pose_into(&self, motion: &Motion, t_s: f64, out: &mut Vec<Vector3<f64>>) {
        let locals = motion.pose(&self.skeleton, t_s, self.skeleton_height());
        let world = self.skeleton.world_matrices(&locals);
        self.skin.deform(&world, &self.world_from_file, out);
    }

    /// The mesh in the bind pose, world space, m.
    pub fn bind_pose(&self) -> Vec<Vector3<f64>> {
        let world_from_mesh = self.world_from_file * self.skin.file_from_mesh;
        self.skin.bind_positions.iter().map(|p| (world_from_mesh * p.push(1.0)).xyz()).collect()
    }
}
