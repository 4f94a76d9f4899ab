//! The editor driven through its UI by the labels a user reads (egui_kittest
//! over AccessKit): live tuning reaches the simulation worker, presets fill
//! every slider, Bake fills the timeline, the light switch changes the
//! viewport image, a bad garment file is refused with the previous scene kept.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use drape::app::Editor;
use drape::app::blit::BlitPipeline;
use drape::app::editor::{FrameKind, RunState};
use drape::app::fabric_panel::PARAMETERS;
use drape::app::panels::editor_ui;
use drape::app::viewport::Viewport;
use drape::bake;
use drape::render::Gpu;
use drape::render::target::read_texture;
use drape::scene::Scene;
use drape::scene::preset::Preset;
use egui::accesskit::Role;
use egui_kittest::Harness;
use egui_kittest::kittest::{NodeT, Queryable};

/// A small cloth over a sphere: bakes in seconds.
const SMALL_SCENE: &str = r#"
[time]
fps = 30.0
duration_s = 0.5
[solver]
steps_per_frame = 2
[[garment]]
name = "cloth"
preset = "cotton"
mesh = { grid = { size_m = 0.8, resolution = 24 } }
translation_m = [0.0, 0.7, 0.0]
self_collision = true
[[collider]]
name = "ball"
shape = { sphere = { radius_m = 0.25 } }
position_m = [0.0, 0.4, 0.0]
[[collider]]
name = "ground"
shape = "plane"
"#;

fn small_scene(dir: &Path) -> Scene {
    let path = dir.join("small.toml");
    std::fs::write(&path, SMALL_SCENE).unwrap();
    Scene::load(&path).unwrap_or_else(|e| panic!("{e}"))
}

fn harness(editor: Editor) -> Harness<'static, Editor> {
    Harness::builder().with_size(egui::Vec2::new(1400.0, 1000.0)).build_ui_state(
        |ui, editor: &mut Editor| {
            editor.update(0.0);
            editor_ui(ui, editor, false);
        },
        editor,
    )
}

/// Lets the worker report until `done` holds (or fails after a minute).
fn wait_until(harness: &mut Harness<'_, Editor>, what: &str, done: impl Fn(&Editor) -> bool) {
    let deadline = Instant::now() + Duration::from_secs(120);
    while !done(harness.state()) {
        assert!(Instant::now() < deadline, "timed out waiting for {what}");
        harness.state_mut().wait_for_worker(Duration::from_millis(200));
    }
    // Let the layout settle (panels change size when a run ends).
    harness.run_steps(3);
}

/// The fabric panel's slider labelled `label`.
fn fabric_parameter(label: &str) -> &'static drape::app::fabric_panel::Parameter {
    PARAMETERS.iter().find(|p| p.label == label).unwrap_or_else(|| panic!("no fabric slider '{label}'"))
}

/// Sets the fabric slider `label` to the SI `value` as a user would drag it
/// (on its named scale, in g/m² or mm).
fn set_fabric(harness: &Harness<'_, Editor>, label: &str, value: f64) {
    let shown = fabric_parameter(label).shown(value);
    harness.get_by_role_and_label(Role::Slider, label).set_value_accesskit(shown);
}

/// Whether `a` and `b` agree to 1e-9 of their size (a slider's scale and back).
fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-9 * a.abs().max(b.abs())
}

fn slider_value(harness: &Harness<'_, Editor>, label: &str) -> f64 {
    let node = harness.get_by_role_and_label(Role::Slider, label);
    node.accesskit_node().numeric_value().unwrap_or_else(|| panic!("slider '{label}' has no value"))
}

#[test]
fn moving_the_stretch_slider_changes_the_workers_fabric() {
    let dir = tempfile::tempdir().unwrap();
    let mut h = harness(Editor::new(small_scene(dir.path())));
    h.run_steps(2);
    assert_eq!(h.state().simulated_fabrics[0].stretch_stiffness_n_per_m, 1500.0, "cotton");
    set_fabric(&h, "Stretch", 3000.0);
    h.run_steps(2);
    assert!(close(h.state().scene.garments[0].fabric.stretch_stiffness_n_per_m, 3000.0));
    wait_until(&mut h, "the worker to take the new stiffness", |e| {
        close(e.simulated_fabrics[0].stretch_stiffness_n_per_m, 3000.0)
    });
    assert!(h.state().dirty(), "an edit marks the scene unsaved");
}

/// Contact (PAPER Fig. 10c): the garment's thickness and friction change
/// live in the fabric panel, the one place they are; a pipeline
/// setting restarts the simulation with the scene edited, and a second one
/// (the edge repulsion) made while the first (constraint sweeps) may still be
/// loading keeps the first.
#[test]
fn contact_changes_live_and_the_collision_pipeline_by_restart() {
    let dir = tempfile::tempdir().unwrap();
    let mut h = harness(Editor::new(small_scene(dir.path())));
    h.run_steps(2);
    set_fabric(&h, "Thickness", 0.004);
    set_fabric(&h, "Friction", 0.8);
    h.run_steps(2);
    let fabric = &h.state().scene.garments[0].fabric;
    assert!(close(fabric.thickness_m, 0.004) && close(fabric.friction, 0.8));
    assert_eq!(slider_value(&h, "Thickness"), 4.0, "shown in mm");
    wait_until(&mut h, "the worker to take the new contact", |e| {
        close(e.simulated_fabrics[0].thickness_m, 0.004) && close(e.simulated_fabrics[0].friction, 0.8)
    });
    h.get_by_label("Collision").click();
    h.run_steps(2);
    h.get_all_by_label("Advanced").last().expect("the collision panel's Advanced fold").click();
    h.run_steps(2);

    h.get_by_role_and_label(Role::SpinButton, "Constraint sweeps").set_value_accesskit(12.0);
    h.run_steps(2);
    h.get_by_role_and_label(Role::Slider, "Edge repulsion").set_value_accesskit(45.0);
    h.run_steps(2);
    h.state_mut().finish_loading();
    h.run_steps(3);
    let collision = &h.state().scene.file.collision;
    assert_eq!((collision.constraint_sweeps, collision.feature_repulsion_stiffness_n_per_m), (12, 45.0));
    assert!(close(h.state().scene.garments[0].fabric.thickness_m, 0.004), "the live edit survives the restart");
}

