//! Linear blend skinning: each vertex follows up to four bones, weighted.

use nalgebra::{Matrix4, Vector3};
use rayon::prelude::*;

/// Most bones a vertex follows.
pub const MAX_INFLUENCES: usize = 4;

/// The skin of a mesh.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Skin {
    /// Vertex positions in the mesh's own frame at bind time, file units.
    pub bind_positions: Vec<Vector3<f64>>,
    /// Per vertex, (bone, weight) pairs: weights sum to 1; unused slots have weight 0.
    pub influences: Vec<[(u32, f32); MAX_INFLUENCES]>,
    /// Per bone, `bone_from_mesh` at bind time (the inverse bind matrix times
    /// the mesh's bind transform); identity for bones that deform nothing.
    pub bone_from_mesh: Vec<Matrix4<f64>>,
    /// `file_from_mesh` at bind time, for vertices no bone moves.
    pub file_from_mesh: Matrix4<f64>,
}

/// Keeps the `MAX_INFLUENCES` largest weights and scales them to sum to 1;
/// `None` when no weight is positive.
pub fn strongest_influences(mut pairs: Vec<(u32, f32)>) -> Option<[(u32, f32); MAX_INFLUENCES]> {
    pairs.retain(|&(_, w)| w.is_finite() && w > 0.0);
    pairs.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
    pairs.truncate(MAX_INFLUENCES);
    let total: f32 = pairs.iter().map(|p| p.1).sum();
    if total <= 0.0 {
        return None;
    }
    let mut out = [(0, 0.0); MAX_INFLUENCES];
    for (slot, (bone, weight)) in out.iter_mut().zip(pairs) {
        *slot = (bone, weight / total);
    }
    Some(out)
}

impl Skin {
    /// Deformed positions `file_from_bone`-skinned into `out`, then mapped by
    /// `world_from_file` (axes and units). Parallel over vertices.
    pub fn deform(&self, file_from_bone: &[Matrix4<f64>], world_from_file: &Matrix4<f64>, out: &mut Vec<Vector3<f64>>) {
        let skinning: Vec<Matrix4<f64>> = file_from_bone
            .iter()
            .zip(&self.bone_from_mesh)
            .map(|(world, bind)| world_from_file * world * bind)
            .collect();
        let rigid = world_from_file * self.file_from_mesh;
        self.bind_positions
            .par_iter()
            .zip(&self.influences)
            .map(|(p, influences)| {
                let point = p.push(1.0);
                let mut sum = Vector3::zeros();
                let mut total = 0.0;
                for &(bone, weight) in influences.iter().filter(|i| i.1 > 0.0) {
                    if let Some(m) = skinning.get(bone as usize) {
                        sum += (m * point).xyz() * f64::from(weight);
                        total += f64::from(weight);
                    }
                }
                match total > 0.0 {
                    true => sum / total,
                    false => (rigid * point).xyz(),
                }
            })
            .collect_into_vec(out);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn influences_keep_the_four_largest_and_normalise() {
        let kept = strongest_influences(vec![(0, 0.1), (1, 0.4), (2, 0.2), (3, 0.2), (4, 0.1), (5, 0.0)]).unwrap();
        assert_eq!(kept.map(|k| k.0), [1, 2, 3, 0]);
        assert!((kept.iter().map(|k| k.1).sum::<f32>() - 1.0).abs() < 1e-6);
        assert!(strongest_influences(vec![(0, 0.0), (1, f32::NAN)]).is_none());
    }

    #[test]
    fn a_vertex_halfway_between_two_bones_moves_half_as_much() {
        let skin = Skin {
            bind_positions: vec![Vector3::new(1.0, 0.0, 0.0)],
            influences: vec![[(0, 0.5), (1, 0.5), (0, 0.0), (0, 0.0)]],
            bone_from_mesh: vec![Matrix4::identity(); 2],
            file_from_mesh: Matrix4::identity(),
        };
        let moved = [Matrix4::identity(), Matrix4::new_translation(&Vector3::new(0.0, 2.0, 0.0))];
        let mut out = Vec::new();
        skin.deform(&moved, &Matrix4::identity(), &mut out);
        assert!((out[0] - Vector3::new(1.0, 1.0, 0.0)).norm() < 1e-12);
        // At the bind pose every vertex is where the mesh put it.
        skin.deform(&[Matrix4::identity(); 2], &Matrix4::new_scaling(0.01), &mut out);
        assert!((out[0] - Vector3::new(0.01, 0.0, 0.0)).norm() < 1e-12);
    }
}
