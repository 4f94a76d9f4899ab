//! A readable account of a resolved scene: what `drape check` prints.

use std::fmt::Write;

use super::Scene;
use crate::sim::PinTarget;
use crate::sim::cloth::SpringKind;
use crate::sim::colliders::Shape;

/// Describes `scene`: timing, each garment (mesh, elements, mass, pins, mesh
/// warnings) and each collider.
pub fn summary(scene: &Scene) -> String {
    let mut out = String::new();
    let source = scene.source.as_ref().map(|p| format!(" ({})", p.display())).unwrap_or_default();
    let _ = writeln!(out, "scene {}{source}", scene.name);
    if !scene.file.description.is_empty() {
        let _ = writeln!(out, "  {}", scene.file.description);
    }
    let _ = writeln!(
        out,
        "  time: {} fps, {} frames ({:.2} s), {} steps per frame (step {:.2} ms)",
        scene.fps,
        scene.frame_count,
        scene.frame_count as f64 / scene.fps,
        scene.steps_per_frame,
        scene.step_duration() * 1e3
    );
    let long_steps = if scene.long_step_error > 0.0 {
        format!(
            "longer, up to a frame, while a step's error estimate stays under {} × the nominal step's free-fall error",
            scene.long_step_error
        )
    } else {
        "never longer than nominal (long_step_error = 0)".to_owned()
    };
    let _ = writeln!(out, "  steps: {long_steps}");
    let _ = writeln!(
        out,
        "  solver: conjugate gradients to relative residual {:e}, at most {} iterations",
        scene.solver.tolerance, scene.solver.max_iterations
    );
    let cloth = scene.cloth();
    for (garment, range) in scene.garments.iter().zip(&cloth.garments) {
        let f = &garment.fabric;
        let stretch = range.springs.clone().filter(|&s| cloth.spring_kind[s] == SpringKind::Stretch).count();
        let mass: f64 = cloth.mass[range.vertices.clone()].iter().sum();
        let _ = writeln!(out, "garment '{}': {}", garment.name, garment.origin);
        let _ = writeln!(out, "  preset {}: {}", garment.preset.name, garment.preset.about.feel);
        let _ = writeln!(
            out,
            "  {} vertices, {} triangles, {} stretch + {} shear springs, {} bending hinges",
            garment.mesh.vertex_count(),
            garment.mesh.triangles.len(),
            stretch,
            range.springs.len() - stretch,
            range.hinges.len()
        );
        let _ = writeln!(
            out,
            "  area {:.3} m², mass {:.4} kg, thickness {:.1} mm, friction {}",
            garment.mesh.area(),
            mass,
            f.thickness_m * 1e3,
            f.friction
        );
        let _ = writeln!(out, "  self-collision: {}", if garment.self_collision { "on" } else { "off" });
        let moving = garment.pins.iter().filter(|p| p.target != PinTarget::Still).count();
        let _ = writeln!(out, "  pins: {} vertices ({} moving)", garment.pins.len(), moving);
        let _ = writeln!(out, "  mesh: {}", garment.report);
        for warning in garment.report.warnings().iter().chain(&garment.warnings) {
            let _ = writeln!(out, "  warning: {warning}");
        }
    }
    for c in &scene.colliders {
        let p = c.placement.rest_pose.translation.vector;
        let motion = if c.placement.motion.is_some() { "kinematic" } else { "static" };
        let _ = writeln!(
            out,
            "collider '{}': {} at ({:.3}, {:.3}, {:.3}), {motion}",
            c.name,
            describe(&c.shape),
            p.x,
            p.y,
            p.z
        );
    }
    for b in &scene.bodies {
        let name = scene.mesh_colliders.get(b.collider).map_or("", |m| m.name.as_str());
        let _ = writeln!(out, "body '{name}': {}", b.origin);
        let parts: Vec<String> =
            b.loaded.parts.iter().map(|p| format!("{} ({}, {} vertices)", p.name, p.kind, p.vertices.len())).collect();
        let _ = writeln!(out, "  meshes: {}", parts.join(", "));
        let left_out: Vec<&str> = b.loaded.left_out().collect();
        if !left_out.is_empty() {
            let _ = writeln!(out, "  meshes left out: {}", left_out.join(", "));
        }
        if let Some(stack) = &b.loaded.stack {
            let _ = writeln!(out, "  animation stack: '{stack}' (of {})", b.loaded.stacks.len());
        }
        if !b.loaded.unmatched_bones.is_empty() {
            let missing = b.loaded.unmatched_bones.join(", ");
            let _ = writeln!(out, "  bones of the motion this body lacks (not moved): {missing}");
        }
    }
    for m in &scene.mesh_colliders {
        let p = m.placement.rest_pose.translation.vector;
        let motion = match (&m.animation, m.placement.motion.is_some()) {
            (Some(a), _) => format!("animated ({} frames at {} fps)", a.frames.len(), a.fps),
            (None, true) => "kinematic".to_owned(),
            (None, false) => "static".to_owned(),
        };
        let _ = writeln!(
            out,
            "collider '{}': triangle mesh, {} vertices, {} triangles, at ({:.3}, {:.3}, {:.3}), {motion}",
            m.name,
            m.vertices.len(),
            m.triangles.len(),
            p.x,
            p.y,
            p.z
        );
    }
    out
}

fn describe(shape: &Shape) -> String {
    match shape {
        Shape::Plane => "plane".into(),
        Shape::Sphere { radius } => format!("sphere r = {radius} m"),
        Shape::Box { half_extents: h } => format!("box {} × {} × {} m", 2.0 * h.x, 2.0 * h.y, 2.0 * h.z),
        Shape::Cylinder { radius, half_height } => format!("cylinder r = {radius} m, h = {} m", 2.0 * half_height),
        Shape::Cone { radius, half_height } => format!("cone r = {radius} m, h = {} m", 2.0 * half_height),
        Shape::Prism { side, half_height } => format!("triangular prism side {side} m, h = {} m", 2.0 * half_height),
    }
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use super::*;

    #[test]
    fn the_summary_says_whether_steps_lengthen_while_the_cloth_is_calm() {
        let text = |solver: &str| {
            let scene = format!(
                "[time]\nduration_s = 1.0\n[solver]\n{solver}\n[[garment]]\nname = \"cloth\"\npreset = \"cotton\"\n\
                 mesh = {{ grid = {{ size_m = 0.5, resolution = 4 }} }}\n"
            );
            summary(&Scene::parse(&scene, "s", Path::new("."), "test scene").expect("a valid scene"))
        };
        assert!(text("steps_per_frame = 2").contains("up to a frame, while a step's error estimate stays under 0.5 ×"));
        assert!(text("long_step_error = 0.0").contains("never longer than nominal"));
    }
}
