//! Light rigs: a few directional lights and a sky/ground ambient, in lux, with
//! the camera exposure that suits them (EV100). Rigs are TOML files
//! (`presets/lights/*.toml`, the shipped ones built in) and can be switched at
//! any frame. Light directions are given relative to the camera, so a rig looks
//! the same from any orbit; a rig may also turn about the vertical axis
//! (turntable lighting).

use std::path::{Path, PathBuf};

use glam::Vec3;
use serde::Deserialize;

/// Most lights a rig may have (the shader's fixed array).
pub const MAX_LIGHTS: usize = 4;

/// The rigs shipped with drape: name and TOML text.
const BUILT_IN: [(&str, &str); 4] = [
    ("studio", include_str!("../../presets/lights/studio.toml")),
    ("daylight", include_str!("../../presets/lights/daylight.toml")),
    ("overcast", include_str!("../../presets/lights/overcast.toml")),
    ("evening", include_str!("../../presets/lights/evening.toml")),
];

/// A lighting set-up.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LightRig {
    /// Short name (`--light NAME`).
    pub name: String,
    /// What it looks like, in a sentence.
    #[serde(default)]
    pub description: String,
    /// Camera exposure, EV at ISO 100: the image scale is 1 / (1.2 · 2^EV100).
    pub exposure_ev100: f32,
    /// Colour behind the scene, display-linear RGB in 0..1 (not exposed).
    pub background: [f32; 3],
    /// Light from the sky and the ground, not shadowed.
    pub ambient: Ambient,
    /// Directional lights, at most [`MAX_LIGHTS`].
    #[serde(rename = "light")]
    pub lights: Vec<Light>,
    /// When positive, the lights turn once about the vertical axis in this
    /// period, s.
    #[serde(default)]
    pub turntable_period_s: f32,
}

/// Hemispherical ambient light: the sky above, light bounced off the ground below.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Ambient {
    /// Illuminance on an upward-facing surface from the sky, lux.
    pub sky_illuminance_lux: f32,
    /// Sky colour, linear RGB in 0..1.
    pub sky_color: [f32; 3],
    /// Illuminance on a downward-facing surface from the ground, lux.
    pub ground_illuminance_lux: f32,
    /// Ground colour, linear RGB in 0..1.
    pub ground_color: [f32; 3],
}

/// A directional light.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Light {
    /// Name, for reports.
    pub name: String,
    /// Direction about the vertical axis relative to the camera: 0 from behind
    /// the camera, +90 from its right, ±180 from behind the subject, degrees.
    pub azimuth_deg: f32,
    /// Height above the horizon, degrees.
    pub elevation_deg: f32,
    /// Illuminance on a surface facing the light, lux.
    pub illuminance_lux: f32,
    /// Colour, linear RGB in 0..1.
    pub color: [f32; 3],
    /// Whether it casts shadows (at most one light per rig).
    #[serde(default)]
    pub shadow: bool,
    /// Apparent angular radius of the source, which sets the width of its
    /// shadows' penumbra, degrees.
    #[serde(default)]
    pub softness_deg: f32,
}

/// A light placed in the world for one frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlacedLight {
    /// Unit vector from the scene towards the light, world space.
    pub towards_light: Vec3,
    /// Colour times illuminance, lux.
    pub illuminance: Vec3,
    /// Whether it casts the shadow map.
    pub shadow: bool,
    /// Angular radius of the source, radians.
    pub softness_rad: f32,
}

/// Why a rig could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum LightRigError {
    /// The file could not be read.
    #[error("cannot read light rig {path}: {source}")]
    Read {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// The TOML is malformed or has unknown keys.
    #[error("light rig {origin}: {problem}")]
    Parse {
        /// The file or built-in name.
        origin: String,
        /// What is wrong, with the line.
        problem: String,
    },
    /// A value is out of range.
    #[error("light rig {origin}: {problem}")]
    Invalid {
        /// The file or built-in name.
        origin: String,
        /// What is wrong, with the allowed range and unit.
        problem: String,
    },
    /// Neither a file nor a built-in rig.
    #[error("no light rig '{name}': give a TOML file or one of {}", built_in_names().join(", "))]
    Unknown {
        /// What was asked for.
        name: String,
    },
}

/// Names of the built-in rigs.
pub fn built_in_names() -> Vec<&'static str> {
    BUILT_IN.iter().map(|(name, _)| *name).collect()
}

impl LightRig {
    /// A built-in rig by name, or a rig file when `name_or_path` is a path to one.
    pub fn find(name_or_path: &str) -> Result<LightRig, LightRigError> {
        if let Some((name, text)) = BUILT_IN.iter().find(|(name, _)| *name == name_or_path) {
            return LightRig::parse(text, name);
        }
        let path = Path::new(name_or_path);
        if path.extension().is_some_and(|e| e == "toml") || path.exists() {
            return LightRig::load(path);
        }
        Err(LightRigError::Unknown { name: name_or_path.to_owned() })
    }

    /// Every built-in rig, in the order of [`built_in_names`].
    pub fn built_in() -> Vec<LightRig> {
        BUILT_IN.iter().filter_map(|(name, text)| LightRig::parse(text, name).ok()).collect()
    }

    /// Reads a rig file.
    pub fn load(path: &Path) -> Result<LightRig, LightRigError> {
        let text = std::fs::read_to_string(path).map_err(|source| LightRigError::Read { path: path.into(), source })?;
        LightRig::parse(&text, &path.display().to_string())
    }

    /// Parses and validates rig TOML; `origin` names it in errors.
    pub fn parse(text: &str, origin: &str) -> Result<LightRig, LightRigError> {
        let rig: LightRig = toml::from_str(text)
            .map_err(|e| LightRigError::Parse { origin: origin.to_owned(), problem: e.to_string() })?;
        rig.validate().map_err(|problem| LightRigError::Invalid { origin: origin.to_owned(), problem })?;
        Ok(rig)
    }

