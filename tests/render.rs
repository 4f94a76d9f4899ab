//! The renderer on lavapipe (or any adapter): coverage of a baked frame, light
//! rigs, the sheen lobe, golden images per rig, and `drape render`.
//!
//! Golden images live in tests/golden/, drawn from the cloth's positions kept
//! there too (`drape_sphere_frame_45.pc2`, frame 45 of a bake of drape_sphere):
//! a change to the solver moves where a fold falls, which is not the
//! renderer's business. `DRAPE_UPDATE_GOLDEN=1 cargo test --release --test
//! render` rewrites the images (look at them before committing).
//! Failed comparisons write the image drawn to target/render-test-output/.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

use drape::bake::Baker;
use drape::io::pc2::read_pc2;
use drape::render::lights::LightRig;
use drape::render::{Bounds, DrawMesh, Gpu, Material, OffscreenTarget, OrbitCamera, Renderer, TextureTarget, View};
use drape::scene::Scene;
use drape::sim::colliders::Shape;
use drape::stage::offscreen::OffscreenStage;
use drape::stage::tessellate::shape_mesh;
use glam::{Mat4, Vec3};
use image::RgbaImage;
use nalgebra::Vector3;

/// Image size of the tests (small: lavapipe is a CPU rasteriser).
const WIDTH: u32 = 320;
const HEIGHT: u32 = 180;
/// The frame of drape_sphere the tests look at (the cloth has settled on the sphere).
const FRAME: usize = 45;

fn repo(path: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(path)
}

/// drape_sphere with the cloth drawn red, so its pixels can be told apart.
fn red_scene() -> Scene {
    let mut scene = Scene::load(&repo("assets/scenes/drape_sphere.toml")).unwrap();
    scene.garments[0].preset.appearance.base_color = [0.7, 0.05, 0.04];
    scene
}

/// The cloth's positions at [`FRAME`], simulated once for all tests.
fn baked_positions() -> &'static (Vec<Vector3<f64>>, f64) {
    static BAKED: OnceLock<(Vec<Vector3<f64>>, f64)> = OnceLock::new();
    BAKED.get_or_init(|| {
        let mut baker = Baker::new(&red_scene()).unwrap();
        while baker.frame() < FRAME {
            baker.advance().unwrap();
        }
        (baker.simulator().positions().to_vec(), baker.simulator().time())
    })
}

fn render_rig(gpu: &Gpu, rig: LightRig) -> RgbaImage {
    let (positions, t) = baked_positions();
    render_positions(gpu, rig, positions, *t)
}

/// The red drape_sphere with its cloth at `positions` at time `t` (s), under `rig`.
fn render_positions(gpu: &Gpu, rig: LightRig, positions: &[Vector3<f64>], t: f64) -> RgbaImage {
    let mut stage = OffscreenStage::new(gpu, &red_scene(), WIDTH, HEIGHT, rig).unwrap();
    stage.render(positions, t).unwrap()
}

/// The cloth's positions the golden images were drawn from, and their time (s).
fn golden_positions() -> (Vec<Vector3<f64>>, f64) {
    let bytes = std::fs::read(repo("tests/golden/drape_sphere_frame_45.pc2")).unwrap();
    let cache = read_pc2(&bytes).unwrap();
    let positions = cache.samples[0].iter().map(|p| Vector3::new(p[0], p[1], p[2]).cast::<f64>()).collect();
    (positions, f64::from(cache.start_frame) / 30.0)
}

/// Relative luminance of an sRGB-encoded pixel, 0..1 (Rec. 709 weights on the encoded values).
fn luma(p: &image::Rgba<u8>) -> f64 {
    (0.2126 * f64::from(p[0]) + 0.7152 * f64::from(p[1]) + 0.0722 * f64::from(p[2])) / 255.0
}

fn is_cloth(p: &image::Rgba<u8>) -> bool {
    f64::from(p[0]) > 1.6 * f64::from(p[1]).max(f64::from(p[2])) + 8.0
}

fn mean_luma(image: &RgbaImage) -> f64 {
    image.pixels().map(luma).sum::<f64>() / f64::from(image.width() * image.height())
}

