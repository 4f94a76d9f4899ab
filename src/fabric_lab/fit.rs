//! Fitting a fabric to measurements: the flexural rigidity from the bending
//! length (`G = w c³`, which the virtual cantilever reproduces), then the
//! shear stiffness that gives the measured drape coefficient in the virtual
//! Cusick test (the bend being fixed, shear decides how easily the cloth
//! forms the doubly curved folds of a drape).

use super::cantilever::{Cantilever, cantilever_test};
use super::cusick::{Cusick, drape_test};
use super::{LabError, weight_per_area};
use crate::scene::preset::{About, Preset};
use crate::sim::fabric::Fabric;

/// Bending damping as a fraction of the rigidity, s (as the shipped presets).
const BEND_DAMPING_TIME_S: f64 = 0.01;
/// The shear stiffness is searched this factor either side of the base's.
const SHEAR_RANGE: f64 = 20.0;
/// Drape tests of the shear search after its two ends.
const SHEAR_BISECTIONS: usize = 6;
/// Elements along the cantilever's overhang.
pub const CANTILEVER_SEGMENTS: usize = 32;

/// What a fabric kit measured on a real fabric.
#[derive(Clone, Debug, PartialEq)]
pub struct Measured {
    /// Cantilever bending length (ASTM D1388), cm.
    pub bending_length_cm: f64,
    /// Area density, g/m².
    pub area_density_gsm: f64,
    /// Cusick drape coefficient, unitless, if measured.
    pub drape_coefficient: Option<f64>,
}

/// A fitted preset with the virtual tests that confirm it.
#[derive(Clone, Debug)]
pub struct Fitted {
    /// The preset.
    pub preset: Preset,
    /// The cantilever test of the fitted fabric.
    pub cantilever: Cantilever,
    /// The drape test of the fitted fabric, when a drape coefficient was fitted.
    pub cusick: Option<Cusick>,
}

impl Measured {
    /// Checks each value's range.
    pub fn validate(&self) -> Result<(), LabError> {
        let check = |what, value: f64, ok: bool, expected| {
            if value.is_finite() && ok { Ok(()) } else { Err(LabError::Target { what, value, expected }) }
        };
        let c = self.bending_length_cm;
        check("bending length (cm)", c, (0.2..=30.0).contains(&c), "0.2 to 30 cm")?;
        let gsm = self.area_density_gsm;
        check("area density (g/m²)", gsm, (5.0..=3000.0).contains(&gsm), "5 to 3000 g/m²")?;
        if let Some(dc) = self.drape_coefficient {
            check("drape coefficient", dc, dc > 0.0 && dc < 1.0, "between 0 and 1, exclusive")?;
        }
        Ok(())
    }
}

/// Fits `base`'s fabric to `measured` and names the result `name`; the drape
/// tests use specimens of `across` vertices across. `log` hears each test as it runs.
pub fn fit(
    base: &Preset,
    name: &str,
    measured: &Measured,
    across: usize,
    log: impl Fn(&str),
) -> Result<Fitted, LabError> {
    measured.validate()?;
    let mut fabric = Fabric {
        area_density_kg_per_m2: measured.area_density_gsm / 1000.0,
        vertex_mass_kg: None,
        ..base.fabric.clone()
    };
    let c = measured.bending_length_cm / 100.0;
    let rigidity = weight_per_area(&fabric)? * c * c * c;
    fabric.bend_stiffness_n_m = rigidity;
    fabric.bend_damping_n_m_s = rigidity * BEND_DAMPING_TIME_S;
    let cusick = match measured.drape_coefficient {
        Some(target) => {
            let (shear, test) = fit_shear(&fabric, target, across, &log)?;
            // Shear damping keeps its ratio to the stiffness (the base's own
            // damping when the base has no shear stiffness to scale from).
            let base_shear = base.fabric.shear_stiffness_n_per_m;
            if base_shear > 0.0 {
                fabric.shear_damping_n_s_per_m *= shear / base_shear;
            }
            fabric.shear_stiffness_n_per_m = shear;
            Some(test)
        }
        None => None,
    };
    log("cantilever test of the fitted fabric ...");
    let cantilever = cantilever_test(&fabric, CANTILEVER_SEGMENTS)?;
    let preset = Preset {
        name: name.to_owned(),
        about: about(base, measured, &cantilever, cusick.as_ref()),
        fabric,
        appearance: base.appearance.clone(),
    };
    Ok(Fitted { preset, cantilever, cusick })
}

