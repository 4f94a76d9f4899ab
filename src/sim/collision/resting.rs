//! The cloth's resting contacts at the start of a step, for the implicit
//! solve to push apart ([`crate::sim::repulsion`]).
//!
//! A fold that rests on itself is left by the response with its feature
//! pairs at the thickness; the next solve, which knows nothing of them,
//! presses them back within it, and every step's passes answer them again
//! (thousands per step on `drape_sphere`, b0ac764). So does cloth
//! drawn taut over a sharp obstacle feature: a table's edge or a needle's
//! tip, which the cloth's edges cut across within the thickness whenever
//! the solve and the strain limits pull it straight (hundreds of pairs per
//! step on `drape_table`, each pass's impulses and projections fighting
//! over them). Only analytic colliders' sharp features count here: a body's
//! skin or a mesh collider's triangles are left to the response alone
//! (pushing a skirt's tiers off the skin in the solve raised their passing
//! strain peaks, 91a3e83). The pairs are the
//! contacts the pipeline remembers (their
//! influence, eq. 16: what snapshots, roll-backs and resumed bakes already
//! restore), taken in key order with their closest points at the step's
//! start (obstacle points where their collider is then), and kept only
//! where they rest: within `band` (a fraction of the thickness) of the
//! thickness. Crossings just answered and pairs that slid apart fall
//! outside it.
//!
//! A pair that rests is remembered for the whole step, unless its obstacle
//! feature is a prop the cloth rests on as on a point (a needle, which the
//! projection after each pass holds the cloth off instead, see
//! [`super::obstacles`]). The memory fades by the decay factor at every
//! response pass that does not see a contact, and a pair its spring holds
//! past the thickness is seen by no pass: it was forgotten within a few
//! steps, lost its spring, fell back within the thickness, was answered and
//! remembered again, over and over (on `drape_table`'s edges, half of the
//! motion left in the settled cloth; remembered on the needles too, the
//! cloth slid on them four times as fast: 9177ffd).

use nalgebra::Vector3;

use super::CollisionPipeline;
use super::geometry::{closest_between_segments, closest_on_triangle};
use crate::sim::repulsion::{Repulsion, RestingPair};

impl CollisionPipeline {
    /// The repulsions of a step of `h` s starting at time `t0` (s) with the
    /// cloth at positions `x` (m), with the resting pairs they push into
    /// `out`; `None` (and no pairs) when the scene turns them off.
    pub fn repulsion(&mut self, x: &[Vector3<f64>], t0: f64, h: f64, out: &mut Vec<RestingPair>) -> Option<Repulsion> {
        let settings = &self.settings;
        let repulsion = Repulsion {
            self_stiffness: settings.repulsion_stiffness,
            feature_stiffness: settings.feature_repulsion_stiffness,
            tip_stiffness: settings.tip_repulsion_stiffness,
            band: settings.repulsion_band,
            h,
        };
        if [repulsion.self_stiffness, repulsion.feature_stiffness, repulsion.tip_stiffness] == [0.0; 3] {
            out.clear();
            return None;
        }
        self.resting_pairs(x, t0, &repulsion, out);
        Some(repulsion)
    }