#[test]
fn choosing_a_preset_sets_every_slider_to_its_values() {
    let dir = tempfile::tempdir().unwrap();
    let mut h = harness(Editor::new(small_scene(dir.path())));
    h.run_steps(2);
    h.get_by_role_and_label(Role::ComboBox, "Preset").click();
    h.run_steps(2);
    h.get_by_label("denim").click();
    h.run_steps(3);
    let mut denim = Preset::builtin("denim").unwrap().fabric;
    assert_eq!(h.state().scene.garments[0].fabric, denim);
    h.get_all_by_label("Advanced").next().expect("the fabric panel's Advanced fold").click();
    h.run_steps(2);
    for p in &PARAMETERS {
        let expected = p.shown(*(p.value)(&mut denim));
        let shown = slider_value(&h, p.label);
        assert!((shown - expected).abs() <= 1e-9 * expected.abs(), "{}: slider {shown}, denim {expected}", p.label);
    }
    wait_until(&mut h, "the worker to take denim", |e| e.simulated_fabrics[0] == e.scene.garments[0].fabric);
}

#[test]
fn bake_reaches_every_frame_and_the_timeline_scrubs_them() {
    let dir = tempfile::tempdir().unwrap();
    let mut h = harness(Editor::new(small_scene(dir.path())));
    h.run_steps(2);
    let frames = h.state().scene.frame_count;
    h.get_by_label("Bake").click();
    h.run_steps(2);
    assert!(matches!(h.state().run, RunState::Baking { .. }));
    wait_until(&mut h, "the bake", |e| e.run == RunState::Idle);
    let editor = h.state();
    assert_eq!(editor.bake_progress, Some((frames, frames)), "progress reached 100 %");
    assert_eq!(editor.timeline.len(), frames + 1, "frame 0 and every baked frame");
    let last = editor.timeline.newest().unwrap();
    assert_eq!(last.record.intersections.pairs(), 0);
    let lowest = last.positions.iter().map(|p| p.y).fold(f64::INFINITY, f64::min);
    assert!(lowest < 0.6, "the cloth fell from 0.7 m onto the ball: lowest {lowest} m");
    assert!(editor.messages.iter().any(|m| m.text.contains(&format!("baked {frames} frames"))));
    h.get_by_label("<").click();
    h.run_steps(2);
    assert_eq!(h.state().timeline.current(), frames - 1, "stepped back one frame");
}

#[test]
fn switching_the_light_changes_the_viewport_image() {
    let dir = tempfile::tempdir().unwrap();
    let gpu = Gpu::headless().unwrap_or_else(|e| panic!("{e}"));
    let mut ui_renderer =
        egui_wgpu::Renderer::new(&gpu.device, wgpu::TextureFormat::Rgba8Unorm, egui_wgpu::RendererOptions::default());
    let mut viewport = Viewport::new(&gpu, wgpu::TextureFormat::Rgba8Unorm).expect("lavapipe runs the renderer");
    viewport.resolution_scale = 1.0;
    let mut h = harness(Editor::new(small_scene(dir.path())));
    wait_until(&mut h, "frame 0", |e| !e.timeline.is_empty());
    let mut render = |h: &mut Harness<'_, Editor>| {
        viewport.render(h.state_mut(), [240, 160], &mut ui_renderer);
        viewport.image().unwrap().unwrap()
    };
    let studio = render(&mut h);
    h.get_by_role_and_label(Role::ComboBox, "Light").click();
    h.run_steps(2);
    h.get_by_label("evening").click();
    h.run_steps(2);
    assert_eq!(h.state().light_rig().name, "evening");
    let evening = render(&mut h);
    let luminance = |image: &image::RgbaImage| {
        image
            .pixels()
            .map(|p| 0.2126 * f64::from(p[0]) + 0.7152 * f64::from(p[1]) + 0.0722 * f64::from(p[2]))
            .sum::<f64>()
            / f64::from(image.width() * image.height())
    };
    let (a, b) = (luminance(&studio), luminance(&evening));
    assert!(a > 5.0 && b > 5.0, "neither image is black: {a}, {b}");
    assert!((a - b).abs() > 2.0, "mean luminance moved: studio {a:.1}, evening {b:.1}");
}

#[test]
fn on_a_software_rasteriser_a_still_view_is_drawn_again_anti_aliased() {
    let dir = tempfile::tempdir().unwrap();
    let gpu = Gpu::headless().unwrap_or_else(|e| panic!("{e}"));
    let software = gpu.software;
    // Lavapipe (whose rasteriser is llvmpipe) must count as one.
    assert_eq!(software, gpu.adapter_name.contains("llvmpipe"), "{}", gpu.adapter_name);
    let mut ui_renderer =
        egui_wgpu::Renderer::new(&gpu.device, wgpu::TextureFormat::Rgba8Unorm, egui_wgpu::RendererOptions::default());
    let mut viewport = Viewport::new(&gpu, wgpu::TextureFormat::Rgba8Unorm).expect("lavapipe runs the renderer");
    viewport.resolution_scale = 1.0;
    let mut h = harness(Editor::new(small_scene(dir.path())));
    wait_until(&mut h, "frame 0", |e| !e.timeline.is_empty() && !e.is_animating());
    let mut render = |h: &mut Harness<'_, Editor>| {
        viewport.render(h.state_mut(), [240, 160], &mut ui_renderer);
        (viewport.image().unwrap().unwrap(), viewport.needs_refinement())
    };
    let (first, refine) = render(&mut h);
    assert_eq!(refine, software, "a new view is drawn at one sample only on a software rasteriser");
    let (second, refine) = render(&mut h);
    assert!(!refine, "the still view is anti-aliased on the next redraw");
    let mean_difference = first
        .pixels()
        .zip(second.pixels())
        .map(|(p, q)| (0..3).map(|c| f64::from(p[c].abs_diff(q[c]))).sum::<f64>())
        .sum::<f64>()
        / f64::from(first.width() * first.height() * 3 * 255);
    assert!(mean_difference < 0.01, "the same view, up to its edges: {mean_difference}");
    assert_eq!(mean_difference > 0.0, software, "the edges changed only where the first image was not anti-aliased");
    h.state_mut().simulate();
    wait_until(&mut h, "frame 1", |e| e.timeline.len() > 1);
    let (_, refine) = render(&mut h);
    assert_eq!(
        refine, software,
        "while the cloth simulates, new frames are drawn at one sample on a software rasteriser"
    );
}

