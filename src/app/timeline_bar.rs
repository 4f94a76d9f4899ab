//! The timeline's bar, full width: a frame ruler over a cache bar that
//! colours each frame by what it is (baked, simulated, stale, not yet
//! simulated), as Blender's cache bar does, with the playhead across both.
//! Clicking or dragging anywhere on it moves the playhead.

use egui::{Align2, Color32, FontId, Rect, Sense, Stroke, Ui, Vec2, pos2};

use super::editor::FrameKind;

/// Height of the ruler with its numbers, points.
const RULER_HEIGHT: f32 = 16.0;
/// Height of the cache bar, points.
const CACHE_HEIGHT: f32 = 8.0;
/// The least room between two numbered ticks, points.
const LABEL_SPACING: f32 = 60.0;

/// The colour of a frame in the cache bar.
pub fn colour(kind: Option<FrameKind>) -> Color32 {
    match kind {
        Some(FrameKind::Baked) => Color32::from_rgb(70, 130, 220),
        Some(FrameKind::Simulated) => Color32::from_rgb(70, 180, 110),
        Some(FrameKind::Stale) => Color32::from_rgb(230, 150, 40),
        None => Color32::from_gray(55),
    }
}

/// The numbered tick spacing, frames: the smallest of 1, 2, 5, 10, 20, 50…
/// leaving at least [`LABEL_SPACING`] points between labels.
fn tick_spacing(frames: usize, width: f32) -> usize {
    let per_frame = width / frames.max(1) as f32;
    let mut decade = 1;
    loop {
        for step in [decade, 2 * decade, 5 * decade] {
            if step as f32 * per_frame >= LABEL_SPACING || step >= frames {
                return step;
            }
        }
        decade *= 10;
    }
}

/// Draws the bar over `0..=frames` with the stored frames' `kinds` and the
/// playhead at `current`; returns the frame the user clicked or dragged to.
pub fn timeline_bar(ui: &mut Ui, frames: usize, kinds: &[FrameKind], current: usize) -> Option<usize> {
    let size = Vec2::new(ui.available_width(), RULER_HEIGHT + CACHE_HEIGHT + 2.0);
    let (rect, response) = ui.allocate_exact_size(size, Sense::click_and_drag());
    let frames = frames.max(1);
    let x_of = |f: f32| rect.left() + rect.width() * f / frames as f32;
    let painter = ui.painter_at(rect);
    painter.rect_filled(rect, 2.0, Color32::from_gray(30));
    let text = ui.visuals().text_color();
    let step = tick_spacing(frames, rect.width());
    let minor = if step >= 10 { step / 5 } else { 1 };
    for f in (0..=frames).step_by(minor.max(1)) {
        let x = x_of(f as f32);
        let numbered = f % step == 0;
        let top = rect.top() + if numbered { 2.0 } else { RULER_HEIGHT - 5.0 };
        painter.line_segment(
            [pos2(x, top), pos2(x, rect.top() + RULER_HEIGHT)],
            Stroke::new(1.0, text.gamma_multiply(0.5)),
        );
        if numbered {
            painter.text(
                pos2(x + 3.0, rect.top() + 1.0),
                Align2::LEFT_TOP,
                f.to_string(),
                FontId::proportional(10.0),
                text,
            );
        }
    }
    let cache = Rect::from_min_max(pos2(rect.left(), rect.top() + RULER_HEIGHT + 1.0), rect.right_bottom());
    painter.rect_filled(cache, 0.0, colour(None));
    for (f, kind) in kinds.iter().enumerate() {
        let span = Rect::from_x_y_ranges(x_of(f as f32 - 0.5).max(rect.left())..=x_of(f as f32 + 0.5), cache.y_range());
        painter.rect_filled(span, 0.0, colour(Some(*kind)));
    }
    let x = x_of(current as f32);
    painter
        .line_segment([pos2(x, rect.top()), pos2(x, rect.bottom())], Stroke::new(2.0, Color32::from_rgb(240, 80, 60)));
    let response = response.on_hover_text(
        "Click or drag to move the playhead. Blue: baked; green: simulated; orange: stale (other settings than now)",
    );
    let pointer = response.interact_pointer_pos()?;
    let frame = ((pointer.x - rect.left()) / rect.width() * frames as f32).round();
    Some(frame.clamp(0.0, frames as f32) as usize)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbered_ticks_are_round_and_far_enough_apart() {
        assert_eq!(tick_spacing(100, 1000.0), 10, "10 px per frame: every 10th frame has room");
        assert_eq!(tick_spacing(130, 1000.0), 10);
        assert_eq!(tick_spacing(1000, 1000.0), 100);
        assert_eq!(tick_spacing(10, 1000.0), 1);
        assert_eq!(tick_spacing(9000, 1200.0), 500);
    }
}
