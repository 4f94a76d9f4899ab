//! The editor's layout: toolbar, the scene / fabric / collision / lights
//! panels (PAPER Fig. 10), with the Export panel ([`super::export_panel`]),
//! the bottom bar ([`super::bottom_bar`]) and the 3D view
//! ([`super::viewport_panel`]) placed in it; messages and the
//! unsaved-changes question.

use std::path::PathBuf;

use egui::{Align2, Color32, Ui, Vec2};

use super::bottom_bar::timeline;
use super::dialog::Purpose;
use super::editor::{Editor, Pending, Quality, RunState};
use super::export_panel::export;
use super::fabric_panel;
use super::viewport_panel;
use crate::scene::preset::Preset;
use crate::stage::fit_map::FitMap;

/// Draws the whole editor into `ui`, with the 3D view's image
/// ([`super::blit::viewport_image`]) when `viewport_drawn` (a grey area
/// otherwise, e.g. in UI tests without a GPU). Returns the viewport's size in
/// physical pixels, for the next render.
pub fn editor_ui(ui: &mut Ui, editor: &mut Editor, viewport_drawn: bool) -> [u32; 2] {
    super::shortcuts::handle(ui.ctx(), editor);
    egui::Panel::top("menu").show(ui, |ui| super::menu::menu_bar(ui, editor));
    egui::Panel::top("toolbar").show(ui, |ui| toolbar(ui, editor));
    egui::Panel::bottom("timeline").show(ui, |ui| timeline(ui, editor));
    egui::Panel::left("controls").resizable(true).default_size(340.0).show(ui, |ui| {
        egui::ScrollArea::vertical().show(ui, |ui| controls(ui, editor));
    });
    let size =
        egui::CentralPanel::no_frame().show(ui, |ui| viewport_panel::viewport_ui(ui, editor, viewport_drawn)).inner;
    super::browse::show(ui.ctx(), editor);
    messages(ui.ctx(), editor);
    unsaved_question(ui.ctx(), editor);
    super::menu::keyboard_window(ui.ctx(), editor);
    size
}

fn toolbar(ui: &mut Ui, editor: &mut Editor) {
    ui.horizontal(|ui| {
        let idle = editor.run == RunState::Idle;
        if idle {
            if ui.button("Simulate").on_hover_text("Run live from the current frame; tune while it runs").clicked() {
                editor.simulate();
            }
        } else if ui.button("Pause").on_hover_text("Stop after the frame in progress").clicked() {
            editor.pause();
        }
        if ui
            .add_enabled(idle, egui::Button::new("Bake"))
            .on_hover_text("Simulate every frame from the start")
            .clicked()
        {
            editor.bake();
        }
        if ui.button("Reset").on_hover_text("Back to frame 0 with the current parameters").clicked() {
            editor.reset();
        }
        ui.separator();
        let mut quality = editor.quality;
        egui::ComboBox::from_label("Quality").selected_text(quality.label()).show_ui(ui, |ui| {
            for q in Quality::ALL {
                ui.selectable_value(&mut quality, q, q.label());
            }
        });
        if quality != editor.quality {
            editor.set_quality(quality);
        }
        ui.label(format!("{} steps/frame", editor.scene.steps_per_frame));
        ui.separator();
        light_menu(ui, editor);
        map_menu(ui, editor);
        ui.separator();
        viewport_panel::compare_controls(ui, editor);
        ui.separator();
        if editor.is_loading() {
            ui.spinner();
            ui.label("loading…");
        }
        let title = format!("{}{}", editor.scene.name, if editor.dirty() { " •" } else { "" });
        ui.label(title).on_hover_text("• marks unsaved changes");
    });
}

fn light_menu(ui: &mut Ui, editor: &mut Editor) {
    let mut rig = editor.rig;
    egui::ComboBox::from_label("Light").selected_text(editor.light_rig().name.clone()).show_ui(ui, |ui| {
        for (k, r) in editor.rigs.iter().enumerate() {
            ui.selectable_value(&mut rig, k, r.name.as_str());
        }
    });
    editor.rig = rig;
}