    /// The remembered contacts whose features lie within the `repulsion`'s
    /// band (a fraction of their thickness) of the thickness with the cloth
    /// at positions `x` (m) and the obstacles where they are at time `t0`
    /// (s), in key order, into `out`; only the kinds the repulsion pushes
    /// (self-contacts, contacts with analytic colliders' sharp features and
    /// with thin props' tips, each where its stiffness is not 0). Those
    /// resting on a feature the cloth wraps round are remembered for the
    /// step (see the module documentation).
    pub fn resting_pairs(&mut self, x: &[Vector3<f64>], t0: f64, repulsion: &Repulsion, out: &mut Vec<RestingPair>) {
        out.clear();
        let cloth = self.particles.len() as u32;
        // Points from here on are triangle meshes' (bodies): not features.
        let first_mesh = cloth + self.obstacles.first_mesh_vertex;
        let holds = &self.obstacles.holds;
        let on_a_tip = |nodes: &[u32]| nodes.iter().any(|&i| i >= cloth && holds[(i - cloth) as usize]);
        let wanted = |key: &[u32; 5]| {
            let stiffness = if key[1..].iter().all(|&i| i < cloth) {
                repulsion.self_stiffness
            } else if key[1..].iter().any(|&i| i >= first_mesh) {
                0.0
            } else if on_a_tip(&key[1..]) {
                repulsion.tip_stiffness
            } else {
                repulsion.feature_stiffness
            };
            stiffness > 0.0
        };
        let keys = &mut self.ws.resting_keys;
        keys.clear();
        keys.extend(self.influence.keys().filter(|key| wanted(key)));
        keys.sort_unstable();
        let kept = self.settings.influence_kept_for_a_step();
        let (obstacles, particles, influence) = (&self.obstacles, &self.particles, &mut self.influence);
        let at = |i: u32| if i < cloth { x[i as usize] } else { obstacles.position((i - cloth) as usize, t0) };
        for key in keys.iter() {
            let nodes = [key[1], key[2], key[3], key[4]];
            let on_cloth = nodes.map(|i| i < cloth);
            let cloth_nodes = nodes.iter().filter(|&&i| i < cloth);
            let thickness = cloth_nodes.map(|&i| particles[i as usize].thickness).fold(0.0, f64::max);
            let Some(mut pair) = pair_at(key[0], nodes, on_cloth, nodes.map(at), thickness) else { continue };
            if (pair.distance - thickness).abs() > repulsion.band * thickness {
                continue;
            }
            pair.on_a_tip = on_a_tip(&nodes);
            if !pair.is_self_contact()
                && !pair.on_a_tip
                && let Some((value, _)) = influence.get_mut(key)
            {
                *value = value.max(kept);
            }
            out.push(pair);
        }
    }
}

/// The pair of `kind` (0 vertex-triangle, 1 edge-edge) between `nodes` at
/// positions `at` (m), or `None` where its features touch.
fn pair_at(
    kind: u32,
    nodes: [u32; 4],
    on_cloth: [bool; 4],
    at: [Vector3<f64>; 4],
    thickness: f64,
) -> Option<RestingPair> {
    let [a, b, c, d] = at;
    let weights = if kind == 0 {
        let [wa, wb, wc] = closest_on_triangle(&a, &b, &c, &d);
        [1.0, -wa, -wb, -wc]
    } else {
        let (s, t) = closest_between_segments(&a, &b, &c, &d);
        [1.0 - s, s, -(1.0 - t), -t]
    };
    let gap = a * weights[0] + b * weights[1] + c * weights[2] + d * weights[3];
    let distance = gap.norm();
    (distance > 0.0).then(|| {
        let normal = gap / distance;
        RestingPair { nodes, on_cloth, weights, normal, distance, thickness, on_a_tip: false }
    })
}

#[cfg(test)]
mod tests {
    use nalgebra::Isometry3;

    use super::*;
    use crate::sim::colliders::{Collider, Shape};
    use crate::sim::collision::obstacles::{ClothScale, MeshCollider, Obstacles};
    use crate::sim::collision::{CollisionMemory, CollisionSettings, ParticleCollision};
    use crate::sim::motion::{Placement, RigidMotion};

    const THICKNESS: f64 = 0.0025;

    /// A pipeline over `particles` cloth particles in `triangles`, the
    /// features of the `analytic` colliders and the `meshes`.
    fn pipeline(
        particles: usize,
        triangles: Vec<[u32; 3]>,
        analytic: &[Collider],
        meshes: &[MeshCollider],
    ) -> CollisionPipeline {
        let surface = ParticleCollision { thickness: THICKNESS, friction: 0.3, pinned: None };
        let scale = ClothScale { longest_edge_m: 1.0, thinnest_m: THICKNESS };
        let garment = vec![0; triangles.len()];
        let obstacles = Obstacles::new(analytic, meshes, scale);
        let settings = CollisionSettings::default();
        CollisionPipeline::new(triangles, garment, vec![true], vec![surface; particles], obstacles, settings).unwrap()
    }

    fn repulsion(self_stiffness: f64, feature_stiffness: f64) -> Repulsion {
        Repulsion { self_stiffness, feature_stiffness, tip_stiffness: feature_stiffness, band: 0.1, h: 1.0 / 60.0 }
    }