/// The shear stiffness (N/m) whose drape test comes closest to `target`, by
/// bisection on its logarithm, with that test.
fn fit_shear(fabric: &Fabric, target: f64, across: usize, log: &impl Fn(&str)) -> Result<(f64, Cusick), LabError> {
    let base = fabric.shear_stiffness_n_per_m.max(1.0);
    let run = |shear: f64| -> Result<Cusick, LabError> {
        let test = drape_test(&Fabric { shear_stiffness_n_per_m: shear, ..fabric.clone() }, across)?;
        log(&format!("drape test, shear {shear:.3} N/m: drape coefficient {:.3}", test.drape_coefficient));
        Ok(test)
    };
    let (mut lo, mut hi) = (base / SHEAR_RANGE, base * SHEAR_RANGE);
    let (at_lo, at_hi) = (run(lo)?, run(hi)?);
    let reachable =
        at_lo.drape_coefficient.min(at_hi.drape_coefficient)..=at_lo.drape_coefficient.max(at_hi.drape_coefficient);
    if !reachable.contains(&target) {
        return Err(LabError::Unreachable(format!(
            "drape coefficient {target} is out of reach for this bending length and area density: shear stiffness \
             from {lo:.3} to {hi:.3} N/m gives {:.3} to {:.3}; check the measurements, or fit the bending length alone",
            reachable.start(),
            reachable.end()
        )));
    }
    let increasing = at_hi.drape_coefficient >= at_lo.drape_coefficient;
    let mut best = if (at_lo.drape_coefficient - target).abs() < (at_hi.drape_coefficient - target).abs() {
        (lo, at_lo)
    } else {
        (hi, at_hi)
    };
    for _ in 0..SHEAR_BISECTIONS {
        let mid = (lo * hi).sqrt();
        let test = run(mid)?;
        if (test.drape_coefficient < target) == increasing {
            lo = mid;
        } else {
            hi = mid;
        }
        if (test.drape_coefficient - target).abs() < (best.1.drape_coefficient - target).abs() {
            best = (mid, test);
        }
    }
    Ok(best)
}

/// Provenance of a fitted preset.
fn about(base: &Preset, measured: &Measured, cantilever: &Cantilever, cusick: Option<&Cusick>) -> About {
    let mut sources = vec![
        format!(
            "Fitted by `drape fabric fit` from {} (base preset) to a measured bending length of {} cm (ASTM D1388) at {} g/m².",
            base.name, measured.bending_length_cm, measured.area_density_gsm
        ),
        format!(
            "Virtual cantilever of the result: bending length {:.3} cm, flexural rigidity {:.4e} N·m.",
            cantilever.bending_length_m * 100.0,
            cantilever.flexural_rigidity_n_m
        ),
    ];
    if let (Some(target), Some(test)) = (measured.drape_coefficient, cusick) {
        sources.push(format!(
            "Shear stiffness fitted to a measured drape coefficient of {target} (Cusick): the virtual test gives {:.3}, {} nodes.",
            test.drape_coefficient, test.nodes
        ));
    }
    About {
        feel: format!("Fitted to measurements, starting from {}: {}", base.name, base.about.feel),
        sources,
        target_bending_length_cm: Some(measured.bending_length_cm),
        target_drape_coefficient: measured.drape_coefficient,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fitting_a_bending_length_sets_the_rigidity_the_cantilever_measures() {
        let base = Preset::builtin("cotton").unwrap();
        let measured = Measured { bending_length_cm: 3.0, area_density_gsm: 200.0, drape_coefficient: None };
        let fitted = fit(&base, "mine", &measured, 21, |_| ()).unwrap();
        let fabric = &fitted.preset.fabric;
        assert_eq!(fabric.area_density_kg_per_m2, 0.2);
        assert!((fabric.bend_stiffness_n_m / (0.2 * 9.81 * 0.03f64.powi(3)) - 1.0).abs() < 1e-12);
        assert!((fitted.cantilever.bending_length_m / 0.03 - 1.0).abs() < 0.05, "{:?}", fitted.cantilever);
        assert_eq!(fitted.preset.about.target_bending_length_cm, Some(3.0));
        // The written preset loads back as it was.
        let again = Preset::parse(&fitted.preset.to_toml(), "fitted", &toml::Table::new()).unwrap();
        assert_eq!(again, fitted.preset);
    }

    #[test]
    fn measurements_out_of_range_are_refused_with_their_unit() {
        let base = Preset::builtin("cotton").unwrap();
        for (c, gsm, dc) in [(f64::NAN, 100.0, None), (2.0, -5.0, None), (2.0, 100.0, Some(1.5))] {
            let measured = Measured { bending_length_cm: c, area_density_gsm: gsm, drape_coefficient: dc };
            let e = fit(&base, "x", &measured, 21, |_| ()).unwrap_err().to_string();
            assert!(e.contains("out of range"), "{e}");
        }
    }
}
