//! The 3D view's panel: its image, the mouse's orbit / pan / zoom, the
//! overlay (the plain summary line, its details), the fit map's legend and
//! the A/B compare labels and controls.

use egui::{Align2, Color32, PointerButton, Rect, Sense, Ui, Vec2};

use super::editor::{Compare, Editor};
use super::stats::{overlay_lines, summary_line};
use crate::stage::fit_map::ramp;

/// The statistics overlay: a plain first line, the engineering detail
/// under it one click away.
fn overlay(ui: &mut Ui, painter: &egui::Painter, rect: Rect, editor: &mut Editor) {
    let Some(frame) = editor.timeline.shown() else { return };
    let mut lines = vec![summary_line(&frame.record, editor.scene.fps, editor.simulation_rate())];
    if let (Some(error), Some(reference)) = (editor.shown_error(), &editor.reference) {
        let mm = error * reference.diagonal_m * 1e3;
        lines.push(format!("error against the reference {:.2} % ({mm:.1} mm RMS)", error * 100.0));
    }
    if editor.show_details {
        lines.extend(overlay_lines(&frame.record));
    }
    let font = egui::FontId::monospace(12.0);
    let galley = painter.layout_no_wrap(lines.join("\n"), font, Color32::from_gray(235));
    let at = rect.min + Vec2::splat(8.0);
    let size = galley.size();
    painter.rect_filled(Rect::from_min_size(at, size).expand(4.0), 3.0, Color32::from_black_alpha(150));
    painter.galley(at, galley, Color32::WHITE);
    let button = Rect::from_min_size(at + Vec2::new(size.x + 10.0, -2.0), Vec2::new(56.0, 18.0));
    let label = if editor.show_details { "less" } else { "details" };
    let tip = "Timings, solver iterations, contacts, strain, rollbacks";
    if ui.put(button, egui::Button::new(label).small()).on_hover_text(tip).clicked() {
        editor.show_details = !editor.show_details;
    }
}

/// Pin the current result as A; then show A, B or both.
pub(super) fn compare_controls(ui: &mut Ui, editor: &mut Editor) {
    let tip = "Keep the current result as A, to compare with the next one (P)";
    if ui.button("Pin A").on_hover_text(tip).clicked() {
        editor.pin_a();
    }
    let Some(pin) = &editor.pinned else { return };
    let a = format!("A: {}", pin.label);
    let name = |c: Compare| match c {
        Compare::A => a.clone(),
        Compare::B => "B: current".to_owned(),
        Compare::SideBySide => "A | B side by side".to_owned(),
    };
    let mut compare = editor.compare;
    egui::ComboBox::from_label("Compare")
        .selected_text(name(compare))
        .show_ui(ui, |ui| {
            for c in [Compare::SideBySide, Compare::A, Compare::B] {
                ui.selectable_value(&mut compare, c, name(c));
            }
        })
        .response
        .on_hover_text("Same frame, same camera (C switches)");
    editor.compare = compare;
    if ui.button("Unpin").on_hover_text("Drop A").clicked() {
        editor.unpin();
    }
}

/// Names what the viewport shows while a result is pinned: A and B over
/// their halves, or A alone.
fn compare_labels(painter: &egui::Painter, rect: Rect, editor: &Editor) {
    let Some(pin) = &editor.pinned else { return };
    let b = format!("B: {}", editor.result_label());
    let a = format!("A: {}", pin.label);
    let label = |at: egui::Pos2, text: String| {
        let font = egui::FontId::proportional(16.0);
        let galley = painter.layout_no_wrap(text, font, Color32::WHITE);
        let place = Rect::from_min_size(at - Vec2::new(galley.size().x, 0.0), galley.size());
        painter.rect_filled(place.expand(4.0), 3.0, Color32::from_black_alpha(160));
        painter.galley(place.min, galley, Color32::WHITE);
    };
    let top_right = rect.right_top() + Vec2::new(-10.0, 10.0);
    match editor.compare {
        Compare::SideBySide => {
            label(rect.center_top() + Vec2::new(-10.0, 10.0), a);
            label(top_right, b);
            painter.line_segment([rect.center_top(), rect.center_bottom()], egui::Stroke::new(2.0, Color32::BLACK));
        }
        Compare::A => label(top_right, a),
        Compare::B => label(top_right, b),
    }
}

