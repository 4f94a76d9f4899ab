//! The virtual fabric lab on the shipped presets: each one's cantilever
//! bending length (ASTM D1388, done on the simulator) is within 5 % of the
//! target its file records.

use drape::fabric_lab::cantilever::{ASTM_ANGLE_DEG, cantilever_test};
use drape::fabric_lab::report::{BENDING_LENGTH_TOLERANCE, FabricReport};
use drape::scene::preset::Preset;

/// Elements along the overhang: coarser than `drape fabric test` (32), still
/// within tolerance (the virtual length converges from below, first order).
const SEGMENTS: usize = 24;

#[test]
fn every_shipped_preset_meets_its_bending_length_target() {
    for name in Preset::builtin_names() {
        let preset = Preset::builtin(name).unwrap();
        let target = preset.about.target_bending_length_cm.expect("every shipped preset records its target");
        let cantilever = cantilever_test(&preset.fabric, SEGMENTS).unwrap();
        assert!((cantilever.chord_angle_deg - ASTM_ANGLE_DEG).abs() < 0.5, "{name}: {cantilever:?}");
        let report = FabricReport { preset, cantilever, cusick: None };
        let error = report.bending_length_error().unwrap();
        assert!(
            error.abs() <= BENDING_LENGTH_TOLERANCE,
            "{name}: virtual bending length {:.3} cm vs target {target} cm ({:+.1} %)",
            report.cantilever.bending_length_m * 100.0,
            error * 100.0
        );
        assert!(report.passes());
    }
}