/// What colours the cloth: its fabric, or a fit map.
fn map_menu(ui: &mut Ui, editor: &mut Editor) {
    let mut map = editor.fit_map;
    let name = |m: Option<FitMap>| m.map_or("Fabric look", FitMap::label);
    egui::ComboBox::from_label("Show")
        .selected_text(name(map))
        .show_ui(ui, |ui| {
            ui.selectable_value(&mut map, None, name(None));
            for m in FitMap::ALL {
                ui.selectable_value(&mut map, Some(m), name(Some(m)));
            }
        })
        .response
        .on_hover_text(
            "Colour the cloth by how far it stretches (of its limit) or how hard it presses on the body (M)",
        );
    editor.fit_map = map;
}

fn controls(ui: &mut Ui, editor: &mut Editor) {
    egui::CollapsingHeader::new("Scene").default_open(true).show(ui, |ui| scene_panel(ui, editor));
    egui::CollapsingHeader::new("Fabric").default_open(true).show(ui, |ui| fabric(ui, editor));
    egui::CollapsingHeader::new("Collision").default_open(false).show(ui, |ui| collision(ui, editor));
    egui::CollapsingHeader::new("Accuracy").default_open(false).show(ui, |ui| accuracy(ui, editor));
    egui::CollapsingHeader::new("Camera").default_open(false).show(ui, |ui| camera(ui, editor));
    egui::CollapsingHeader::new("Export").default_open(true).show(ui, |ui| export(ui, editor));
}

/// A labelled path field with a button that uses it and one that browses;
/// returns the path when the first is pressed (or Enter typed in the field).
fn path_row(ui: &mut Ui, editor: &mut Editor, field: Field, button: &str, hint: &str) -> Option<PathBuf> {
    let (label, purpose) = field.describe();
    let mut chosen = None;
    let mut browse = false;
    ui.horizontal(|ui| {
        let name = ui.label(label);
        let value = field.value(editor);
        let edit = egui::TextEdit::singleline(value).desired_width(150.0).hint_text(hint);
        let response = ui.add(edit).labelled_by(name.id);
        let entered = response.lost_focus() && ui.input(|i| i.key_pressed(egui::Key::Enter));
        if ui.button(button).clicked() || entered {
            chosen = Some(PathBuf::from(value.trim()));
        }
        browse = ui.button("…").on_hover_text("Choose a file").clicked();
    });
    if browse {
        let current = field.value(editor).clone();
        editor.browse(purpose, &current);
    }
    chosen.filter(|p| !p.as_os_str().is_empty())
}

/// The path fields of the panels.
#[derive(Clone, Copy)]
enum Field {
    Scene,
    Garment,
    Body,
    Motion,
    Fabric,
}

impl Field {
    fn describe(self) -> (&'static str, Purpose) {
        match self {
            Field::Scene => ("Scene", Purpose::OpenScene),
            Field::Garment => ("OBJ", Purpose::Garment),
            Field::Body => ("Body", Purpose::Body),
            Field::Motion => ("Motion", Purpose::Motion),
            Field::Fabric => ("File", Purpose::LoadFabric),
        }
    }

    fn value(self, editor: &mut Editor) -> &mut String {
        let paths = &mut editor.paths;
        match self {
            Field::Scene => &mut paths.scene,
            Field::Garment => &mut paths.garment,
            Field::Body => &mut paths.body,
            Field::Motion => &mut paths.motion,
            Field::Fabric => &mut paths.fabric,
        }
    }
}

fn scene_panel(ui: &mut Ui, editor: &mut Editor) {
    let hint = "path/to/scene.toml";
    if let Some(path) = path_row(ui, editor, Field::Scene, "Open", hint) {
        editor.open_scene(path);
    }
    ui.horizontal(|ui| {
        if ui.button("Save").on_hover_text("Write the scene file with every current setting").clicked() {
            let path = PathBuf::from(editor.paths.scene.trim());
            editor.save_scene(&path);
        }
        if ui.button("Save as…").on_hover_text("Save the scene under another name").clicked() {
            let current = editor.paths.scene.clone();
            editor.browse(Purpose::SaveScene, &current);
        }
        ui.label(format!("{} frames at {} fps", editor.scene.frame_count, editor.scene.fps));
    });
    ui.separator();
    garment_fields(ui, editor);
    ui.separator();
    body_fields(ui, editor);
    ui.label("Or drop an OBJ, FBX, .motion or scene file on the window.");
}