fn centroid(pixels: impl Iterator<Item = (u32, u32)>) -> Option<(f64, f64)> {
    let (mut sx, mut sy, mut n) = (0.0, 0.0, 0.0);
    for (x, y) in pixels {
        sx += f64::from(x);
        sy += f64::from(y);
        n += 1.0;
    }
    (n > 0.0).then(|| (sx / n, sy / n))
}

#[test]
fn a_baked_frame_shows_cloth_in_the_centre_and_ground_around_it() {
    let gpu = Gpu::headless().unwrap();
    let image = render_rig(&gpu, LightRig::find("studio").unwrap());
    let (w, h) = (image.width(), image.height());
    let centre = (w * 2 / 5..w * 3 / 5).flat_map(|x| (h * 2 / 5..h * 3 / 5).map(move |y| (x, y)));
    let centre: Vec<_> = centre.collect();
    let cloth_in_centre = centre.iter().filter(|&&(x, y)| is_cloth(image.get_pixel(x, y))).count();
    assert!(cloth_in_centre * 10 > centre.len() * 6, "{cloth_in_centre} of {} centre pixels are cloth", centre.len());
    // The border (outer tenth) is ground: no cloth, no background, not black.
    let border: Vec<_> = image
        .enumerate_pixels()
        .filter(|(x, y, _)| *x < w / 10 || *x >= w * 9 / 10 || *y >= h * 9 / 10)
        .map(|(_, _, p)| *p)
        .collect();
    assert!(border.iter().all(|p| !is_cloth(p)));
    let ground_like = border.iter().filter(|p| (0.15..0.9).contains(&luma(p))).count();
    assert!(
        ground_like * 100 > border.len() * 95,
        "{ground_like} of {} border pixels look like lit ground",
        border.len()
    );
    let black = image.pixels().filter(|p| p[0].max(p[1]).max(p[2]) == 0).count();
    assert!(black * 100 < image.pixels().len(), "{black} black pixels");
    assert!((0.15..0.85).contains(&mean_luma(&image)));
}

/// Image offset from the cloth's centroid to the centroid of the pixels that
/// the key light's shadow darkens.
fn shadow_offset(gpu: &Gpu, rig: &LightRig) -> (f64, f64) {
    let lit = render_rig(gpu, rig.clone());
    let mut unshadowed = rig.clone();
    unshadowed.lights.iter_mut().for_each(|l| l.shadow = false);
    let reference = render_rig(gpu, unshadowed);
    let shadowed = lit
        .enumerate_pixels()
        .filter(|&(x, y, p)| !is_cloth(p) && luma(reference.get_pixel(x, y)) - luma(p) > 0.08)
        .map(|(x, y, _)| (x, y));
    let cloth = lit.enumerate_pixels().filter(|(_, _, p)| is_cloth(p)).map(|(x, y, _)| (x, y));
    let (shadow, cloth) = (centroid(shadowed).expect("a shadow on the ground"), centroid(cloth).unwrap());
    (shadow.0 - cloth.0, shadow.1 - cloth.1)
}

#[test]
fn light_rigs_change_brightness_and_where_the_shadow_falls() {
    let gpu = Gpu::headless().unwrap();
    let rigs: Vec<LightRig> = ["studio", "daylight", "evening"].iter().map(|n| LightRig::find(n).unwrap()).collect();
    let lumas: Vec<f64> = rigs.iter().map(|r| mean_luma(&render_rig(&gpu, r.clone()))).collect();
    for i in 0..lumas.len() {
        for j in 0..i {
            assert!(
                (lumas[i] - lumas[j]).abs() > 0.02,
                "{} and {}: mean luminance {lumas:?}",
                rigs[i].name,
                rigs[j].name
            );
        }
    }
    let angle = |(dx, dy): (f64, f64)| dy.atan2(dx).to_degrees();
    let offsets: Vec<(f64, f64)> = rigs.iter().map(|r| shadow_offset(&gpu, r)).collect();
    // Studio's key and the evening lamp are on the camera's left: shadows fall
    // right; the daylight sun is on the right: its shadow falls left.
    assert!(offsets[0].0 > 5.0 && offsets[2].0 > 5.0 && offsets[1].0 < -5.0, "{offsets:?}");
    let between = |a: f64, b: f64| ((a - b + 540.0) % 360.0 - 180.0).abs();
    assert!(between(angle(offsets[0]), angle(offsets[1])) > 45.0, "{offsets:?}");
    assert!(between(angle(offsets[2]), angle(offsets[1])) > 45.0, "{offsets:?}");
}