    /// Of the remembered contacts, those between cloth particles resting
    /// within the band of the thickness, in key order; with the obstacle
    /// repulsion off, none with an obstacle's point.
    #[test]
    fn resting_pairs_are_the_remembered_cloth_contacts_at_the_thickness() {
        let mut pipeline = pipeline(6, vec![[0, 1, 2], [3, 4, 5]], &[], &[]);
        let remembered = [
            ([0, 0, 3, 4, 5], 1.0, true),  // 20 cm apart
            ([0, 3, 0, 1, 2], 1.0, true),  // at the thickness
            ([0, 4, 0, 1, 2], 0.1, false), // 5 % past it
            ([0, 5, 0, 1, 2], 1.0, true),  // at half of it: a crossing just answered
            ([0, 6, 0, 1, 2], 1.0, true),  // an obstacle's point
        ];
        pipeline.restore_memory(&CollisionMemory::from_entries(&remembered));
        let x = [
            Vector3::new(0.0, 0.0, 0.0),
            Vector3::new(1.0, 0.0, 0.0),
            Vector3::new(0.0, 0.0, 1.0),
            Vector3::new(0.2, THICKNESS, 0.2),
            Vector3::new(0.3, 1.05 * THICKNESS, 0.1),
            Vector3::new(0.2, 0.5 * THICKNESS, 0.3),
        ];
        let mut pairs = Vec::new();
        pipeline.resting_pairs(&x, 0.0, &repulsion(0.5, 0.0), &mut pairs);
        let nodes: Vec<[u32; 4]> = pairs.iter().map(|p| p.nodes).collect();
        assert_eq!(nodes, [[3, 0, 1, 2], [4, 0, 1, 2]]);
        assert!(pairs.iter().all(RestingPair::is_self_contact));
        assert!((pairs[1].distance - 1.05 * THICKNESS).abs() < 1e-12 && pairs[1].thickness == THICKNESS);
    }

    /// A cloth triangle that its spring holds just past a table's corner is
    /// seen by no response pass: remembered at the step's start while it
    /// rests, it outlives a step of passes that miss it, where a faint memory
    /// fades out in a few. A pair past the band is left to fade, and so are
    /// a cloth triangle resting on a needle's tip (which the projection holds
    /// the cloth off, and whose spring is the tips') and a fold resting on
    /// itself.
    #[test]
    fn a_pair_resting_on_a_wrapped_feature_is_remembered_through_a_step_that_never_sees_it() {
        // A 1 m box whose top face is y = 0, corner 7 at (0.5, 0, 0.5); a
        // needle at x = 2 m whose top is at y = 0.
        let at = |x: f64, y: f64| Placement { rest_pose: Isometry3::translation(x, y, 0.0), motion: None };
        let table = Collider {
            name: "table".into(),
            shape: Shape::Box { half_extents: Vector3::repeat(0.5) },
            placement: at(0.0, -0.5),
            friction: None,
        };
        let needle = Collider {
            name: "needle".into(),
            shape: Shape::Cylinder { radius: 0.003, half_height: 0.2 },
            placement: at(2.0, -0.2),
            friction: None,
        };
        let mut pipeline = pipeline(9, vec![[0, 1, 2], [3, 4, 5], [6, 7, 8]], &[table, needle], &[]);
        let obstacle = |k: u32| 9 + k;
        let on_the_tip = |k: &u32| {
            let p = pipeline.obstacles.position(*k as usize, 0.0);
            p.x > 1.9 && p.y.abs() < 1e-12 && p.z.abs() < 1e-12
        };
        let tip = (0..pipeline.obstacles.vertex_count() as u32).find(on_the_tip).expect("the needle's rim at x > 2");
        let on_the_corner = [0, obstacle(7), 0, 1, 2];
        let corner_far_away = [0, obstacle(7), 3, 4, 5];
        let on_the_needle = [0, obstacle(tip), 3, 4, 5];
        let on_itself = [0, 6, 0, 1, 2];
        let faint = |key| (key, 0.01, false);
        let memory = [faint(on_the_corner), faint(corner_far_away), faint(on_the_needle), faint(on_itself)];
        pipeline.restore_memory(&CollisionMemory::from_entries(&memory));
        let l = 1.05 * THICKNESS;
        let x = [
            Vector3::new(0.4, l, 0.4),
            Vector3::new(0.7, l, 0.4),
            Vector3::new(0.4, l, 0.7),
            Vector3::new(1.9, l, -0.1),
            Vector3::new(2.3, l, -0.1),
            Vector3::new(1.9, l, 0.3),
            Vector3::new(0.45, 2.0 * l, 0.45),
            Vector3::new(0.0, 0.5, 0.0),
            Vector3::new(0.0, 0.5, 0.1),
        ];
        let mut pairs = Vec::new();
        pipeline.resting_pairs(&x, 0.0, &repulsion(0.5, 30.0), &mut pairs);
        let nodes: Vec<[u32; 4]> = pairs.iter().map(|p| p.nodes).collect();
        assert_eq!(nodes, [[6, 0, 1, 2], [obstacle(7), 0, 1, 2], [obstacle(tip), 3, 4, 5]], "three rest");
        let on_a_tip: Vec<bool> = pairs.iter().map(|p| p.on_a_tip).collect();
        assert_eq!(on_a_tip, [false, false, true], "only the needle's rim is a tip");
        for _ in 0..pipeline.settings.passes {
            pipeline.respond_pass(0.01);
        }
        let mut memory = CollisionMemory::default();
        pipeline.save_memory(&mut memory);
        let entries = memory.entries();
        let kept: Vec<[u32; 5]> = entries.iter().map(|e| e.0).collect();
        assert_eq!(kept, [on_the_corner]);
        let settings = &pipeline.settings;
        let influence = entries[0].1;
        assert!(influence * settings.influence_decay + 1.0 < settings.influence_threshold, "{influence}");
    }