fn garment_fields(ui: &mut Ui, editor: &mut Editor) {
    let names: Vec<String> = editor.scene.garments.iter().map(|g| g.name.clone()).collect();
    let mut chosen = editor.garment;
    egui::ComboBox::from_label("Garment").selected_text(names.get(chosen).cloned().unwrap_or_default()).show_ui(
        ui,
        |ui| {
            for (k, name) in names.iter().enumerate() {
                ui.selectable_value(&mut chosen, k, name.as_str());
            }
        },
    );
    if chosen != editor.garment {
        editor.garment = chosen;
        editor.paths.garment = match editor.scene.file.garments.get(chosen).map(|g| &g.mesh) {
            Some(crate::scene::file::MeshSpec::Obj(obj)) => obj.display().to_string(),
            _ => String::new(),
        };
    }
    let g = editor.garment;
    if let Some(path) = path_row(ui, editor, Field::Garment, "Load OBJ", "garment.obj") {
        editor.use_garment_mesh(path);
    }
    let Some(spec) = editor.scene_file().garments.get(g) else { return };
    let (mut translation, mut rotation, mut scale) = (spec.translation_m, spec.rotation_deg, spec.scale);
    let mut changed = false;
    egui::Grid::new("garment transform").num_columns(2).show(ui, |ui| {
        ui.label("Move (m)").on_hover_text("Translation of the garment relative to the body, metres");
        changed |= vector_fields(ui, &mut translation, 0.005);
        ui.end_row();
        ui.label("Rotate (°)").on_hover_text("Rotation about X, Y, Z, degrees");
        changed |= vector_fields(ui, &mut rotation, 0.5);
        ui.end_row();
        let label = ui.label("Scale").on_hover_text("Uniform scale factor");
        changed |=
            ui.add(egui::DragValue::new(&mut scale).speed(0.005).range(0.01..=100.0)).labelled_by(label.id).changed();
        ui.end_row();
    });
    if changed {
        editor.edit_scene("garment placement", |file| {
            if let Some(spec) = file.garments.get_mut(g) {
                (spec.translation_m, spec.rotation_deg, spec.scale) = (translation, rotation, scale);
            }
        });
    }
}

/// X, Y and Z fields of a vector; true when one changed.
fn vector_fields(ui: &mut Ui, v: &mut [f64; 3], speed: f64) -> bool {
    ui.horizontal(|ui| {
        let mut changed = false;
        for (c, axis) in v.iter_mut().zip(["X", "Y", "Z"]) {
            let label = ui.label(axis);
            changed |= ui.add(egui::DragValue::new(c).speed(speed)).labelled_by(label.id).changed();
        }
        changed
    })
    .inner
}

fn body_fields(ui: &mut Ui, editor: &mut Editor) {
    if editor.scene.file.bodies.is_empty() {
        ui.label("No body in this scene yet.");
        if let Some(path) = path_row(ui, editor, Field::Body, "Load body", "body.fbx or walk.motion") {
            editor.use_body(path);
        }
        return;
    }
    after_the_motion(ui, editor);
    let mut body_only = editor.timeline.body_only;
    let tip = "Play the body's motion alone over the whole frame range, without the cloth";
    if ui.checkbox(&mut body_only, "Preview the motion alone").on_hover_text(tip).changed() {
        editor.timeline.set_body_only(body_only);
    }
    if let Some(path) = path_row(ui, editor, Field::Body, "Load body", "body.fbx or walk.motion") {
        editor.use_body(path);
    }
    let hint = "other.fbx (bones matched by name)";
    if let Some(path) = path_row(ui, editor, Field::Motion, "Use motion", hint) {
        editor.use_motion(path);
    }
    body_meshes_ui(ui, editor);
}

