//! The cantilever bending test (ASTM D1388, option A; Peirce 1930), done
//! virtually.
//!
//! A 25 mm strip lies on a platform and is pushed over its edge until its tip,
//! bending under its own weight, touches a plane inclined at 41.5° below the
//! platform. The bending length is half the overhang then:
//! `c = l / 2`, and the flexural rigidity is `G = w c³` (w the weight per
//! area): the inextensible heavy elastica ([`super::elastica`]) puts the
//! tip's chord at 41.5° when `w l³ / G = 8.004`, i.e. `c = l / 2` to 0.02 %.
//!
//! The virtual test clamps the strip at the platform's edge, lets it settle,
//! reads the chord angle from the edge to the tip and, as the operator slides
//! the strip, adjusts the overhang until that angle is 41.5°. The bending
//! length is read from the last trial with the elastica (exactly `l / 2` at
//! 41.5°, and exact near it too).

use nalgebra::Vector3;

use super::elastica;
use super::{LabError, Settled, Specimen, settle, weight_per_area};
use crate::mesh::generate;
use crate::sim::fabric::Fabric;

/// Angle of the test's inclined plane below the horizontal, degrees.
pub const ASTM_ANGLE_DEG: f64 = 41.5;
/// Width of the strip, m (ASTM D1388: 25 mm).
pub const STRIP_WIDTH_M: f64 = 0.025;
/// The overhang is accepted when the chord angle is this close to 41.5°, degrees.
const ANGLE_TOLERANCE_DEG: f64 = 0.2;
/// The operator slides the strip at most this many times.
const MAX_TRIALS: usize = 8;
/// Clamped rows of elements behind the edge.
const CLAMPED_COLUMNS: usize = 2;

/// What the cantilever test measured.
#[derive(Clone, Debug, PartialEq)]
pub struct Cantilever {
    /// Overhang of the strip beyond the edge in the last trial, m.
    pub overhang_m: f64,
    /// Angle below the horizontal of the chord from the edge to the tip, degrees.
    pub chord_angle_deg: f64,
    /// Bending length `c`, m.
    pub bending_length_m: f64,
    /// Flexural rigidity `G = w c³`, N·m.
    pub flexural_rigidity_n_m: f64,
    /// Overhangs tried.
    pub trials: usize,
    /// Vertices of the strip.
    pub vertices: usize,
}

/// Runs the test on `fabric` with `segments` elements along the overhang.
pub fn cantilever_test(fabric: &Fabric, segments: usize) -> Result<Cantilever, LabError> {
    let w = weight_per_area(fabric)?;
    if fabric.bend_stiffness_n_m <= 0.0 {
        return Err(LabError::Unreachable(
            "bend_stiffness_n_m = 0: a fabric without bending stiffness hangs straight down (bending length 0)".into(),
        ));
    }
    // The first overhang: twice the bending length an operator would guess
    // from the fabric's hand; trials correct it from what the strip does.
    let mut overhang = 2.0 * (fabric.bend_stiffness_n_m / w).cbrt();
    // Overhangs known to hang short of, and past, the angle.
    let (mut short, mut past) = (0.0_f64, f64::INFINITY);
    let mut trials = 0;
    loop {
        trials += 1;
        let specimen = strip(overhang, segments, fabric);
        let settled = settle(&specimen, fabric)?;
        let angle = chord_angle(&settled, &specimen, segments);
        let bending_length = elastica::bending_length(overhang, angle);
        let miss = angle.to_degrees() - ASTM_ANGLE_DEG;
        if miss.abs() < ANGLE_TOLERANCE_DEG || trials == MAX_TRIALS {
            return Ok(Cantilever {
                overhang_m: overhang,
                chord_angle_deg: angle.to_degrees(),
                bending_length_m: bending_length,
                flexural_rigidity_n_m: w * bending_length.powi(3),
                trials,
                vertices: specimen.mesh.vertex_count(),
            });
        }
        if miss < 0.0 {
            short = short.max(overhang);
        } else {
            past = past.min(overhang);
        }
        // Slide to where the elastica puts 41.5° for this strip, unless
        // that leaves what the trials so far bracket: then halve the bracket.
        overhang = 2.0 * bending_length;
        if !(short < overhang && overhang < past) {
            overhang = 0.5 * (short + past);
        }
    }
}