#[test]
fn the_viewport_blit_copies_its_image_texel_for_texel() {
    use wgpu::util::DeviceExt;
    let gpu = Gpu::headless().unwrap_or_else(|e| panic!("{e}"));
    let (width, height) = (64, 32);
    let texels: Vec<u8> = (0..width * height)
        .flat_map(|i| [(i % width * 4) as u8, (i / width * 8) as u8, (i * 7 % 256) as u8, (i % 128 + 64) as u8])
        .collect();
    let size = wgpu::Extent3d { width, height, depth_or_array_layers: 1 };
    let texture = |usage| wgpu::TextureDescriptor {
        label: None,
        size,
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: wgpu::TextureFormat::Rgba8Unorm,
        usage,
        view_formats: &[],
    };
    let source = gpu.device.create_texture_with_data(
        &gpu.queue,
        &texture(wgpu::TextureUsages::TEXTURE_BINDING),
        wgpu::util::TextureDataOrder::LayerMajor,
        &texels,
    );
    let target =
        gpu.device.create_texture(&texture(wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC));
    let image = BlitPipeline::new(&gpu.device, wgpu::TextureFormat::Rgba8Unorm)
        .image(&gpu.device, &source.create_view(&Default::default()));
    let mut encoder = gpu.device.create_command_encoder(&Default::default());
    {
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: &target.create_view(&Default::default()),
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations { load: wgpu::LoadOp::Clear(wgpu::Color::RED), store: wgpu::StoreOp::Store },
            })],
            ..Default::default()
        });
        image.draw(&mut pass);
    }
    gpu.queue.submit([encoder.finish()]);
    let copied = read_texture(&gpu, &target, (width, height)).unwrap();
    assert_eq!(copied.into_raw(), texels, "every texel lands on its pixel, unblended");
}

#[test]
fn a_malformed_garment_obj_is_reported_and_the_scene_kept() {
    let dir = tempfile::tempdir().unwrap();
    let bad: PathBuf = dir.path().join("broken.obj");
    std::fs::write(&bad, "v 0 0 0\nv 1 0\nf 1 2 3\n").unwrap();
    let mut h = harness(Editor::new(small_scene(dir.path())));
    h.run_steps(2);
    let vertices = h.state().scene.garments[0].mesh.vertex_count();
    let generation = h.state().generation;
    h.get_by_role_and_label(Role::TextInput, "OBJ").set_text_value_accesskit(&bad.display().to_string());
    h.run_steps(2);
    h.get_by_label("Load OBJ").click();
    h.run_steps(2);
    h.state_mut().finish_loading();
    h.run_steps(3);
    let editor = h.state();
    assert_eq!(editor.scene.garments[0].mesh.vertex_count(), vertices, "the previous garment stays");
    assert_eq!(editor.generation, generation, "nothing was redrawn");
    let error = editor.messages.iter().find(|m| m.error).expect("an error is shown");
    assert!(error.text.contains("broken.obj"), "names the file: {}", error.text);
    h.get_by_label_contains("broken.obj");
}

/// Lets exports report until none is running.
fn wait_for_export(harness: &mut Harness<'_, Editor>) {
    let deadline = Instant::now() + Duration::from_secs(120);
    while harness.state().export.is_some() {
        assert!(Instant::now() < deadline, "timed out waiting for the export");
        std::thread::sleep(Duration::from_millis(20));
        harness.state_mut().update(0.0);
    }
    harness.run_steps(3);
}

#[test]
fn a_saved_scene_reopens_to_the_same_bake_and_the_export_holds_it() {
    let dir = tempfile::tempdir().unwrap();
    let mut h = harness(Editor::new(small_scene(dir.path())));
    h.run_steps(2);
    h.get_by_role_and_label(Role::ComboBox, "Quality").click();
    h.run_steps(2);
    h.get_by_label("Final").click();
    h.run_steps(2);
    set_fabric(&h, "Bending", 4e-5);
    h.run_steps(2);
    h.get_by_label("Bake").click();
    h.run_steps(2);
    wait_until(&mut h, "the bake", |e| e.run == RunState::Idle);

    let out = dir.path().join("export");
    h.get_by_role_and_label(Role::TextInput, "Folder").set_text_value_accesskit(&out.display().to_string());
    h.run_steps(2);
    h.get_by_label("OBJ + PC2").click();
    h.run_steps(2);
    wait_for_export(&mut h);
    let frames = h.state().scene.frame_count;
    assert!(out.join(format!("frame_{frames:04}.obj")).is_file() && out.join("cloth.pc2").is_file());
    assert!(h.state().messages.iter().any(|m| m.text.starts_with("exported to")));

    h.get_by_label("Save").click();
    h.run_steps(2);
    assert!(!h.state().dirty(), "saved");
    let reopened = Scene::load(&dir.path().join("small.toml")).unwrap_or_else(|e| panic!("{e}"));
    assert!(close(reopened.garments[0].fabric.bend_stiffness_n_m, 4e-5));
    assert_eq!(reopened.steps_per_frame, 4, "Final quality: twice the scene's 2 steps");
    let cancel = std::sync::atomic::AtomicBool::new(false);
    let mut last = Vec::new();
    bake::run(&reopened, frames, &cancel, |sim, _| {
        last = sim.positions().to_vec();
        Ok(())
    })
    .unwrap();
    let editor_last = h.state().timeline.newest().unwrap().positions.clone();
    assert_eq!(*editor_last, last, "the reopened scene bakes to the editor's frames, bit for bit");
}

#[test]
fn quitting_with_unsaved_changes_asks_first() {
    let dir = tempfile::tempdir().unwrap();
    let mut h = harness(Editor::new(small_scene(dir.path())));
    h.run_steps(2);
    assert!(h.state_mut().request_quit(), "nothing to lose: the window closes");
    set_fabric(&h, "Weight", 0.2);
    h.run_steps(2);
    assert!(!h.state_mut().request_quit(), "unsaved changes keep the window open");
    h.run_steps(3);
    h.get_by_label("Unsaved changes");
    h.get_by_label("Cancel").click();
    h.run_steps(3);
    assert!(!h.state().quit && h.query_by_label("Unsaved changes").is_none());
    assert!(!h.state_mut().request_quit());
    h.run_steps(3);
    h.get_by_label("Discard").click();
    h.run_steps(2);
    assert!(h.state().quit, "discarding closes the window");
}