/// The first body's meshes, each kept or left out by a tick, and its
/// animation stacks to choose from.
/// What the body does once its motion ends, while the cloth simulates on.
fn after_the_motion(ui: &mut Ui, editor: &mut Editor) {
    let cycles = editor.scene_file().bodies.first().is_some_and(|b| b.cycle);
    let mut chosen = cycles;
    let name = |cycle: bool| if cycle { "Loop the motion" } else { "Hold the last pose" };
    egui::ComboBox::from_label("After the motion").selected_text(name(chosen)).show_ui(ui, |ui| {
        for option in [false, true] {
            ui.selectable_value(&mut chosen, option, name(option));
        }
    })
    .response
    .on_hover_text("What the body does when its motion ends and the cloth simulates on: loop a cycle such as an in-place walk, or stand still");
    if chosen != cycles {
        editor.edit_scene(if chosen { "loop the motion" } else { "hold the last pose" }, |file| {
            if let Some(body) = file.bodies.first_mut() {
                body.cycle = chosen;
            }
        });
    }
}

fn body_meshes_ui(ui: &mut Ui, editor: &mut Editor) {
    let Some(loaded) = editor.scene.bodies.first().map(|b| b.loaded.clone()) else { return };
    if loaded.meshes.len() > 1 {
        let mut toggled = None;
        ui.horizontal_wrapped(|ui| {
            ui.label("Meshes").on_hover_text("The body's meshes the cloth collides with and the viewport shows");
            for name in &loaded.meshes {
                let mut kept = loaded.parts.iter().any(|p| &p.name == name);
                let kind = loaded.parts.iter().find(|p| &p.name == name).map_or("left out", |p| p.kind);
                if ui.checkbox(&mut kept, name.as_str()).on_hover_text(kind).changed() {
                    toggled = Some((name.clone(), kept));
                }
            }
        });
        if let Some((name, keep)) = toggled {
            editor.keep_body_mesh(&name, keep);
        }
    }
    if loaded.stacks.len() > 1 {
        let current = loaded.stack.clone().unwrap_or_default();
        let mut chosen = None;
        egui::ComboBox::from_label("Animation").selected_text(current.as_str()).show_ui(ui, |ui| {
            for name in &loaded.stacks {
                if ui.selectable_label(*name == current, name.as_str()).clicked() && *name != current {
                    chosen = Some(name.clone());
                }
            }
        });
        if let Some(name) = chosen {
            editor.use_stack(name);
        }
    }
}

fn fabric(ui: &mut Ui, editor: &mut Editor) {
    let g = editor.garment;
    let current = editor.scene.file.garments.get(g).map(|s| s.preset.clone()).unwrap_or_default();
    let mut preset = None;
    egui::ComboBox::from_label("Preset").selected_text(current.as_str()).show_ui(ui, |ui| {
        for name in Preset::builtin_names() {
            if ui.selectable_label(current == name, name).clicked() {
                preset = Some(name.to_owned());
            }
        }
    });
    if let Some(name) = preset {
        editor.choose_preset(&name);
    }
    if let Some(garment) = editor.scene.garments.get(g) {
        ui.label(egui::RichText::new(&garment.preset.about.feel).italics());
    }
    if let Some(path) = path_row(ui, editor, Field::Fabric, "Load preset", "fabric.toml") {
        editor.choose_preset(&path.display().to_string());
    }
    if ui.button("Save parameters…").on_hover_text("Write these parameters as a preset file").clicked() {
        let current = editor.paths.fabric.clone();
        editor.browse(Purpose::SaveFabric, &current);
    }
    let Some(garment) = editor.scene.garments.get_mut(g) else { return };
    if let Some(parameter) = fabric_panel::sliders(ui, &mut garment.fabric) {
        editor.fabric_changed(parameter);
    }
}

