//! The fabric parameter set: the paper's Table 1 in SI units, plus area density,
//! friction and collision thickness.
//!
//! Stiffnesses are material properties, independent of the mesh: stretch and
//! shear are stated for a unit square of cloth (N/m: the force per metre of
//! width that one unit of strain produces), bending as flexural rigidity (N·m,
//! the bending moment per metre of width per unit curvature, the quantity the
//! cantilever test of ASTM D1388 measures). The solver scales each spring and
//! bending element by its rest geometry.

use serde::{Deserialize, Serialize};

/// Mechanical parameters of one fabric, SI units.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Fabric {
    /// Mass per area, kg/m². Vertex masses follow from it by area (lumped).
    pub area_density_kg_per_m2: f64,
    /// Optional mass of every vertex, kg (the paper's `VertexMass`); when set it
    /// overrides the area density.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub vertex_mass_kg: Option<f64>,
    /// Stretch (structural) stiffness of a unit square, N/m (`StructCoef`).
    pub stretch_stiffness_n_per_m: f64,
    /// Stretch damping of a unit square, N·s/m (`StructDamp`).
    pub stretch_damping_n_s_per_m: f64,
    /// Fraction of the stretch stiffness with which the cloth resists being
    /// shortened in its own plane, unitless (0..1). Fabric buckles into folds
    /// long before it compresses, so this is small for wovens and knits.
    pub compression_ratio: f64,
    /// In-plane shear stiffness of a unit square, N/m (`ShearCoef`).
    pub shear_stiffness_n_per_m: f64,
    /// Shear damping of a unit square, N·s/m (`ShearDamp`).
    pub shear_damping_n_s_per_m: f64,
    /// Flexural rigidity, N·m (`BendCoef`); cotton shirting is ~1e-5.
    pub bend_stiffness_n_m: f64,
    /// Bending damping, N·m·s (`BendDamp`).
    pub bend_damping_n_m_s: f64,
    /// Global (air) damping: fraction of velocity removed per second, 1/s (`Damper`).
    pub air_damping_per_s: f64,
    /// Gravitational acceleration, m/s² (`Gravity`).
    pub gravity_m_per_s2: [f64; 3],
    /// Largest simulation step this fabric is tuned for while it moves, s
    /// (`SimulationDeltT`); steps lengthen past it while the cloth is calm
    /// ([`super::adaptive`]).
    pub time_step_s: f64,
    /// Coulomb friction coefficient against colliders and itself, unitless.
    pub friction: f64,
    /// Collision thickness: the distance kept from colliders, m.
    pub thickness_m: f64,
    /// Largest stretch the cloth's structural edges may reach, as a strain
    /// (unitless: 0.01 = 1 %), enforced as inextensibility constraints
    /// (PAPER eq. 6). Real wovens stretch ~1-3 % under everyday loads, knits
    /// ~10 % or more. Absent: no constraint, the stretch springs alone.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub strain_limit: Option<f64>,
}

/// A parameter outside its physical range.
#[derive(Debug, thiserror::Error, PartialEq)]
#[error("{field} = {value} is out of range: {expected}")]
pub struct FabricError {
    /// Parameter name as written in files.
    pub field: &'static str,
    /// The value given.
    pub value: f64,
    /// The accepted range with its unit.
    pub expected: &'static str,
}