/// A fabric ball lit from the camera's direction, with or without sheen: its
/// renderer and view.
fn ball_scene(gpu: &Gpu, sheen: [f32; 3]) -> (Renderer, View) {
    let ball = shape_mesh(&Shape::Sphere { radius: 0.5 }).unwrap();
    let material = Material { sheen_color: sheen, sheen_roughness: 0.4, ..Material::matte([0.35, 0.12, 0.1], 0.8) };
    let mesh = DrawMesh {
        name: "ball".into(),
        vertices: ball.vertices,
        indices: ball.indices,
        material,
        world_from_model: Mat4::IDENTITY,
        casts_shadow: true,
    };
    let mut renderer = Renderer::new(gpu).expect("lavapipe runs the renderer");
    renderer.set_meshes(&[mesh]);
    let rig = LightRig::parse(
        r#"name = "headlight"
exposure_ev100 = 9.0
background = [0.0, 0.0, 0.0]
[ambient]
sky_illuminance_lux = 0
sky_color = [1, 1, 1]
ground_illuminance_lux = 0
ground_color = [1, 1, 1]
[[light]]
name = "head"
azimuth_deg = 0
elevation_deg = 0
illuminance_lux = 1500
color = [1, 1, 1]
"#,
        "headlight",
    )
    .unwrap();
    let camera = OrbitCamera { target: Vec3::ZERO, yaw_deg: 0.0, pitch_deg: 0.0, distance_m: 3.0, fov_y_deg: 30.0 };
    let bounds = Bounds { min: Vec3::splat(-0.5), max: Vec3::splat(0.5) };
    (renderer, View::new(camera, 1.0, &rig, 0.0, bounds))
}

/// [`ball_scene`]'s image, 200 × 200.
fn sheen_ball(gpu: &Gpu, sheen: [f32; 3]) -> RgbaImage {
    let (renderer, view) = ball_scene(gpu, sheen);
    OffscreenTarget::new(gpu, 200, 200).render(gpu, &renderer, &view).unwrap()
}

#[test]
fn sheen_brightens_grazing_angles_and_keeps_energy_head_on() {
    let gpu = Gpu::headless().unwrap();
    let (plain, sheen) = (sheen_ball(&gpu, [0.0; 3]), sheen_ball(&gpu, [1.0; 3]));
    let row = plain.height() / 2;
    // First pixel of the ball from the left, then two pixels in: a grazing view.
    let edge = (0..plain.width()).find(|&x| luma(plain.get_pixel(x, row)) > 0.01).unwrap();
    let grazing = edge + 2;
    let (without, with) = (luma(plain.get_pixel(grazing, row)), luma(sheen.get_pixel(grazing, row)));
    assert!(with > without + 0.05, "grazing pixel: {with} with sheen, {without} without");
    let centre = plain.width() / 2;
    let (without, with) = (luma(plain.get_pixel(centre, row)), luma(sheen.get_pixel(centre, row)));
    assert!(with <= without + 1e-9, "head-on the sheen takes energy from the base layer: {with} vs {without}");
}

/// Mean and 95th percentile of the per-pixel largest channel difference, 0..1.
fn difference(a: &RgbaImage, b: &RgbaImage) -> (f64, f64) {
    let mut diffs: Vec<f64> = a
        .pixels()
        .zip(b.pixels())
        .map(|(p, q)| (0..3).map(|c| f64::from(p[c].abs_diff(q[c]))).fold(0.0, f64::max) / 255.0)
        .collect();
    diffs.sort_by(f64::total_cmp);
    let mean = diffs.iter().sum::<f64>() / diffs.len() as f64;
    (mean, diffs[diffs.len() * 95 / 100])
}

