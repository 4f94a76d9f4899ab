//! The editor's bottom bar: playback buttons, the full-width timeline bar,
//! the playback speed, and the running job's progress.

use egui::Ui;

use super::editor::{Editor, FrameKind, RunState};

/// Playback speeds offered, times real time.
const SPEEDS: [f64; 6] = [0.1, 0.25, 0.5, 1.0, 2.0, 4.0];

/// The bottom bar: playback, the timeline bar, speed, and job progress.
pub(super) fn timeline(ui: &mut Ui, editor: &mut Editor) {
    ui.horizontal(|ui| {
        playback_buttons(ui, editor);
        ui.separator();
        let t = &mut editor.timeline;
        ui.checkbox(&mut t.looping, "Loop").on_hover_text("Play from the start again after the newest frame");
        let mut speed = t.speed;
        egui::ComboBox::from_label("Speed").selected_text(format!("{speed}×")).width(60.0).show_ui(ui, |ui| {
            for s in SPEEDS {
                ui.selectable_value(&mut speed, s, format!("{s}×"));
            }
        });
        t.speed = speed;
        ui.separator();
        let (k, range) = (t.current(), t.range);
        ui.label(format!("frame {k} of {range} · {:.2} s", t.time_of(k)));
        if editor.shown_is_stale() {
            ui.colored_label(super::timeline_bar::colour(Some(FrameKind::Stale)), "stale")
                .on_hover_text("Simulated with other settings than the current ones: re-simulate to see them");
        }
        let resimulate = ui
            .add_enabled(
                k < editor.timeline.last() || editor.shown_is_stale(),
                egui::Button::new("Re-simulate from here"),
            )
            .on_hover_text("Drop the frames after this one and simulate on from it with the current settings");
        if resimulate.clicked() {
            editor.resimulate_from_here();
        }
        job_progress(ui, editor);
    });
    let kinds = editor.frame_kinds();
    let t = &mut editor.timeline;
    let frames = t.range.max(t.last());
    if let Some(frame) = super::timeline_bar::timeline_bar(ui, frames, &kinds, t.current()) {
        t.seek(frame);
    }
}

fn playback_buttons(ui: &mut Ui, editor: &mut Editor) {
    let t = &mut editor.timeline;
    if ui.button("|<").on_hover_text("First frame (Home)").clicked() {
        t.seek(0);
    }
    if ui.button("<").on_hover_text("Previous frame (left arrow)").clicked() {
        t.step(-1);
    }
    let label = if t.playing { "Pause" } else { "Play" };
    if ui.button(label).on_hover_text("Play the simulated frames (Space)").clicked() {
        t.playing = !t.playing;
    }
    if ui.button(">").on_hover_text("Next frame (right arrow)").clicked() {
        t.step(1);
    }
    if ui.button(">|").on_hover_text("Newest frame (End)").clicked() {
        t.seek(t.end());
    }
}

/// The bake's and the export's progress, time left and Cancel.
fn job_progress(ui: &mut Ui, editor: &mut Editor) {
    let mut cancel_export = false;
    if let Some(job) = &editor.export {
        ui.separator();
        let left = job.time_left_s().map_or(String::new(), |s| format!(", {s:.0} s left"));
        let text = format!("export {}/{}{left}", job.done, job.total);
        ui.add(egui::ProgressBar::new(job.done as f32 / job.total.max(1) as f32).text(text).desired_width(220.0));
        cancel_export = ui.button("Cancel export").on_hover_text("Stop after the file in progress (Esc)").clicked();
    }
    if cancel_export {
        editor.cancel_export();
    }
    if let RunState::Baking { done, total, .. } = editor.run {
        ui.separator();
        let left = editor.bake_time_left_s().map_or(String::new(), |s| format!(", {s:.0} s left"));
        let text = format!("bake {done}/{total}{left}");
        ui.add(egui::ProgressBar::new(done as f32 / total.max(1) as f32).text(text).desired_width(260.0));
        if ui.button("Cancel").on_hover_text("Stop the bake: the last complete bake comes back (Esc)").clicked() {
            editor.pause();
        }
    }
}