    /// A cloth edge drawn over a box's top edge and a cloth triangle lying
    /// on its corner rest on the obstacle: measured from where the box is,
    /// with its points marked as no cloth's, and left out when the feature
    /// repulsion is off. A mesh collider's vertex under the cloth is never a
    /// resting feature.
    #[test]
    fn cloth_resting_on_an_obstacle_feature_rests_against_the_obstacle_where_it_is() {
        // A 1 m box whose top face is y = 0; corner 2 is (−0.5, 0, −0.5),
        // corner 3 (0.5, 0, −0.5) and corner 7 (0.5, 0, 0.5).
        let table = Collider {
            name: "table".into(),
            shape: Shape::Box { half_extents: Vector3::repeat(0.5) },
            placement: Placement { rest_pose: Isometry3::translation(0.0, -0.5, 0.0), motion: None },
            friction: None,
        };
        // A mesh tetrahedron with its apex at (0.55, 0, 0.55), under the same triangle.
        let apex = Vector3::new(0.55, 0.0, 0.55);
        let tetrahedron = MeshCollider {
            name: "tetrahedron".into(),
            vertices: vec![
                apex,
                apex - Vector3::new(0.1, 0.1, 0.0),
                apex - Vector3::new(0.0, 0.1, 0.1),
                apex - Vector3::y() * 0.1,
            ],
            triangles: vec![[0, 1, 2], [0, 2, 3], [0, 3, 1], [1, 3, 2]],
            placement: Placement { rest_pose: Isometry3::identity(), motion: None },
            friction: None,
            animation: None,
        };
        let mut pipeline = pipeline(5, vec![[0, 1, 2], [2, 3, 4]], &[table], &[tetrahedron]);
        let corner = |k: u32| 5 + k;
        let mesh_apex = 5 + 8;
        let remembered = [
            ([1, 0, 1, corner(2), corner(3)], 1.0, true), // a cloth edge across the top edge
            ([0, corner(7), 2, 3, 4], 1.0, true),         // the corner under a cloth triangle
            ([0, mesh_apex, 2, 3, 4], 1.0, true),         // a mesh's vertex under it
        ];
        pipeline.restore_memory(&CollisionMemory::from_entries(&remembered));
        let lifted = 1.05 * THICKNESS;
        let x = [
            Vector3::new(0.0, THICKNESS, -0.6),
            Vector3::new(0.0, THICKNESS, -0.4),
            Vector3::new(0.4, lifted, 0.4),
            Vector3::new(0.7, lifted, 0.4),
            Vector3::new(0.4, lifted, 0.7),
        ];
        let mut pairs = Vec::new();
        pipeline.resting_pairs(&x, 0.0, &repulsion(0.5, 10.0), &mut pairs);
        let nodes: Vec<[u32; 4]> = pairs.iter().map(|p| p.nodes).collect();
        assert_eq!(nodes, [[corner(7), 2, 3, 4], [0, 1, corner(2), corner(3)]]);
        assert_eq!(pairs[0].on_cloth, [false, true, true, true]);
        assert_eq!(pairs[1].on_cloth, [true, true, false, false]);
        assert!((pairs[0].distance - lifted).abs() < 1e-12 && (pairs[0].normal + Vector3::y()).norm() < 1e-12);
        assert!((pairs[1].distance - THICKNESS).abs() < 1e-12 && (pairs[1].normal - Vector3::y()).norm() < 1e-12);
        assert!(pairs.iter().all(|p| p.thickness == THICKNESS && !p.is_self_contact()));
        pipeline.resting_pairs(&x, 0.0, &repulsion(0.5, 0.0), &mut pairs);
        assert!(pairs.is_empty(), "{pairs:?}");
    }