/// The fit map's colour scale, in the viewport's lower left corner.
fn map_legend(painter: &egui::Painter, rect: Rect, editor: &Editor) {
    let Some(map) = editor.fit_map else { return };
    let (title, [low, middle, high]) = map.legend(&editor.scene);
    let bar = Rect::from_min_size(rect.left_bottom() + Vec2::new(16.0, -40.0), Vec2::new(220.0, 12.0));
    painter.rect_filled(
        bar.expand2(Vec2::new(8.0, 26.0)).translate(Vec2::new(0.0, -8.0)),
        4.0,
        Color32::from_black_alpha(150),
    );
    let steps = 64;
    for k in 0..steps {
        let [r, g, b] = ramp(k as f32 / (steps - 1) as f32);
        let x = bar.left() + bar.width() * k as f32 / steps as f32;
        let cell =
            Rect::from_min_size(egui::pos2(x, bar.top()), Vec2::new(bar.width() / steps as f32 + 0.5, bar.height()));
        painter.rect_filled(cell, 0.0, Color32::from_rgb(r, g, b));
    }
    let (font, white) = (egui::FontId::proportional(12.0), Color32::from_gray(235));
    painter.text(bar.left_top() - Vec2::new(0.0, 3.0), Align2::LEFT_BOTTOM, title, font.clone(), white);
    painter.text(bar.left_bottom() + Vec2::new(0.0, 2.0), Align2::LEFT_TOP, low, font.clone(), white);
    painter.text(bar.center_bottom() + Vec2::new(0.0, 2.0), Align2::CENTER_TOP, middle, font.clone(), white);
    painter.text(bar.right_bottom() + Vec2::new(0.0, 2.0), Align2::RIGHT_TOP, high, font, white);
}

/// The central panel: the view's image (grey when `drawn` is false, as in
/// UI tests), the mouse's camera moves, the overlays; returns the view's size
/// in physical pixels, for the next render.
pub(super) fn viewport_ui(ui: &mut Ui, editor: &mut Editor, drawn: bool) -> [u32; 2] {
    let (rect, response) = ui.allocate_exact_size(ui.available_size(), Sense::click_and_drag());
    let painter = ui.painter_at(rect);
    if drawn {
        painter.add(super::blit::viewport_image(rect));
    } else {
        painter.rect_filled(rect, 0.0, Color32::from_gray(40));
    }
    editor.viewport_aspect = rect.aspect_ratio();
    let pixels = rect.size() * ui.ctx().pixels_per_point();
    editor.viewport_pixels = [pixels.x.round().max(1.0) as u32, pixels.y.round().max(1.0) as u32];
    let (shown, t) = (editor.shown_camera(), editor.shown_time_s());
    let delta = response.drag_delta();
    if response.dragged_by(PointerButton::Primary) {
        editor.camera.orbit(shown, t, delta.x, delta.y);
    } else if response.dragged_by(PointerButton::Secondary) || response.dragged_by(PointerButton::Middle) {
        editor.camera.pan(shown, t, delta.x, delta.y, rect.height());
    }
    if let Some(pointer) = response.hover_pos() {
        let scroll = ui.input(|i| i.smooth_scroll_delta.y);
        if scroll != 0.0 {
            let at = (pointer - rect.center()) / (0.5 * rect.size());
            editor.camera.zoom(shown, t, scroll, glam::Vec2::new(at.x, -at.y), rect.aspect_ratio());
        }
    }
    if response.double_clicked() {
        editor.camera.frame_all();
    }
    overlay(ui, &painter, rect, editor);
    map_legend(&painter, rect, editor);
    compare_labels(&painter, rect, editor);
    editor.viewport_pixels
}
