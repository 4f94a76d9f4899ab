//! The fail-safe: rigid impact zones (Provot 1997, Bridson et al. 2002).
//! Points whose features still cross after the impulse passes are merged into
//! zones that move rigidly, or with the kinematic point they hold, until
//! nothing crosses.

use std::collections::HashMap;
use std::time::Instant;

use nalgebra::Vector3;

use super::detect::{Detection, Scope};
use super::response::{Points, rigidify};
use super::{CollisionPipeline, CollisionReport};
use crate::sim::motion::Placement;

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
            let mut members: HashMap<u32, Vec<u32>> = HashMap::new();
            let roots: std::collections::BTreeSet<u32> =
                crossings.iter().map(|c| self.ws.zones.find(c.nodes[0])).collect();
            for i in 0..total as u32 {
                let root = self.ws.zones.find(i);
                if roots.contains(&root) {
                    members.entry(root).or_default().push(i);
                }
            }
            for root in roots {
                let zone = &members[&root];
                let kinematic = zone.iter().find_map(|&i| self.kinematic(i));
                let ws = &mut self.ws;
                let mut points = Points {
                    start: &ws.start,
                    end: &mut ws.end,
                    velocity: &mut ws.velocity,
                    inverse_mass: &ws.inverse_mass,
                    moved: &mut ws.moved,
                    h: window.h(),
                };
                let carry = kinematic.map(|placement| {
                    let step = placement.world_from_local(window.t1) * placement.world_from_local(window.t0).inverse();
                    move |p: &Vector3<f64>| (step * nalgebra::Point3::from(*p)).coords
                });
                rigidify(&mut points, zone, carry.as_ref().map(|f| f as &dyn Fn(&Vector3<f64>) -> Vector3<f64>));
            }
            report.response += clock.elapsed();
            self.ws.contacts = crossings;
        }
    }

    /// The prescribed motion of point `i`, if it has one (pinned particle or
    /// obstacle vertex).
    fn kinematic(&self, i: u32) -> Option<Placement> {
        match self.particles.get(i as usize) {
            Some(p) => p.pinned,
            None => {
                let o = &self.obstacles;
                let body = o.vertex_collider[i as usize - self.particles.len()];
                Some(o.bodies[body as usize].placement)
            }
        }
    }
}
