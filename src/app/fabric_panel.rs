//! The fabric panel (PAPER Fig. 10d): every Table 1 parameter as a slider
//! with its unit and what it does to the cloth, a preset menu, and the
//! parameter file ("AttributeFile") loaded and saved.

use crate::sim::fabric::Fabric;

/// One slider of the panel.
pub struct Parameter {
    /// Label shown (and used by UI tests to find the slider).
    pub label: &'static str,
    /// Unit shown after the value.
    pub unit: &'static str,
    /// What the parameter does to the cloth (the tooltip).
    pub effect: &'static str,
    /// Slider range (the field accepts any valid value outside it).
    pub range: (f64, f64),
    /// Logarithmic slider (values spanning decades).
    pub logarithmic: bool,
    /// The value in a fabric.
    pub value: fn(&mut Fabric) -> &mut f64,
}

/// The panel's sliders, in the paper's Table 1 order, then contact.
pub const PARAMETERS: [Parameter; 13] = [
    Parameter {
        label: "Stretch stiffness",
        unit: "N/m",
        effect: "Resistance to stretching along the threads (per unit square). Higher: the cloth keeps its length \
                 under its own weight; lower: it sags and elongates like a knit.",
        range: (10.0, 1e5),
        logarithmic: true,
        value: |f| &mut f.stretch_stiffness_n_per_m,
    },
    Parameter {
        label: "Stretch damping",
        unit: "N·s/m",
        effect: "Damps stretching oscillations: higher stops the cloth bouncing on its springs.",
        range: (1e-4, 10.0),
        logarithmic: true,
        value: |f| &mut f.stretch_damping_n_s_per_m,
    },
    Parameter {
        label: "Shear stiffness",
        unit: "N/m",
        effect: "Resistance to the weave skewing (per unit square). Lower lets the cloth drape on the bias and \
                 wrap round curves; higher makes it behave like paper.",
        range: (0.1, 1e4),
        logarithmic: true,
        value: |f| &mut f.shear_stiffness_n_per_m,
    },
    Parameter {
        label: "Shear damping",
        unit: "N·s/m",
        effect: "Damps shearing oscillations.",
        range: (1e-5, 1.0),
        logarithmic: true,
        value: |f| &mut f.shear_damping_n_s_per_m,
    },
    Parameter {
        label: "Bend stiffness",
        unit: "N·m",
        effect: "Flexural rigidity. Higher: fewer, larger, rounder folds (denim, leather); lower: many fine \
                 folds that cling (silk, chiffon).",
        range: (1e-8, 1e-2),
        logarithmic: true,
        value: |f| &mut f.bend_stiffness_n_m,
    },
    Parameter {
        label: "Bend damping",
        unit: "N·m·s",
        effect: "Damps folding motion: higher makes folds settle slowly, as in heavy or lined cloth.",
        range: (1e-10, 1e-4),
        logarithmic: true,
        value: |f| &mut f.bend_damping_n_m_s,
    },
    Parameter {
        label: "Air damping",
        unit: "1/s",
        effect: "Fraction of velocity lost per second to the air. Higher: the cloth floats down and swings less.",
        range: (0.0, 5.0),
        logarithmic: false,
        value: |f| &mut f.air_damping_per_s,
    },
    Parameter {
        label: "Area density",
        unit: "kg/m²",
        effect: "Mass per area (silk ~0.06, cotton ~0.14, denim ~0.35). Heavier cloth hangs straighter and \
                 swings with more momentum.",
        range: (0.01, 1.0),
        logarithmic: true,
        value: |f| &mut f.area_density_kg_per_m2,
    },
    Parameter {
        label: "Gravity",
        unit: "m/s²",
        effect: "Vertical acceleration (negative is down).",
        range: (-20.0, 0.0),
        logarithmic: false,
        value: |f| &mut f.gravity_m_per_s2[1],
    },
    Parameter {
        label: "Time step",
        unit: "s",
        effect: "Longest solver step for this fabric while it moves. Shorter steps are more accurate and \
                 slower; the frame is split into as many steps as it needs, and steps lengthen up to a frame \
                 while the cloth is calm (the scene's long_step_error).",
        range: (1e-4, 0.05),
        logarithmic: true,
        value: |f| &mut f.time_step_s,
    },
    Parameter {
        label: "Compression",
        unit: "× stretch",
        effect: "Fraction of the stretch stiffness that resists in-plane compression. Low values let the cloth \
                 buckle into folds instead of shrinking.",
        range: (0.0, 1.0),
        logarithmic: false,
        value: |f| &mut f.compression_ratio,
    },
    Parameter {
        label: "Friction",
        unit: "μ",
        effect: "Coulomb friction against the body, colliders and itself. Higher: the cloth grips instead of \
                 sliding off.",
        range: (0.0, 2.0),
        logarithmic: false,
        value: |f| &mut f.friction,
    },
    Parameter {
        label: "Thickness",
        unit: "m",
        effect: "Distance the cloth keeps from the body, colliders and itself. Too small lets fast motion \
                 tunnel; too large floats the cloth visibly.",
        range: (5e-4, 0.02),
        logarithmic: true,
        value: |f| &mut f.thickness_m,
    },
];