fn collision(ui: &mut Ui, editor: &mut Editor) {
    let g = editor.garment;
    ui.label("Friction and thickness are the fabric's: the Fabric panel sets them, live.");
    let mut settings = editor.scene_file().collision.clone();
    let mut self_collision = editor.scene_file().garments.get(g).is_some_and(|s| s.self_collision);
    let mut changed = false;
    let tip = "Keep the garment out of itself (folds, layers); restarts the simulation";
    changed |= ui.checkbox(&mut self_collision, "Self-collision").on_hover_text(tip).changed();
    let advanced = egui::CollapsingHeader::new("Advanced").id_salt("collision advanced");
    advanced.show(ui, |ui| {
        ui.label("The contact solver's settings (PAPER §4); changing one restarts the simulation.");
        changed |= solver_knobs(ui, &mut settings);
    });
    if changed {
        editor.edit_scene("collision settings", move |file| {
            file.collision = settings;
            if let Some(spec) = file.garments.get_mut(g) {
                spec.self_collision = self_collision;
            }
        });
    }
}

/// The collision pipeline's settings; true when one changed.
fn solver_knobs(ui: &mut Ui, settings: &mut crate::scene::file::CollisionSettings) -> bool {
    let mut changed = false;
    egui::Grid::new("collision settings").num_columns(2).show(ui, |ui| {
        let mut row = |ui: &mut Ui, name: &str, tip: &str, widget: &mut dyn FnMut(&mut Ui) -> egui::Response| {
            let label = ui.label(name).on_hover_text(tip);
            changed |= widget(ui).labelled_by(label.id).changed();
            ui.end_row();
        };
        let tip = "Detect-and-respond passes per step before impact zones take over";
        row(ui, "Passes", tip, &mut |ui| ui.add(egui::DragValue::new(&mut settings.passes).range(1..=50)));
        let tip = "Share of the contacts' shortfall a pass must remove for another pass to run (0: off)";
        row(ui, "Pass progress", tip, &mut |ui| ui.add(egui::Slider::new(&mut settings.pass_progress, 0.0..=0.9)));
        let tip = "How fast a contact's influence fades when it is not seen again (eq. 16)";
        row(ui, "Influence decay", tip, &mut |ui| {
            ui.add(egui::Slider::new(&mut settings.influence_decay, 0.05..=0.95))
        });
        let tip = "Influence at which contacts are solved together (semi-global constraints)";
        row(ui, "Influence threshold", tip, &mut |ui| {
            ui.add(egui::Slider::new(&mut settings.influence_threshold, 0.5..=10.0))
        });
        let tip = "Sweeps over the contacts solved together (eq. 16) in each pass";
        row(ui, "Constraint sweeps", tip, &mut |ui| {
            ui.add(egui::DragValue::new(&mut settings.constraint_sweeps).range(1..=100))
        });
        let tip = "Springs pushing the cloth's resting self-contacts apart in the solve, N/m (0: off)";
        row(ui, "Repulsion", tip, &mut |ui| {
            ui.add(egui::Slider::new(&mut settings.repulsion_stiffness_n_per_m, 0.0..=20.0).suffix(" N/m"))
        });
        let tip =
            "Springs pushing the cloth off the colliders' sharp edges and tips it rests on, in the solve, N/m (0: off)";
        row(ui, "Edge repulsion", tip, &mut |ui| {
            let stiffness = &mut settings.feature_repulsion_stiffness_n_per_m;
            ui.add(egui::Slider::new(stiffness, 0.0..=100.0).suffix(" N/m"))
        });
        let tip = "Springs holding the cloth on the tips of thin props it rests on as on a point (needles), in the \
                   solve, N/m (0: off)";
        row(ui, "Tip repulsion", tip, &mut |ui| {
            let stiffness = &mut settings.tip_repulsion_stiffness_n_per_m;
            ui.add(egui::Slider::new(stiffness, 0.0..=500.0).suffix(" N/m"))
        });
        let tip = "Rounds of rigid impact zones before a step gives up";
        row(ui, "Impact-zone rounds", tip, &mut |ui| {
            ui.add(egui::DragValue::new(&mut settings.zone_rounds).range(1..=200))
        });
    });
    changed
}