#[test]
fn a_one_sample_image_is_the_anti_aliased_one_but_its_edges() {
    let gpu = Gpu::headless().unwrap();
    let (renderer, view) = ball_scene(&gpu, [1.0; 3]);
    let target = TextureTarget::new(&gpu, 200, 200);
    let draw = |antialiased| {
        target.render(&gpu, &renderer, &view, antialiased);
        target.read(&gpu).unwrap()
    };
    let (single, multi) = (draw(false), draw(true));
    assert_eq!(multi, sheen_ball(&gpu, [1.0; 3]), "anti-aliased, the viewport's image is the offline one");
    assert!(luma(single.get_pixel(100, 100)) > 0.1, "the ball is drawn at one sample too");
    let (mean, p95) = difference(&single, &multi);
    assert!(mean < 0.01 && p95 < 0.02, "mean {mean}, 95th percentile {p95}");
    assert!(mean > 0.0, "the silhouette is not anti-aliased at one sample");
}

#[test]
fn every_light_rig_matches_its_golden_image() {
    let gpu = Gpu::headless().unwrap();
    let update = std::env::var_os("DRAPE_UPDATE_GOLDEN").is_some();
    let (positions, t) = golden_positions();
    let mut failures = Vec::new();
    for rig in LightRig::built_in() {
        let name = rig.name.clone();
        let image = render_positions(&gpu, rig, &positions, t);
        let golden = repo(&format!("tests/golden/drape_sphere_{name}.png"));
        if update {
            image.save(&golden).unwrap();
            continue;
        }
        let expected = image::open(&golden).unwrap_or_else(|e| panic!("{}: {e}", golden.display())).to_rgba8();
        let (mean, p95) = difference(&image, &expected);
        // Bounds that survive driver and rasteriser differences (like wgpu's
        // own example tests), far below what a changed shader or light moves.
        if mean > 0.01 || p95 > 0.04 {
            let out = repo("target/render-test-output");
            std::fs::create_dir_all(&out).unwrap();
            image.save(out.join(format!("drape_sphere_{name}.png"))).unwrap();
            failures.push(format!("{name}: mean difference {mean:.4}, 95th percentile {p95:.4}"));
        }
    }
    assert!(failures.is_empty(), "{failures:#?} (images drawn are in target/render-test-output)");
}

fn drape(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_drape")).args(args).output().expect("the drape binary runs")
}

#[test]
fn render_command_writes_frames_of_a_bake_and_refuses_bad_options() {
    let dir = tempfile::tempdir().unwrap();
    let (bake, frames) = (dir.path().join("bake"), dir.path().join("png"));
    let scene = repo("assets/scenes/drape_sphere.toml");
    let baked = drape(&["bake", scene.to_str().unwrap(), "--out", bake.to_str().unwrap(), "--frames", "3"]);
    assert!(baked.status.success(), "{}", String::from_utf8_lossy(&baked.stderr));
    let args = ["render", bake.to_str().unwrap(), "--out", frames.to_str().unwrap()];
    let rendered = drape(&[&args[..], &["--frames", "1..3", "--light", "overcast", "--size", "96x64"]].concat());
    assert!(rendered.status.success(), "{}", String::from_utf8_lossy(&rendered.stderr));
    let mut written: Vec<String> =
        std::fs::read_dir(&frames).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    written.sort();
    assert_eq!(written, ["frame_0001.png", "frame_0002.png", "frame_0003.png"]);
    let image = image::open(frames.join("frame_0003.png")).unwrap();
    assert_eq!((image.width(), image.height()), (96, 64));

    for (extra, expected) in [
        (["--light", "disco"], "no light rig 'disco'"),
        (["--size", "12x9000"], "--size 12x9000"),
        (["--frames", "2..9"], "the last frame available is 3"),
        (["--frames", "b..c"], "--frames b..c"),
    ] {
        let out = drape(&[&args[..], &extra[..]].concat());
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{extra:?}: {stderr}");
        assert!(stderr.contains(expected), "{extra:?}: {stderr}");
    }
    std::fs::remove_file(bake.join("summary.json")).unwrap();
    let out = drape(&args);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("--scene"), "{stderr}");
}

