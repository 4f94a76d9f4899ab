//! Hinge blocks the factor does not store, each replaced by a bound of its
//! norm on the two diagonal blocks it couples (see [`super`]), so the
//! factored matrix stays positive definite.

use super::*;

/// A block the factor drops, above the diagonal: its slot, row and column.
#[derive(Clone, Copy, Debug)]
pub(super) struct DroppedBlock {
    pub(super) slot: u32,
    pub(super) row: u32,
    pub(super) column: u32,
}

/// The blocks of `pattern` above the diagonal that are not `kept`.
pub(super) fn dropped_blocks(pattern: &BlockPattern, kept: &[bool]) -> Vec<DroppedBlock> {
    (0..pattern.rows())
        .flat_map(|row| pattern.row(row).map(move |slot| (row, slot)))
        .filter(|&(row, slot)| pattern.column(slot) > row && !kept[slot])
        .map(|(row, slot)| DroppedBlock { slot: slot as u32, row: row as u32, column: pattern.column(slot) as u32 })
        .collect()
}

/// An upper bound of the spectral norm of `d`: `√(‖d‖₁ ‖d‖∞)`, exact for a
/// multiple of the identity.
pub(super) fn spectral_norm_bound(d: &Matrix3<f64>) -> f64 {
    let magnitudes = d.abs();
    let (columns, rows) = (magnitudes.row_sum().max(), magnitudes.column_sum().max());
    (columns * rows).sqrt()
}

/// The blocks the factor drops, and each particle's among them in
/// compressed rows (a block appears under both particles it couples).
#[derive(Clone, Debug)]
pub(super) struct DroppedBlocks {
    pub(super) blocks: Vec<DroppedBlock>,
    start: Vec<u32>,
    of_particle: Vec<u32>,
}

impl DroppedBlocks {
    pub(super) fn new(particles: usize, blocks: Vec<DroppedBlock>) -> Self {
        let mut start = vec![0u32; particles + 1];
        for block in &blocks {
            start[block.row as usize + 1] += 1;
            start[block.column as usize + 1] += 1;
        }
        for i in 0..particles {
            start[i + 1] += start[i];
        }
        let mut next = start.clone();
        let mut of_particle = vec![0u32; blocks.len() * 2];
        for (b, block) in blocks.iter().enumerate() {
            for particle in [block.row, block.column] {
                of_particle[next[particle as usize] as usize] = b as u32;
                next[particle as usize] += 1;
            }
        }
        DroppedBlocks { blocks, start, of_particle }
    }

    /// The indices in `blocks` of the dropped blocks of `particle`.
    pub(super) fn of(&self, particle: usize) -> &[u32] {
        &self.of_particle[self.start[particle] as usize..self.start[particle + 1] as usize]
    }
}