fn accuracy(ui: &mut Ui, editor: &mut Editor) {
    ui.label(
        "How far the simulated frames are from a reference run of this scene with 16× smaller steps and a \
         tight solver tolerance (RMS over the vertices, relative to the cloth's size).",
    );
    let mut cancel = false;
    match &editor.reference_job {
        Some(job) => {
            let (done, total) = (job.done, job.total);
            ui.horizontal(|ui| {
                let fraction = done as f32 / total.max(1) as f32;
                ui.add(egui::ProgressBar::new(fraction).text(format!("reference {done}/{total}")).desired_width(200.0));
                cancel = ui.button("Cancel").clicked();
            });
        }
        None => {
            let tip = "Runs in the background; changing the fabric discards it";
            if ui.button("Compute reference").on_hover_text(tip).clicked() {
                editor.compute_reference();
            }
        }
    }
    if cancel {
        editor.cancel_reference();
    }
    if let (Some(reference), Some((mean, last))) = (&editor.reference, editor.run_error()) {
        let mm = |e: f64| e * reference.diagonal_m * 1e3;
        ui.label(format!(
            "reference at {} steps/frame; these frames: mean error {:.2} % ({:.1} mm), newest {:.2} % ({:.1} mm)",
            reference.steps_per_frame,
            mean * 100.0,
            mm(mean),
            last * 100.0,
            mm(last)
        ));
    }
}

fn camera(ui: &mut Ui, editor: &mut Editor) {
    if ui.button("Frame all").on_hover_text("Back to the scene's framing").clicked() {
        editor.camera.frame_all();
    }
    let mut turntable = editor.camera.turntable_period_s.is_some();
    if ui.checkbox(&mut turntable, "Turntable").changed() {
        editor.camera.turntable_period_s = turntable.then_some(8.0);
    }
    if let Some(period) = &mut editor.camera.turntable_period_s {
        ui.add(egui::Slider::new(period, 2.0..=60.0).text("s per turn"));
    }
    ui.label("Left drag: orbit · right or middle drag: pan · wheel: zoom");
}

fn messages(ctx: &egui::Context, editor: &mut Editor) {
    if editor.messages.is_empty() {
        return;
    }
    let mut dismissed = None;
    egui::Area::new(egui::Id::unique("messages")).anchor(Align2::RIGHT_BOTTOM, Vec2::new(-12.0, -60.0)).show(
        ctx,
        |ui| {
            for (k, message) in editor.messages.iter().enumerate() {
                let fill = if message.error { Color32::from_rgb(110, 30, 30) } else { Color32::from_rgb(30, 60, 40) };
                egui::Frame::popup(ui.style()).fill(fill).show(ui, |ui| {
                    ui.set_max_width(420.0);
                    ui.horizontal(|ui| {
                        ui.label(egui::RichText::new(&message.text).color(Color32::WHITE));
                        if message.error && ui.small_button("Dismiss").on_hover_text("Dismiss").clicked() {
                            dismissed = Some(k);
                        }
                    });
                });
            }
        },
    );
    if let Some(k) = dismissed {
        editor.messages.remove(k);
    }
}

/// The question asked before an action would lose unsaved changes.
fn unsaved_question(ctx: &egui::Context, editor: &mut Editor) {
    let Some(action) = editor.pending.clone() else { return };
    let doing = match &action {
        Pending::Quit => "quitting".to_owned(),
        Pending::Open(path) => format!("opening {}", path.display()),
        Pending::Reload => "reading the scene file again".to_owned(),
        Pending::New => "starting a new scene".to_owned(),
    };
    egui::Modal::new(egui::Id::unique("unsaved")).show(ctx, |ui| {
        ui.heading("Unsaved changes");
        ui.label(format!("Save the changes to '{}' before {doing}?", editor.scene.name));
        ui.horizontal(|ui| {
            if ui.button("Save").clicked() {
                let path = PathBuf::from(editor.paths.scene.trim());
                editor.save_scene(&path);
                match editor.dirty() {
                    true => editor.pending = None,
                    false => editor.carry_out(action.clone()),
                }
            }
            if ui.button("Discard").clicked() {
                editor.carry_out(action.clone());
            }
            if ui.button("Cancel").clicked() {
                editor.pending = None;
            }
        });
    });
}
