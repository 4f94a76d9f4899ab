//! Skinning as the FBX SDK defines it: each vertex follows the bones of its
//! clusters, weighted, by linear blending, by dual quaternions, or by a
//! per-vertex mix of the two.

use nalgebra::{Matrix4, Quaternion, UnitQuaternion, Vector3};
use rayon::prelude::*;

use super::transform::rotation_and_scale;

/// How a skin blends its bones (FBX `SkinningType`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum SkinningMethod {
    /// Weighted sum of the bones' matrices (the default).
    #[default]
    Linear,
    /// As linear (FBX keeps the name for skins with one bone per vertex).
    Rigid,
    /// Dual quaternions: rotations blended without the volume loss of linear skinning.
    DualQuaternion,
    /// Per vertex, a mix of linear and dual-quaternion results.
    Blend,
}

/// A cluster: the bone it follows and where the geometry was, relative to
/// that bone, when the skin was bound.
#[derive(Clone, Debug, PartialEq)]
pub struct Cluster {
    /// Index of the bone in the body's skeleton.
    pub bone: usize,
    /// `bone_from_geometry` at bind: the cluster's `Transform` times the
    /// mesh node's geometric transform.
    pub bone_from_geometry: Matrix4<f64>,
}

/// The skin of one mesh.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Skin {
    /// How the bones blend.
    pub method: SkinningMethod,
    /// The clusters.
    pub clusters: Vec<Cluster>,
    /// Per vertex, where its influences start in `influences`; one more
    /// entry marks the end.
    pub starts: Vec<u32>,
    /// (cluster, weight) pairs, each vertex's heaviest first.
    pub influences: Vec<(u32, f64)>,
    /// Per vertex, the share of dual-quaternion skinning (0: linear, 1:
    /// dual quaternions); empty when the method alone decides.
    pub dual_quaternion_share: Vec<f64>,
    /// `node_from_file` of the mesh's node at bind, when the skinned mesh
    /// also moves with its node since then (Maya's skin clusters work in
    /// the mesh's own space); `None`: bones alone place it (the FBX SDK).
    pub node_at_bind_inverse: Option<Matrix4<f64>>,
}

/// A cluster's current matrix as translation, rotation and scale (dual quaternion skinning).
#[derive(Clone, Copy, Debug)]
struct RigidPart {
    translation: Vector3<f64>,
    rotation: Quaternion<f64>,
    scale: Vector3<f64>,
}

impl Skin {
    /// A skin from per-vertex (cluster, weight) lists: weights that are not
    /// finite are dropped, the rest kept heaviest first (ties by cluster).
    pub fn from_weights(
        method: SkinningMethod,
        clusters: Vec<Cluster>,
        weights: Vec<Vec<(u32, f64)>>,
        dual_quaternion_share: Vec<f64>,
    ) -> Skin {
        let mut starts = Vec::with_capacity(weights.len() + 1);
        let mut influences = Vec::new();
        starts.push(0);
        for mut vertex in weights {
            vertex.retain(|w| w.1.is_finite());
            vertex.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
            influences.extend(vertex);
            starts.push(influences.len() as u32);
        }
        Skin { method, clusters, starts, influences, dual_quaternion_share, node_at_bind_inverse: None }
    }

    /// The influences of vertex `v`.
    pub fn vertex_influences(&self, v: usize) -> &[(u32, f64)] {
        let (Some(&a), Some(&b)) = (self.starts.get(v), self.starts.get(v + 1)) else { return &[] };
        self.influences.get(a as usize..b as usize).unwrap_or(&[])
    }

    /// The number of vertices the skin covers.
    pub fn vertex_count(&self) -> usize {
        self.starts.len().saturating_sub(1)
    }

