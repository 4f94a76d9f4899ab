//! The editor's background jobs: exports and the reference run.

use std::path::PathBuf;

use super::Editor;
use crate::app::export::{self, ExportKind, ImageCamera, ImageRequest};
use crate::app::job::Job;
use crate::app::reference;

impl Editor {
    /// Starts exporting the simulated frames into the export folder.
    pub fn export(&mut self, kind: ExportKind) {
        if self.export.is_some() {
            return self.tell("an export is already running", false);
        }
        if self.timeline.len() < 2 {
            return self.tell("nothing to export yet: Simulate or Bake first", false);
        }
        let dir = PathBuf::from(self.paths.export.trim());
        self.remember_export_folder(&dir);
        let frames = self.timeline.frames().to_vec();
        self.export = Some(export::start(kind, self.scene.clone(), frames, self.light_rig().clone(), dir));
    }

    /// Exports PNG frames as the Export panel's choices say, with the fit
    /// map shown (and its legend).
    pub fn export_images(&mut self) {
        let [w, h] = self.viewport_pixels;
        let choices = self.images;
        let request = ImageRequest {
            size: choices.size.unwrap_or((w.max(16), h.max(16))),
            camera: match choices.through_view {
                true => ImageCamera::View(self.camera, self.figure.clone()),
                false => ImageCamera::Scene,
            },
            map: self.fit_map,
            only_frame: (!choices.all_frames).then(|| self.timeline.current().min(self.timeline.last())),
        };
        self.export(ExportKind::Images(request));
    }

    /// Keeps the export folder in the scene file (relative to it), so the
    /// next export of this scene goes there too.
    fn remember_export_folder(&mut self, dir: &std::path::Path) {
        let relative = crate::app::dialog::relative_to(dir, &self.base_dir());
        if self.scene.file.export.folder.as_ref() != Some(&relative) {
            self.scene.file.export.folder = Some(relative);
            self.commit("export folder");
        }
    }

    pub(super) fn poll_export(&mut self) {
        let Some(job) = &mut self.export else { return };
        let Some(result) = job.poll() else { return };
        let (cancelled, done, total) = (job.cancelled(), job.done, job.total);
        self.export = None;
        match result {
            _ if cancelled => self.tell(format!("export cancelled after {done} of {total} frames"), false),
            Ok(dir) => self.tell(format!("exported to {}", dir.display()), false),
            Err(reason) => self.tell(format!("export stopped: {reason}"), true),
        }
    }

    /// Starts the reference run: this scene with its current fabrics at 16×
    /// the Balanced steps per frame and a tight tolerance, whatever the
    /// quality chosen, so every quality can be compared with it.
    pub fn compute_reference(&mut self) {
        if self.reference_job.is_some() {
            return;
        }
        let mut scene = self.scene.clone();
        (scene.steps_per_frame, scene.solver.tolerance) = self.base_effort;
        self.reference = None;
        self.reference_job = Some(reference::start(scene));
    }

    /// Drops the reference (the parameters it was run with changed).
    pub(super) fn forget_reference(&mut self) {
        if let Some(job) = self.reference_job.take() {
            job.cancel();
            self.tell("the reference run was stopped: the fabric or scene changed", false);
        }
        self.reference = None;
    }

    pub(super) fn poll_reference(&mut self) {
        let Some(result) = self.reference_job.as_mut().and_then(Job::poll) else { return };
        self.reference_job = None;
        match result {
            Ok(reference) => self.reference = Some(reference),
            Err(reason) => self.tell(format!("reference run stopped: {reason}"), true),
        }
    }

    /// Stops a reference run in progress.
    pub fn cancel_reference(&mut self) {
        if let Some(job) = &self.reference_job {
            job.cancel();
        }
    }

    /// Error of the frame shown against the reference (relative RMS over the
    /// cloth's rest diagonal, unitless), when there is one.
    pub fn shown_error(&self) -> Option<f64> {
        let reference = self.reference.as_ref()?;
        let frame = self.timeline.current().min(self.timeline.last());
        reference.error(frame, &self.timeline.frame(frame)?.positions)
    }

    /// Mean error over the simulated frames and the error of the newest one
    /// against the reference (unitless), when there is one.
    pub fn run_error(&self) -> Option<(f64, f64)> {
        let reference = self.reference.as_ref()?;
        let errors: Vec<f64> =
            self.timeline.frames().iter().enumerate().filter_map(|(k, f)| reference.error(k, &f.positions)).collect();
        let last = *errors.last()?;
        Some((errors.iter().sum::<f64>() / errors.len() as f64, last))
    }

    /// Stops an export in progress.
    pub fn cancel_export(&mut self) {
        if let Some(job) = &self.export {
            job.cancel();
        }
    }
}
