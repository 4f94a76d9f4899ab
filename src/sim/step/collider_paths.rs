//! Each particle's path against the analytic colliders, and the triangle
//! collision pipeline a scene needs.

use super::*;

/// The cloth particles' straight paths over one step, for resolving them
/// against the analytic colliders.
pub(super) struct ColliderPaths<'a> {
    /// Positions at the start of the step, m.
    start: &'a [Vector3<f64>],
    /// Pinned particles, which no collider moves.
    fixed: &'a [bool],
    surfaces: &'a [ParticleSurface],
    colliders: &'a [Collider],
    window: StepWindow,
}

impl<'a> ColliderPaths<'a> {
    /// The paths from `start` (m) over `window`, pinned particles `fixed`.
    pub(super) fn new(
        start: &'a [Vector3<f64>],
        fixed: &'a [bool],
        surfaces: &'a [ParticleSurface],
        colliders: &'a [Collider],
        window: StepWindow,
    ) -> Self {
        ColliderPaths { start, fixed, surfaces, colliders, window }
    }

    /// Resolves every free particle `selected` (by index and proposed end)
    /// from its start to its proposed `end` (m, corrected in place with its
    /// `velocity`, m/s) against the analytic colliders, writing its contact
    /// count, the collider it ends resting on and the normals it was pushed
    /// off along (zero for the others). Returns the contacts of the selected
    /// particles and whether any end moved.
    pub(super) fn resolve(
        &self,
        end: &mut [Vector3<f64>],
        velocity: &mut [Vector3<f64>],
        selected: impl Fn(usize, &Vector3<f64>) -> bool + Sync,
        contacts: &mut [u32],
        resting_on: &mut [u32],
        pushed: &mut [Vector3<f64>],
    ) -> (u32, bool) {
        if self.colliders.is_empty() {
            return (0, false);
        }
        end.par_iter_mut()
            .zip(velocity.par_iter_mut())
            .zip(contacts.par_iter_mut().zip(resting_on.par_iter_mut()))
            .zip(pushed.par_iter_mut())
            .enumerate()
            .with_min_len(CHUNK)
            .map(|(i, (((end, velocity), (contacts, resting)), pushed))| {
                *pushed = Vector3::zeros();
                if !selected(i, end) {
                    return (0, false);
                }
                if self.fixed[i] {
                    (*contacts, *resting) = (0, NO_COLLIDER);
                    return (0, false);
                }
                let proposed = *end;
                let surface = self.surfaces[i];
                let found = resolve_particle(&self.start[i], end, velocity, surface, self.colliders, self.window);
                (*contacts, *resting, *pushed) =
                    (found.touches, found.resting_on.unwrap_or(NO_COLLIDER), found.pushed_along);
                (found.touches, *end != proposed)
            })
            .reduce(|| (0, false), |a, b| (a.0 + b.0, a.1 || b.1))
    }
}

/// The triangle-collision pipeline of `cloth`, if the scene needs one.
pub(super) fn collision_pipeline(
    cloth: &Cloth,
    pins: &[Pin],
    colliders: &[Collider],
    meshes: &[MeshCollider],
    settings: &Settings,
) -> Option<CollisionPipeline> {
    let mut particles: Vec<ParticleCollision> = (0..cloth.vertex_count())
        .map(|i| {
            let f = cloth.fabric_of(i);
            ParticleCollision { thickness: f.thickness_m, friction: f.friction, pinned: None }
        })
        .collect();
    for pin in pins {
        // A rigid mesh carries a point glued to it as its own motion carries its
        // vertices: the same rigid motion applied to the point's start. A point
        // glued to a deforming mesh moves its own way.
        let rigid = |motion| Kinematic::Rigid(Placement { rest_pose: nalgebra::Isometry3::identity(), motion });
        let kinematic = match &pin.target {
            PinTarget::Still => rigid(None),
            PinTarget::Moving(motion) => rigid(Some(*motion)),
            PinTarget::OnMesh { mesh, .. } => match &meshes[*mesh as usize] {
                m if m.animation.is_some() => Kinematic::Deforming,
                m => rigid(m.placement.motion),
            },
        };
        particles[pin.vertex as usize].pinned = Some(kinematic);
    }
    let scale = ClothScale::of(&cloth.rest_positions, &cloth.triangles, particles.iter().map(|p| p.thickness));
    let self_collision =
        (0..cloth.garments.len()).map(|g| settings.self_collision.get(g).copied().unwrap_or(true)).collect();
    CollisionPipeline::new(
        cloth.triangles.clone(),
        cloth.triangle_garment.clone(),
        self_collision,
        particles,
        Obstacles::new(colliders, meshes, scale),
        settings.collision.clone(),
    )
}