    /// Skinned positions, file space: `geometry` (the mesh's points after
    /// blend shapes) moved by the bones' current `file_from_bone`;
    /// vertices no cluster weighs follow `file_from_geometry` (the mesh
    /// node's own transform, `file_from_node` times its geometric one).
    /// Parallel over vertices, the same bits at any thread count.
    pub fn deform(
        &self,
        geometry: &[Vector3<f64>],
        file_from_bone: &[Matrix4<f64>],
        (file_from_node, file_from_geometry): (&Matrix4<f64>, &Matrix4<f64>),
        out: &mut [Vector3<f64>],
    ) {
        let since_bind = self.node_at_bind_inverse.map(|inverse| file_from_node * inverse);
        let matrices: Vec<Matrix4<f64>> = self
            .clusters
            .iter()
            .map(|c| {
                let m = file_from_bone.get(c.bone).copied().unwrap_or_else(Matrix4::identity) * c.bone_from_geometry;
                since_bind.map_or(m, |s| s * m)
            })
            .collect();
        let needs_rigid = self.method != SkinningMethod::Linear && self.method != SkinningMethod::Rigid
            || !self.dual_quaternion_share.is_empty();
        let rigid: Vec<RigidPart> = match needs_rigid {
            true => matrices.iter().map(rigid_part).collect(),
            false => Vec::new(),
        };
        let default_share = if self.method == SkinningMethod::DualQuaternion { 1.0 } else { 0.0 };
        out.par_iter_mut().zip(geometry).enumerate().for_each(|(v, (out, p))| {
            let influences = self.vertex_influences(v);
            let total: f64 = influences.iter().map(|i| i.1).sum();
            if total <= 0.0 {
                *out = file_from_geometry.transform_point(&(*p).into()).coords;
                return;
            }
            let share = self.dual_quaternion_share.get(v).copied().unwrap_or(default_share);
            let linear = if share < 1.0 { Some(linear_blend(&matrices, influences, total)) } else { None };
            let dual = if share > 0.0 { Some(dual_quaternion_blend(&rigid, influences, total)) } else { None };
            let m = match (linear, dual) {
                (Some(l), Some(d)) => l * (1.0 - share) + d * share,
                (Some(l), None) => l,
                (None, Some(d)) => d,
                (None, None) => Matrix4::identity(),
            };
            *out = m.transform_point(&(*p).into()).coords;
        });
    }
}

/// Σ w · M over the influences, divided by their total when it is not 1.
fn linear_blend(matrices: &[Matrix4<f64>], influences: &[(u32, f64)], total: f64) -> Matrix4<f64> {
    let mut sum = Matrix4::zeros();
    for &(c, w) in influences {
        if let Some(m) = matrices.get(c as usize) {
            sum += m * w;
        }
    }
    if total != 1.0 { sum / total } else { sum }
}

/// A matrix split into translation, rotation and scale (no iteration).
fn rigid_part(m: &Matrix4<f64>) -> RigidPart {
    let linear = m.fixed_view::<3, 3>(0, 0).into_owned();
    let (rotation, scale) = rotation_and_scale(&linear).unwrap_or((nalgebra::Rotation3::identity(), Vector3::zeros()));
    RigidPart {
        translation: m.fixed_view::<3, 1>(0, 3).into_owned(),
        rotation: UnitQuaternion::from_rotation_matrix(&rotation).into_inner(),
        scale,
    }
}