    fn validate(&self) -> Result<(), String> {
        check(self.exposure_ev100, -6.0, 24.0, "exposure_ev100", "EV")?;
        check(self.turntable_period_s, 0.0, 1e6, "turntable_period_s", "s")?;
        color(&self.background, "background")?;
        let a = &self.ambient;
        check(a.sky_illuminance_lux, 0.0, 2e5, "ambient.sky_illuminance_lux", "lux")?;
        check(a.ground_illuminance_lux, 0.0, 2e5, "ambient.ground_illuminance_lux", "lux")?;
        color(&a.sky_color, "ambient.sky_color")?;
        color(&a.ground_color, "ambient.ground_color")?;
        if self.lights.len() > MAX_LIGHTS {
            return Err(format!("{} lights, at most {MAX_LIGHTS} are supported", self.lights.len()));
        }
        if self.lights.iter().filter(|l| l.shadow).count() > 1 {
            return Err("more than one light has shadow = true; only one light casts shadows".into());
        }
        for l in &self.lights {
            let key = |k: &str| format!("light '{}': {k}", l.name);
            check(l.azimuth_deg, -360.0, 360.0, &key("azimuth_deg"), "degrees")?;
            check(l.elevation_deg, -90.0, 90.0, &key("elevation_deg"), "degrees")?;
            check(l.illuminance_lux, 0.0, 2e5, &key("illuminance_lux"), "lux")?;
            check(l.softness_deg, 0.0, 30.0, &key("softness_deg"), "degrees")?;
            color(&l.color, &key("color"))?;
        }
        Ok(())
    }

    /// The camera exposure: scene luminance (cd/m²) to the tone mapper's input.
    pub fn exposure(&self) -> f32 {
        1.0 / (1.2 * 2f32.powf(self.exposure_ev100))
    }

    /// The lights in world space at time `t_s` for a camera at `camera_yaw_deg`.
    pub fn placed(&self, camera_yaw_deg: f32, t_s: f32) -> Vec<PlacedLight> {
        let turn = match self.turntable_period_s {
            p if p > 0.0 => 360.0 * (t_s / p).fract(),
            _ => 0.0,
        };
        self.lights
            .iter()
            .map(|l| {
                let (azimuth, elevation) =
                    ((camera_yaw_deg + l.azimuth_deg + turn).to_radians(), l.elevation_deg.to_radians());
                PlacedLight {
                    towards_light: Vec3::new(
                        elevation.cos() * azimuth.sin(),
                        elevation.sin(),
                        elevation.cos() * azimuth.cos(),
                    ),
                    illuminance: Vec3::from(l.color) * l.illuminance_lux,
                    shadow: l.shadow,
                    softness_rad: l.softness_deg.to_radians(),
                }
            })
            .collect()
    }
}

fn check(value: f32, low: f32, high: f32, key: &str, unit: &str) -> Result<(), String> {
    match value.is_finite() && (low..=high).contains(&value) {
        true => Ok(()),
        false => Err(format!("{key} = {value} is outside {low}..{high} {unit}")),
    }
}

fn color(rgb: &[f32; 3], key: &str) -> Result<(), String> {
    match rgb.iter().all(|c| c.is_finite() && (0.0..=1.0).contains(c)) {
        true => Ok(()),
        false => Err(format!("{key} = {rgb:?}: each channel must be in 0..1 (linear RGB)")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_built_in_rig_parses_and_is_named_after_its_file() {
        let rigs = LightRig::built_in();
        assert_eq!(rigs.len(), BUILT_IN.len());
        for (rig, name) in rigs.iter().zip(built_in_names()) {
            assert_eq!(rig.name, name);
            assert_eq!(rig.lights.iter().filter(|l| l.shadow).count(), 1, "{name} needs a shadow light");
        }
    }

    #[test]
    fn exposure_follows_ev100() {
        let rig = LightRig::find("daylight").unwrap();
        // Sunny 16: EV100 15 maps 100 000 lux on white paper (≈ 25 000 cd/m²) near mid-range.
        let luminance = 100_000.0 * 0.8 / std::f32::consts::PI;
        assert!((0.4..1.0).contains(&(luminance * rig.exposure())));
    }

    #[test]
    fn azimuth_is_relative_to_the_camera_and_the_turntable_turns_it() {
        let mut rig = LightRig::find("studio").unwrap();
        rig.lights[0].azimuth_deg = 90.0;
        rig.lights[0].elevation_deg = 0.0;
        let right_of_camera_at_yaw_0 = rig.placed(0.0, 0.0)[0].towards_light;
        assert!((right_of_camera_at_yaw_0 - Vec3::X).length() < 1e-6);
        rig.turntable_period_s = 4.0;
        let quarter_turn = rig.placed(0.0, 1.0)[0].towards_light;
        assert!((quarter_turn - Vec3::NEG_Z).length() < 1e-5, "{quarter_turn}");
    }

    #[test]
    fn bad_values_and_unknown_names_are_clear_errors() {
        let text = BUILT_IN[0].1.replace("illuminance_lux = 2000", "illuminance_lux = -5");
        let e = LightRig::parse(&text, "mine.toml").unwrap_err().to_string();
        assert!(e.contains("mine.toml") && e.contains("illuminance_lux = -5") && e.contains("lux"), "{e}");
        let e = LightRig::find("disco").unwrap_err().to_string();
        assert!(e.contains("disco") && e.contains("studio"), "{e}");
        let e = LightRig::parse("name = 3", "x.toml").unwrap_err().to_string();
        assert!(e.contains("x.toml"), "{e}");
    }
}
