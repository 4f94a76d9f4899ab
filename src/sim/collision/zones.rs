//! The fail-safe: rigid impact zones (Provot 1997, Bridson et al. 2002).
//! Points whose features still cross after the impulse passes are merged into
//! zones that move rigidly, or with the kinematic point they hold, until
//! nothing crosses. After each round the pass hook corrects the result (a
//! point a zone carried into an analytic collider is moved out); a point it
//! moves is held on that path, kinematic, for the rest of the step, so the
//! next rounds move its zone around it instead of back into the collider.

use std::time::Instant;

use nalgebra::{Isometry3, Matrix3, Point3, Rotation3, Translation3, UnitQuaternion, Vector3};

use super::detect::{Detection, Scope};
use super::response::{Points, PrescribedEnd, rigidify};
use super::{CollisionPipeline, CollisionReport, Kinematic, PassHook, ResponseStage};

impl CollisionPipeline {
    /// Rigid impact zones until nothing crosses (or the rounds run out), run
    /// right after the impulse passes (their last detection's contacts are in
    /// the workspace); `after_round` corrects each round's result before the
    /// next detection checks it. Returns the rounds used and the crossings
    /// left.
    pub(super) fn impact_zones(
        &mut self,
        window: crate::sim::contact::StepWindow,
        after_round: PassHook,
        report: &mut CollisionReport,
    ) -> (u32, u32) {
        let total = self.ws.start.len();
        self.ws.zones.reset(total);
        let mut round = 0;
        loop {
            // The first round follows the impulse passes' last (proximity)
            // detection; later ones the zones' own moves.
            if round == 0 {
                self.detect_again(Detection::Crossings, report);
            } else {
                self.detect(Detection::Crossings, Scope::Moved, report);
            }
            let crossings = std::mem::take(&mut self.ws.contacts);
            if crossings.is_empty() || round == self.settings.zone_rounds {
                let left = crossings.len() as u32;
                self.ws.contacts = crossings;
                return (round, left);
            }
            round += 1;
            let clock = Instant::now();
            for c in &crossings {
                for k in 1..4 {
                    if c.hit.weights[k] != 0.0 {
                        self.ws.zones.join(c.nodes[0], c.nodes[k]);
                    }
                }
            }
            self.group_zones(&crossings);
            let mut start = 0;
            while start < self.ws.zone_members.len() {
                let root = self.ws.zone_members[start].0;
                let end = start + self.ws.zone_members[start..].partition_point(|&(r, _)| r == root);
                let kinematic: Vec<(u32, Kinematic)> = self.ws.zone_members[start..end]
                    .iter()
                    .filter_map(|&(_, i)| Some((i, self.kinematic(i)?)))
                    .collect();
                // A zone holding a deforming point (a body's skin) first moves
                // with the rigid motion that best fits its kinematic points; if
                // that has not freed it within half the rounds (cloth pinched
                // between two parts of the body moving apart), each free point
                // moves with its nearest kinematic point. A zone holding only
                // rigid bodies moves with the rigid body it holds.
                let deforming = kinematic.iter().any(|(_, k)| *k == Kinematic::Deforming);
                let anchors: Vec<(Vector3<f64>, Vector3<f64>)> = match deforming {
                    true => {
                        kinematic.iter().map(|&(i, _)| (self.ws.start[i as usize], self.ws.end[i as usize])).collect()
                    }
                    false => Vec::new(),
                };
                let per_point = deforming && round > self.settings.zone_rounds / 2;
                let rigid = match deforming {
                    true => Some(rigid_fit(anchors.iter().copied())),
                    false => kinematic.iter().find_map(|(_, k)| match k {
                        Kinematic::Rigid(p) => {
                            Some(p.world_from_local(window.t1) * p.world_from_local(window.t0).inverse())
                        }
                        Kinematic::Deforming => None,
                    }),
                };
                let carry = move |p: &Vector3<f64>| -> Vector3<f64> {
                    match (per_point, rigid) {
                        (true, _) => p + nearest_displacement(&anchors, p),
                        (false, Some(step)) => (step * Point3::from(*p)).coords,
                        (false, None) => *p,
                    }
                };
                let carried = rigid.is_some();
                let ws = &mut self.ws;
                let mut points = Points {
                    start: &ws.start,
                    end: &mut ws.end,
                    velocity: &mut ws.velocity,
                    inverse_mass: &ws.inverse_mass,
                    moved: &mut ws.moved,
                    h: window.h(),
                };
                let zone = ws.zone_members[start..end].iter().map(|&(_, i)| i);
                rigidify(&mut points, zone, carried.then_some(&carry as &PrescribedEnd));
                start = end;
            }
            self.ws.contacts = crossings;
            self.run_hook(after_round, ResponseStage::ImpactZones);
            report.response += clock.elapsed();
        }
    }