    /// A moving collider's feature is measured where the collider is at the
    /// step's start: a box sliding along x by 1 m/s, a cloth edge resting
    /// across its top edge where that edge is at 2 s.
    #[test]
    fn a_moving_feature_is_measured_where_its_collider_is_at_the_step_start() {
        let motion = RigidMotion {
            velocity: Vector3::x(),
            angular_velocity: Vector3::zeros(),
            pivot: Vector3::zeros(),
            start: 0.0,
            end: f64::INFINITY,
        };
        let sliding = Collider {
            name: "sliding box".into(),
            shape: Shape::Box { half_extents: Vector3::repeat(0.5) },
            placement: Placement { rest_pose: Isometry3::translation(0.0, -0.5, 0.0), motion: Some(motion) },
            friction: None,
        };
        let mut pipeline = pipeline(3, vec![[0, 1, 2]], &[sliding], &[]);
        // Corners 2 and 6 span the box's top edge along z at x = −0.5 (at rest).
        let remembered = [([1, 0, 1, 3 + 2, 3 + 6], 1.0, true)];
        pipeline.restore_memory(&CollisionMemory::from_entries(&remembered));
        let x = [Vector3::new(1.3, THICKNESS, 0.0), Vector3::new(1.7, THICKNESS, 0.0), Vector3::new(1.5, 0.1, 0.5)];
        let mut pairs = Vec::new();
        pipeline.resting_pairs(&x, 2.0, &repulsion(0.5, 30.0), &mut pairs);
        assert_eq!(pairs.len(), 1, "at 2 s the edge lies under the cloth: {pairs:?}");
        assert!((pairs[0].distance - THICKNESS).abs() < 1e-12 && (pairs[0].normal - Vector3::y()).norm() < 1e-12);
        pipeline.resting_pairs(&x, 0.0, &repulsion(0.5, 30.0), &mut pairs);
        assert!(pairs.is_empty(), "at the start the edge is 2 m away: {pairs:?}");
    }

    #[test]
    fn a_vertex_over_a_triangle_rests_along_the_triangle_normal() {
        let x = [
            Vector3::new(0.25, 0.0025, 0.25),
            Vector3::new(0.0, 0.0, 0.0),
            Vector3::new(1.0, 0.0, 0.0),
            Vector3::new(0.0, 0.0, 1.0),
        ];
        let pair = pair_at(0, [0, 1, 2, 3], [true; 4], x, 0.0025).unwrap();
        assert!((pair.distance - 0.0025).abs() < 1e-15);
        assert!((pair.normal - Vector3::y()).norm() < 1e-12);
        let expected = [1.0, -0.5, -0.25, -0.25];
        assert!(pair.weights.iter().zip(expected).all(|(w, e)| (w - e).abs() < 1e-12), "{:?}", pair.weights);
    }

    #[test]
    fn crossing_edges_rest_along_their_common_normal() {
        let x = [
            Vector3::new(-1.0, 0.003, 0.0),
            Vector3::new(1.0, 0.003, 0.0),
            Vector3::new(0.0, 0.0, -1.0),
            Vector3::new(0.0, 0.0, 3.0),
        ];
        let pair = pair_at(1, [0, 1, 2, 3], [true; 4], x, 0.0025).unwrap();
        assert!((pair.distance - 0.003).abs() < 1e-15);
        let expected = [0.5, 0.5, -0.75, -0.25];
        assert!(pair.weights.iter().zip(expected).all(|(w, e)| (w - e).abs() < 1e-12), "{:?}", pair.weights);
        assert!((pair.normal - Vector3::y()).norm() < 1e-12);
    }
}
