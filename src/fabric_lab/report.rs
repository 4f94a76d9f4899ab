//! What `drape fabric test` prints: each virtual test's figures next to the
//! preset's targets, and whether the preset passes.

use std::fmt::Write as _;

use super::cantilever::{Cantilever, STRIP_WIDTH_M};
use super::cusick::{Cusick, DISC_RADIUS_M, SPECIMEN_RADIUS_M};
use crate::scene::preset::Preset;

/// A preset passes when its virtual bending length is within this fraction
/// of its target.
pub const BENDING_LENGTH_TOLERANCE: f64 = 0.05;

/// The virtual tests of one preset.
#[derive(Clone, Debug)]
pub struct FabricReport {
    /// The preset tested.
    pub preset: Preset,
    /// Its cantilever test.
    pub cantilever: Cantilever,
    /// Its drape test, unless skipped.
    pub cusick: Option<Cusick>,
}

impl FabricReport {
    /// Relative deviation of the bending length from the preset's target, if it has one.
    pub fn bending_length_error(&self) -> Option<f64> {
        let target = self.preset.about.target_bending_length_cm? / 100.0;
        Some(self.cantilever.bending_length_m / target - 1.0)
    }

    /// Whether the bending length is within tolerance of its target (true without a target).
    pub fn passes(&self) -> bool {
        self.bending_length_error().is_none_or(|e| e.abs() <= BENDING_LENGTH_TOLERANCE)
    }

    /// The report as text lines.
    pub fn text(&self) -> String {
        let c = &self.cantilever;
        let mut out = format!("{}\n", self.preset.name);
        let _ = write!(
            out,
            "  cantilever (ASTM D1388, {:.0} mm strip, {} vertices): overhang {:.2} cm, tip chord at {:.2}°, \
             bending length {:.3} cm",
            STRIP_WIDTH_M * 1000.0,
            c.vertices,
            c.overhang_m * 100.0,
            c.chord_angle_deg,
            c.bending_length_m * 100.0
        );
        match (self.preset.about.target_bending_length_cm, self.bending_length_error()) {
            (Some(target), Some(error)) => {
                let verdict = if self.passes() { "pass" } else { "FAIL" };
                let _ = write!(out, " (target {target} cm: {:+.1} %, {verdict})", error * 100.0);
            }
            _ => out += " (no target)",
        }
        let _ = writeln!(out, ", flexural rigidity {:.4e} N·m", c.flexural_rigidity_n_m);
        if let Some(d) = &self.cusick {
            let _ = write!(
                out,
                "  drape (Cusick, {:.0} cm specimen on {:.0} cm disc): drape coefficient {:.3}, {} nodes, ",
                SPECIMEN_RADIUS_M * 200.0,
                DISC_RADIUS_M * 200.0,
                d.drape_coefficient,
                d.nodes
            );
            if d.at_rest {
                let _ = write!(out, "at rest after {:.2} s", d.settled_s);
            } else {
                let _ = write!(out, "still moving after {:.2} s", d.settled_s);
            }
            if let Some(target) = self.preset.about.target_drape_coefficient {
                let _ = write!(out, " (target {target})");
            }
            out += "\n";
        }
        out
    }
}

/// The reports as a Markdown table (BENCHMARKS.md).
pub fn markdown_table(reports: &[FabricReport]) -> String {
    let mut out = String::from(
        "| preset | g/m² | target c (cm) | virtual c (cm) | error | G (N·m) | drape coefficient | nodes |\n\
         |---|---:|---:|---:|---:|---:|---:|---:|\n",
    );
    for r in reports {
        let target = r.preset.about.target_bending_length_cm.map_or("-".into(), |t| format!("{t}"));
        let error = r.bending_length_error().map_or("-".into(), |e| format!("{:+.1} %", e * 100.0));
        let (dc, nodes) = r
            .cusick
            .as_ref()
            .map_or(("-".into(), "-".into()), |d| (format!("{:.3}", d.drape_coefficient), d.nodes.to_string()));
        let _ = writeln!(
            out,
            "| {} | {:.0} | {target} | {:.3} | {error} | {:.3e} | {dc} | {nodes} |",
            r.preset.name,
            r.preset.fabric.area_density_kg_per_m2 * 1000.0,
            r.cantilever.bending_length_m * 100.0,
            r.cantilever.flexural_rigidity_n_m
        );
    }
    out
}
