//! The fabric panel (PAPER Fig. 10d) in a designer's words: weight in g/m²,
//! stretch, shear and bending as named 0-100 scales (soft → firm, the SI
//! value and the saved file's key in the tooltip), the largest stretch the
//! threads allow, friction and thickness (the cloth's contact, in this one
//! place); damping, compression, gravity and the time step under
//! "Advanced". A preset menu, and the parameter file loaded and saved.

use crate::sim::fabric::Fabric;

/// How a slider shows its parameter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Display {
    /// A 0-100 scale spread logarithmically over the parameter's range, with
    /// the words at its ends ("soft", "stiff").
    Scale {
        /// What 0 feels like.
        low: &'static str,
        /// What 100 feels like.
        high: &'static str,
    },
    /// The value times `factor`, in `unit` (g/m² for kg/m², mm for m).
    Units {
        /// Shown value per SI value.
        factor: f64,
        /// Unit shown.
        unit: &'static str,
    },
}

/// One slider of the panel.
pub struct Parameter {
    /// Label shown (and used by UI tests to find the slider).
    pub label: &'static str,
    /// The SI unit of the value.
    pub unit: &'static str,
    /// The key of the value in scene and preset files.
    pub key: &'static str,
    /// What the parameter does to the cloth (the tooltip).
    pub effect: &'static str,
    /// Range of the SI value the slider spans (the field accepts any valid
    /// value outside it).
    pub range: (f64, f64),
    /// Logarithmic slider (values spanning decades).
    pub logarithmic: bool,
    /// How the value is shown.
    pub display: Display,
    /// Under the "Advanced" fold.
    pub advanced: bool,
    /// The value in a fabric.
    pub value: fn(&mut Fabric) -> &mut f64,
}

impl Parameter {
    /// What the slider shows for the SI `value`.
    pub fn shown(&self, value: f64) -> f64 {
        match self.display {
            Display::Scale { .. } => {
                let (lo, hi) = self.range;
                100.0 * (value.max(f64::MIN_POSITIVE) / lo).ln() / (hi / lo).ln()
            }
            Display::Units { factor, .. } => value * factor,
        }
    }

    /// The SI value of what the slider shows.
    pub fn from_shown(&self, shown: f64) -> f64 {
        match self.display {
            Display::Scale { .. } => {
                let (lo, hi) = self.range;
                lo * (hi / lo).powf(shown / 100.0)
            }
            Display::Units { factor, .. } => shown / factor,
        }
    }
}

const fn units(unit: &'static str) -> Display {
    Display::Units { factor: 1.0, unit }
}