/// A 1 m square OBJ garment with UVs, an MTL and a PNG whose left half is blue
/// and right half yellow, seen from straight above.
fn textured_scene(dir: &Path) -> Scene {
    let texture = RgbaImage::from_fn(64, 64, |x, _| match x < 32 {
        true => image::Rgba([20, 40, 230, 255]),
        false => image::Rgba([240, 210, 20, 255]),
    });
    texture.save(dir.join("halves.png")).unwrap();
    std::fs::write(dir.join("cloth.mtl"), "newmtl printed\nKd 1 1 1\nmap_Kd halves.png\n").unwrap();
    let obj = "mtllib cloth.mtl\no cloth\nv -0.5 0 -0.5\nv 0.5 0 -0.5\nv 0.5 0 0.5\nv -0.5 0 0.5\n\
               vt 0 1\nvt 1 1\nvt 1 0\nvt 0 0\nusemtl printed\nf 4/4 3/3 2/2 1/1\n";
    std::fs::write(dir.join("cloth.obj"), obj).unwrap();
    let scene = "[time]\nduration_s = 0.1\n[[garment]]\nname = \"printed\"\npreset = \"cotton\"\n\
                 mesh = { obj = \"cloth.obj\" }\ntranslation_m = [0.0, 0.5, 0.0]\n\
                 [camera]\nyaw_deg = 0.0\npitch_deg = 89.0\n";
    std::fs::write(dir.join("scene.toml"), scene).unwrap();
    Scene::load(&dir.join("scene.toml")).unwrap()
}

#[test]
fn base_colour_textures_from_the_mtl_follow_the_uvs() {
    let dir = tempfile::tempdir().unwrap();
    let scene = textured_scene(dir.path());
    let gpu = Gpu::headless().unwrap();
    let rest: Vec<Vector3<f64>> = scene.garments[0].mesh.positions.clone();
    let mut stage = OffscreenStage::new(&gpu, &scene, 160, 160, LightRig::find("daylight").unwrap()).unwrap();
    let image = stage.render(&rest, 0.0).unwrap();
    let row = 80;
    let rgb = |x| image.get_pixel(x, row).0.map(i32::from);
    let (left, right) = (rgb(50), rgb(110));
    // Seen from above with yaw 0, +X (u = 1, yellow) is on the right.
    assert!(left[2] > left[0].max(left[1]) + 60, "left pixel {left:?} should be blue");
    assert!(right[0].min(right[1]) > right[2] + 60, "right pixel {right:?} should be yellow");
}

#[test]
fn a_missing_texture_is_an_error_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let scene = textured_scene(dir.path());
    std::fs::remove_file(dir.path().join("halves.png")).unwrap();
    let gpu = Gpu::headless().unwrap();
    let Err(e) = OffscreenStage::new(&gpu, &scene, 64, 64, LightRig::find("studio").unwrap()) else {
        panic!("a missing texture must fail");
    };
    assert!(e.to_string().contains("halves.png"), "{e}");
}

#[test]
fn the_scene_camera_turns_with_the_turntable_period() {
    let dir = tempfile::tempdir().unwrap();
    let mut scene = textured_scene(dir.path());
    scene.file.camera.pitch_deg = Some(20.0);
    scene.file.camera.turntable_period_s = Some(8.0);
    let stage = drape::stage::Stage::new(&scene).unwrap();
    let (start, quarter) = (stage.camera(1.0, 0.0), stage.camera(1.0, 2.0));
    assert!((quarter.yaw_deg - start.yaw_deg - 90.0).abs() < 1e-3);
    assert_eq!(start.distance_m, quarter.distance_m);
}

/// An adapter that cannot run the renderer (OpenGL, which has no reads of
/// depth texels; or none at all) is an error that says what to install, with
/// exit code 2 and no image: not wgpu's panic.
#[test]
fn an_adapter_without_the_renderers_features_is_an_error_not_a_panic() {
    let dir = tempfile::tempdir().unwrap();
    let frames = dir.path().join("png");
    let scene = repo("assets/scenes/drape_sphere.toml");
    let out = Command::new(env!("CARGO_BIN_EXE_drape"))
        .args([
            "render",
            scene.to_str().unwrap(),
            "--out",
            frames.to_str().unwrap(),
            "--frames",
            "0",
            "--size",
            "64x48",
        ])
        .env("WGPU_BACKEND", "gl")
        .output()
        .expect("the drape binary runs");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("mesa-vulkan-drivers") && !stderr.contains("panicked"), "{stderr}");
    let written = std::fs::read_dir(&frames).map_or(0, |entries| entries.count());
    assert_eq!(written, 0, "no image is written");
}