impl Fabric {
    /// Checks every parameter against its physical range.
    pub fn validate(&self) -> Result<(), FabricError> {
        let check = |field, value: f64, ok: bool, expected| {
            if value.is_finite() && ok { Ok(()) } else { Err(FabricError { field, value, expected }) }
        };
        let d = self.area_density_kg_per_m2;
        check("area_density_kg_per_m2", d, d > 0.0 && d <= 20.0, "0 < value ≤ 20 kg/m²")?;
        if let Some(m) = self.vertex_mass_kg {
            check("vertex_mass_kg", m, m > 0.0, "a positive mass in kg")?;
        }
        let non_negative = [
            ("stretch_stiffness_n_per_m", self.stretch_stiffness_n_per_m, "≥ 0 N/m"),
            ("stretch_damping_n_s_per_m", self.stretch_damping_n_s_per_m, "≥ 0 N·s/m"),
            ("shear_stiffness_n_per_m", self.shear_stiffness_n_per_m, "≥ 0 N/m"),
            ("shear_damping_n_s_per_m", self.shear_damping_n_s_per_m, "≥ 0 N·s/m"),
            ("bend_stiffness_n_m", self.bend_stiffness_n_m, "≥ 0 N·m"),
            ("bend_damping_n_m_s", self.bend_damping_n_m_s, "≥ 0 N·m·s"),
            ("air_damping_per_s", self.air_damping_per_s, "≥ 0 1/s"),
        ];
        for (field, value, expected) in non_negative {
            check(field, value, value >= 0.0, expected)?;
        }
        let c = self.compression_ratio;
        check("compression_ratio", c, (0.0..=1.0).contains(&c), "0 ≤ value ≤ 1")?;
        for g in self.gravity_m_per_s2 {
            check("gravity_m_per_s2", g, g.abs() <= 1000.0, "components within ±1000 m/s²")?;
        }
        let dt = self.time_step_s;
        check("time_step_s", dt, dt > 0.0 && dt <= 0.1, "0 < value ≤ 0.1 s")?;
        check("friction", self.friction, (0.0..=10.0).contains(&self.friction), "0 ≤ value ≤ 10")?;
        let h = self.thickness_m;
        check("thickness_m", h, h > 0.0 && h <= 0.05, "0 < value ≤ 0.05 m")?;
        if let Some(limit) = self.strain_limit {
            check("strain_limit", limit, (0.0..=1.0).contains(&limit), "0 ≤ value ≤ 1 (a strain: 0.01 = 1 %)")?;
        }
        Ok(())
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A plain cotton-like fabric for unit tests.
    pub(crate) fn cotton() -> Fabric {
        Fabric {
            area_density_kg_per_m2: 0.135,
            vertex_mass_kg: None,
            stretch_stiffness_n_per_m: 2000.0,
            stretch_damping_n_s_per_m: 0.04,
            compression_ratio: 0.1,
            shear_stiffness_n_per_m: 60.0,
            shear_damping_n_s_per_m: 0.004,
            bend_stiffness_n_m: 1.6e-5,
            bend_damping_n_m_s: 3e-7,
            air_damping_per_s: 0.2,
            gravity_m_per_s2: [0.0, -9.81, 0.0],
            time_step_s: 1.0 / 60.0,
            friction: 0.4,
            thickness_m: 0.0025,
            strain_limit: Some(0.01),
        }
    }

    #[test]
    fn cotton_is_valid() {
        assert_eq!(cotton().validate(), Ok(()));
    }

    #[test]
    fn negative_nan_and_zero_values_are_refused_by_name() {
        let mut f = cotton();
        f.vertex_mass_kg = Some(-1.0);
        assert_eq!(f.validate().unwrap_err().field, "vertex_mass_kg");
        let mut f = cotton();
        f.stretch_stiffness_n_per_m = f64::NAN;
        let err = f.validate().unwrap_err();
        assert_eq!(err.field, "stretch_stiffness_n_per_m");
        assert!(err.to_string().contains("N/m"), "{err}");
        let mut f = cotton();
        f.time_step_s = 0.0;
        assert_eq!(f.validate().unwrap_err().field, "time_step_s");
        let mut f = cotton();
        f.thickness_m = -0.001;
        assert_eq!(f.validate().unwrap_err().field, "thickness_m");
        let mut f = cotton();
        f.strain_limit = Some(-0.01);
        assert_eq!(f.validate().unwrap_err().field, "strain_limit");
    }
}
