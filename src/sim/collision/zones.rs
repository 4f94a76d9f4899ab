//! The fail-safe: rigid impact zones (Provot 1997, Bridson et al. 2002).
//! Points whose features still cross after the impulse passes are merged into
//! zones that move rigidly, or with the kinematic point they hold, until
//! nothing crosses. A crossing between free points and rigid kinematic points
//! that all move alike (a pinned ring's edge, a collider's face, points
//! already carried) carries its free points with that motion at once:
//! kinematic, with it, for the rest of the step, as a rigid zone would move
//! them. A zone that holds kinematic points moving differently (pins turning
//! against each other) has no rigid motion that follows them all; it moves
//! with their motions blended by distance, rigid to within round-off near
//! each group, and the free points that this step's crossings join move
//! rigidly together inside it (the motion that best fits the blend over
//! them), so features that cross because the blend moves their points
//! unevenly are resolved as in a rigid zone. The zone as a whole is not
//! rigid, so this is no proof that nothing crosses; it frees what following
//! one group alone never could (2aa8eae, 754e523). Every round
//! tests again the crossings whose points it could not move, so what is
//! left is reported. After each round the pass hook corrects the result (a
//! point a zone carried into an analytic collider is moved out); a point it
//! moves is held on that path, kinematic, for the rest of the step, so the
//! next rounds move its zone around it instead of back into the collider.

use std::time::Instant;

use nalgebra::{Isometry3, Matrix3, Point3, Rotation3, Translation3, UnitQuaternion, Vector3};

use super::detect::Detection;
use super::response::{Points, PrescribedEnd, rigidify};
use super::{CollisionPipeline, CollisionReport, Kinematic, PassHook, ResponseStage};
use crate::sim::contact::StepWindow;
use crate::sim::motion::Placement;

