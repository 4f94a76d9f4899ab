//! `drape export` (and `drape bake --export`): a finished bake folder as
//! USD, glTF or MDD files, with a progress bar.

use std::path::Path;
use std::sync::atomic::AtomicBool;

use drape::export::{ExportRequest, Format, export, open_bake};
use indicatif::{ProgressBar, ProgressStyle};

use crate::{Failure, input};

/// What `drape export` asks for besides the folder and the formats.
pub struct ExportOptions<'a> {
    /// The file (or MDD folder) to write; one format only.
    pub out: Option<&'a Path>,
    /// `A..B` or `N`.
    pub frames: Option<&'a str>,
    /// Leave the bodies out.
    pub no_body: bool,
    /// glTF: a morph target every K frames.
    pub every: usize,
    /// glTF: 16-bit positions and normals.
    pub quantize: bool,
    /// The scene of the bake, when its summary names none.
    pub scene: Option<&'a Path>,
}

/// Exports the bake in `dir` in each of `formats`.
pub fn run_export(dir: &Path, formats: &[Format], options: &ExportOptions<'_>) -> Result<(), Failure> {
    if formats.len() > 1 && options.out.is_some() {
        return Err(Failure::Input("--out names one file: give one --format with it".into()));
    }
    let (scene, frames) = open_bake(dir, options.scene).map_err(input)?;
    let last = frames.frame_count().saturating_sub(1);
    let range = match options.frames {
        Some(text) => Some(crate::cli::render::parse_frames(Some(text), last)?),
        None => None,
    };
    for &format in formats {
        let request = ExportRequest {
            format,
            out: options.out.map(Path::to_owned),
            frames: range.clone(),
            body: !options.no_body,
            every: options.every,
            quantize: options.quantize,
        };
        let bar = ProgressBar::new(1).with_style(
            ProgressStyle::with_template(&format!("{} {{bar:30}} {{percent}} %  eta {{eta}}", format.name()))
                .unwrap_or(ProgressStyle::default_bar()),
        );
        let progress = |done: usize, total: usize| {
            bar.set_length(total as u64);
            bar.set_position(done as u64);
        };
        let started = std::time::Instant::now();
        let report = export(&scene, &frames, &request, dir, &progress, &AtomicBool::new(false));
        bar.finish_and_clear();
        let report = report.map_err(input)?;
        let seconds = started.elapsed().as_secs_f64();
        for (file, bytes) in &report.files {
            println!("{}: {} ({:.1} MB) in {seconds:.2} s", format.name(), file.display(), *bytes as f64 / 1e6);
        }
    }
    Ok(())
}

/// Formats from a comma-separated list (`usd,gltf`).
pub fn parse_formats(text: &str) -> Result<Vec<Format>, Failure> {
    text.split(',')
        .map(|name| {
            Format::named(name).ok_or_else(|| Failure::Input(format!("--format {name}: expected usd, gltf or mdd")))
        })
        .collect()
}
