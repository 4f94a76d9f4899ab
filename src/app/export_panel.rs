//! The Export panel: the bake folder, USD / glTF / MDD, and PNG images of
//! this view or the scene camera at a chosen size.

use egui::Ui;

use super::dialog::Purpose;
use super::editor::Editor;
use super::export::ExportKind;
use crate::export::Format;

/// Image sizes offered for PNG frames: name, pixels (`None`: the viewport's).
const IMAGE_SIZES: [(&str, Option<(u32, u32)>); 5] = [
    ("1280 × 720", Some((1280, 720))),
    ("1920 × 1080", Some((1920, 1080))),
    ("3840 × 2160", Some((3840, 2160))),
    ("1080 × 1350 (portrait)", Some((1080, 1350))),
    ("as the viewport", None),
];

/// The Export panel's contents.
pub(super) fn export(ui: &mut Ui, editor: &mut Editor) {
    let mut browse = false;
    ui.horizontal(|ui| {
        let name = ui.label("Folder");
        ui.add(egui::TextEdit::singleline(&mut editor.paths.export).desired_width(180.0)).labelled_by(name.id);
        browse = ui.button("…").on_hover_text("Choose the export folder (kept in the scene file)").clicked();
    });
    if browse {
        let current = editor.paths.export.clone();
        editor.browse(Purpose::ExportFolder, &current);
    }
    let free = editor.export.is_none();
    ui.label("For other tools, with the body:");
    ui.horizontal(|ui| {
        let formats = [
            (Format::Usd, "USD", "One .usda with the body: Maya, Houdini, Unreal, Omniverse, Blender"),
            (Format::Gltf, "glTF", "One .glb with the body, a morph target per frame: browsers, three.js, Blender"),
            (Format::Mdd, "MDD", "A point cache per garment: Marvelous Designer, Houdini, Modo"),
        ];
        for (format, label, tip) in formats {
            if ui.add_enabled(free, egui::Button::new(label)).on_hover_text(tip).clicked() {
                editor.export(ExportKind::Format(format));
            }
        }
        if ui.add_enabled(free, egui::Button::new("OBJ + PC2")).on_hover_text("OBJ sequence and point caches").clicked()
        {
            editor.export(ExportKind::Geometry);
        }
    });
    ui.label("Pictures, as the viewport shows them (with the fit map and its legend):");
    image_choices(ui, editor);
    let tip = "PNG frames frame_NNNN.png in the export folder";
    if ui.add_enabled(free, egui::Button::new("Export PNG")).on_hover_text(tip).clicked() {
        editor.export_images();
    }
}

fn image_choices(ui: &mut Ui, editor: &mut Editor) {
    let choices = &mut editor.images;
    ui.horizontal(|ui| {
        ui.radio_value(&mut choices.through_view, true, "This view").on_hover_text("The camera as you placed it");
        ui.radio_value(&mut choices.through_view, false, "Scene camera").on_hover_text("The scene file's camera");
    });
    ui.horizontal(|ui| {
        ui.radio_value(&mut choices.all_frames, true, "Every frame");
        ui.radio_value(&mut choices.all_frames, false, "This frame");
    });
    let name = IMAGE_SIZES.iter().find(|(_, s)| *s == choices.size).map_or("", |(n, _)| n);
    egui::ComboBox::from_label("Size").selected_text(name).show_ui(ui, |ui| {
        for (label, size) in IMAGE_SIZES {
            ui.selectable_value(&mut choices.size, size, label);
        }
    });
}
