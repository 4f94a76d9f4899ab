//! Blend shapes: named channels whose percentage moves a mesh's points
//! towards one or more target shapes (in-betweens), before skinning.

use nalgebra::Vector3;

/// One target of a channel: offsets of some of the mesh's points.
#[derive(Clone, Debug, PartialEq)]
pub struct ShapeTarget {
    /// The channel's weight at which this target is reached fully, as a
    /// fraction (FBX `FullWeights` / 100).
    pub full_weight: f64,
    /// The points it moves.
    pub indices: Vec<u32>,
    /// Their offsets, geometry frame, file units.
    pub offsets: Vec<Vector3<f64>>,
}

/// A blend-shape channel.
#[derive(Clone, Debug, PartialEq)]
pub struct ShapeChannel {
    /// Its name (animations find it by it).
    pub name: String,
    /// Its static weight, percent (FBX `DeformPercent`).
    pub percent: f64,
    /// Targets in increasing `full_weight` (file order among equals).
    pub targets: Vec<ShapeTarget>,
}

impl ShapeChannel {
    /// How much of each target a channel weight of `percent` uses: linear
    /// between neighbouring targets (with an implicit empty target at 0),
    /// and on along the nearest two beyond the last ones.
    pub fn target_weights(&self, percent: f64) -> Vec<f64> {
        let omega = percent / 100.0;
        let mut weights = vec![0.0; self.targets.len()];
        // The ladder of targets on omega's side of zero, from zero outwards
        // (`None` is the implicit zero target).
        let positive = omega > 0.0;
        let mut ladder: Vec<Option<usize>> = vec![None];
        let side: Vec<usize> = (0..self.targets.len())
            .filter(|&i| if positive { self.targets[i].full_weight >= 0.0 } else { self.targets[i].full_weight < 0.0 })
            .collect();
        if side.is_empty() {
            // No target on that side: extrapolate the nearest one on the other.
            let nearest = match positive {
                true => (0..self.targets.len()).next_back(),
                false => (0..self.targets.len()).next(),
            };
            ladder.extend(nearest.map(Some));
        } else if positive {
            ladder.extend(side.into_iter().map(Some));
        } else {
            ladder.extend(side.into_iter().rev().map(Some));
        }
        if ladder.len() < 2 {
            return weights;
        }
        let tau = |t: Option<usize>| t.map_or(0.0, |i| self.targets[i].full_weight);
        let beyond = |t: Option<usize>| if positive { tau(t) > omega } else { tau(t) < omega };
        let upper = ladder.iter().skip(1).position(|&t| beyond(t)).map_or(ladder.len() - 1, |k| k + 1);
        let (below, above) = (ladder[upper - 1], ladder[upper]);
        let span = tau(above) - tau(below);
        if span == 0.0 {
            return weights;
        }
        let lambda = (omega - tau(below)) / span;
        if let Some(i) = below {
            weights[i] = 1.0 - lambda;
        }
        if let Some(i) = above {
            weights[i] = lambda;
        }
        weights
    }

    /// Adds the channel's offsets at `percent` to `points`.
    pub fn apply(&self, percent: f64, points: &mut [Vector3<f64>]) {
        for (target, weight) in self.targets.iter().zip(self.target_weights(percent)) {
            if weight == 0.0 {
                continue;
            }
            for (&i, offset) in target.indices.iter().zip(&target.offsets) {
                if let Some(p) = points.get_mut(i as usize) {
                    *p += offset * weight;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn channel(full_weights: &[f64]) -> ShapeChannel {
        let targets = full_weights
            .iter()
            .map(|&w| ShapeTarget { full_weight: w, indices: vec![0], offsets: vec![Vector3::new(w, 0.0, 0.0)] })
            .collect();
        ShapeChannel { name: "smile".into(), percent: 0.0, targets }
    }

    #[test]
    fn one_target_follows_the_percentage_beyond_its_ends() {
        let c = channel(&[1.0]);
        assert_eq!(c.target_weights(50.0), vec![0.5]);
        assert_eq!(c.target_weights(200.0), vec![2.0]);
        assert_eq!(c.target_weights(-100.0), vec![-1.0]);
        assert_eq!(c.target_weights(0.0), vec![0.0]);
    }

    #[test]
    fn in_betweens_blend_their_two_neighbours() {
        let c = channel(&[0.5, 1.0]);
        assert_eq!(c.target_weights(25.0), vec![0.5, 0.0]);
        assert_eq!(c.target_weights(75.0), vec![0.5, 0.5]);
        assert_eq!(c.target_weights(150.0), vec![-1.0, 2.0]);
        // A negative in-between ladder, walked from zero downwards.
        let c = channel(&[-0.499, -0.249, 1.0]);
        let w = c.target_weights(-100.0);
        assert!((w[0] - (-1.0 + 0.249) / (-0.499 + 0.249)).abs() < 1e-12 && w[2] == 0.0, "{w:?}");
    }

    #[test]
    fn offsets_are_added_by_their_weights() {
        let c = channel(&[0.5, 1.0]);
        let mut points = [Vector3::zeros()];
        c.apply(75.0, &mut points);
        // Half of the 0.5 target's offset and half of the 1.0 target's.
        assert!((points[0].x - 0.75).abs() < 1e-12);
    }
}
