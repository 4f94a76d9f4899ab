//! The menu bar: File, Edit (with the history), View, Simulation, Help.
//! Every item is an [`Action`], shown with its shortcut.

use egui::Ui;

use super::editor::{Action, Editor, RunState};
use super::examples::{examples_folder, examples_in};
use super::orbit::ViewSide;
use super::shortcuts::{keyboard_table, keys_of};
use crate::scene::file::SceneKind;
use crate::stage::fit_map::FitMap;

/// Draws the menu bar.
pub fn menu_bar(ui: &mut Ui, editor: &mut Editor) {
    egui::MenuBar::new().ui(ui, |ui| {
        ui.menu_button("File", |ui| file_menu(ui, editor));
        ui.menu_button("Edit", |ui| edit_menu(ui, editor));
        ui.menu_button("View", |ui| view_menu(ui, editor));
        ui.menu_button("Simulation", |ui| simulation_menu(ui, editor));
        ui.menu_button("Help", |ui| {
            if ui.button("Keyboard").clicked() {
                editor.show_keyboard = true;
            }
        });
    });
}

/// A menu item for `action`, with its shortcut; does it when clicked.
fn item(ui: &mut Ui, editor: &mut Editor, label: &str, action: Action) {
    let mut button = egui::Button::new(label);
    if let Some(keys) = keys_of(ui.ctx(), action) {
        button = button.shortcut_text(keys);
    }
    if ui.add(button).clicked() {
        editor.act(action);
    }
}

fn file_menu(ui: &mut Ui, editor: &mut Editor) {
    item(ui, editor, "New", Action::New);
    item(ui, editor, "Open…", Action::Open);
    ui.menu_button("Examples", |ui| examples_menu(ui, editor));
    item(ui, editor, "Save", Action::Save);
    item(ui, editor, "Save as…", Action::SaveAs);
    item(ui, editor, "Reload from disk", Action::Reload);
    ui.separator();
    item(ui, editor, "Quit", Action::Quit);
}

/// The shipped scenes: demos first, then the hard cases; the description
/// on hover. Opening one asks first when there are unsaved changes.
fn examples_menu(ui: &mut Ui, editor: &mut Editor) {
    let examples = editor.examples.get_or_insert_with(|| examples_in(&examples_folder())).clone();
    let mut chosen = None;
    for (kind, heading) in [(SceneKind::Demo, "Demos"), (SceneKind::HardCase, "Hard cases (stress tests)")] {
        ui.label(egui::RichText::new(heading).weak());
        for example in examples.iter().filter(|e| e.kind == kind) {
            if ui.button(&example.name).on_hover_text(&example.description).clicked() {
                chosen = Some(example.path.clone());
            }
        }
        if kind == SceneKind::Demo {
            ui.separator();
        }
    }
    if let Some(path) = chosen {
        editor.open_scene(path);
        ui.close();
    }
}

fn edit_menu(ui: &mut Ui, editor: &mut Editor) {
    let (undo, redo) = editor.history.labels();
    let undo_label = undo.last().map_or("Undo".to_owned(), |l| format!("Undo {l}"));
    let redo_label = redo.first().map_or("Redo".to_owned(), |l| format!("Redo {l}"));
    let (can_undo, can_redo) = (!undo.is_empty(), !redo.is_empty());
    ui.add_enabled_ui(can_undo, |ui| item(ui, editor, &undo_label, Action::Undo));
    ui.add_enabled_ui(can_redo, |ui| item(ui, editor, &redo_label, Action::Redo));
    ui.menu_button("History", |ui| history_list(ui, editor));
}

/// Every step: the done ones (click to go back to just after it), the
/// current state, the undone ones (click to redo up to it).
fn history_list(ui: &mut Ui, editor: &mut Editor) {
    let (undo, redo) = editor.history.labels();
    let (undo, redo): (Vec<String>, Vec<String>) =
        (undo.iter().map(|s| s.to_string()).collect(), redo.iter().map(|s| s.to_string()).collect());
    if undo.is_empty() && redo.is_empty() {
        ui.label("No edits yet");
    }
    let mut go = None;
    ui.label(egui::RichText::new("opened").weak());
    for (k, label) in undo.iter().enumerate() {
        if ui.button(label).on_hover_text("Go back to just after this edit").clicked() {
            go = Some(k as isize + 1 - undo.len() as isize);
        }
    }
    ui.label(egui::RichText::new("▶ now").strong());
    for (k, label) in redo.iter().enumerate() {
        let text = egui::RichText::new(label).italics();
        if ui.button(text).on_hover_text("Redo up to this edit").clicked() {
            go = Some(k as isize + 1);
        }
    }
    if let Some(steps) = go {
        for _ in 0..steps.unsigned_abs() {
            editor.act(if steps < 0 { Action::Undo } else { Action::Redo });
        }
    }
}

fn view_menu(ui: &mut Ui, editor: &mut Editor) {
    item(ui, editor, "Frame the figure", Action::Frame);
    for side in ViewSide::ALL {
        item(ui, editor, side.label(), Action::View(side));
    }
    if ui.button("Scene camera").on_hover_text("The scene's own view (double click in the view)").clicked() {
        editor.camera.frame_all();
    }
    ui.separator();
    let mut map = editor.fit_map;
    ui.radio_value(&mut map, None, "Fabric look");
    for m in FitMap::ALL {
        ui.radio_value(&mut map, Some(m), m.label());
    }
    editor.fit_map = map;
    ui.separator();
    let mut follow = editor.camera.follow;
    if ui.checkbox(&mut follow, "Follow the figure").on_hover_text("Keep the figure framed while it walks").changed() {
        editor.act(Action::Follow);
    }
}

fn simulation_menu(ui: &mut Ui, editor: &mut Editor) {
    let label = if editor.run == RunState::Idle { "Simulate" } else { "Pause the simulation" };
    item(ui, editor, label, Action::SimulateOrPause);
    ui.add_enabled_ui(editor.run == RunState::Idle, |ui| item(ui, editor, "Bake", Action::Bake));
    item(ui, editor, "Cancel the running job", Action::Cancel);
    ui.separator();
    item(ui, editor, if editor.timeline.playing { "Pause playback" } else { "Play" }, Action::PlayPause);
    item(ui, editor, "First frame", Action::FirstFrame);
    item(ui, editor, "Newest frame", Action::LastFrame);
}

/// The Help ▸ Keyboard window, while open.
pub fn keyboard_window(ctx: &egui::Context, editor: &mut Editor) {
    let mut open = editor.show_keyboard;
    egui::Window::new("Keyboard").open(&mut open).resizable(false).show(ctx, keyboard_table);
    editor.show_keyboard = open;
}