/// Dual-quaternion blend of the influences' rigid parts, with their scales
/// averaged: `T · R · S` of the blend.
fn dual_quaternion_blend(parts: &[RigidPart], influences: &[(u32, f64)], total: f64) -> Matrix4<f64> {
    let Some(first) = influences.first().and_then(|i| parts.get(i.0 as usize)) else { return Matrix4::identity() };
    let (mut real, mut dual, mut scale) = (Quaternion::default(), Quaternion::default(), Vector3::zeros());
    for &(c, w) in influences {
        let Some(part) = parts.get(c as usize) else { continue };
        let q = if first.rotation.dot(&part.rotation) < 0.0 { -part.rotation } else { part.rotation };
        let moved = Quaternion::from_imag(part.translation * 0.5) * q;
        real += q * w;
        dual += moved * w;
        scale += part.scale * w;
    }
    if total != 1.0 && total.abs() > 1e-12 {
        (real, dual, scale) = (real / total, dual / total, scale / total);
    }
    let norm_squared = real.norm_squared();
    if norm_squared <= 0.0 {
        return Matrix4::identity();
    }
    let translation = (dual * real.conjugate()).imag() * 2.0 / norm_squared;
    let rotation = UnitQuaternion::from_quaternion(real);
    Matrix4::new_translation(&translation) * rotation.to_homogeneous() * Matrix4::new_nonuniform_scaling(&scale)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn two_bone_skin(method: SkinningMethod) -> Skin {
        let clusters = (0..2).map(|bone| Cluster { bone, bone_from_geometry: Matrix4::identity() }).collect();
        Skin::from_weights(method, clusters, vec![vec![(0, 0.5), (1, 0.5)], vec![]], Vec::new())
    }

    #[test]
    fn a_vertex_halfway_between_two_bones_moves_half_as_much() {
        let skin = two_bone_skin(SkinningMethod::Linear);
        let moved = [Matrix4::identity(), Matrix4::new_translation(&Vector3::new(0.0, 2.0, 0.0))];
        let geometry = [Vector3::new(1.0, 0.0, 0.0), Vector3::new(5.0, 0.0, 0.0)];
        let mut out = [Vector3::zeros(); 2];
        let node = Matrix4::new_translation(&Vector3::new(0.0, 0.0, 1.0));
        skin.deform(&geometry, &moved, (&node, &node), &mut out);
        assert!((out[0] - Vector3::new(1.0, 1.0, 0.0)).norm() < 1e-12);
        // A vertex no bone weighs follows the mesh's own node.
        assert!((out[1] - Vector3::new(5.0, 0.0, 1.0)).norm() < 1e-12);
    }

    #[test]
    fn a_mesh_in_its_nodes_space_moves_with_its_node_since_bind() {
        let mut skin = two_bone_skin(SkinningMethod::Linear);
        let bind = Matrix4::new_translation(&Vector3::new(1.0, 0.0, 0.0));
        skin.node_at_bind_inverse = bind.try_inverse();
        let node_now = Matrix4::new_translation(&Vector3::new(1.0, 3.0, 0.0));
        let bones = [Matrix4::identity(); 2];
        let mut out = [Vector3::zeros(); 2];
        skin.deform(&[Vector3::zeros(), Vector3::zeros()], &bones, (&node_now, &node_now), &mut out);
        assert!((out[0] - Vector3::new(0.0, 3.0, 0.0)).norm() < 1e-12, "moved by the node's 3 up since bind");
    }

    #[test]
    fn weights_that_do_not_sum_to_one_are_normalised_and_all_are_kept() {
        let clusters = (0..6).map(|bone| Cluster { bone, bone_from_geometry: Matrix4::identity() }).collect();
        let six = vec![(0, 0.1), (1, 0.4), (2, 0.2), (3, 0.2), (4, 0.1), (5, f64::NAN)];
        let skin = Skin::from_weights(SkinningMethod::Linear, clusters, vec![six], Vec::new());
        assert_eq!(skin.vertex_influences(0).iter().map(|i| i.0).collect::<Vec<_>>(), [1, 2, 3, 0, 4]);
        let mut bones = vec![Matrix4::identity(); 6];
        bones[4] = Matrix4::new_translation(&Vector3::new(2.0, 0.0, 0.0));
        let mut out = [Vector3::zeros()];
        skin.deform(&[Vector3::zeros()], &bones, (&Matrix4::identity(), &Matrix4::identity()), &mut out);
        // The fifth influence (0.1 of 1.0) is not dropped.
        assert!((out[0] - Vector3::new(0.2, 0.0, 0.0)).norm() < 1e-12);
    }

    #[test]
    fn dual_quaternions_keep_the_length_linear_blending_loses() {
        // Two bones turned ±90° about Z: linear blending collapses the
        // vertex onto the axis, dual quaternions keep its distance.
        let turn =
            |deg: f64| nalgebra::Rotation3::from_axis_angle(&Vector3::z_axis(), deg.to_radians()).to_homogeneous();
        let bones = [turn(90.0), turn(-90.0)];
        let geometry = [Vector3::new(1.0, 0.0, 0.0)];
        let (mut linear, mut dual, mut half) = ([Vector3::zeros()], [Vector3::zeros()], [Vector3::zeros()]);
        let id = Matrix4::identity();
        two_bone_skin(SkinningMethod::Linear).deform(&geometry, &bones, (&id, &id), &mut linear);
        two_bone_skin(SkinningMethod::DualQuaternion).deform(&geometry, &bones, (&id, &id), &mut dual);
        let mut blend = two_bone_skin(SkinningMethod::Blend);
        blend.dual_quaternion_share = vec![0.5, 0.5];
        blend.deform(&geometry, &bones, (&id, &id), &mut half);
        assert!(linear[0].norm() < 1e-12);
        assert!((dual[0].norm() - 1.0).abs() < 1e-12);
        assert!((half[0] - (linear[0] + dual[0]) / 2.0).norm() < 1e-12);
    }

    #[test]
    fn dual_quaternions_carry_the_bones_scale() {
        let clusters = vec![Cluster { bone: 0, bone_from_geometry: Matrix4::identity() }];
        let skin = Skin::from_weights(SkinningMethod::DualQuaternion, clusters, vec![vec![(0, 1.0)]], Vec::new());
        let bone = Matrix4::new_translation(&Vector3::new(0.0, 1.0, 0.0)) * Matrix4::new_scaling(3.0);
        let mut out = [Vector3::zeros()];
        let id = Matrix4::identity();
        skin.deform(&[Vector3::new(1.0, 0.0, 0.0)], &[bone], (&id, &id), &mut out);
        assert!((out[0] - Vector3::new(3.0, 1.0, 0.0)).norm() < 1e-12);
    }
}
