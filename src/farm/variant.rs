//! One variant made into a scene: the sweep's values set by their dotted
//! keys in the base scene's table, asset paths made absolute (the variant's
//! scene lives in its own folder, maybe on another machine's view of a
//! shared filesystem), checked by resolving it, and keyed by a hash of
//! everything its bake depends on.

use std::path::{Path, PathBuf};

use sha2::{Digest, Sha256};

use crate::scene::Scene;
use crate::scene::file::{MeshSpec, SceneFile, ShapeSpec};

/// A variant's scene, ready to bake.
#[derive(Clone, Debug, PartialEq)]
pub struct ResolvedVariant {
    /// Its scene file's text (TOML), asset paths absolute.
    pub scene_text: String,
    /// The same with the paths as the base scene writes them (relative to
    /// it): what the key hashes, so that keys do not depend on where the
    /// sweep's files are.
    pub portable_text: String,
    /// The files its bake reads, in scene order: as written, and absolute.
    pub assets: Vec<(PathBuf, PathBuf)>,
}

/// Sets `value` at the dotted `key` of `table`: table keys by name, array
/// entries by index (`garment.0.fabric.friction`); missing tables on the way
/// are made.
pub fn set_key(table: &mut toml::Table, key: &str, value: toml::Value) -> Result<(), String> {
    let parts: Vec<&str> = key.split('.').collect();
    let Some((last, path)) = parts.split_last() else { return Err("an empty key".into()) };
    let mut here = table;
    let mut walked = String::new();
    let mut rest = path.iter().peekable();
    while let Some(&part) = rest.next() {
        walked = if walked.is_empty() { part.to_owned() } else { format!("{walked}.{part}") };
        let entry = here.entry(part).or_insert_with(|| toml::Value::Table(toml::Table::new()));
        here = match entry {
            toml::Value::Table(t) => t,
            toml::Value::Array(items) => {
                let index = rest.next().ok_or_else(|| format!("{walked} is a list: give an index after it"))?;
                let k: usize = index.parse().map_err(|_| format!("{walked}.{index}: {index} is not an index"))?;
                let len = items.len();
                let item = items.get_mut(k).ok_or_else(|| format!("{walked}.{k}: the scene has {len}"))?;
                walked = format!("{walked}.{k}");
                item.as_table_mut().ok_or_else(|| format!("{walked} is not a table"))?
            }
            _ => return Err(format!("{walked} is a value, not a table")),
        };
    }
    here.insert((*last).to_owned(), value);
    Ok(())
}

/// The base scene at `base` with `settings` applied, its paths absolute,
/// checked by resolving it as it will be baked.
pub fn resolve(base: &Path, settings: &[(String, toml::Value)]) -> Result<ResolvedVariant, String> {
    let text = std::fs::read_to_string(base).map_err(|e| format!("{}: {e}", base.display()))?;
    let mut table: toml::Table = toml::from_str(&text).map_err(|e| format!("{}: {e}", base.display()))?;
    for (key, value) in settings {
        set_key(&mut table, key, value.clone()).map_err(|e| format!("{key}: {e}"))?;
    }
    let mut file: SceneFile = table.try_into().map_err(|e: toml::de::Error| e.to_string())?;
    let portable_text = toml::to_string(&file).map_err(|e| e.to_string())?;
    let folder = std::fs::canonicalize(base.parent().unwrap_or(Path::new(".")))
        .map_err(|e| format!("{}: {e}", base.display()))?;
    let assets = absolute_assets(&mut file, &folder);
    Scene::resolve(file.clone(), &folder.join("variant.toml")).map_err(|e| e.to_string())?;
    let scene_text = toml::to_string(&file).map_err(|e| e.to_string())?;
    Ok(ResolvedVariant { scene_text, portable_text, assets })
}

/// Makes every asset path of `file` absolute from `folder`; the files it
/// reads, in scene order, as written and absolute.
fn absolute_assets(file: &mut SceneFile, folder: &Path) -> Vec<(PathBuf, PathBuf)> {
    let mut assets = Vec::new();
    let mut absolute = |path: &mut PathBuf| {
        let written = path.clone();
        *path = folder.join(&*path);
        assets.push((written, path.clone()));
    };
    for garment in &mut file.garments {
        if let MeshSpec::Obj(obj) = &mut garment.mesh {
            absolute(obj);
        }
        if is_preset_file(&garment.preset) {
            let mut preset = PathBuf::from(&garment.preset);
            absolute(&mut preset);
            garment.preset = preset.to_string_lossy().into_owned();
        }
    }
    for body in &mut file.bodies {
        absolute(&mut body.file);
        if let Some(motion) = &mut body.motion {
            absolute(motion);
        }
    }
    for collider in &mut file.colliders {
        if let ShapeSpec::Mesh { obj, .. } = &mut collider.shape {
            absolute(obj);
        }
    }
    assets
}

/// Whether a garment's `preset` names a file (as [`crate::scene::preset::Preset::resolve`] decides).
fn is_preset_file(preset: &str) -> bool {
    preset.ends_with(".toml") || preset.contains('/') || preset.contains('\\')
}

/// The variant's key: SHA-256 (hex) of drape's version, the frames baked,
/// whether the reference is measured, the scene text as written and every
/// asset's path as written and bytes. The same sweep gives the same keys on
/// any machine with the same files.
pub fn key(variant: &ResolvedVariant, frames: Option<usize>, reference: bool) -> Result<String, std::io::Error> {
    let mut hash = Sha256::new();
    hash.update(format!("drape {}\nframes {frames:?}\nreference {reference}\n", env!("CARGO_PKG_VERSION")));
    hash.update(variant.portable_text.as_bytes());
    for (written, absolute) in &variant.assets {
        let bytes = std::fs::read(absolute)?;
        hash.update(format!("\n{} {}\n", written.display(), bytes.len()));
        hash.update(&bytes);
    }
    Ok(hash.finalize().iter().map(|b| format!("{b:02x}")).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dotted_keys_reach_tables_and_list_entries() {
        let mut table: toml::Table =
            toml::from_str("[[garment]]\nname = \"a\"\n[solver]\nsteps_per_frame = 2").unwrap();
        set_key(&mut table, "garment.0.fabric.friction", toml::Value::Float(0.3)).unwrap();
        set_key(&mut table, "solver.steps_per_frame", toml::Value::Integer(4)).unwrap();
        assert_eq!(table["garment"][0]["fabric"]["friction"].as_float(), Some(0.3));
        assert_eq!(table["solver"]["steps_per_frame"].as_integer(), Some(4));
        let err = |key: &str| set_key(&mut table.clone(), key, toml::Value::Integer(1)).unwrap_err();
        assert!(err("garment.3.preset").contains("the scene has 1"));
        assert!(err("garment.x.preset").contains("not an index"));
        assert!(err("solver.steps_per_frame.x").contains("is a value"));
    }
}