#[test]
fn file_dialogs_offer_only_what_they_read_and_load_the_choice() {
    let dir = tempfile::tempdir().unwrap();
    let garment = include_str!("../assets/garments/skirt.obj");
    std::fs::write(dir.path().join("other.obj"), garment).unwrap();
    std::fs::write(dir.path().join("notes.txt"), "not a mesh").unwrap();
    let mut h = harness(Editor::new(small_scene(dir.path())));
    h.run_steps(2);
    h.get_all_by_label("…").next().expect("a browse button").click();
    h.run_steps(3);
    assert!(h.query_all_by_label_contains("Open a scene").count() > 0, "the dialog is open");
    h.get_by_label_contains("small.toml");
    assert!(h.query_by_label_contains("notes.txt").is_none(), "only scene files are offered");
    h.get_by_label("Cancel").click();
    h.run_steps(3);
    assert!(h.state().browse.is_none(), "cancelled");

    let buttons: Vec<_> = h.get_all_by_label("…").collect();
    buttons[1].click();
    h.run_steps(3);
    h.get_by_label_contains("other.obj").click();
    h.run_steps(2);
    h.get_all_by_label("Open").last().expect("the dialog's Open button").click();
    h.run_steps(3);
    assert!(h.state().browse.is_none() && h.state().is_loading());
    h.state_mut().finish_loading();
    h.run_steps(2);
    let editor = h.state();
    let skirt_vertices = garment.lines().filter(|l| l.starts_with("v ")).count();
    assert_eq!(editor.scene.garments[0].mesh.vertex_count(), skirt_vertices, "the skirt replaced the grid");
    assert!(editor.paths.garment.ends_with("other.obj"));
}

/// Bakes at `quality` through the UI and returns the error of the newest
/// frame against the reference.
fn bake_error_at(h: &mut Harness<'_, Editor>, quality: &str) -> f64 {
    h.get_by_role_and_label(Role::ComboBox, "Quality").click();
    h.run_steps(2);
    h.get_by_label(quality).click();
    h.run_steps(2);
    h.get_by_label("Bake").click();
    h.run_steps(2);
    wait_until(h, "the bake", |e| e.run == RunState::Idle);
    h.state().run_error().expect("an error against the reference").1
}

#[test]
fn the_reference_run_measures_the_error_of_each_quality() {
    let dir = tempfile::tempdir().unwrap();
    let mut h = harness(Editor::new(small_scene(dir.path())));
    h.run_steps(2);
    h.get_by_label("Accuracy").click();
    h.run_steps(2);
    h.get_by_label("Compute reference").click();
    h.run_steps(2);
    let deadline = Instant::now() + Duration::from_secs(300);
    while h.state().reference.is_none() {
        assert!(
            Instant::now() < deadline && h.state().reference_job.is_some(),
            "the reference run ended without result"
        );
        std::thread::sleep(Duration::from_millis(50));
        h.state_mut().update(0.0);
    }
    let reference = h.state().reference.clone().unwrap();
    assert_eq!(reference.steps_per_frame, 32, "16 × the scene's 2 steps");
    assert_eq!(reference.frames.len(), h.state().scene.frame_count + 1);
    let preview = bake_error_at(&mut h, "Preview");
    let fine = bake_error_at(&mut h, "Final");
    // Preview (one step a frame, solves ten times looser) is about 5 % of the
    // cloth's diagonal from the reference on this drop (5.007e-2 here since
    // 86a72f4; `drape bench accuracy` at its end: 4.98e-2 before, 5.01e-2
    // after): a bound with room, not the figure itself.
    assert!(preview > 0.0 && preview < 0.07, "Preview: {preview}");
    assert!(fine < preview, "Final ({fine}) is closer to the reference than Preview ({preview})");
    h.get_by_label_contains("these frames: mean error");
}

#[test]
fn a_dropped_file_is_used_for_what_it_is_or_refused() {
    let dir = tempfile::tempdir().unwrap();
    let mut editor = Editor::new(small_scene(dir.path()));
    drape::app::browse::dropped(&mut editor, dir.path().join("notes.txt"));
    assert!(editor.messages.iter().any(|m| m.error && m.text.contains("notes.txt")));
    assert!(!editor.is_loading());
    drape::app::browse::dropped(&mut editor, dir.path().join("walk.fbx"));
    editor.finish_loading();
    assert!(editor.messages.iter().any(|m| m.error && m.text.contains("walk.fbx")), "a missing body is named");
    assert!(editor.scene.file.bodies.is_empty() && !editor.dirty(), "a failed load leaves the scene unmodified");
    let skirt = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/garments/skirt.obj");
    drape::app::browse::dropped(&mut editor, skirt);
    editor.finish_loading();
    assert_eq!(editor.scene.garments[0].name, "cloth");
    assert!(editor.scene.garments[0].mesh.vertex_count() > 24 * 24, "the skirt replaced the grid");
    let relative = editor.scene.file.garments[0].mesh.clone();
    assert!(
        matches!(relative, drape::scene::file::MeshSpec::Obj(p) if p.is_relative()),
        "written relative to the scene"
    );
}

/// The Scene panel lists a character's meshes, each with a tick, and its
/// animation stacks: unticking the eyes leaves them out of the collider and
/// writes `exclude` into the scene; choosing Idle plays that stack.
#[test]
fn a_characters_meshes_and_stacks_are_chosen_in_the_scene_panel() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/scenes/skirt_character_walk.toml");
    let mut h = harness(Editor::new(Scene::load(&path).unwrap()));
    h.run_steps(2);
    let vertices = |e: &Editor| e.scene.mesh_colliders[e.scene.bodies[0].collider].vertices.len();
    let before = vertices(h.state());
    h.get_by_role_and_label(Role::CheckBox, "Eye_L").click();
    h.run_steps(2);
    h.state_mut().finish_loading();
    h.run_steps(2);
    assert_eq!(h.state().scene.file.bodies[0].exclude, ["Eye_L"]);
    assert_eq!(vertices(h.state()), before - 114, "the eye's vertices left the collider");
    assert!(h.state().dirty(), "the scene is marked changed");

    h.get_by_label("Animation").click();
    h.run_steps(2);
    h.get_by_label("Idle").click();
    h.run_steps(2);
    h.state_mut().finish_loading();
    h.run_steps(2);
    let body = &h.state().scene.bodies[0].loaded;
    assert_eq!((body.stack.as_deref(), h.state().scene.file.bodies[0].stack.as_deref()), (Some("Idle"), Some("Idle")));
}

