//! The keyboard: one table of shortcuts, read by the key handler, the menus
//! (which show each item's keys) and the Help ▸ Keyboard panel.

use egui::{Key, KeyboardShortcut, Modifiers};

use super::editor::{Action, Editor};
use super::orbit::ViewSide;

/// A key (with modifiers) and what it does.
#[derive(Clone, Copy, Debug)]
pub struct Shortcut {
    /// The keys.
    pub keys: KeyboardShortcut,
    /// What they do.
    pub action: Action,
    /// What they do, in the Keyboard panel's words.
    pub what: &'static str,
}

const fn key(modifiers: Modifiers, key: Key, action: Action, what: &'static str) -> Shortcut {
    Shortcut { keys: KeyboardShortcut::new(modifiers, key), action, what }
}

const CTRL: Modifiers = Modifiers::COMMAND;
const CTRL_SHIFT: Modifiers = Modifiers::COMMAND.plus(Modifiers::SHIFT);
const SHIFT: Modifiers = Modifiers::SHIFT;
const NONE: Modifiers = Modifiers::NONE;

/// Every shortcut, the more specific before the less (Ctrl+Shift+S before
/// Ctrl+S: egui matches extra Shift loosely).
pub const SHORTCUTS: &[Shortcut] = &[
    key(CTRL_SHIFT, Key::S, Action::SaveAs, "Save the scene as…"),
    key(CTRL, Key::S, Action::Save, "Save the scene"),
    key(CTRL, Key::O, Action::Open, "Open a scene…"),
    key(CTRL, Key::N, Action::New, "New scene"),
    key(CTRL, Key::Q, Action::Quit, "Quit"),
    key(CTRL_SHIFT, Key::Z, Action::Redo, "Redo"),
    key(CTRL, Key::Y, Action::Redo, "Redo"),
    key(CTRL, Key::Z, Action::Undo, "Undo"),
    key(CTRL, Key::B, Action::Bake, "Bake every frame"),
    key(SHIFT, Key::Space, Action::SimulateOrPause, "Simulate / pause the simulation"),
    key(NONE, Key::Space, Action::PlayPause, "Play / pause the frames"),
    key(NONE, Key::Escape, Action::Cancel, "Cancel the running bake, export or reference run"),
    key(NONE, Key::Home, Action::FirstFrame, "First frame"),
    key(NONE, Key::End, Action::LastFrame, "Newest frame"),
    key(NONE, Key::ArrowLeft, Action::PreviousFrame, "Previous frame"),
    key(NONE, Key::ArrowRight, Action::NextFrame, "Next frame"),
    key(NONE, Key::F, Action::Frame, "Frame the garment and body"),
    key(NONE, Key::M, Action::NextFitMap, "Show the fabric, the strain map, the contact map in turn"),
    key(NONE, Key::P, Action::PinA, "Pin the current result as A"),
    key(NONE, Key::C, Action::NextCompare, "Compare: A, B, A and B side by side in turn"),
    key(CTRL, Key::Num1, Action::View(ViewSide::Back), "Back view"),
    key(NONE, Key::Num1, Action::View(ViewSide::Front), "Front view"),
    key(CTRL, Key::Num3, Action::View(ViewSide::Left), "Left side view"),
    key(NONE, Key::Num3, Action::View(ViewSide::Right), "Right side view"),
    key(NONE, Key::Num7, Action::View(ViewSide::Top), "Top view"),
    key(NONE, Key::Num9, Action::View(ViewSide::ThreeQuarter), "Three-quarter view"),
];

/// The keys of `action`'s first shortcut, as the menus show them.
pub fn keys_of(ctx: &egui::Context, action: Action) -> Option<String> {
    SHORTCUTS.iter().find(|s| s.action == action).map(|s| ctx.format_shortcut(&s.keys))
}

/// Does what the keys pressed this frame ask, unless a text field has them
/// (Ctrl+Z there undoes typing, not the scene) or a question is open.
pub fn handle(ctx: &egui::Context, editor: &mut Editor) {
    if ctx.text_edit_focused() || editor.pending.is_some() || editor.browse.is_some() {
        return;
    }
    for shortcut in SHORTCUTS {
        if ctx.input_mut(|i| i.consume_shortcut(&shortcut.keys)) {
            editor.act(shortcut.action);
        }
    }
}

/// The Help ▸ Keyboard panel's table.
pub fn keyboard_table(ui: &mut egui::Ui) {
    egui::Grid::new("keyboard").striped(true).show(ui, |ui| {
        for shortcut in SHORTCUTS {
            ui.monospace(ui.ctx().format_shortcut(&shortcut.keys));
            ui.label(shortcut.what);
            ui.end_row();
        }
        ui.monospace("Left drag");
        ui.label("Orbit around the framed figure");
        ui.end_row();
        ui.monospace("Right / middle drag");
        ui.label("Pan");
        ui.end_row();
        ui.monospace("Wheel");
        ui.label("Zoom towards the cursor");
        ui.end_row();
        ui.monospace("Double click");
        ui.label("The scene's own view");
        ui.end_row();
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn no_two_shortcuts_share_keys_and_specific_ones_come_first() {
        for (k, a) in SHORTCUTS.iter().enumerate() {
            for b in &SHORTCUTS[k + 1..] {
                assert_ne!(a.keys, b.keys, "{} and {}", a.what, b.what);
                let shadowed = a.keys.logical_key == b.keys.logical_key
                    && b.keys.modifiers.contains(a.keys.modifiers)
                    && b.keys.modifiers != a.keys.modifiers;
                assert!(!shadowed, "'{}' would take the keys of '{}', listed after it", a.what, b.what);
            }
        }
    }
}
