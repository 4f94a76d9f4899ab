//! Sweep files: a base scene and the values to vary, read into the list of
//! variants they name.
//!
//! ```toml
//! base = "../scenes/small_drape.toml"     # relative to the sweep file
//! frames = 10                             # optional: bake only the first frames
//! reference = true                        # optional: each variant's error against its 16× reference
//! mode = "product"                        # every combination of the axes (default), or "list"
//!
//! [[axis]]
//! key = "garment.0.preset"                # any scene value, by its dotted key
//! values = ["cotton", "silk", "denim"]
//!
//! [[axis]]
//! key = "garment.0.fabric.friction"
//! values = [0.2, 0.6]
//!
//! [slurm]                                 # resources of one task
//! cpus_per_task = 2
//! mem = "2G"
//! time = "00:30:00"
//! ```
//!
//! With `mode = "list"`, `[[variant]]` tables name each variant's values
//! instead: `set = { "garment.0.preset" = "silk", "solver.steps_per_frame" = 4 }`.
//! A value that is a file (`garment.0.mesh.obj`, `body.0.file`) is relative
//! to the base scene, as in the scene file itself.

use std::path::{Path, PathBuf};

use serde::Deserialize;

use super::FarmError;

/// How the axes make variants.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Mode {
    /// Every combination of the axes' values, the last axis varying fastest.
    #[default]
    Product,
    /// The `[[variant]]` tables, in order.
    List,
}

/// One varied value: a dotted scene key and its values.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Axis {
    /// Dotted key into the scene file, e.g. `garment.0.fabric.friction`.
    pub key: String,
    /// The values it takes.
    pub values: Vec<toml::Value>,
}

/// One variant of a list sweep.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ListedVariant {
    /// Dotted scene keys and their values.
    pub set: toml::Table,
}

/// Resources one farm task asks the scheduler for.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SlurmResources {
    /// Cores per task (the solver's threads).
    #[serde(default = "default_cpus")]
    pub cpus_per_task: u32,
    /// Memory per task, Slurm's syntax (e.g. `2G`), if asked.
    pub mem: Option<String>,
    /// Time limit per task, Slurm's syntax (e.g. `00:30:00`), if asked.
    pub time: Option<String>,
}

fn default_cpus() -> u32 {
    2
}

impl Default for SlurmResources {
    fn default() -> Self {
        SlurmResources { cpus_per_task: default_cpus(), mem: None, time: None }
    }
}

/// A sweep file as written.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SweepFile {
    /// The base scene, relative to the sweep file.
    pub base: PathBuf,
    /// Bake only the first frames of each variant (default: the scene's range).
    pub frames: Option<usize>,
    /// Also run each variant's 16× reference and report the error against it.
    #[serde(default)]
    pub reference: bool,
    /// Product of the axes, or a list of variants.
    #[serde(default)]
    pub mode: Mode,
    /// The axes of a product sweep.
    #[serde(default)]
    pub axis: Vec<Axis>,
    /// The variants of a list sweep.
    #[serde(default)]
    pub variant: Vec<ListedVariant>,
    /// What each task asks of Slurm.
    #[serde(default)]
    pub slurm: SlurmResources,
}

/// One variant: the values it sets, in the sweep's order.
#[derive(Clone, Debug, PartialEq)]
pub struct Variant {
    /// Dotted keys and values.
    pub settings: Vec<(String, toml::Value)>,
}

impl Variant {
    /// A short label: each key's last part and its value, e.g.
    /// `preset silk · friction 0.2`.
    pub fn label(&self) -> String {
        let parts: Vec<String> = self
            .settings
            .iter()
            .map(|(key, value)| format!("{} {}", key.rsplit('.').next().unwrap_or(key), plain(value)))
            .collect();
        if parts.is_empty() { "base".to_owned() } else { parts.join(" · ") }
    }
}

/// A value as a person writes it (strings without quotes).
pub fn plain(value: &toml::Value) -> String {
    match value {
        toml::Value::String(s) => s.clone(),
        other => other.to_string(),
    }
}

/// A sweep read from its file.
#[derive(Clone, Debug, PartialEq)]
pub struct Sweep {
    /// The sweep file.
    pub path: PathBuf,
    /// The base scene, as a path from the working folder.
    pub base: PathBuf,
    /// Frames to bake per variant, if fewer than the scene's.
    pub frames: Option<usize>,
    /// Whether each variant's error against its reference is measured.
    pub reference: bool,
    /// Every variant, in order.
    pub variants: Vec<Variant>,
    /// Resources of one task.
    pub slurm: SlurmResources,
}