/// The Export panel's USD, glTF and MDD buttons write the simulated frames
/// for other tools into the export folder, each file whole and holding
/// every frame (the formats' own checks are in tests/exports.rs).
#[test]
fn the_export_panel_writes_usd_gltf_and_mdd_of_the_simulated_frames() {
    let dir = tempfile::tempdir().unwrap();
    let mut h = harness(Editor::new(small_scene(dir.path())));
    h.run_steps(2);
    h.get_by_label("Bake").click();
    h.run_steps(2);
    wait_until(&mut h, "the bake", |e| e.run == RunState::Idle);
    let frames = h.state().timeline.len();
    let out = dir.path().join("for other tools");
    h.get_by_role_and_label(Role::TextInput, "Folder").set_text_value_accesskit(&out.display().to_string());
    h.run_steps(2);
    for label in ["USD", "glTF", "MDD"] {
        h.get_by_label(label).click();
        h.run_steps(2);
        wait_for_export(&mut h);
    }
    let usda = std::fs::read_to_string(out.join("small.usda")).unwrap();
    assert!(usda.starts_with("#usda 1.0") && usda.contains(&format!("endTimeCode = {}", frames - 1)));
    assert_eq!(&std::fs::read(out.join("small.glb")).unwrap()[..4], b"glTF");
    let mdd = drape::io::mdd::read_mdd(&std::fs::read(out.join("cloth.mdd")).unwrap()).unwrap();
    assert_eq!(mdd.frames.len(), frames);
    let last = h.state().timeline.newest().unwrap().positions.clone();
    let written = mdd.frames[frames - 1][5];
    assert_eq!(written, [last[5].x as f32, last[5].y as f32, last[5].z as f32], "the newest frame, as simulated");
}

/// Ctrl+Z puts a dragged slider back in one step (the drag's values
/// coalesce), the running simulation gets the fabric back, the scene is no
/// longer marked unsaved; Ctrl+Shift+Z and the Edit menu redo and undo it.
#[test]
fn ctrl_z_restores_a_sliders_value_and_the_workers_fabric() {
    let dir = tempfile::tempdir().unwrap();
    let mut h = harness(Editor::new(small_scene(dir.path())));
    h.run_steps(2);
    let stiffness = |e: &Editor| e.simulated_fabrics[0].stretch_stiffness_n_per_m;
    for value in [2000.0, 2600.0, 3000.0] {
        set_fabric(&h, "Stretch", value);
        h.run_steps(2);
    }
    wait_until(&mut h, "the worker to take 3000 N/m", |e| close(stiffness(e), 3000.0));
    assert!(h.state().title().ends_with(" •"), "{}", h.state().title());

    h.key_press_modifiers(egui::Modifiers::COMMAND, egui::Key::Z);
    h.run_steps(2);
    let cotton = fabric_parameter("Stretch").shown(1500.0);
    assert_eq!(slider_value(&h, "Stretch"), cotton, "one undo takes the whole drag back");
    wait_until(&mut h, "the worker to take cotton's 1500 N/m again", |e| stiffness(e) == 1500.0);
    assert!(!h.state().dirty(), "back at the saved value: nothing unsaved");
    assert_eq!(h.state().title(), "drape — small");

    h.key_press_modifiers(egui::Modifiers::COMMAND | egui::Modifiers::SHIFT, egui::Key::Z);
    h.run_steps(2);
    assert!(close(slider_value(&h, "Stretch"), fabric_parameter("Stretch").shown(3000.0)), "redone");
    wait_until(&mut h, "the worker to take 3000 N/m again", |e| close(stiffness(e), 3000.0));

    h.get_by_label("Edit").click();
    h.run_steps(2);
    h.get_by_label_contains("Undo Stretch of cloth").click();
    h.run_steps(2);
    assert_eq!(slider_value(&h, "Stretch"), cotton, "undone from the menu");
}

/// Space plays and pauses; typing a space in a path field does not; Help ▸
/// Keyboard lists the keys.
#[test]
fn space_toggles_play_but_not_while_typing() {
    let dir = tempfile::tempdir().unwrap();
    let mut h = harness(Editor::new(small_scene(dir.path())));
    h.run_steps(2);
    h.key_press(egui::Key::Space);
    h.run_steps(1);
    assert!(h.state().timeline.playing, "Space plays");
    h.key_press(egui::Key::Space);
    h.run_steps(1);
    assert!(!h.state().timeline.playing, "Space pauses");
    h.get_by_role_and_label(Role::TextInput, "Scene").focus();
    h.run_steps(1);
    h.key_press(egui::Key::Space);
    h.run_steps(1);
    assert!(!h.state().timeline.playing, "a space typed in a field is text");

    h.get_by_label("Help").click();
    h.run_steps(2);
    h.get_by_label("Keyboard").click();
    h.run_steps(2);
    h.get_by_label("Play / pause the frames");
    h.get_by_label("Frame the garment and body");
}

/// Opening another scene with unsaved changes asks; Cancel keeps every
/// change; Discard opens it and the title follows.
#[test]
fn opening_a_scene_with_unsaved_changes_asks_and_cancel_keeps_everything() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("other.toml"), SMALL_SCENE.replace("\"cloth\"", "\"shawl\"")).unwrap();
    let mut h = harness(Editor::new(small_scene(dir.path())));
    h.run_steps(2);
    set_fabric(&h, "Weight", 0.2);
    h.run_steps(2);
    let other = dir.path().join("other.toml").display().to_string();
    h.state_mut().paths.scene = other.clone();
    h.run_steps(1);
    h.get_by_label("Open").click();
    h.run_steps(3);
    h.get_by_label("Unsaved changes");
    h.get_by_label("Cancel").click();
    h.run_steps(3);
    let editor = h.state();
    assert!(!editor.is_loading() && editor.pending.is_none(), "nothing opened");
    assert_eq!((editor.scene.name.as_str(), editor.scene.garments[0].name.as_str()), ("small", "cloth"));
    assert!(close(editor.scene.garments[0].fabric.area_density_kg_per_m2, 0.2), "the change is kept");
    assert_eq!(editor.title(), "drape — small •");

    h.get_by_label("Open").click();
    h.run_steps(3);
    h.get_by_label("Discard").click();
    h.run_steps(2);
    h.state_mut().finish_loading();
    h.run_steps(2);
    assert_eq!(h.state().scene.garments[0].name, "shawl");
    assert_eq!(h.state().title(), "drape — other", "the title names the scene opened, saved");
    h.key_press_modifiers(egui::Modifiers::COMMAND, egui::Key::Z);
    h.run_steps(2);
    assert_eq!(h.state().scene.garments[0].name, "shawl", "opening starts a new history");
}

/// The fraction of the viewport's height the box around `points` fills
/// through the editor's camera, and whether all of it is in view.
fn projected_height(editor: &Editor, points: &[nalgebra::Vector3<f64>]) -> (f32, bool) {
    let camera = editor.shown_camera();
    let clip_from_world = camera.projection(editor.viewport_aspect, 10.0) * camera.view();
    let ndc: Vec<glam::Vec3> = points
        .iter()
        .map(|p| clip_from_world.project_point3(glam::Vec3::new(p.x as f32, p.y as f32, p.z as f32)))
        .collect();
    let (low, high) = ndc.iter().fold((f32::MAX, f32::MIN), |(lo, hi), p| (lo.min(p.y), hi.max(p.y)));
    let inside = ndc.iter().all(|p| p.x.abs() <= 1.0 && p.y.abs() <= 1.0);
    ((high - low) / 2.0, inside)
}