/// The panel's sliders: the designer's first, then the advanced ones.
pub const PARAMETERS: [Parameter; 13] = [
    Parameter {
        label: "Weight",
        unit: "kg/m²",
        key: "area_density_kg_per_m2",
        effect: "Fabric weight (silk ~60 g/m², cotton shirting ~135, denim ~350). Heavier cloth hangs \
                 straighter and swings with more momentum.",
        range: (0.01, 1.0),
        logarithmic: true,
        display: Display::Units { factor: 1000.0, unit: "g/m²" },
        advanced: false,
        value: |f| &mut f.area_density_kg_per_m2,
    },
    Parameter {
        label: "Stretch",
        unit: "N/m",
        key: "stretch_stiffness_n_per_m",
        effect: "Resistance to stretching along the threads. Firm: the cloth keeps its length under its own \
                 weight; stretchy: it sags and elongates like a knit.",
        range: (10.0, 1e5),
        logarithmic: false,
        display: Display::Scale { low: "stretchy", high: "firm" },
        advanced: false,
        value: |f| &mut f.stretch_stiffness_n_per_m,
    },
    Parameter {
        label: "Shear",
        unit: "N/m",
        key: "shear_stiffness_n_per_m",
        effect: "Resistance to the weave skewing. Loose: the cloth drapes on the bias and wraps round curves; \
                 firm: it behaves like paper.",
        range: (0.1, 1e4),
        logarithmic: false,
        display: Display::Scale { low: "loose", high: "firm" },
        advanced: false,
        value: |f| &mut f.shear_stiffness_n_per_m,
    },
    Parameter {
        label: "Bending",
        unit: "N·m",
        key: "bend_stiffness_n_m",
        effect: "Stiffness against folding. Stiff: fewer, larger, rounder folds (denim, leather); soft: many \
                 fine folds that cling (silk, chiffon).",
        range: (1e-8, 1e-2),
        logarithmic: false,
        display: Display::Scale { low: "soft", high: "stiff" },
        advanced: false,
        value: |f| &mut f.bend_stiffness_n_m,
    },
    Parameter {
        label: "Friction",
        unit: "",
        key: "friction",
        effect: "Grip against the body, the colliders and itself (Coulomb coefficient). Higher: the cloth \
                 grips instead of sliding off.",
        range: (0.0, 2.0),
        logarithmic: false,
        display: units(""),
        advanced: false,
        value: |f| &mut f.friction,
    },
    Parameter {
        label: "Thickness",
        unit: "m",
        key: "thickness_m",
        effect: "Distance the cloth keeps from the body, the colliders and itself. Too small lets fast motion \
                 tunnel; too large floats the cloth visibly.",
        range: (5e-4, 0.02),
        logarithmic: true,
        display: Display::Units { factor: 1000.0, unit: "mm" },
        advanced: false,
        value: |f| &mut f.thickness_m,
    },
    Parameter {
        label: "Stretch damping",
        unit: "N·s/m",
        key: "stretch_damping_n_s_per_m",
        effect: "Damps stretching oscillations: higher stops the cloth bouncing on its springs.",
        range: (1e-4, 10.0),
        logarithmic: true,
        display: units("N·s/m"),
        advanced: true,
        value: |f| &mut f.stretch_damping_n_s_per_m,
    },
    Parameter {
        label: "Shear damping",
        unit: "N·s/m",
        key: "shear_damping_n_s_per_m",
        effect: "Damps shearing oscillations.",
        range: (1e-5, 1.0),
        logarithmic: true,
        display: units("N·s/m"),
        advanced: true,
        value: |f| &mut f.shear_damping_n_s_per_m,
    },
    Parameter {
        label: "Bend damping",
        unit: "N·m·s",
        key: "bend_damping_n_m_s",
        effect: "Damps folding motion: higher makes folds settle slowly, as in heavy or lined cloth.",
        range: (1e-10, 1e-4),
        logarithmic: true,
        display: units("N·m·s"),
        advanced: true,
        value: |f| &mut f.bend_damping_n_m_s,
    },
    Parameter {
        label: "Air damping",
        unit: "1/s",
        key: "air_damping_per_s",
        effect: "Fraction of velocity lost per second to the air. Higher: the cloth floats down and swings less.",
        range: (0.0, 5.0),
        logarithmic: false,
        display: units("1/s"),
        advanced: true,
        value: |f| &mut f.air_damping_per_s,
    },
    Parameter {
        label: "Compression",
        unit: "× stretch",
        key: "compression_ratio",
        effect: "Fraction of the stretch stiffness that resists in-plane compression. Low values let the cloth \
                 buckle into folds instead of shrinking.",
        range: (0.0, 1.0),
        logarithmic: false,
        display: units("× stretch"),
        advanced: true,
        value: |f| &mut f.compression_ratio,
    },
    Parameter {
        label: "Gravity",
        unit: "m/s²",
        key: "gravity_m_per_s2",
        effect: "Vertical acceleration (negative is down).",
        range: (-20.0, 0.0),
        logarithmic: false,
        display: units("m/s²"),
        advanced: true,
        value: |f| &mut f.gravity_m_per_s2[1],
    },
    Parameter {
        label: "Time step",
        unit: "s",
        key: "time_step_s",
        effect: "Longest solver step for this fabric while it moves. Shorter steps are more accurate and \
                 slower; the frame is split into as many steps as it needs, and steps lengthen up to a frame \
                 while the cloth is calm (the scene's long_step_error).",
        range: (1e-4, 0.05),
        logarithmic: true,
        display: units("s"),
        advanced: true,
        value: |f| &mut f.time_step_s,
    },
];