    /// Lists every point of a zone that holds one of `crossings`, as
    /// `(zone root, point)` sorted by root, in the workspace.
    fn group_zones(&mut self, crossings: &[super::response::Contact]) {
        let ws = &mut self.ws;
        let total = ws.start.len();
        ws.zone_root.clear();
        ws.zone_root.resize(total, false);
        for c in crossings {
            let root = ws.zones.find(c.nodes[0]);
            ws.zone_root[root as usize] = true;
        }
        ws.zone_members.clear();
        for i in 0..total as u32 {
            let root = ws.zones.find(i);
            if ws.zone_root[root as usize] {
                ws.zone_members.push((root, i));
            }
        }
        ws.zone_members.sort_unstable();
    }

    /// The prescribed motion of point `i`, if it has one (pinned particle,
    /// obstacle vertex, or a particle the pass hook moved after a round,
    /// held on its start-to-end path).
    fn kinematic(&self, i: u32) -> Option<Kinematic> {
        match self.particles.get(i as usize) {
            Some(_) if self.ws.held[i as usize] => Some(Kinematic::Deforming),
            Some(p) => p.pinned,
            None => {
                let o = &self.obstacles;
                let body = &o.bodies[o.vertex_collider[i as usize - self.particles.len()] as usize];
                Some(match body.animation {
                    Some(_) => Kinematic::Deforming,
                    None => Kinematic::Rigid(body.placement),
                })
            }
        }
    }
}

/// The displacement over the step of the anchor (start, end) whose start is
/// nearest to `p`.
fn nearest_displacement(anchors: &[(Vector3<f64>, Vector3<f64>)], p: &Vector3<f64>) -> Vector3<f64> {
    anchors
        .iter()
        .min_by(|a, b| (a.0 - p).norm_squared().total_cmp(&(b.0 - p).norm_squared()))
        .map_or_else(Vector3::zeros, |(start, end)| end - start)
}

/// The rigid motion that best maps each pair's first point onto its second
/// (least squares, Kabsch): the translation of the centroids and the rotation
/// from the SVD of the cross-covariance. With fewer than three points, or all
/// on a line, only the translation.
fn rigid_fit(pairs: impl Iterator<Item = (Vector3<f64>, Vector3<f64>)> + Clone) -> Isometry3<f64> {
    let n = pairs.clone().count() as f64;
    if n == 0.0 {
        return Isometry3::identity();
    }
    let from = pairs.clone().map(|p| p.0).sum::<Vector3<f64>>() / n;
    let to = pairs.clone().map(|p| p.1).sum::<Vector3<f64>>() / n;
    let covariance: Matrix3<f64> = pairs.map(|(a, b)| (a - from) * (b - to).transpose()).sum();
    let svd = covariance.svd(true, true);
    let rotation = match (svd.u, svd.v_t) {
        (Some(u), Some(v_t)) if n >= 3.0 && svd.singular_values[1] > 1e-12 * svd.singular_values[0].max(1e-300) => {
            let v = v_t.transpose();
            let d = (v * u.transpose()).determinant().signum();
            Rotation3::from_matrix_unchecked(v * Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, d)) * u.transpose())
        }
        _ => Rotation3::identity(),
    };
    let rotation = UnitQuaternion::from_rotation_matrix(&rotation);
    Isometry3::from_parts(Translation3::from(to - rotation * from), rotation)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_point_follows_the_nearest_anchor() {
        let anchors = [(Vector3::zeros(), Vector3::x()), (Vector3::new(0.0, 1.0, 0.0), Vector3::new(0.0, 1.0, -1.0))];
        assert_eq!(nearest_displacement(&anchors, &Vector3::new(0.0, 0.2, 0.0)), Vector3::x());
        assert_eq!(nearest_displacement(&anchors, &Vector3::new(0.0, 0.9, 0.0)), -Vector3::z());
        assert_eq!(nearest_displacement(&[], &Vector3::zeros()), Vector3::zeros());
    }

    #[test]
    fn rigid_fit_recovers_a_rigid_motion_and_falls_back_to_translation() {
        let motion = Isometry3::new(Vector3::new(0.1, -0.2, 0.3), Vector3::new(0.2, -0.4, 0.1));
        let points = [Vector3::zeros(), Vector3::x(), Vector3::y(), Vector3::new(0.3, 0.2, 1.0)];
        let pairs: Vec<_> = points.iter().map(|p| (*p, (motion * Point3::from(*p)).coords)).collect();
        let fit = rigid_fit(pairs.iter().copied());
        for p in points {
            assert!((fit * Point3::from(p) - motion * Point3::from(p)).norm() < 1e-9);
        }
        let single = rigid_fit([(Vector3::x(), Vector3::new(1.0, 2.0, 0.0))].into_iter());
        assert!((single.translation.vector - Vector3::new(0.0, 2.0, 0.0)).norm() < 1e-12);
        assert_eq!(single.rotation, UnitQuaternion::identity());
    }
}