/// F frames the body where it is at the frame shown, not the walk: its
/// projected box fills at least 60 % of the viewport's height and all of it
/// is in view; the side views and "follow" keep it there as it walks on.
#[test]
fn frame_fits_the_body_at_the_frame_shown() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/scenes/skirt_walk.toml");
    let mut h = harness(Editor::new(Scene::load(&path).unwrap()));
    h.run_steps(2);
    wait_until(&mut h, "frame 0", |e| !e.timeline.is_empty());
    h.get_by_role_and_label(Role::CheckBox, "Preview the motion alone").click();
    h.run_steps(2);
    h.state_mut().timeline.seek(90);
    h.key_press(egui::Key::F);
    h.run_steps(2);
    let body = |e: &Editor, t: f64| e.scene.mesh_colliders[e.scene.bodies[0].collider].world_vertices(t);
    let at_90 = body(h.state(), 3.0);
    let (height, inside) = projected_height(h.state(), &at_90);
    assert!(
        inside && height >= 0.6,
        "the body at frame 90 fills {:.0} % of the height, in view: {inside}",
        height * 100.0
    );

    h.key_press(egui::Key::Num1);
    h.run_steps(2);
    let (height, inside) = projected_height(h.state(), &at_90);
    assert!(inside && height >= 0.6, "front view: {:.0} %, in view: {inside}", height * 100.0);
    let walked = h.state().figure.shift(3.0, 4.0).length();
    assert!(walked > 0.3, "the body walks on ({walked} m in a second)");
    h.state_mut().timeline.seek(120);
    h.run_steps(2);
    let (height, inside) = projected_height(h.state(), &body(h.state(), 4.0));
    assert!(inside && height >= 0.5, "followed a second later: {:.0} %, in view: {inside}", height * 100.0);
}

/// The small scene lasting `duration_s`.
fn small_scene_lasting(dir: &Path, duration_s: f64) -> Scene {
    let path = dir.join("small.toml");
    std::fs::write(&path, SMALL_SCENE.replace("duration_s = 0.5", &format!("duration_s = {duration_s}"))).unwrap();
    Scene::load(&path).unwrap_or_else(|e| panic!("{e}"))
}

/// A new bake cancelled part way gives the timeline back to the last
/// complete bake, bit for bit, and Simulate goes on from its end, past the
/// scene's range.
#[test]
fn a_cancelled_bake_keeps_the_previous_bake_and_simulate_goes_on_past_the_end() {
    let dir = tempfile::tempdir().unwrap();
    let mut h = harness(Editor::new(small_scene_lasting(dir.path(), 2.0)));
    h.run_steps(2);
    let frames = h.state().scene.frame_count;
    h.key_press_modifiers(egui::Modifiers::COMMAND, egui::Key::B);
    h.run_steps(2);
    wait_until(&mut h, "the first bake", |e| e.run == RunState::Idle && e.timeline.last() == frames);
    let baked: Vec<_> = h.state().timeline.frames().iter().map(|f| f.positions.clone()).collect();

    set_fabric(&h, "Stretch", 400.0);
    h.run_steps(2);
    h.get_by_label("Bake").click();
    h.run_steps(2);
    wait_until(&mut h, "the second bake to start", |e| matches!(e.run, RunState::Baking { done, .. } if done >= 3));
    h.get_by_label("Cancel").click();
    h.run_steps(2);
    wait_until(&mut h, "the cancel", |e| e.run == RunState::Idle);
    let editor = h.state();
    assert_eq!(editor.timeline.len(), frames + 1, "every frame of the previous bake is back");
    for (k, (kept, first)) in editor.timeline.frames().iter().zip(&baked).enumerate() {
        assert_eq!(*kept.positions, **first, "frame {k} is the first bake's");
    }
    assert!(editor.messages.iter().any(|m| m.text.contains("previous bake is back")));

    h.key_press_modifiers(egui::Modifiers::SHIFT, egui::Key::Space);
    h.run_steps(2);
    wait_until(&mut h, "frames past the end", |e| e.timeline.last() >= frames + 5);
    h.key_press_modifiers(egui::Modifiers::SHIFT, egui::Key::Space);
    h.run_steps(2);
    wait_until(&mut h, "the pause", |e| e.run == RunState::Idle);
    let editor = h.state();
    let next = &editor.timeline.frame(frames + 1).unwrap().positions;
    let step = baked[frames].iter().zip(next.iter()).map(|(a, b)| (a - b).norm()).fold(0.0, f64::max);
    assert!(step < 0.01, "the first frame past the end goes on from the bake's last ({step} m in a frame)");
}

/// After a fabric change the frames simulated before it are stale (the
/// timeline says so for the frame shown); new frames are not; "Re-simulate
/// from here" drops the frames after the one shown and simulates on from it.
#[test]
fn frames_simulated_with_other_settings_are_marked_stale() {
    let dir = tempfile::tempdir().unwrap();
    let mut h = harness(Editor::new(small_scene(dir.path())));
    h.run_steps(2);
    let frames = h.state().scene.frame_count;
    h.get_by_label("Bake").click();
    h.run_steps(2);
    wait_until(&mut h, "the bake", |e| e.run == RunState::Idle && e.timeline.last() == frames);
    assert!(h.state().frame_kinds().iter().all(|k| *k == FrameKind::Baked));
    assert!(h.query_by_label("stale").is_none());

    h.get_by_role_and_label(Role::ComboBox, "Preset").click();
    h.run_steps(2);
    h.get_by_label("silk").click();
    h.run_steps(3);
    assert!(h.state().frame_kinds().iter().all(|k| *k == FrameKind::Stale), "every frame was cotton");
    h.get_by_label("stale");

    h.state_mut().timeline.seek(5);
    h.run_steps(2);
    h.get_by_label("Re-simulate from here").click();
    h.run_steps(2);
    wait_until(&mut h, "silk frames", |e| e.timeline.last() >= 9);
    h.state_mut().pause();
    wait_until(&mut h, "the pause", |e| e.run == RunState::Idle);
    let kinds = h.state().frame_kinds();
    assert!(kinds[..=5].iter().all(|k| *k == FrameKind::Stale), "frames 0-5 stay cotton");
    assert!(kinds[6..].iter().all(|k| *k == FrameKind::Simulated), "frames from 6 on are silk: {kinds:?}");
}