/// Draws the sliders of `fabric`: the designer's, the largest stretch, and
/// the advanced ones under their fold; returns the label of the one that
/// changed. A value typed outside the physical range is refused by the
/// caller's validation.
pub fn sliders(ui: &mut egui::Ui, fabric: &mut Fabric) -> Option<&'static str> {
    let mut changed = None;
    egui::Grid::new("fabric parameters").num_columns(2).striped(true).show(ui, |ui| {
        for p in PARAMETERS.iter().filter(|p| !p.advanced) {
            if slider_row(ui, p, fabric) {
                changed = Some(p.label);
            }
        }
        let label = ui.label("Max stretch").on_hover_text(STRAIN_LIMIT_EFFECT);
        if strain_limit(ui, fabric, label.id) {
            changed = Some("Max stretch");
        }
        ui.end_row();
    });
    egui::CollapsingHeader::new("Advanced").id_salt("fabric advanced").show(ui, |ui| {
        egui::Grid::new("fabric advanced parameters").num_columns(2).striped(true).show(ui, |ui| {
            for p in PARAMETERS.iter().filter(|p| p.advanced) {
                if slider_row(ui, p, fabric) {
                    changed = Some(p.label);
                }
            }
        });
    });
    changed
}

/// One grid row: the label, then the slider of parameter `p` of `fabric`
/// as its display says, the SI value and the file's key in the tooltip;
/// returns true when it changed.
fn slider_row(ui: &mut egui::Ui, p: &Parameter, fabric: &mut Fabric) -> bool {
    let value = (p.value)(fabric);
    let now = format!("Now {}{} ({} in the scene and preset files)", format_value(*value), suffix(p.unit), p.key);
    let tip = format!("{}\n\n{now}", p.effect);
    let label = ui.label(p.label).on_hover_text(&tip);
    let mut shown = p.shown(*value);
    let (lo, hi) = (p.shown(p.range.0), p.shown(p.range.1));
    let slider = egui::Slider::new(&mut shown, lo..=hi).clamping(egui::SliderClamping::Never);
    let (slider, words) = match p.display {
        Display::Scale { low, high } => (slider.custom_formatter(|v, _| format!("{v:.0}")), Some((low, high))),
        Display::Units { unit, .. } => {
            let slider = slider.logarithmic(p.logarithmic).suffix(suffix(unit));
            (slider.custom_formatter(|v, _| format_value(v)), None)
        }
    };
    let changed = ui
        .horizontal(|ui| {
            let changed = ui.add(slider).labelled_by(label.id).on_hover_text(&tip).changed();
            if let Some((low, high)) = words {
                ui.label(egui::RichText::new(format!("{low} … {high}")).small().weak());
            }
            changed
        })
        .inner;
    if changed {
        *value = p.from_shown(shown);
    }
    ui.end_row();
    changed
}

const STRAIN_LIMIT_EFFECT: &str = "Largest stretch the threads allow, enforced exactly (PAPER eq. 6): wovens \
                                   ~1-3 %, knits 10 % or more. Off: the stretch alone decides \
                                   (strain_limit in the files).";

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

/// " unit" after a number, or nothing for a unitless value.
fn suffix(unit: &str) -> String {
    if unit.is_empty() { String::new() } else { format!(" {unit}") }
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
    fn named_scales_run_logarithmically_over_the_range_and_back() {
        let stretch = &PARAMETERS[1];
        assert_eq!(stretch.label, "Stretch");
        assert!((stretch.shown(10.0) - 0.0).abs() < 1e-12 && (stretch.shown(1e5) - 100.0).abs() < 1e-12);
        assert!((stretch.shown(1000.0) - 50.0).abs() < 1e-9, "the middle of 10..1e5 N/m is 1000 N/m");
        for value in [12.0, 1500.0, 9e4] {
            assert!((stretch.from_shown(stretch.shown(value)) / value - 1.0).abs() < 1e-12);
        }
        let weight = &PARAMETERS[0];
        assert_eq!(weight.shown(0.135), 135.0, "g/m²");
    }

    #[test]
    fn values_print_with_three_significant_digits() {
        assert_eq!(format_value(2000.0), "2000");
        assert_eq!(format_value(0.135), "0.135");
        assert_eq!(format_value(1.6e-5), "1.60e-5");
        assert_eq!(format_value(0.0), "0");
    }
}
