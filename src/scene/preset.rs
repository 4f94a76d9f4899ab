//! Fabric presets: a [`Fabric`] with its provenance and appearance, one TOML
//! file each. The shipped presets (`presets/*.toml`) are built into the binary,
//! so scenes can name them from anywhere; a scene may also give a path.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::sim::fabric::{Fabric, FabricError};

/// The shipped presets: name and file text.
const BUILT_IN: [(&str, &str); 8] = [
    ("cotton", include_str!("../../presets/cotton.toml")),
    ("silk", include_str!("../../presets/silk.toml")),
    ("denim", include_str!("../../presets/denim.toml")),
    ("wool", include_str!("../../presets/wool.toml")),
    ("chiffon", include_str!("../../presets/chiffon.toml")),
    ("jersey", include_str!("../../presets/jersey.toml")),
    ("leather", include_str!("../../presets/leather.toml")),
    ("polyester", include_str!("../../presets/polyester.toml")),
];

/// A fabric preset as stored in a file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Preset {
    /// Short name, e.g. `cotton`.
    pub name: String,
    /// What it is meant to feel like and where its numbers come from.
    #[serde(default)]
    pub about: About,
    /// The mechanical parameters.
    pub fabric: Fabric,
    /// How it looks.
    #[serde(default)]
    pub appearance: Appearance,
}

/// Provenance of a preset.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct About {
    /// The intended hand and drape, in a sentence.
    #[serde(default)]
    pub feel: String,
    /// Where each number comes from.
    #[serde(default)]
    pub sources: Vec<String>,
    /// Cantilever bending length (ASTM D1388) the preset is tuned to, cm.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub target_bending_length_cm: Option<f64>,
    /// Cusick drape coefficient the preset is tuned to, unitless (0..1).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub target_drape_coefficient: Option<f64>,
}

/// Surface appearance for rendering and material export.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Appearance {
    /// Base colour, linear RGB in 0..1.
    pub base_color: [f32; 3],
    /// Perceptual roughness of the specular lobe, 0..1.
    pub roughness: f32,
    /// Sheen (fibre rim light) colour, linear RGB in 0..1.
    pub sheen_color: [f32; 3],
    /// Sheen roughness, 0..1.
    pub sheen_roughness: f32,
    /// Colour of the back side, linear RGB in 0..1 (default: the base colour).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub back_color: Option<[f32; 3]>,
}

impl Appearance {
    /// Checks every colour channel and roughness is within 0..1.
    fn validate(&self) -> Result<(), String> {
        let colors = [
            ("base_color", Some(self.base_color)),
            ("sheen_color", Some(self.sheen_color)),
            ("back_color", self.back_color),
        ];
        for (key, rgb) in colors {
            if let Some(rgb) = rgb.filter(|c| !c.iter().all(|v| (0.0..=1.0).contains(v))) {
                return Err(format!("{key} = {rgb:?}: each channel must be in 0..1 (linear RGB)"));
            }
        }
        for (key, value) in [("roughness", self.roughness), ("sheen_roughness", self.sheen_roughness)] {
            if !(0.0..=1.0).contains(&value) {
                return Err(format!("{key} = {value}: must be in 0..1"));
            }
        }
        Ok(())
    }
}

impl Default for Appearance {
    fn default() -> Self {
        Appearance {
            base_color: [0.7, 0.7, 0.7],
            roughness: 0.8,
            sheen_color: [0.8; 3],
            sheen_roughness: 0.5,
            back_color: None,
        }
    }
}

/// Why a preset could not be used.
#[derive(Debug, thiserror::Error)]
pub enum PresetError {
    /// Neither a built-in name nor a file path.
    #[error("unknown preset '{name}': the built-in presets are {builtin}; or give the path of a .toml preset file")]
    Unknown {
        /// The name asked for.
        name: String,
        /// The built-in names, comma-separated.
        builtin: String,
    },
    /// The file could not be read.
    #[error("cannot read preset file {path}: {source}")]
    Read {
        /// File path.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The file is not a valid preset.
    #[error("preset {origin}: {message}")]
    Parse {
        /// File path or built-in name.
        origin: String,
        /// What is wrong, with line and column.
        message: String,
    },
    /// An `[appearance]` value is out of range.
    #[error("preset {origin}: appearance: {problem}")]
    Appearance {
        /// File path or built-in name.
        origin: String,
        /// The value and its allowed range.
        problem: String,
    },
    /// A parameter is out of range.
    #[error("preset {origin}: {source}")]
    Invalid {
        /// File path or built-in name.
        origin: String,
        /// The offending parameter.
        source: FabricError,
    },
}

impl Preset {
    /// Names of the built-in presets.
    pub fn builtin_names() -> impl Iterator<Item = &'static str> {
        BUILT_IN.iter().map(|(name, _)| *name)
    }

    /// A built-in preset by name.
    pub fn builtin(name: &str) -> Result<Preset, PresetError> {
        Self::resolve(name, Path::new(""), &toml::Table::new())
    }

