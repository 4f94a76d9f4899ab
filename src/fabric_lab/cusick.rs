//! The Cusick drape test (BS 5058, BS EN ISO 9073-9), done virtually.
//!
//! A round specimen of 30 cm diameter is clamped between two discs of 18 cm
//! and hangs around them under its own weight. The drape coefficient is the
//! share of the hanging ring that its shadow still covers:
//! `DC = (A_shadow − A_disc) / (A_specimen − A_disc)`: 1 for a board that
//! does not bend, towards 0 for a limp fabric that falls straight down. Limp
//! fabrics (chiffon, jersey) give ~0.2-0.4, shirting ~0.5-0.7, stiff leather
//! and denim ~0.8 and more. The nodes are the folds around the rim.

use nalgebra::{Isometry3, Vector3};

use super::shadow::Shadow;
use super::{LabError, Specimen, settle, weight_per_area};
use crate::mesh::topology::Topology;
use crate::mesh::{TriMesh, generate};
use crate::sim::colliders::{Collider, Shape};
use crate::sim::fabric::Fabric;
use crate::sim::motion::Placement;

/// Radius of the specimen, m (30 cm diameter).
pub const SPECIMEN_RADIUS_M: f64 = 0.15;
/// Radius of the supporting and clamping discs, m (18 cm diameter).
pub const DISC_RADIUS_M: f64 = 0.09;
/// Vertices across the specimen's diameter at the standard resolution
/// (7.5 mm elements).
pub const STANDARD_ACROSS: usize = 41;

/// What the drape test measured.
#[derive(Clone, Debug)]
pub struct Cusick {
    /// Drape coefficient, unitless (0..1).
    pub drape_coefficient: f64,
    /// Folds around the rim.
    pub nodes: usize,
    /// Area of the shadow, m².
    pub shadow_area_m2: f64,
    /// Simulated time the specimen took to come to rest, s.
    pub settled_s: f64,
    /// Whether it came to rest within the time limit.
    pub at_rest: bool,
    /// The shadow the area was measured on.
    pub shadow: Shadow,
}

/// Runs the test on `fabric` with a specimen of `across` vertices over its
/// diameter, its threads along X and Z.
pub fn drape_test(fabric: &Fabric, across: usize) -> Result<Cusick, LabError> {
    weight_per_area(fabric)?;
    if across < 9 {
        return Err(LabError::Target {
            what: "vertices across the drape specimen",
            value: across as f64,
            expected: "9 or more",
        });
    }
    let specimen = specimen(fabric, across);
    let settled = settle(&specimen, fabric)?;
    let disc = std::f64::consts::PI * DISC_RADIUS_M * DISC_RADIUS_M;
    let flat = specimen.mesh.area();
    // The shadow over the whole specimen, flat or hanging, with a margin.
    let shadow = Shadow::cast(&settled.positions, &specimen.mesh.triangles, SPECIMEN_RADIUS_M + 0.01);
    let shadow_area = shadow.area_m2();
    let rim: Vec<Vector3<f64>> = rim_vertices(&specimen.mesh).into_iter().map(|i| settled.positions[i]).collect();
    Ok(Cusick {
        drape_coefficient: ((shadow_area - disc) / (flat - disc)).clamp(0.0, 1.0),
        nodes: count_nodes(&rim),
        shadow_area_m2: shadow_area,
        settled_s: settled.time_s,
        at_rest: settled.at_rest(&specimen),
        shadow,
    })
}

