//! The fail-safe: rigid impact zones (Provot 1997, Bridson et al. 2002).
//! Points whose features still cross after the impulse passes are merged into
//! zones that move rigidly, or with the kinematic point they hold, until
//! nothing crosses.

use std::time::Instant;

use nalgebra::{Point3, Vector3};

use super::detect::{Detection, Scope};
use super::response::{Points, rigidify};
use super::{CollisionPipeline, CollisionReport, Kinematic};

impl CollisionPipeline {
    /// Rigid impact zones until nothing crosses (or the rounds run out).
    /// Returns the rounds used and the crossings left.
    pub(super) fn impact_zones(
        &mut self,
        window: crate::sim::contact::StepWindow,
        report: &mut CollisionReport,
    ) -> (u32, u32) {
        let total = self.ws.start.len();
        self.ws.zones.reset(total);
        let mut round = 0;
        loop {
            self.detect(Detection::Crossings, if round == 0 { Scope::All } else { Scope::Moved }, report);
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
                // A zone holding a deforming point (a body's skin) moves each of
                // its free points with the nearest kinematic point: cloth pinched
                // between two parts of a body follows the part it touches. A zone
                // holding only rigid bodies moves with the rigid body it holds.
                let deforming = kinematic.iter().any(|(_, k)| *k == Kinematic::Deforming);
                let anchors: Vec<(Vector3<f64>, Vector3<f64>)> = match deforming {
                    true => {
                        kinematic.iter().map(|&(i, _)| (self.ws.start[i as usize], self.ws.end[i as usize])).collect()
                    }
                    false => Vec::new(),
                };
                let rigid = kinematic.iter().find_map(|(_, k)| match k {
                    Kinematic::Rigid(p) => {
                        Some(p.world_from_local(window.t1) * p.world_from_local(window.t0).inverse())
                    }
                    Kinematic::Deforming => None,
                });
                let carry = move |p: &Vector3<f64>| -> Vector3<f64> {
                    match (anchors.is_empty(), rigid) {
                        (false, _) => p + nearest_displacement(&anchors, p),
                        (true, Some(step)) => (step * Point3::from(*p)).coords,
                        (true, None) => *p,
                    }
                };
                let carried = deforming || rigid.is_some();
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
                rigidify(&mut points, zone, carried.then_some(&carry as &dyn Fn(&Vector3<f64>) -> Vector3<f64>));
                start = end;
            }
            report.response += clock.elapsed();
            self.ws.contacts = crossings;
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

    /// The prescribed motion of point `i`, if it has one (pinned particle or
    /// obstacle vertex).
    fn kinematic(&self, i: u32) -> Option<Kinematic> {
        match self.particles.get(i as usize) {
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
}