impl CollisionPipeline {
    /// Rigid impact zones until nothing crosses (or the rounds run out), run
    /// right after the impulse passes (their last detection's contacts are in
    /// the workspace); `after_round` corrects each round's result before the
    /// next detection checks it; at most `rounds` rounds. Returns the rounds
    /// used and the crossings left.
    pub(super) fn impact_zones(
        &mut self,
        window: StepWindow,
        after_round: PassHook,
        report: &mut CollisionReport,
        rounds: u32,
    ) -> (u32, u32) {
        let total = self.ws.start.len();
        self.ws.zones.reset(total);
        self.ws.inner_zones.reset(total);
        let mut round = 0;
        loop {
            // The first round follows the impulse passes' last (proximity)
            // detection, later ones the zones' own moves; either way the
            // contacts none of whose points moved since are tested again (a
            // crossing between kinematic points moves in no round, and would
            // otherwise drop out of the list while it still crosses).
            self.detect_again(Detection::Crossings, report);
            let crossings = std::mem::take(&mut self.ws.contacts);
            if crossings.is_empty() || round == rounds {
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
                self.carry_or_join(c, window);
            }
            self.group_zones(&crossings);
            if self.ws.correction_kept {
                self.revert_zones();
                self.ws.contacts = crossings;
                self.run_hook(after_round, ResponseStage::ImpactZones);
                report.response += clock.elapsed();
                continue;
            }
            let mut start = 0;
            while start < self.ws.zone_members.len() {
                let root = self.ws.zone_members[start].0;
                let end = start + self.ws.zone_members[start..].partition_point(|&(r, _)| r == root);
                let kinematic: Vec<(u32, Kinematic)> = self.ws.zone_members[start..end]
                    .iter()
                    .filter_map(|&(_, i)| Some((i, self.kinematic(i)?)))
                    .collect();
                let motion = self.zone_motion(&kinematic, round, window);
                if matches!(motion, ZoneMotion::Blended(_)) {
                    self.move_blended(start..end, &motion, window.h());
                    start = end;
                    continue;
                }
                let carried = !matches!(motion, ZoneMotion::Free);
                let carry = move |p: &Vector3<f64>| motion.end(p);
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

    /// How a zone whose kinematic points are `kinematic` moves in round
    /// `round` of a step over `window`. A zone holding a deforming point (a
    /// body's skin) first moves with the rigid motion that best fits its
    /// kinematic points; if that has not freed it within half the rounds
    /// (cloth pinched between two parts of the body moving apart), each free
    /// point moves with its nearest kinematic point. A zone holding rigid
    /// points that all move alike moves with them; one holding rigid points
    /// that move apart (a cloth wrung between two pins turning against each
    /// other) blends their motions.
    fn zone_motion(&self, kinematic: &[(u32, Kinematic)], round: u32, window: StepWindow) -> ZoneMotion {
        if kinematic.iter().any(|(_, k)| *k == Kinematic::Deforming) {
            let anchors = kinematic.iter().map(|&(i, _)| (self.ws.start[i as usize], self.ws.end[i as usize]));
            return match round > self.settings.zone_rounds / 2 {
                true => ZoneMotion::Nearest(anchors.collect()),
                false => ZoneMotion::Rigid(rigid_fit(anchors)),
            };
        }
        let mut moves = rigid_moves(kinematic, &self.ws.start, window);
        match moves.len() {
            0 => ZoneMotion::Free,
            1 => ZoneMotion::Rigid(moves.remove(0).step),
            _ => ZoneMotion::Blended(moves),
        }
    }

    /// Carries the free points of crossing `c` with its kinematic points if
    /// it has some and they all move with one rigid motion over `window`,
    /// else joins them in the inner zones. Any zone holding the crossing
    /// could only move them with that motion; made kinematic, they can no
    /// longer be pulled off it by a blended zone's rigid group (a ring's
    /// first row dragged back by a group reaching the tube's middle left the
    /// wrung `twist` crossing its own ring at 2.75 s). Carried points carry
    /// in turn (the rows a ring has wrung onto each other follow it
    /// together); where the points carried by two rings cross, no zone can
    /// move them, and the crossing is reported left.
    fn carry_or_join(&mut self, c: &super::response::Contact, window: StepWindow) {
        let points = || (0..4).filter(|&k| c.hit.weights[k] != 0.0).map(|k| c.nodes[k] as usize);
        if let Some((placement, step)) = self.common_rigid_motion(points(), window) {
            let ws = &mut self.ws;
            for i in points() {
                if ws.inverse_mass[i] == 0.0 {
                    continue;
                }
                ws.held[i] = Some(Kinematic::Rigid(placement));
                ws.inverse_mass[i] = 0.0;
                ws.end[i] = (step * Point3::from(ws.start[i])).coords;
                ws.velocity[i] = (ws.end[i] - ws.start[i]) / window.h();
                ws.moved[i] = true;
            }
            return;
        }
        let ws = &mut self.ws;
        let mut free = points().filter(|&i| ws.inverse_mass[i] > 0.0).map(|i| i as u32);
        if let Some(first) = free.next() {
            for i in free {
                ws.inner_zones.join(first, i);
            }
        }
    }

    /// The placement and step over `window` that every kinematic point
    /// among `points` follows, if they have some and all move alike with
    /// one rigid motion.
    fn common_rigid_motion(
        &self,
        points: impl Iterator<Item = usize>,
        window: StepWindow,
    ) -> Option<(Placement, Isometry3<f64>)> {
        let mut common: Option<(Placement, Isometry3<f64>)> = None;
        for i in points {
            match self.kinematic(i as u32) {
                None => {}
                Some(Kinematic::Deforming) => return None,
                Some(Kinematic::Rigid(placement)) => {
                    let step = step_over(&placement, window);
                    match common {
                        None => common = Some((placement, step)),
                        Some((_, first)) if same_motion(&first, &step) => {}
                        Some(_) => return None,
                    }
                }
            }
        }
        common
    }

    /// Moves the free points of the zone `zone_members[members]` as the
    /// blended `motion` takes them ([`blended_end`]), except that the points an
    /// inner zone joins (crossings between free points the blend left)
    /// move together with the rigid motion that best fits the blend over
    /// them: two features that cross while their points move apart unevenly
    /// cannot cross once they move rigidly. Over a step of `h` s.
    fn move_blended(&mut self, members: std::ops::Range<usize>, motion: &ZoneMotion, h: f64) {
        let ws = &mut self.ws;
        let mut inner: Vec<(u32, u32)> = ws.zone_members[members]
            .iter()
            .filter(|&&(_, i)| ws.inverse_mass[i as usize] > 0.0)
            .map(|&(_, i)| (ws.inner_zones.find(i), i))
            .collect();
        inner.sort_unstable();
        for group in inner.chunk_by(|a, b| a.0 == b.0) {
            let blend = |i: u32| (ws.start[i as usize], motion.end(&ws.start[i as usize]));
            let fit = (group.len() > 1).then(|| rigid_fit(group.iter().map(|&(_, i)| blend(i))));
            for &(_, i) in group {
                let (from, to) = blend(i);
                let i = i as usize;
                ws.end[i] = fit.map_or(to, |fit| (fit * Point3::from(from)).coords);
                ws.velocity[i] = (ws.end[i] - from) / h;
                ws.moved[i] = true;
            }
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

    /// The kinematic motion of point `i` this round, if it has one (pinned
    /// particle, obstacle vertex, a particle the pass hook moved after a
    /// round, held on its start-to-end path, or one a crossing carried
    /// along with a rigid motion).
    fn kinematic(&self, i: u32) -> Option<Kinematic> {
        match self.particles.get(i as usize) {
            Some(p) => self.ws.held[i as usize].or(p.pinned),
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

/// How the free points of an impact zone move over the step.
enum ZoneMotion {
    /// Rigidly, keeping their momentum: the zone holds no kinematic point.
    Free,
    /// With one rigid motion, from the step's start to its end.
    Rigid(Isometry3<f64>),
    /// Each with the displacement of its nearest anchor (start, end).
    Nearest(Vec<(Vector3<f64>, Vector3<f64>)>),
    /// With several rigid motions blended by distance ([`blended_end`]).
    Blended(Vec<RigidMove>),
}

impl ZoneMotion {
    /// Where a point starting at `p` (m) ends the step, m (`p` itself for a
    /// free zone, which [`rigidify`] moves instead).
    fn end(&self, p: &Vector3<f64>) -> Vector3<f64> {
        match self {
            ZoneMotion::Free => *p,
            ZoneMotion::Rigid(step) => (step * Point3::from(*p)).coords,
            ZoneMotion::Nearest(anchors) => p + nearest_displacement(anchors, p),
            ZoneMotion::Blended(moves) => blended_end(moves, p),
        }
    }
}

/// One rigid motion over the step that some of a zone's kinematic points
/// follow: a pinned ring, or a collider.
struct RigidMove {
    /// From the step's start to its end.
    step: Isometry3<f64>,
    /// Where the points that follow it start, m.
    starts: Vec<Vector3<f64>>,
}

/// Two steps closer than this (m of translation, rad of rotation) are one
/// motion: still colliders at different poses all make the identity, up to
/// round-off.
const SAME_MOTION: f64 = 1e-12;

/// The distinct rigid motions of a zone's rigid kinematic points (`(point,
/// motion)`, `start` positions indexed by point) over `window`, in the
/// order they first appear.
fn rigid_moves(kinematic: &[(u32, Kinematic)], start: &[Vector3<f64>], window: StepWindow) -> Vec<RigidMove> {
    let mut moves: Vec<RigidMove> = Vec::new();
    for &(i, k) in kinematic {
        let Kinematic::Rigid(placement) = k else { continue };
        let step = step_over(&placement, window);
        match moves.iter_mut().find(|m| same_motion(&m.step, &step)) {
            Some(m) => m.starts.push(start[i as usize]),
            None => moves.push(RigidMove { step, starts: vec![start[i as usize]] }),
        }
    }
    moves
}

/// How `placement` moves its points from the start of `window` to its end.
fn step_over(placement: &Placement, window: StepWindow) -> Isometry3<f64> {
    placement.world_from_local(window.t1) * placement.world_from_local(window.t0).inverse()
}

/// Whether two steps are one motion, to within [`SAME_MOTION`].
fn same_motion(a: &Isometry3<f64>, b: &Isometry3<f64>) -> bool {
    (a.translation.vector - b.translation.vector).norm() <= SAME_MOTION && same_rotation(&a.rotation, &b.rotation)
}

/// Whether two rotations differ by less than [`SAME_MOTION`] (their unit
/// quaternions, either sign, are that close: about half the angle between).
fn same_rotation(a: &UnitQuaternion<f64>, b: &UnitQuaternion<f64>) -> bool {
    let (a, b) = (a.coords, b.coords);
    (a - b).norm().min((a + b).norm()) <= SAME_MOTION
}

/// Where a point starting at `p` ends under rigid motions that pull apart:
/// each motion's end for it, weighted by the inverse square of its distance
/// to the nearest point following that motion (Shepard interpolation). Near
/// one group of points the map is that group's rigid motion; between them it
/// turns smoothly from one to the other, so points near each other move
/// nearly alike wherever they are.
fn blended_end(moves: &[RigidMove], p: &Vector3<f64>) -> Vector3<f64> {
    let (mut weighted, mut total) = (Vector3::zeros(), 0.0);
    for m in moves {
        let end = (m.step * Point3::from(*p)).coords;
        let nearest = m.starts.iter().map(|s| (s - p).norm_squared()).fold(f64::INFINITY, f64::min);
        if nearest == 0.0 {
            return end;
        }
        weighted += end / nearest;
        total += 1.0 / nearest;
    }
    if total > 0.0 { weighted / total } else { *p }
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
    use crate::sim::collision::ccd::Hit;
    use crate::sim::collision::response::{Contact, ContactKind};
    use crate::sim::motion::RigidMotion;

    #[test]
    fn a_point_follows_the_nearest_anchor() {
        let anchors = [(Vector3::zeros(), Vector3::x()), (Vector3::new(0.0, 1.0, 0.0), Vector3::new(0.0, 1.0, -1.0))];
        assert_eq!(nearest_displacement(&anchors, &Vector3::new(0.0, 0.2, 0.0)), Vector3::x());
        assert_eq!(nearest_displacement(&anchors, &Vector3::new(0.0, 0.9, 0.0)), -Vector3::z());
        assert_eq!(nearest_displacement(&[], &Vector3::zeros()), Vector3::zeros());
    }

    /// A placement at `rest` turning about the X axis at `deg_per_s`.
    fn turning(rest: Vector3<f64>, deg_per_s: f64) -> Placement {
        let motion = RigidMotion {
            velocity: Vector3::zeros(),
            angular_velocity: Vector3::new(deg_per_s.to_radians(), 0.0, 0.0),
            pivot: Vector3::zeros(),
            start: 0.0,
            end: f64::INFINITY,
        };
        Placement { rest_pose: Isometry3::translation(rest.x, rest.y, rest.z), motion: Some(motion) }
    }

    fn still(rest: Vector3<f64>) -> Placement {
        Placement { rest_pose: Isometry3::translation(rest.x, rest.y, rest.z), motion: None }
    }

    const WINDOW: StepWindow = StepWindow { t0: 0.3, t1: 0.3 + 1.0 / 60.0 };

    #[test]
    fn kinematic_points_are_grouped_by_how_they_move() {
        let start: Vec<Vector3<f64>> = (0..6).map(|i| Vector3::new(i as f64, 0.1, 0.0)).collect();
        let kinematic = [
            (0, Kinematic::Rigid(turning(Vector3::zeros(), 180.0))),
            (1, Kinematic::Rigid(still(Vector3::new(0.3, 0.0, 0.0)))),
            (2, Kinematic::Rigid(turning(Vector3::zeros(), -180.0))),
            (3, Kinematic::Rigid(turning(Vector3::zeros(), 180.0))),
            // Two still colliders at different poses both stay put.
            (4, Kinematic::Rigid(still(Vector3::new(-2.0, 1.0, 0.5)))),
            (5, Kinematic::Deforming),
        ];
        let moves = rigid_moves(&kinematic, &start, WINDOW);
        let starts: Vec<Vec<Vector3<f64>>> = moves.iter().map(|m| m.starts.clone()).collect();
        assert_eq!(starts, vec![vec![start[0], start[3]], vec![start[1], start[4]], vec![start[2]]]);
        // 180 °/s for 1/60 s: 3° about X.
        let turned = moves[0].step * Point3::new(0.0, 0.1, 0.0);
        let three = 3f64.to_radians();
        assert!((turned.coords - Vector3::new(0.0, 0.1 * three.cos(), 0.1 * three.sin())).norm() < 1e-12, "{turned}");
    }

    #[test]
    fn a_blended_point_follows_the_motion_it_is_near_and_turns_smoothly_between() {
        let left = RigidMove { step: Isometry3::translation(0.0, 0.01, 0.0), starts: vec![Vector3::zeros()] };
        let right =
            RigidMove { step: Isometry3::translation(0.0, -0.01, 0.0), starts: vec![Vector3::new(1.0, 0.0, 0.0)] };
        let moves = [left, right];
        let end = |x: f64| blended_end(&moves, &Vector3::new(x, 0.0, 0.0)) - Vector3::new(x, 0.0, 0.0);
        assert_eq!(end(0.0), Vector3::new(0.0, 0.01, 0.0), "on a point of the first motion: exactly it");
        assert_eq!(end(1.0), Vector3::new(0.0, -0.01, 0.0));
        assert!(end(0.5).norm() < 1e-15, "halfway: the mean");
        // Inverse-square weights: at a fifth of the way, 16 : 1.
        assert!((end(0.2).y - 0.01 * 15.0 / 17.0).abs() < 1e-15, "{}", end(0.2));
        // Neighbours 1 mm apart move alike to within a small part of that.
        let most = (0..1000).map(|k| (end((k + 1) as f64 * 1e-3) - end(k as f64 * 1e-3)).norm()).fold(0.0, f64::max);
        assert!(most < 1e-4, "{most}");
        assert_eq!(blended_end(&[], &Vector3::x()), Vector3::x());
    }

    /// A flat 3 × 3 cloth (1 cm apart, its corner 0 pinned with `pin`)
    /// loaded for a step of `h`, every point in one zone.
    fn one_zone_pinned(h: f64, pin: Placement) -> CollisionPipeline {
        use crate::mesh::generate;
        use crate::sim::collision::obstacles::{ClothScale, Obstacles};
        use crate::sim::collision::{ClothState, CollisionSettings, ParticleCollision};
        let grid = generate::grid(0.02, 3);
        let start = grid.positions.clone();
        let (mut end, mut velocity) = (start.clone(), vec![Vector3::zeros(); start.len()]);
        let mut particles = vec![ParticleCollision { thickness: 0.002, friction: 0.0, pinned: None }; start.len()];
        particles[0].pinned = Some(Kinematic::Rigid(pin));
        let scale = ClothScale { longest_edge_m: 0.01, thinnest_m: 0.002 };
        let obstacles = Obstacles::new(&[], &[], scale);
        let mut pipeline = CollisionPipeline::new(
            grid.triangles,
            vec![0; 8],
            vec![true],
            particles,
            obstacles,
            CollisionSettings::default(),
        )
        .expect("a self-colliding cloth has a pipeline");
        let mass = vec![1e-3; start.len()];
        let cloth = ClothState { start: &start, end: &mut end, velocity: &mut velocity, mass: &mass };
        pipeline.load(&cloth, StepWindow { t0: 0.0, t1: h });
        pipeline.ws.zone_members = (0..start.len() as u32).map(|i| (0, i)).collect();
        pipeline.ws.inner_zones.reset(start.len());
        pipeline
    }

    /// [`one_zone_pinned`] with a still pin.
    fn one_zone(h: f64) -> CollisionPipeline {
        one_zone_pinned(h, still(Vector3::zeros()))
    }

    /// An edge-edge crossing of `nodes` halfway along both edges.
    fn crossing(nodes: [u32; 4]) -> Contact {
        let hit = Hit {
            time: 0.5,
            weights: [0.5, 0.5, -0.5, -0.5],
            normal: Vector3::z(),
            start_distance: 1e-4,
            crossing: true,
        };
        Contact { kind: ContactKind::EdgeEdge, nodes, hit, thickness: 0.002, friction: 0.0 }
    }

    #[test]
    fn a_crossing_with_a_turning_pin_carries_its_free_points_and_they_carry_in_turn() {
        let h = 0.01;
        let pin = turning(Vector3::zeros(), 180.0);
        let mut pipeline = one_zone_pinned(h, pin);
        let window = StepWindow { t0: 0.0, t1: h };
        let step = pin.world_from_local(h) * pin.world_from_local(0.0).inverse();
        pipeline.carry_or_join(&crossing([0, 7, 1, 6]), window);
        let ws = &pipeline.ws;
        for i in [1usize, 6, 7] {
            assert_ne!(ws.start[i].z, 0.0, "point {i} is off the pin's axis");
            assert_eq!(ws.end[i], (step * Point3::from(ws.start[i])).coords, "point {i} turns with the pin");
            assert!((ws.velocity[i] - (ws.end[i] - ws.start[i]) / h).norm() < 1e-12);
            assert!(ws.moved[i] && ws.inverse_mass[i] == 0.0);
            assert_eq!(pipeline.kinematic(i as u32), Some(Kinematic::Rigid(pin)), "and is kinematic with it");
        }
        // A crossing of free points alone joins them, carrying nothing.
        pipeline.carry_or_join(&crossing([3, 4, 5, 2]), window);
        let ws = &mut pipeline.ws;
        assert!([3usize, 4, 5, 2].iter().all(|&i| ws.inverse_mass[i] > 0.0 && !ws.moved[i]));
        let root = ws.inner_zones.find(3);
        assert!([4, 5, 2].iter().all(|&i| ws.inner_zones.find(i) == root));
        assert_ne!(ws.inner_zones.find(8), root);
        // Carried points carry in turn.
        pipeline.carry_or_join(&crossing([1, 8, 5, 2]), window);
        for i in [2usize, 5, 8] {
            let ws = &pipeline.ws;
            assert_eq!(ws.end[i], (step * Point3::from(ws.start[i])).coords, "point {i} turns with the pin");
            assert_eq!(pipeline.kinematic(i as u32), Some(Kinematic::Rigid(pin)));
        }
    }

    #[test]
    fn a_crossing_with_pins_moving_apart_carries_nothing() {
        let h = 0.01;
        let mut pipeline = one_zone_pinned(h, turning(Vector3::zeros(), 180.0));
        pipeline.particles[8].pinned = Some(Kinematic::Rigid(turning(Vector3::zeros(), -180.0)));
        pipeline.ws.inverse_mass[8] = 0.0;
        pipeline.carry_or_join(&crossing([0, 4, 5, 8]), StepWindow { t0: 0.0, t1: h });
        let ws = &mut pipeline.ws;
        assert!(!ws.moved[4] && !ws.moved[5] && ws.inverse_mass[4] > 0.0);
        assert_eq!(ws.inner_zones.find(4), ws.inner_zones.find(5), "its free points are joined");
    }

    /// Two triangles whose points a zone already carries with two motions,
    /// one passing down through the other: no zone can move them, so every
    /// round finds the crossing again, and it is reported left at the end.
    #[test]
    fn a_crossing_no_zone_can_move_is_reported_to_the_end() {
        use crate::sim::collision::obstacles::{ClothScale, Obstacles};
        use crate::sim::collision::{ClothState, CollisionSettings, ParticleCollision};
        let (h, drop) = (0.01, Vector3::new(0.0, -0.1, 0.0));
        let fixed = [Vector3::new(0.0, 0.0, 0.0), Vector3::new(0.1, 0.0, 0.0), Vector3::new(0.0, 0.0, 0.1)];
        // Its lowest corner drops through the fixed one's inside.
        let sinking = [Vector3::new(0.02, 0.05, 0.02), Vector3::new(0.03, 0.08, 0.02), Vector3::new(0.02, 0.08, 0.03)];
        let start: Vec<Vector3<f64>> = fixed.iter().chain(&sinking).copied().collect();
        let mut end: Vec<Vector3<f64>> =
            start.iter().enumerate().map(|(i, p)| if i < 3 { *p } else { p + drop }).collect();
        let mut velocity: Vec<Vector3<f64>> = start.iter().zip(&end).map(|(a, b)| (b - a) / h).collect();
        let motion = RigidMotion {
            velocity: drop / h,
            angular_velocity: Vector3::zeros(),
            pivot: Vector3::zeros(),
            start: 0.0,
            end: f64::INFINITY,
        };
        let falling = Placement { rest_pose: Isometry3::identity(), motion: Some(motion) };
        let particles = vec![ParticleCollision { thickness: 0.002, friction: 0.0, pinned: None }; 6];
        let scale = ClothScale { longest_edge_m: 0.15, thinnest_m: 0.002 };
        let obstacles = Obstacles::new(&[], &[], scale);
        let settings = CollisionSettings::default();
        let mut pipeline =
            CollisionPipeline::new(vec![[0, 1, 2], [3, 4, 5]], vec![0; 2], vec![true], particles, obstacles, settings)
                .expect("a self-colliding cloth has a pipeline");
        let mass = vec![1e-3; start.len()];
        let window = StepWindow { t0: 0.0, t1: h };
        let cloth = ClothState { start: &start, end: &mut end, velocity: &mut velocity, mass: &mass };
        pipeline.load(&cloth, window);
        for i in 0..6 {
            pipeline.ws.held[i] = Some(Kinematic::Rigid(if i < 3 { still(Vector3::zeros()) } else { falling }));
            pipeline.ws.inverse_mass[i] = 0.0;
            pipeline.ws.moved[i] = true;
        }
        let mut report = CollisionReport::default();
        let all = pipeline.settings.zone_rounds;
        let (rounds, left) = pipeline.impact_zones(window, &mut |_| false, &mut report, all);
        assert_eq!(rounds, pipeline.settings.zone_rounds, "every round found it");
        assert!(left > 0, "and it is reported left");
        assert_eq!(&pipeline.ws.end[3..], &start[3..].iter().map(|p| p + drop).collect::<Vec<_>>()[..]);
    }

    #[test]
    fn points_joined_by_a_crossing_move_rigidly_inside_a_blended_zone() {
        let h = 0.01;
        let mut pipeline = one_zone(h);
        let start = pipeline.ws.start.clone();
        // Two motions pulling the cloth's sides apart, 1 mm each way.
        let motion = ZoneMotion::Blended(vec![
            RigidMove { step: Isometry3::translation(0.0, 0.001, 0.0), starts: vec![Vector3::new(-0.02, 0.0, 0.0)] },
            RigidMove { step: Isometry3::translation(0.0, -0.001, 0.0), starts: vec![Vector3::new(0.02, 0.0, 0.0)] },
        ]);
        for (a, b) in [(3, 4), (4, 5), (4, 1)] {
            pipeline.ws.inner_zones.join(a, b);
        }
        pipeline.move_blended(0..start.len(), &motion, h);
        let ws = &pipeline.ws;
        let joined = [1usize, 3, 4, 5];
        for &a in &joined {
            for &b in &joined {
                let (before, after) = ((start[a] - start[b]).norm(), (ws.end[a] - ws.end[b]).norm());
                assert!((before - after).abs() < 1e-12, "{a}-{b}: {before} → {after}");
            }
            assert!(ws.moved[a] && (ws.velocity[a] - (ws.end[a] - start[a]) / h).norm() < 1e-9);
        }
        assert_ne!(ws.end[3].y, ws.end[5].y, "the joined points turn with the blend");
        for i in [2usize, 6, 7, 8] {
            assert_eq!(ws.end[i], motion.end(&start[i]), "a point on its own follows the blend");
        }
        assert_eq!((ws.end[0], ws.moved[0]), (start[0], false), "the pinned corner is left to its pin");
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
