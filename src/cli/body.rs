//! `drape body` and `drape import-motion`: what a character file holds (its
//! meshes, nodes, stacks and motion), how another file's motion fits it, and
//! its motion baked into a motion cache.

use std::path::Path;

use drape::body::motion::Motion;
use drape::body::skin::SkinningMethod;
use drape::body::{Body, BodyPart, StackSummary};
use drape::io::fbx::{BodyOptions, FbxError, FbxMotion, read_body, read_motion};

use crate::{Failure, input};

/// Most frames `drape body` skins to time it (spread over the motion).
const TIMED_FRAMES: usize = 240;

/// The motion of an FBX file (stack `stack`, else its first), for `--motion`.
pub fn motion_of(path: &Path, stack: Option<&str>) -> Result<Motion, Failure> {
    let file = read_motion(path, stack).map_err(input)?;
    file.motion.ok_or_else(|| Failure::Input(format!("{} has no animation", path.display())))
}

/// `drape body FILE [--motion OTHER] [--stack NAME]`.
pub fn run_body(path: &Path, motion_path: Option<&Path>, stack: Option<&str>) -> Result<(), Failure> {
    let own_stack = if motion_path.is_none() { stack } else { None };
    let options = BodyOptions { stack: own_stack.map(str::to_owned), ..Default::default() };
    let started = std::time::Instant::now();
    let body = match read_body(path, &options) {
        Ok(body) => body,
        Err(FbxError::NoMesh { .. }) => return describe_motion_file(path, own_stack),
        Err(e) => return Err(input(e)),
    };
    let read_ms = started.elapsed().as_secs_f64() * 1e3;
    describe_body(path, &body);
    println!("read in {read_ms:.1} ms");
    let motion = match motion_path {
        Some(other) => motion_of(other, stack)?,
        None => match body.motion.clone() {
            Some(m) => m,
            None => {
                println!("no animation: a static body");
                return Ok(());
            }
        },
    };
    describe_motion(&motion, Some(&body));
    time_skinning(&body, &motion);
    Ok(())
}

fn describe_body(path: &Path, body: &Body) {
    let (low, high) = body.mesh.bounds().unwrap_or_default();
    println!(
        "{}: {}; {} meshes, {} vertices, {} triangles, {:.2} m tall",
        path.display(),
        body.source,
        body.parts.len(),
        body.mesh.vertex_count(),
        body.mesh.triangles.len(),
        high.y - low.y
    );
    let width = body.parts.iter().map(|p| p.name.chars().count()).max().unwrap_or(4).max(4);
    println!("  {:<width$}  {:>8}  moves", "mesh", "vertices");
    for part in &body.parts {
        println!("  {:<width$}  {:>8}  {}", part.name, part.points.len(), how_it_moves(body, part));
    }
    let bones: usize = body.skeleton.bones.len();
    println!("nodes: {bones} (bones, meshes' nodes and groups)");
    print_stacks(&body.stacks, body.motion.as_ref().map(|m| m.name.as_str()));
}

/// "skinned (linear, 53 bones), blend shapes: Breathe" and the like.
fn how_it_moves(body: &Body, part: &BodyPart) -> String {
    let mut text = part.kind.label().to_owned();
    if let Some(skin) = &part.skin {
        let method = match skin.method {
            SkinningMethod::Linear | SkinningMethod::Rigid => "linear",
            SkinningMethod::DualQuaternion => "dual quaternion",
            SkinningMethod::Blend => "linear and dual quaternion blended",
        };
        text += &format!(" ({method}, {} bones)", skin.clusters.len());
    } else if let Some(parent) = body.skeleton.bones[part.node].parent {
        text += &format!(" (under {})", body.skeleton.bones[parent].name);
    }
    if !part.shapes.is_empty() {
        let names: Vec<&str> = part.shapes.iter().map(|s| s.name.as_str()).collect();
        text += &format!(", blend shapes: {}", names.join(", "));
    }
    text
}

fn print_stacks(stacks: &[StackSummary], used: Option<&str>) {
    if stacks.is_empty() {
        println!("animation stacks: none");
        return;
    }
    let list: Vec<String> = stacks
        .iter()
        .map(|s| {
            let mark = if Some(s.name.as_str()) == used { " (used)" } else { "" };
            format!("'{}' {:.3}..{:.3} s{mark}", s.name, s.start_s, s.end_s)
        })
        .collect();
    println!("animation stacks: {}", list.join(", "));
}

/// A file without a mesh: its skeleton and motion, to drive other bodies.
fn describe_motion_file(path: &Path, stack: Option<&str>) -> Result<(), Failure> {
    let FbxMotion { skeleton, motion, stacks, source } = read_motion(path, stack).map_err(input)?;
    println!(
        "{}: {source}; no mesh: a skeleton of {} nodes and its animation, a motion for other bodies \
         (`motion = \"...\"` in a scene's [[body]], or --motion)",
        path.display(),
        skeleton.bones.len()
    );
    print_stacks(&stacks, motion.as_ref().map(|m| m.name.as_str()));
    match motion {
        Some(m) => describe_motion(&m, None),
        None => println!("no animation"),
    }
    Ok(())
}