/// A cotton square hanging from two corners: stretched to its limit (1 %)
/// at the pins, slack at the hem.
const HANGING_SCENE: &str = r#"
[time]
fps = 30.0
duration_s = 1.0
[solver]
steps_per_frame = 2
[[garment]]
name = "cloth"
preset = "cotton"
mesh = { grid = { size_m = 0.6, resolution = 24 } }
translation_m = [0.0, 1.2, 0.0]
rotation_deg = [90.0, 0.0, 0.0]
[[garment.pin]]
vertices = [0, 23]
[[collider]]
name = "ground"
shape = "plane"
"#;

/// The colour of `image` around the point `p` (m) seen through the
/// editor's camera, averaged over a 5 × 5 pixel square.
fn colour_at(editor: &Editor, image: &image::RgbaImage, p: &nalgebra::Vector3<f64>) -> [f64; 3] {
    let camera = editor.shown_camera();
    let aspect = image.width() as f32 / image.height() as f32;
    let ndc = (camera.projection(aspect, 10.0) * camera.view())
        .project_point3(glam::Vec3::new(p.x as f32, p.y as f32, p.z as f32));
    let (x, y) = ((ndc.x + 1.0) * 0.5 * image.width() as f32, (1.0 - ndc.y) * 0.5 * image.height() as f32);
    let mut sum = [0.0; 3];
    for dy in -2..=2 {
        for dx in -2..=2 {
            let px = image.get_pixel((x as i32 + dx) as u32, (y as i32 + dy) as u32);
            (0..3).for_each(|c| sum[c] += f64::from(px[c]) / 25.0);
        }
    }
    sum
}

/// The strain map colours the cloth where it is stretched to its limit in
/// the limit's colour (red) and where it is slack in the ramp's start
/// (blue), with the legend naming the limit.
#[test]
fn the_strain_map_shows_the_limits_colour_where_the_cloth_is_at_its_limit() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("hanging.toml");
    std::fs::write(&path, HANGING_SCENE).unwrap();
    let gpu = Gpu::headless().unwrap_or_else(|e| panic!("{e}"));
    let mut ui_renderer =
        egui_wgpu::Renderer::new(&gpu.device, wgpu::TextureFormat::Rgba8Unorm, egui_wgpu::RendererOptions::default());
    let mut viewport = Viewport::new(&gpu, wgpu::TextureFormat::Rgba8Unorm).expect("lavapipe runs the renderer");
    viewport.resolution_scale = 1.0;
    let mut h = harness(Editor::new(Scene::load(&path).unwrap()));
    h.run_steps(2);
    h.get_by_label("Bake").click();
    h.run_steps(2);
    wait_until(&mut h, "the bake", |e| e.run == RunState::Idle && e.timeline.last() == e.scene.frame_count);
    h.get_by_role_and_label(Role::ComboBox, "Show").click();
    h.run_steps(2);
    h.get_by_label("Strain map").click();
    h.run_steps(2);
    h.key_press(egui::Key::Num1);
    h.run_steps(2);
    assert_eq!(h.state().fit_map, Some(drape::stage::fit_map::FitMap::Strain));
    let (_, [_, _, full_scale]) = drape::stage::fit_map::FitMap::Strain.legend(&h.state().scene);
    assert_eq!(full_scale, "1.0 % (the limit)", "the legend's red end is the limit");
    viewport.render(h.state_mut(), [480, 480], &mut ui_renderer);
    let image = viewport.image().unwrap().unwrap();
    let shot = Path::new(env!("CARGO_MANIFEST_DIR")).join("target/fit_maps/strain.png");
    std::fs::create_dir_all(shot.parent().unwrap()).unwrap();
    image.save(&shot).unwrap();

    let editor = h.state();
    let positions = editor.timeline.newest().unwrap().positions.clone();
    let mesh = &editor.scene.garments[0].mesh;
    let strain = drape::stage::fit_map::vertex_strain(mesh, &positions);
    let limit = editor.scene.garments[0].fabric.strain_limit.unwrap();
    // Inside the square (24 × 24 vertices), so the pixels around it are cloth.
    let interior = |i: &usize| (1..23).contains(&(i % 24)) && (1..23).contains(&(i / 24));
    let (stretched, most) =
        (0..strain.len()).filter(interior).fold((0, 0.0), |b, i| if strain[i] > b.1 { (i, strain[i]) } else { b });
    assert!(most >= 0.9 * limit, "the cloth reaches its limit at the pins: {:.2} %", most * 100.0);
    let [r, g, b] = colour_at(editor, &image, &positions[stretched]);
    assert!(r > 1.5 * g && r > 1.5 * b, "at {:.2} % strain the map is red: {r:.0} {g:.0} {b:.0}", most * 100.0);
    let (slack, least) =
        (0..strain.len()).filter(interior).fold((0, f64::MAX), |b, i| if strain[i] < b.1 { (i, strain[i]) } else { b });
    assert!(least < 0.1 * limit);
    let [r, _, b] = colour_at(editor, &image, &positions[slack]);
    assert!(b > 1.5 * r, "a slack vertex is blue: {r:.0} {b:.0} ({} in {})", least, shot.display());
}