/// The specimen: a disc of [`SPECIMEN_RADIUS_M`] centred over a pedestal of
/// [`DISC_RADIUS_M`], clamped inside the disc radius.
fn specimen(fabric: &Fabric, across: usize) -> Specimen {
    let mesh = generate::disc(SPECIMEN_RADIUS_M, across);
    let clamped = (0..mesh.vertex_count() as u32)
        .filter(|&i| {
            let p = mesh.positions[i as usize];
            p.x.hypot(p.z) <= DISC_RADIUS_M + 1e-9
        })
        .collect();
    // The pedestal: a cylinder under the clamp, its top clear of the clamped
    // cloth by twice the collision thickness, so the hanging cloth folds
    // around a solid support rather than through it.
    let height = 0.2;
    let top = -2.0 * fabric.thickness_m;
    let pedestal = Collider {
        name: "pedestal".into(),
        shape: Shape::Cylinder { radius: DISC_RADIUS_M, half_height: 0.5 * height },
        placement: Placement { rest_pose: Isometry3::translation(0.0, top - 0.5 * height, 0.0), motion: None },
        friction: None,
    };
    Specimen {
        mesh,
        clamped,
        colliders: vec![pedestal],
        self_collision: true,
        step_s: 1.0 / 120.0,
        rest_speed: 2e-3,
        quiet_s: 0.25,
        max_time_s: 6.0,
    }
}

/// The specimen's boundary vertices, in order of their angle around the axis.
fn rim_vertices(mesh: &TriMesh) -> Vec<usize> {
    let topology = Topology::new(&mesh.triangles);
    let mut rim: Vec<usize> =
        topology.edges.iter().filter(|e| !e.is_interior()).flat_map(|e| e.vertices).map(|v| v as usize).collect();
    rim.sort_unstable();
    rim.dedup();
    let angle = |i: &usize| mesh.positions[*i].z.atan2(mesh.positions[*i].x);
    rim.sort_by(|a, b| angle(a).total_cmp(&angle(b)));
    rim
}

/// Folds of the hem: peaks of the rim's distance from the axis, counted
/// around the circle after smoothing over a twelfth of a turn, above the mean.
pub fn count_nodes(rim: &[Vector3<f64>]) -> usize {
    let n = rim.len();
    if n < 12 {
        return 0;
    }
    let radius: Vec<f64> = rim.iter().map(|p| p.x.hypot(p.z)).collect();
    let half = (n / 24).max(1);
    let smooth: Vec<f64> = (0..n)
        .map(|i| (0..=2 * half).map(|k| radius[(i + n + k - half) % n]).sum::<f64>() / (2 * half + 1) as f64)
        .collect();
    let mean = smooth.iter().sum::<f64>() / n as f64;
    let spread = smooth.iter().map(|r| (r - mean).abs()).fold(0.0, f64::max);
    if spread < 1e-4 {
        return 0;
    }
    (0..n)
        .filter(|&i| {
            let r = smooth[i];
            r > mean && (1..=half).all(|k| r > smooth[(i + n - k) % n] && r >= smooth[(i + k) % n])
        })
        .count()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::fabric::tests::cotton;

    #[test]
    fn nodes_are_the_peaks_of_a_wavy_hem() {
        let hem = |folds: usize| -> Vec<Vector3<f64>> {
            (0..120)
                .map(|j| {
                    let a = std::f64::consts::TAU * j as f64 / 120.0;
                    let r = 0.12 + 0.01 * (folds as f64 * a).cos();
                    Vector3::new(r * a.cos(), -0.05, r * a.sin())
                })
                .collect()
        };
        for folds in [4, 6, 9] {
            assert_eq!(count_nodes(&hem(folds)), folds);
        }
        assert_eq!(count_nodes(&hem(0)), 0);
    }

    /// Stiffer fabric stands out further: the drape coefficient grows with
    /// the flexural rigidity, and lies strictly between the limp and rigid limits.
    #[test]
    fn drape_coefficient_grows_with_bending_stiffness() {
        let with_rigidity = |g: f64| Fabric { bend_stiffness_n_m: g, bend_damping_n_m_s: 0.01 * g, ..cotton() };
        let limp = drape_test(&with_rigidity(2e-6), 25).unwrap();
        let stiff = drape_test(&with_rigidity(2e-4), 25).unwrap();
        assert!(stiff.at_rest, "{}", stiff.settled_s);
        assert!(0.0 < limp.drape_coefficient && limp.drape_coefficient < stiff.drape_coefficient);
        assert!(stiff.drape_coefficient < 1.0, "{}", stiff.drape_coefficient);
        assert!(limp.nodes >= 3, "{}", limp.nodes);
    }
}