fn describe_motion(motion: &Motion, body: Option<&Body>) {
    println!(
        "motion '{}': {:.3} s ({:.3}..{:.3} s of its file), {} animated nodes, {} animated blend-shape channels",
        motion.name,
        motion.duration_s(),
        motion.start_s,
        motion.end_s,
        motion.nodes.len(),
        motion.shapes.len()
    );
    let Some(body) = body else { return };
    let matched = motion.bone_match(&body.skeleton);
    println!("{} of its animated nodes found in this body", matched.matched.len());
    if !matched.is_complete() {
        println!("nodes of the motion this body lacks (not moved): {}", matched.missing_in_skeleton.join(", "));
    }
}

/// Skins up to `TIMED_FRAMES` frames at 30 fps spread over the motion, and prints the median.
fn time_skinning(body: &Body, motion: &Motion) {
    let frames = ((motion.duration_s() * 30.0).floor() as usize + 1).clamp(1, TIMED_FRAMES);
    let step = if frames > 1 { motion.duration_s() / (frames - 1) as f64 } else { 0.0 };
    let mut posed = Vec::new();
    let mut times_ms = Vec::with_capacity(frames);
    for frame in 0..frames {
        let started = std::time::Instant::now();
        body.pose_into(motion, frame as f64 * step, &mut posed);
        times_ms.push(started.elapsed().as_secs_f64() * 1e3);
    }
    println!(
        "skinning: median {:.3} ms per frame over {frames} frames, {} threads",
        drape::bake::summary::median(&times_ms),
        rayon::current_num_threads()
    );
}

/// `drape import-motion`: the skinned body frame by frame into a motion cache.
pub fn run_import_motion(
    path: &Path,
    motion_path: Option<&Path>,
    stack: Option<&str>,
    fps: f64,
    cycle: bool,
    out: &Path,
) -> Result<(), Failure> {
    use drape::io::motion_cache::{MotionCache, write_motion_cache};
    use drape::sim::vertex_animation::VertexAnimation;
    if !(fps.is_finite() && (1.0..=1000.0).contains(&fps)) {
        return Err(Failure::Input(format!("--fps {fps}: expected 1 to 1000 frames per second")));
    }
    let own_stack = if motion_path.is_none() { stack } else { None };
    let body =
        read_body(path, &BodyOptions { stack: own_stack.map(str::to_owned), ..Default::default() }).map_err(input)?;
    let motion = match motion_path {
        Some(other) => motion_of(other, stack)?,
        None => body.motion.clone().ok_or_else(|| Failure::Input(format!("{} has no animation", path.display())))?,
    };
    let matched = motion.bone_match(&body.skeleton);
    if !matched.is_complete() {
        eprintln!(
            "warning: nodes of the motion this body lacks (not moved): {}",
            matched.missing_in_skeleton.join(", ")
        );
    }
    let count = (motion.duration_s() * fps).floor() + 1.0;
    let bytes = count * body.mesh.vertex_count() as f64 * 24.0;
    if bytes > 4e9 {
        return Err(Failure::Input(format!(
            "{count} frames of {} vertices would take {:.1} GB: lower --fps or choose a shorter stack",
            body.mesh.vertex_count(),
            bytes / 1e9
        )));
    }
    let mut posed = Vec::new();
    let started = std::time::Instant::now();
    let frames: Vec<_> = (0..count as usize)
        .map(|f| {
            body.pose_into(&motion, f as f64 / fps, &mut posed);
            posed.clone()
        })
        .collect();
    let seconds = started.elapsed().as_secs_f64();
    let count = frames.len();
    let cache = MotionCache {
        triangles: body.mesh.triangles.clone(),
        animation: VertexAnimation { fps, start_s: 0.0, frames, cycle, lead_in: 0 },
    };
    write_motion_cache(out, &cache).map_err(input)?;
    // Read it back as a scene would, and time a frame's load (a copy).
    let loaded = drape::io::motion_cache::read_motion_cache(out).map_err(input)?;
    let started = std::time::Instant::now();
    let mut frame = Vec::new();
    for f in 0..count {
        loaded.animation.positions_at(f as f64 / fps, &mut frame);
    }
    let load_ms = started.elapsed().as_secs_f64() * 1e3 / count.max(1) as f64;
    println!(
        "{count} frames of {} vertices at {fps} fps in {} ({:.2} ms per frame to skin, {:.3} ms to load a cached frame)",
        body.mesh.vertex_count(),
        out.display(),
        seconds * 1e3 / count.max(1) as f64,
        load_ms
    );
    Ok(())
}
