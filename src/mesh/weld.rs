//! Welding of coincident vertices: files split one physical point into several
//! vertices at UV seams, between groups, or by accident; the cloth must be one
//! piece.

use std::collections::HashMap;

use nalgebra::Vector3;

/// For every input vertex, the index of the vertex it was welded into (the first
/// vertex, in input order, within `tolerance_m` of it), and how many merged.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Welding {
    /// `representative[i]` is the surviving vertex that stands for vertex `i`.
    pub representative: Vec<u32>,
    /// Number of vertices merged into an earlier one.
    pub merged: usize,
}

/// Finds vertices within `tolerance_m` of an earlier vertex (a uniform hash grid
/// of cell size `tolerance_m`; deterministic: earlier vertices win).
pub fn find_coincident(positions: &[Vector3<f64>], tolerance_m: f64) -> Welding {
    let cell_of = |p: &Vector3<f64>| (p / tolerance_m).map(|c| c.floor() as i64);
    let mut cells: HashMap<Vector3<i64>, Vec<u32>> = HashMap::new();
    let mut representative = Vec::with_capacity(positions.len());
    let mut merged = 0;
    for (i, p) in positions.iter().enumerate() {
        let cell = cell_of(p);
        let earlier = neighbour_cells(cell)
            .filter_map(|c| cells.get(&c))
            .flatten()
            .copied()
            .filter(|&j| (positions[j as usize] - p).norm() <= tolerance_m)
            .min();
        match earlier {
            Some(j) => {
                representative.push(j);
                merged += 1;
            }
            None => {
                representative.push(i as u32);
                cells.entry(cell).or_default().push(i as u32);
            }
        }
    }
    Welding { representative, merged }
}

fn neighbour_cells(cell: Vector3<i64>) -> impl Iterator<Item = Vector3<i64>> {
    (-1..=1).flat_map(move |dx| (-1..=1).flat_map(move |dy| (-1..=1).map(move |dz| cell + Vector3::new(dx, dy, dz))))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn coincident_and_near_vertices_weld_to_the_first() {
        let positions = [
            Vector3::new(0.0, 0.0, 0.0),
            Vector3::new(1.0, 0.0, 0.0),
            Vector3::new(0.0, 0.0, 0.0),
            Vector3::new(1.0 + 1e-9, 0.0, 0.0),
            Vector3::new(0.5, 0.0, 0.0),
        ];
        let welding = find_coincident(&positions, 1e-7);
        assert_eq!(welding.representative, vec![0, 1, 0, 1, 4]);
        assert_eq!(welding.merged, 2);
    }

    #[test]
    fn vertices_across_a_cell_border_still_weld() {
        let tol = 1e-3;
        let positions = [Vector3::new(tol - 1e-5, 0.0, 0.0), Vector3::new(tol + 1e-5, 0.0, 0.0)];
        assert_eq!(find_coincident(&positions, tol).representative, vec![0, 0]);
    }
}