/// PNG export draws the frame shown through the view composed on screen,
/// at the size chosen, with the fit map and its legend; the folder is kept
/// in the scene file; a cancelled export is reported as a cancel.
#[test]
fn png_export_draws_this_view_with_the_fit_map_legend_and_a_cancel_is_a_cancel() {
    let dir = tempfile::tempdir().unwrap();
    let mut h = harness(Editor::new(small_scene(dir.path())));
    h.run_steps(2);
    h.get_by_label("Bake").click();
    h.run_steps(2);
    wait_until(&mut h, "the bake", |e| e.run == RunState::Idle && e.timeline.last() == e.scene.frame_count);
    let folder = dir.path().join("pictures");
    h.state_mut().paths.export = folder.display().to_string();
    h.key_press(egui::Key::M);
    h.run_steps(2);
    assert!(h.state().fit_map.is_some(), "M shows the strain map");
    h.get_by_label("Fabric").click(); // folded: the Export panel's size list fits under it
    h.run_steps(2);
    h.get_by_label("This frame").click();
    h.run_steps(2);
    h.get_by_role_and_label(Role::ComboBox, "Size").click();
    h.run_steps(2);
    h.get_by_label("1280 × 720").click();
    h.run_steps(2);
    h.get_by_label("Export PNG").click();
    h.run_steps(2);
    wait_for_export(&mut h);
    let last = h.state().timeline.last();
    let image = image::open(folder.join(format!("frame_{last:04}.png"))).unwrap().to_rgba8();
    assert_eq!(image.dimensions(), (1280, 720));
    let kept = Path::new(env!("CARGO_MANIFEST_DIR")).join("target/fit_maps/export_strain.png");
    std::fs::create_dir_all(kept.parent().unwrap()).unwrap();
    image.save(&kept).unwrap();
    let legend_start = image.get_pixel(24, 720 - 16 - 8 - 13 - 6).0;
    assert_eq!(legend_start[..3], drape::stage::fit_map::ramp(0.0), "the legend's ramp is drawn in");
    let cloth_colours = image.pixels().filter(|p| i32::from(p[2]) > i32::from(p[0]) + 60).count();
    assert!(cloth_colours > 2000, "the cloth is coloured by the map ({cloth_colours} blue pixels)");
    let remembered = h.state().scene.file.export.folder.clone();
    assert_eq!(remembered.as_deref(), Some(Path::new("pictures")), "kept relative to the scene");
    assert!(h.state().dirty(), "and saved with it");

    h.get_by_label("Every frame").click();
    h.run_steps(1);
    h.get_by_label("Export PNG").click();
    h.run_steps(1);
    h.key_press(egui::Key::Escape);
    h.run_steps(1);
    wait_for_export(&mut h);
    let messages = &h.state().messages;
    assert!(messages.iter().any(|m| !m.error && m.text.starts_with("export cancelled after")), "{messages:?}");
    assert!(!messages.iter().any(|m| m.error));
}

/// Pin A (cotton), switch to silk and simulate: A and B side by side show
/// two different images at the same frame, and toggling shows A, then B.
#[test]
fn a_b_compare_shows_two_images_that_differ_after_a_preset_switch() {
    let dir = tempfile::tempdir().unwrap();
    let gpu = Gpu::headless().unwrap_or_else(|e| panic!("{e}"));
    let mut ui_renderer =
        egui_wgpu::Renderer::new(&gpu.device, wgpu::TextureFormat::Rgba8Unorm, egui_wgpu::RendererOptions::default());
    let mut viewport = Viewport::new(&gpu, wgpu::TextureFormat::Rgba8Unorm).expect("lavapipe runs the renderer");
    viewport.resolution_scale = 1.0;
    let mut h = harness(Editor::new(small_scene(dir.path())));
    h.run_steps(2);
    h.get_by_label("Bake").click();
    h.run_steps(2);
    wait_until(&mut h, "the cotton bake", |e| e.run == RunState::Idle && e.timeline.last() == e.scene.frame_count);
    h.get_by_label("Pin A").click();
    h.run_steps(2);
    h.get_by_role_and_label(Role::ComboBox, "Preset").click();
    h.run_steps(2);
    h.get_by_label("silk").click();
    h.run_steps(2);
    h.get_by_label("Bake").click();
    h.run_steps(2);
    wait_until(&mut h, "the silk bake", |e| e.run == RunState::Idle && e.timeline.last() == e.scene.frame_count);
    h.get_by_role_and_label(Role::ComboBox, "Compare").click();
    h.run_steps(2);
    h.get_by_label("A | B side by side").click();
    h.run_steps(2);
    let mut render = |h: &mut Harness<'_, Editor>| {
        viewport.render(h.state_mut(), [480, 240], &mut ui_renderer);
        viewport.image().unwrap().unwrap()
    };
    let both = render(&mut h);
    let half = |x0: u32| image::RgbaImage::from_fn(240, 240, |x, y| *both.get_pixel(x0 + x, y));
    let (a, b) = (half(0), half(240));
    let shot = Path::new(env!("CARGO_MANIFEST_DIR")).join("target/compare/side_by_side.png");
    std::fs::create_dir_all(shot.parent().unwrap()).unwrap();
    both.save(&shot).unwrap();
    let (mean, share) = difference(&a, &b);
    assert!(share > 0.02 && mean > 2.0, "A and B differ: mean {mean:.1}, {:.1} % of pixels", share * 100.0);

    h.key_press(egui::Key::C);
    h.run_steps(2);
    assert_eq!(h.state().compare, drape::app::editor::Compare::A);
    let only_a = render(&mut h);
    h.key_press(egui::Key::C);
    h.run_steps(2);
    let only_b = render(&mut h);
    let (mean, _) = difference(&only_a, &only_b);
    assert!(mean > 2.0, "toggling shows another image: mean difference {mean:.1}");
}

/// Mean absolute difference of two images' channels and the share of
/// pixels that differ by more than 24 in some channel.
fn difference(a: &image::RgbaImage, b: &image::RgbaImage) -> (f64, f64) {
    let pixels = a.pixels().zip(b.pixels());
    let (mut sum, mut changed, mut count) = (0.0, 0usize, 0usize);
    for (p, q) in pixels {
        let d: Vec<i32> = (0..3).map(|c| (i32::from(p[c]) - i32::from(q[c])).abs()).collect();
        sum += f64::from(d.iter().sum::<i32>()) / 3.0;
        changed += usize::from(d.iter().any(|&x| x > 24));
        count += 1;
    }
    (sum / count as f64, changed as f64 / count as f64)
}

/// File ▸ Examples lists the demos apart from the hard cases, each with its
/// description on hover; choosing one opens it (the title follows).
#[test]
fn the_examples_menu_lists_demos_apart_from_hard_cases_and_opens_one() {
    let dir = tempfile::tempdir().unwrap();
    let mut h = harness(Editor::new(small_scene(dir.path())));
    h.run_steps(2);
    h.get_by_role_and_label(Role::Button, "File").click();
    h.run_steps(2);
    h.get_by_label("Examples").click();
    h.run_steps(2);
    let demos = h.get_by_label("Demos").rect().min.y;
    let hard = h.get_by_label("Hard cases (stress tests)").rect().min.y;
    let skirt = h.get_by_label("skirt_walk").rect().min.y;
    let twist = h.get_by_label("twist").rect().min.y;
    assert!(demos < skirt && skirt < hard && hard < twist, "demos first, then the hard cases");
    h.get_by_label("drape_sphere").hover();
    h.run_steps(60);
    h.get_by_label_contains("dropped from 1 m onto a sphere of radius 0.3 m");
    h.get_by_label("drape_sphere").click();
    h.run_steps(2);
    // Loaded on a thread: done within the steps, or waited for here.
    h.state_mut().finish_loading();
    h.run_steps(2);
    assert_eq!(h.state().title(), "drape — drape_sphere", "{:?}", h.state().messages);
}
