//! `drape fabric test | fit`: the virtual fabric lab on presets, and a
//! preset fitted to a fabric's measurements.

use std::path::Path;

use drape::fabric_lab;
use drape::scene::preset::Preset;

use crate::{Failure, input};

/// `drape fabric test`: the virtual cantilever (and, with `drape`, the Cusick
/// drape) of each preset against its targets; exit 3 when a bending length
/// is off; drape pictures into `pictures`.
pub(crate) fn run_fabric_test(
    presets: &[String],
    drape: bool,
    across: usize,
    pictures: Option<&Path>,
) -> Result<(), Failure> {
    let names: Vec<String> =
        if presets.is_empty() { Preset::builtin_names().map(str::to_owned).collect() } else { presets.to_vec() };
    let mut reports = Vec::new();
    for name in &names {
        let preset = Preset::resolve(name, Path::new(""), &toml::Table::new()).map_err(input)?;
        eprintln!("testing {} ...", preset.name);
        let lab = |e: fabric_lab::LabError| Failure::Input(format!("{}: {e}", preset.name));
        let cantilever = fabric_lab::cantilever::cantilever_test(&preset.fabric, fabric_lab::fit::CANTILEVER_SEGMENTS)
            .map_err(lab)?;
        let cusick =
            if drape { Some(fabric_lab::cusick::drape_test(&preset.fabric, across).map_err(lab)?) } else { None };
        if let (Some(dir), Some(test)) = (pictures, &cusick) {
            write_drape_picture(dir, &preset.name, test)?;
        }
        let report = fabric_lab::report::FabricReport { preset, cantilever, cusick };
        print!("{}", report.text());
        reports.push(report);
    }
    if reports.len() > 1 {
        println!("\n{}", fabric_lab::report::markdown_table(&reports));
    }
    let failed: Vec<&str> = reports.iter().filter(|r| !r.passes()).map(|r| r.preset.name.as_str()).collect();
    if failed.is_empty() {
        Ok(())
    } else {
        Err(Failure::Found(format!("bending length off its target by more than 5 %: {}", failed.join(", "))))
    }
}

/// Writes `test`'s shadow to DIR/<name>_drape.png.
fn write_drape_picture(dir: &Path, name: &str, test: &fabric_lab::cusick::Cusick) -> Result<(), Failure> {
    std::fs::create_dir_all(dir).map_err(|e| Failure::Input(format!("{}: {e}", dir.display())))?;
    let path = dir.join(format!("{name}_drape.png"));
    let picture = test.shadow.picture(fabric_lab::cusick::DISC_RADIUS_M);
    drape::io::atomic::write_file(&path, |w| {
        picture.write_to(w, image::ImageFormat::Png).map_err(std::io::Error::other)
    })
    .map_err(input)?;
    eprintln!("wrote {}", path.display());
    Ok(())
}

/// `drape fabric fit`: a preset fitted to measured bending length, weight and
/// drape coefficient, written to `out`.
pub(crate) fn run_fabric_fit(
    measured: &fabric_lab::fit::Measured,
    base: &str,
    name: Option<&str>,
    across: usize,
    out: &Path,
) -> Result<(), Failure> {
    let base = Preset::resolve(base, Path::new(""), &toml::Table::new()).map_err(input)?;
    let stem = out.file_stem().and_then(|s| s.to_str()).unwrap_or("fitted");
    let fitted = fabric_lab::fit::fit(&base, name.unwrap_or(stem), measured, across, |line| eprintln!("{line}"))
        .map_err(input)?;
    drape::io::atomic::write_file(out, |w| std::io::Write::write_all(w, fitted.preset.to_toml().as_bytes()))
        .map_err(input)?;
    let report = fabric_lab::report::FabricReport {
        preset: fitted.preset.clone(),
        cantilever: fitted.cantilever,
        cusick: fitted.cusick,
    };
    print!("{}", report.text());
    println!(
        "bend stiffness {:.4e} N·m, shear stiffness {:.4} N/m; wrote {}",
        fitted.preset.fabric.bend_stiffness_n_m,
        fitted.preset.fabric.shear_stiffness_n_per_m,
        out.display()
    );
    Ok(())
}