    /// Resolves a scene's `preset = "..."`: a built-in name, or a path (relative
    /// to `base_dir`) when it ends in `.toml` or contains a path separator.
    /// `overrides` replace individual `[fabric]` values.
    pub fn resolve(reference: &str, base_dir: &Path, overrides: &toml::Table) -> Result<Preset, PresetError> {
        let is_path = reference.ends_with(".toml") || reference.contains('/') || reference.contains('\\');
        if is_path {
            let path = base_dir.join(reference);
            let text =
                std::fs::read_to_string(&path).map_err(|source| PresetError::Read { path: path.clone(), source })?;
            return Preset::parse(&text, &path.display().to_string(), overrides);
        }
        let (_, text) = BUILT_IN.iter().find(|(n, _)| *n == reference).ok_or_else(|| PresetError::Unknown {
            name: reference.to_owned(),
            builtin: Self::builtin_names().collect::<Vec<_>>().join(", "),
        })?;
        Preset::parse(text, &format!("'{reference}' (built in)"), overrides)
    }

    /// Parses preset text, applies `overrides` to its `[fabric]` table, validates.
    pub fn parse(text: &str, origin: &str, overrides: &toml::Table) -> Result<Preset, PresetError> {
        let parse_error = |message: String| PresetError::Parse { origin: origin.to_owned(), message };
        let mut table: toml::Table = toml::from_str(text).map_err(|e| parse_error(e.to_string()))?;
        if let Some(toml::Value::Table(fabric)) = table.get_mut("fabric") {
            for (key, value) in overrides {
                fabric.insert(key.clone(), value.clone());
            }
        }
        let preset: Preset = table.try_into().map_err(|e: toml::de::Error| parse_error(e.to_string()))?;
        preset.fabric.validate().map_err(|source| PresetError::Invalid { origin: origin.to_owned(), source })?;
        preset
            .appearance
            .validate()
            .map_err(|problem| PresetError::Appearance { origin: origin.to_owned(), problem })?;
        Ok(preset)
    }

    /// The preset as TOML text (provenance, fabric, appearance).
    pub fn to_toml(&self) -> String {
        toml::to_string_pretty(self).unwrap_or_default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_builtin_preset_loads_validates_and_documents_itself() {
        for name in Preset::builtin_names() {
            let preset = Preset::builtin(name).unwrap_or_else(|e| panic!("{e}"));
            assert_eq!(preset.name, name);
            assert!(!preset.about.feel.is_empty() && preset.about.sources.len() >= 2, "{name}");
            // Flexural rigidity follows the Peirce relation G = w c³ from the target.
            let c = preset.about.target_bending_length_cm.unwrap() / 100.0;
            let w = preset.fabric.area_density_kg_per_m2 * 9.81;
            assert!((preset.fabric.bend_stiffness_n_m / (w * c * c * c) - 1.0).abs() < 1e-3, "{name}");
        }
    }

    #[test]
    fn appearance_values_out_of_range_name_the_key() {
        let text =
            BUILT_IN.iter().find(|(n, _)| *n == "silk").unwrap().1.replace("roughness = 0.45", "roughness = 1.5");
        let e = Preset::parse(&text, "mine.toml", &toml::Table::new()).unwrap_err().to_string();
        assert!(e.contains("mine.toml") && e.contains("roughness = 1.5") && e.contains("0..1"), "{e}");
    }

    #[test]
    fn presets_round_trip_through_toml() {
        let preset = Preset::builtin("denim").unwrap();
        let again = Preset::parse(&preset.to_toml(), "round trip", &toml::Table::new()).unwrap();
        assert_eq!(again, preset);
    }

    #[test]
    fn overrides_replace_single_values_and_are_validated() {
        let mut overrides = toml::Table::new();
        overrides.insert("stretch_stiffness_n_per_m".into(), toml::Value::Float(150_000.0));
        let stiff = Preset::resolve("cotton", Path::new("."), &overrides).unwrap();
        assert_eq!(stiff.fabric.stretch_stiffness_n_per_m, 150_000.0);
        assert_eq!(stiff.fabric.area_density_kg_per_m2, 0.135);

        overrides.insert("friction".into(), toml::Value::Float(-1.0));
        let err = Preset::resolve("cotton", Path::new("."), &overrides).unwrap_err();
        assert!(err.to_string().contains("friction = -1"), "{err}");

        let mut typo = toml::Table::new();
        typo.insert("stretch_stifness".into(), toml::Value::Float(1.0));
        let err = Preset::resolve("cotton", Path::new("."), &typo).unwrap_err();
        assert!(err.to_string().contains("unknown field `stretch_stifness`"), "{err}");
    }

    #[test]
    fn unknown_names_list_the_builtin_ones() {
        let err = Preset::builtin("velvet").unwrap_err().to_string();
        assert!(err.contains("unknown preset 'velvet'") && err.contains("cotton, silk"), "{err}");
    }
}