/// The parameter labelled `label`.
pub fn parameter(label: &str) -> Option<&'static Parameter> {
    PARAMETERS.iter().find(|p| p.label == label)
}

/// Draws the sliders of `fabric`; returns true when one changed. A value
/// typed outside the physical range is refused by the caller's validation.
pub fn sliders(ui: &mut egui::Ui, fabric: &mut Fabric) -> Option<&'static str> {
    let mut changed = None;
    egui::Grid::new("fabric parameters").num_columns(2).striped(true).show(ui, |ui| {
        for p in &PARAMETERS {
            if slider_row(ui, p, p.label, fabric) {
                changed = Some(p.label);
            }
        }
        let label = ui.label("Strain limit").on_hover_text(STRAIN_LIMIT_EFFECT);
        if strain_limit(ui, fabric, label.id) {
            changed = Some("Strain limit");
        }
        ui.end_row();
    });
    changed
}

/// The contact parameters of `fabric` (friction and thickness) again, for
/// the collision panel, labelled "Contact friction" and "Contact
/// thickness" (the fabric panel's own sliders keep their names); returns
/// true when one changed.
pub fn contact_sliders(ui: &mut egui::Ui, fabric: &mut Fabric) -> Option<&'static str> {
    let mut changed = None;
    egui::Grid::new("contact parameters").num_columns(2).show(ui, |ui| {
        for (name, label) in [("Friction", "Contact friction"), ("Thickness", "Contact thickness")] {
            if let Some(p) = parameter(name)
                && slider_row(ui, p, label, fabric)
            {
                changed = Some(p.label);
            }
        }
    });
    changed
}

/// One grid row: `label`, then the slider of parameter `p` of `fabric`, with
/// its unit and effect; returns true when it changed.
fn slider_row(ui: &mut egui::Ui, p: &Parameter, label: &str, fabric: &mut Fabric) -> bool {
    let label = ui.label(label).on_hover_text(p.effect);
    let slider = egui::Slider::new((p.value)(fabric), p.range.0..=p.range.1)
        .logarithmic(p.logarithmic)
        .suffix(format!(" {}", p.unit))
        .clamping(egui::SliderClamping::Never)
        .custom_formatter(|v, _| format_value(v));
    let changed = ui.add(slider).labelled_by(label.id).on_hover_text(p.effect).changed();
    ui.end_row();
    changed
}

const STRAIN_LIMIT_EFFECT: &str = "Largest stretch the threads allow, enforced exactly (PAPER eq. 6): wovens \
                                   ~1-3 %, knits 10 % or more. Off: the stretch springs alone.";

fn strain_limit(ui: &mut egui::Ui, fabric: &mut Fabric, label: egui::Id) -> bool {
    let mut on = fabric.strain_limit.is_some();
    let mut changed = false;
    ui.horizontal(|ui| {
        if ui.checkbox(&mut on, "").labelled_by(label).on_hover_text(STRAIN_LIMIT_EFFECT).changed() {
            fabric.strain_limit = on.then_some(0.02);
            changed = true;
        }
        if let Some(limit) = &mut fabric.strain_limit {
            let mut percent = *limit * 100.0;
            let slider = egui::Slider::new(&mut percent, 0.1..=30.0).logarithmic(true).suffix(" %");
            if ui.add(slider).labelled_by(label).on_hover_text(STRAIN_LIMIT_EFFECT).changed() {
                *limit = percent / 100.0;
                changed = true;
            }
        }
    });
    changed
}

/// A value with three significant digits, in plain or scientific notation.
fn format_value(v: f64) -> String {
    let magnitude = v.abs();
    if magnitude == 0.0 {
        "0".to_owned()
    } else if (1e-2..1e4).contains(&magnitude) {
        let decimals = (2 - magnitude.log10().floor() as i32).clamp(0, 4) as usize;
        format!("{v:.decimals$}")
    } else {
        format!("{v:.2e}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::preset::Preset;

    #[test]
    fn every_slider_reaches_a_distinct_field_and_covers_every_shipped_preset() {
        let mut fabric = Preset::builtin("cotton").unwrap().fabric;
        for (k, p) in PARAMETERS.iter().enumerate() {
            *(p.value)(&mut fabric) = 1000.0 + k as f64;
        }
        for (k, p) in PARAMETERS.iter().enumerate() {
            assert_eq!(*(p.value)(&mut fabric), 1000.0 + k as f64, "{} shares a field", p.label);
        }
        for name in Preset::builtin_names() {
            let mut fabric = Preset::builtin(name).unwrap().fabric;
            for p in &PARAMETERS {
                let v = *(p.value)(&mut fabric);
                assert!(p.range.0 <= v && v <= p.range.1, "{name}: {} = {v} outside its slider", p.label);
            }
        }
    }

    #[test]
    fn values_print_with_three_significant_digits() {
        assert_eq!(format_value(2000.0), "2000");
        assert_eq!(format_value(0.135), "0.135");
        assert_eq!(format_value(1.6e-5), "1.60e-5");
        assert_eq!(format_value(0.0), "0");
    }
}