/// The strip: `overhang` beyond the edge (x = 0, running along +X at y = 0)
/// and [`CLAMPED_COLUMNS`] elements clamped behind it; square elements,
/// [`STRIP_WIDTH_M`] wide.
fn strip(overhang: f64, segments: usize, fabric: &Fabric) -> Specimen {
    let dx = overhang / segments as f64;
    let rows = ((STRIP_WIDTH_M / dx).round() as usize).max(2) + 1;
    let columns = segments + CLAMPED_COLUMNS + 1;
    let length = dx * (columns - 1) as f64;
    let mut mesh = generate::rectangle(length, STRIP_WIDTH_M, columns, rows);
    let shift = Vector3::new(0.5 * length - CLAMPED_COLUMNS as f64 * dx, 0.0, 0.0);
    mesh.positions.iter_mut().for_each(|p| *p += shift);
    let clamped =
        (0..rows).flat_map(|row| (0..=CLAMPED_COLUMNS).map(move |col| (row * columns + col) as u32)).collect();
    // A natural period of the strip, ~ l² √(ρ/G); steps resolve it and the
    // test waits out several.
    let period = overhang * overhang * (fabric.area_density_kg_per_m2 / fabric.bend_stiffness_n_m).sqrt();
    Specimen {
        mesh,
        clamped,
        colliders: Vec::new(),
        self_collision: false,
        step_s: (period / 20.0).clamp(1e-4, 1.0 / 120.0),
        rest_speed: 1e-4 * overhang / period.max(1e-3),
        quiet_s: period,
        max_time_s: (30.0 * period).clamp(1.0, 30.0),
    }
}

/// Angle below the horizontal of the chord from the clamped edge to the tip
/// (the mean of the free end's vertices), radians.
fn chord_angle(settled: &Settled, specimen: &Specimen, segments: usize) -> f64 {
    let columns = segments + CLAMPED_COLUMNS + 1;
    let rows = specimen.mesh.vertex_count() / columns;
    let tip: Vector3<f64> =
        (0..rows).map(|row| settled.positions[row * columns + columns - 1]).sum::<Vector3<f64>>() / rows as f64;
    (-tip.y).atan2(tip.x)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::fabric::tests::cotton;

    /// The virtual test on a thin strip at fine resolution recovers the
    /// analytic bending length `c = (G/w)^⅓` of the fabric's rigidity.
    #[test]
    fn virtual_cantilever_matches_the_peirce_relation() {
        for rigidity in [4e-6, 1.6e-5, 2e-4] {
            let fabric = Fabric { bend_stiffness_n_m: rigidity, bend_damping_n_m_s: rigidity * 0.01, ..cotton() };
            let w = weight_per_area(&fabric).unwrap();
            let analytic = (rigidity / w).cbrt();
            let test = cantilever_test(&fabric, 24).unwrap();
            let error = test.bending_length_m / analytic - 1.0;
            assert!(error.abs() < 0.05, "G = {rigidity}: c = {} vs {analytic} ({test:?})", test.bending_length_m);
            assert!((test.chord_angle_deg - ASTM_ANGLE_DEG).abs() < 1.0, "{test:?}");
        }
    }

    #[test]
    fn a_fabric_without_weight_or_bending_is_refused() {
        let weightless = Fabric { gravity_m_per_s2: [0.0; 3], ..cotton() };
        assert!(matches!(cantilever_test(&weightless, 8), Err(LabError::NoGravity)));
        let limp = Fabric { bend_stiffness_n_m: 0.0, ..cotton() };
        assert!(matches!(cantilever_test(&limp, 8), Err(LabError::Unreachable(_))));
    }
}