/// At most this many variants (a typo in a product must not write a
/// million folders).
pub const MAX_VARIANTS: usize = 10_000;

impl Sweep {
    /// Reads the sweep file at `path`: errors name the file, and the line of
    /// a syntax error.
    pub fn load(path: &Path) -> Result<Sweep, FarmError> {
        let text = std::fs::read_to_string(path).map_err(|e| FarmError::io(path, e))?;
        Sweep::parse(&text, path)
    }

    /// Reads sweep text that came from `path`.
    pub fn parse(text: &str, path: &Path) -> Result<Sweep, FarmError> {
        let bad = |problem: String| FarmError::Sweep { file: path.to_owned(), problem };
        let file: SweepFile = toml::from_str(text).map_err(|e| bad(e.to_string()))?;
        let variants = match file.mode {
            Mode::Product => product(&file.axis).map_err(bad)?,
            Mode::List => {
                file.variant.iter().map(|v| Variant { settings: v.set.clone().into_iter().collect() }).collect()
            }
        };
        if variants.is_empty() {
            return Err(bad(
                "no variants: give [[axis]] tables with values, or mode = \"list\" and [[variant]] tables".into(),
            ));
        }
        if file.frames == Some(0) {
            return Err(bad("frames = 0: bake at least one frame".into()));
        }
        let base = path.parent().unwrap_or(Path::new("")).join(&file.base);
        Ok(Sweep {
            path: path.to_owned(),
            base,
            frames: file.frames,
            reference: file.reference,
            variants,
            slurm: file.slurm,
        })
    }
}

/// Every combination of `axes`' values, the last axis varying fastest.
fn product(axes: &[Axis]) -> Result<Vec<Variant>, String> {
    let mut count: usize = 1;
    for axis in axes {
        if axis.values.is_empty() {
            return Err(format!("axis {} has no values", axis.key));
        }
        count = count.saturating_mul(axis.values.len());
    }
    if count > MAX_VARIANTS {
        return Err(format!("{count} variants: at most {MAX_VARIANTS}"));
    }
    let mut variants = vec![Variant { settings: Vec::new() }];
    for axis in axes {
        variants = variants
            .iter()
            .flat_map(|v| {
                axis.values.iter().map(move |value| {
                    let mut settings = v.settings.clone();
                    settings.push((axis.key.clone(), value.clone()));
                    Variant { settings }
                })
            })
            .collect();
    }
    Ok(variants)
}

#[cfg(test)]
mod tests {
    use super::*;

    const SWEEP: &str = r#"
base = "scene.toml"
frames = 5
[[axis]]
key = "garment.0.preset"
values = ["cotton", "silk"]
[[axis]]
key = "garment.0.fabric.friction"
values = [0.2, 0.6, 0.9]
"#;

    #[test]
    fn a_product_sweep_varies_the_last_axis_fastest() {
        let sweep = Sweep::parse(SWEEP, Path::new("sweeps/s.toml")).unwrap();
        assert_eq!(sweep.variants.len(), 6);
        assert_eq!(sweep.base, Path::new("sweeps/scene.toml"));
        assert_eq!(sweep.variants[1].label(), "preset cotton · friction 0.6");
        assert_eq!(sweep.variants[3].label(), "preset silk · friction 0.2");
        assert_eq!(sweep.slurm.cpus_per_task, 2);
    }

    #[test]
    fn bad_sweeps_name_the_file_and_the_problem() {
        let err = |text: &str| Sweep::parse(text, Path::new("s.toml")).unwrap_err().to_string();
        assert!(err("base = \"a.toml\"\n[[axis]]\nkey = \"x\"\nvalues = []").contains("axis x has no values"));
        assert!(err("base = \"a.toml\"\nmode = \"list\"").contains("no variants"));
        let typo = err("base = \"a.toml\"\n[[axes]]\nkey = \"x\"");
        assert!(typo.contains("s.toml") && typo.contains("line 2"), "{typo}");
        let huge = "base = \"a.toml\"\n".to_owned()
            + &(0..5)
                .map(|k| format!("[[axis]]\nkey = \"k{k}\"\nvalues = {:?}\n", (0..20).collect::<Vec<_>>()))
                .collect::<String>();
        assert!(err(&huge).contains("at most"));
    }
}
