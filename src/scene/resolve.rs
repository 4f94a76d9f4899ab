//! Resolving a scene file: every value checked and named in its error,
//! presets, meshes, pins, glue, bodies and colliders turned into what the
//! simulator takes.

use super::*;

/// Resolves a parsed file against its folder, naming `origin` in errors.
pub(super) struct Resolver<'a> {
    pub(super) base_dir: &'a Path,
    pub(super) origin: &'a str,
}

impl Resolver<'_> {
    fn invalid(&self, what: impl Into<String>, problem: impl Into<String>) -> SceneError {
        SceneError::Invalid { origin: self.origin.to_owned(), what: what.into(), problem: problem.into() }
    }

    /// Checks that `value` is finite and within `range`, or says so.
    fn check(&self, what: &str, value: f64, ok: impl Fn(f64) -> bool, expected: &str) -> Result<(), SceneError> {
        if value.is_finite() && ok(value) {
            Ok(())
        } else {
            Err(self.invalid(what, format!("{value} is out of range: {expected}")))
        }
    }

    pub(super) fn scene(&self, file: SceneFile, name: &str) -> Result<Scene, SceneError> {
        self.check("time.fps", file.time.fps, |v| v > 0.0 && v <= 1000.0, "0 < fps ≤ 1000")?;
        self.check("time.duration_s", file.time.duration_s, |v| v > 0.0 && v <= 36_000.0, "0 < duration ≤ 36000 s")?;
        let solver = &file.solver;
        self.check("solver.tolerance", solver.tolerance, |v| v > 0.0 && v < 1.0, "0 < tolerance < 1")?;
        let long_step = solver.long_step_error;
        self.check("solver.long_step_error", long_step, |v| (0.0..=100.0).contains(&v), "0 ≤ value ≤ 100")?;
        if solver.max_iterations == 0 {
            return Err(self.invalid("solver.max_iterations", "must be at least 1"));
        }
        if let Some(steps) = solver.steps_per_frame
            && !(1..=10_000).contains(&steps)
        {
            return Err(self.invalid("solver.steps_per_frame", format!("{steps} is out of range: 1 ≤ steps ≤ 10000")));
        }
        if file.garments.is_empty() {
            return Err(self.invalid("garment", "the scene has no [[garment]]"));
        }
        let (mut colliders, mut mesh_colliders) = (Vec::new(), Vec::new());
        for spec in &file.colliders {
            match self.collider(spec)? {
                SceneCollider::Analytic(c) => colliders.push(c),
                SceneCollider::Mesh(m) => mesh_colliders.push(m),
            }
        }
        let mut bodies = Vec::new();
        for spec in &file.bodies {
            if mesh_colliders.iter().any(|m: &MeshCollider| m.name == spec.name) {
                let why = "another body or mesh collider has this name: give each [[body]] its own `name`";
                return Err(self.invalid(format!("body '{}'", spec.name), why));
            }
            bodies.push(self.body(spec, &file, &mut mesh_colliders)?);
        }
        let garments =
            file.garments.iter().map(|g| self.garment(g, &file, &mesh_colliders)).collect::<Result<Vec<_>, _>>()?;
        for (i, g) in garments.iter().enumerate() {
            if garments[..i].iter().any(|other| other.name == g.name) {
                return Err(self.invalid(format!("garment '{}'", g.name), "two garments have this name"));
            }
        }
        let collision = self.collision(&file.collision)?;
        self.camera(&file.camera)?;
        let fps = file.time.fps;
        let steps_per_frame = solver.steps_per_frame.unwrap_or_else(|| {
            let finest = garments.iter().map(|g| g.fabric.time_step_s).fold(f64::INFINITY, f64::min);
            ((1.0 / fps) / finest - 1e-9).ceil().max(1.0) as u32
        });
        Ok(Scene {
            name: name.to_owned(),
            source: None,
            fps,
            frame_count: (file.time.duration_s * fps).round().max(1.0) as usize,
            steps_per_frame,
            long_step_error: long_step,
            solver: PcgSettings {
                tolerance: solver.tolerance,
                max_iterations: solver.max_iterations,
                preconditioner: solver.preconditioner,
            },
            strain_limiting: solver.strain_limiting,
            garments,
            colliders,
            mesh_colliders,
            bodies,
            collision,
            file,
        })
    }

    fn body(&self, spec: &BodySpec, file: &SceneFile, meshes: &mut Vec<MeshCollider>) -> Result<SceneBody, SceneError> {
        let what = format!("body '{}'", spec.name);
        for v in spec.position_m.iter().chain(&spec.rotation_deg).chain([spec.start_s].iter()) {
            self.check(&format!("{what}: pose"), *v, |_| true, "finite numbers")?;
        }
        self.check(&format!("{what}: blend_in_s"), spec.blend_in_s, |b| (0.0..=60.0).contains(&b), "0 to 60 s")?;
        self.check(&format!("{what}: speed"), spec.speed, |v| v > 0.0 && v <= 100.0, "0 < speed ≤ 100")?;
        if let Some(mu) = spec.friction {
            self.check(&format!("{what}: friction"), mu, |m| (0.0..=10.0).contains(&m), "0 ≤ friction ≤ 10")?;
        }
        let (collider, surface, loaded) =
            load_body(spec, self.base_dir, file.time.fps, file.time.duration_s).map_err(|source| SceneError::Body {
                origin: self.origin.to_owned(),
                body: spec.name.clone(),
                source: Box::new(source),
            })?;
        meshes.push(collider);
        let origin = self.base_dir.join(&spec.file).display().to_string();
        Ok(SceneBody { collider: meshes.len() - 1, surface, origin, loaded })
    }

    fn camera(&self, camera: &CameraSpec) -> Result<(), SceneError> {
        let optional = [
            ("camera.yaw_deg", camera.yaw_deg, -360.0, 360.0, "degrees"),
            ("camera.pitch_deg", camera.pitch_deg, -89.0, 89.0, "degrees"),
            ("camera.fov_deg", camera.fov_deg, 5.0, 120.0, "degrees"),
            ("camera.distance_m", camera.distance_m, 0.01, 1000.0, "m"),
            ("camera.turntable_period_s", camera.turntable_period_s, 0.1, 1e5, "s"),
        ];
        for (what, value, low, high, unit) in optional {
            if let Some(v) = value {
                self.check(what, v, |v| (low..=high).contains(&v), &format!("{low} to {high} {unit}"))?;
            }
        }
        for v in camera.target_m.iter().flatten() {
            self.check("camera.target_m", *v, |_| true, "finite coordinates, m")?;
        }
        Ok(())
    }

    fn garment(&self, spec: &GarmentSpec, file: &SceneFile, meshes: &[MeshCollider]) -> Result<Garment, SceneError> {
        let what = format!("garment '{}'", spec.name);
        let preset_error =
            |source| SceneError::Preset { origin: self.origin.to_owned(), garment: spec.name.clone(), source };
        let mut overrides = spec.fabric.clone();
        if let Some(t) = file.collision.thickness_m {
            overrides.insert("thickness_m".into(), toml::Value::Float(t));
        }
        if let Some(mu) = file.collision.friction {
            overrides.insert("friction".into(), toml::Value::Float(mu));
        }
        let preset = Preset::resolve(&spec.preset, self.base_dir, &overrides).map_err(preset_error)?;

        let (mut mesh, report, warnings, origin) = self.mesh(&spec.mesh, &what, &spec.name)?;
        let pinned = spec
            .pins
            .iter()
            .enumerate()
            .map(|(k, pin)| Ok((pin, self.pin_vertices(pin, &mesh, &format!("{what}: pin {}", k + 1))?)))
            .collect::<Result<Vec<_>, SceneError>>()?;

        self.check(&format!("{what}: scale"), spec.scale, |s| s > 0.0, "a positive factor")?;
        for v in spec.translation_m.iter().chain(&spec.rotation_deg) {
            self.check(&format!("{what}: transform"), *v, |_| true, "finite numbers")?;
        }
        let world_from_model = Similarity3::from_parts(
            Translation3::from(Vector3::from(spec.translation_m)),
            rotation(spec.rotation_deg),
            spec.scale,
        );
        mesh.transform(&world_from_model);

        let mut pins = Vec::new();
        for (k, (pin, vertices)) in pinned.into_iter().enumerate() {
            let what = format!("{what}: pin {}", k + 1);
            if let Some(name) = &pin.attach {
                if pin.motion.is_some() {
                    let why = "give `attach` or `motion`, not both: an attached vertex moves with its mesh";
                    return Err(self.invalid(&what, why));
                }
                let glued = self.glue(name, meshes, &mesh, &vertices, preset.fabric.thickness_m, &what)?;
                pins.extend(glued);
                continue;
            }
            let centroid =
                vertices.iter().map(|&v| mesh.positions[v as usize]).sum::<Vector3<f64>>() / vertices.len() as f64;
            let target = match &pin.motion {
                Some(m) => PinTarget::Moving(RigidMotion::from_spec(m, centroid)),
                None => PinTarget::Still,
            };
            pins.extend(vertices.into_iter().map(|vertex| Pin { vertex, target: target.clone() }));
        }
        pins.sort_by_key(|p| p.vertex);
        pins.dedup_by_key(|p| p.vertex);

        Ok(Garment {
            name: spec.name.clone(),
            fabric: preset.fabric.clone(),
            preset,
            mesh,
            report,
            warnings,
            pins,
            self_collision: spec.self_collision,
            origin,
        })
    }

    fn mesh(
        &self,
        spec: &MeshSpec,
        what: &str,
        garment: &str,
    ) -> Result<(TriMesh, MeshReport, Vec<String>, String), SceneError> {
        let resolution = |n: usize, name: &str| {
            if (2..=MAX_RESOLUTION).contains(&n) {
                Ok(())
            } else {
                Err(self
                    .invalid(format!("{what}: {name}"), format!("{n} is out of range: 2 ≤ value ≤ {MAX_RESOLUTION}")))
            }
        };
        let positive =
            |v: f64, name: &str| self.check(&format!("{what}: {name}"), v, |v| v > 0.0, "a positive length in m");
        match spec {
            MeshSpec::Obj(path) => {
                let path = self.base_dir.join(path);
                let obj = read_obj(&path).map_err(|source| SceneError::Obj {
                    origin: self.origin.to_owned(),
                    garment: garment.to_owned(),
                    source,
                })?;
                Ok((obj.mesh, obj.report, obj.warnings, path.display().to_string()))
            }
            MeshSpec::Grid { size_m, resolution: n } => {
                positive(*size_m, "size_m")?;
                resolution(*n, "resolution")?;
                Ok((
                    generate::grid(*size_m, *n),
                    MeshReport::default(),
                    Vec::new(),
                    format!("grid {size_m} m, {n} × {n} vertices"),
                ))
            }
            MeshSpec::Tube { radius_m, length_m, around, along } => {
                positive(*radius_m, "radius_m")?;
                positive(*length_m, "length_m")?;
                resolution(*along, "along")?;
                if !(3..=MAX_RESOLUTION).contains(around) {
                    return Err(self.invalid(
                        format!("{what}: around"),
                        format!("{around} is out of range: 3 ≤ value ≤ {MAX_RESOLUTION}"),
                    ));
                }
                let origin = format!("tube r = {radius_m} m, {length_m} m long, {around} × {along} vertices");
                Ok((generate::tube(*radius_m, *length_m, *around, *along), MeshReport::default(), Vec::new(), origin))
            }
        }
    }

    /// The vertices a pin group selects, in the mesh's own coordinates.
    /// Pins gluing `vertices` of the (placed) garment `mesh` to the mesh
    /// collider `name`, each at the point of it closest at time 0, kept at
    /// `thickness` (m) from the surface on the side the vertex starts on.
    fn glue(
        &self,
        name: &str,
        meshes: &[MeshCollider],
        mesh: &TriMesh,
        vertices: &[u32],
        thickness: f64,
        what: &str,
    ) -> Result<Vec<Pin>, SceneError> {
        let Some((index, collider)) = meshes.iter().enumerate().find(|(_, m)| m.name == name) else {
            return Err(self.invalid(what, format!("`attach = \"{name}\"` names no mesh collider of this scene")));
        };
        let world_from_local = collider.placement.world_from_local(0.0);
        let corners: Vec<[Vector3<f64>; 3]> = collider
            .triangles
            .iter()
            .map(|t| t.map(|v| world_from_local.transform_point(&collider.vertices[v as usize].into()).coords))
            .collect();
        let pin = |vertex: u32| {
            let p = mesh.positions[vertex as usize];
            let closest = |(t, [a, b, c]): (usize, &[Vector3<f64>; 3])| {
                let w = closest_on_triangle(&p, a, b, c);
                ((a * w[0] + b * w[1] + c * w[2] - p).norm_squared(), t, w)
            };
            let (squared, triangle, weights) =
                corners.iter().enumerate().map(closest).min_by(|x, y| x.0.total_cmp(&y.0))?;
            let [a, b, c] = &corners[triangle];
            // The vertex keeps where it was fitted relative to the triangle (a
            // waistband with ease stays eased), at least the fabric's thickness
            // off the surface on its side.
            let on_surface = a * weights[0] + b * weights[1] + c * weights[2];
            let frame = triangle_frame(a, b, c);
            let mut offset_m = frame.transpose() * (p - on_surface);
            let side = if (b - a).cross(&(c - a)).dot(&(p - a)) < 0.0 { -1.0 } else { 1.0 };
            if offset_m.z * side < thickness && squared.sqrt() < thickness {
                offset_m = Vector3::new(0.0, 0.0, side * thickness);
            }
            let target = PinTarget::OnMesh { mesh: index as u32, triangle: triangle as u32, weights, offset_m };
            Some(Pin { vertex, target })
        };
        let pins = vertices.iter().map(|&v| pin(v)).collect::<Option<Vec<Pin>>>();
        pins.ok_or_else(|| self.invalid(what, format!("mesh collider '{name}' has no triangles to attach to")))
    }

    fn pin_vertices(&self, pin: &PinSpec, mesh: &TriMesh, what: &str) -> Result<Vec<u32>, SceneError> {
        let count = mesh.vertex_count();
        if let Some(&bad) = pin.vertices.iter().find(|&&v| v as usize >= count) {
            return Err(self.invalid(
                what,
                format!("vertex {bad} does not exist: the mesh has {count} vertices (0..{})", count - 1),
            ));
        }
        let mut vertices = pin.vertices.clone();
        if let Some(region) = &pin.region {
            let (lo, hi) = (Vector3::from(region.min_m), Vector3::from(region.max_m));
            let inside = |p: &Vector3<f64>| (0..3).all(|k| p[k] >= lo[k] && p[k] <= hi[k]);
            vertices.extend((0..count as u32).filter(|&v| inside(&mesh.positions[v as usize])));
        }
        if vertices.is_empty() {
            return Err(self.invalid(what, "selects no vertex (give `vertices` or a `region` that contains some)"));
        }
        if let Some(motion) = &pin.motion {
            self.motion(motion, what)?;
        }
        Ok(vertices)
    }

    fn motion(&self, motion: &crate::sim::motion::MotionSpec, what: &str) -> Result<(), SceneError> {
        let values = motion
            .velocity_m_per_s
            .iter()
            .chain(&motion.angular_velocity_deg_per_s)
            .chain(motion.pivot_m.iter().flatten());
        for &v in values.chain([motion.start_s].iter()) {
            self.check(&format!("{what}: motion"), v, |_| true, "finite numbers")?;
        }
        if motion.end_s.is_some_and(|end| end.is_nan() || end < motion.start_s) {
            return Err(self.invalid(format!("{what}: motion"), "end_s must be a number not before start_s"));
        }
        Ok(())
    }

    fn collider(&self, spec: &ColliderSpec) -> Result<SceneCollider, SceneError> {
        let what = format!("collider '{}'", spec.name);
        for v in spec.position_m.iter().chain(&spec.rotation_deg) {
            self.check(&format!("{what}: pose"), *v, |_| true, "finite numbers")?;
        }
        if let Some(mu) = spec.friction {
            self.check(&format!("{what}: friction"), mu, |m| (0.0..=10.0).contains(&m), "0 ≤ friction ≤ 10")?;
        }
        if let Some(motion) = &spec.motion {
            self.motion(motion, &what)?;
        }
        let position = Vector3::from(spec.position_m);
        let placement = Placement {
            rest_pose: Isometry3::from_parts(Translation3::from(position), rotation(spec.rotation_deg)),
            motion: spec.motion.as_ref().map(|m| RigidMotion::from_spec(m, position)),
        };
        let (name, friction) = (spec.name.clone(), spec.friction);
        if let ShapeSpec::Mesh { obj, scale } = &spec.shape {
            self.check(&format!("{what}: scale"), *scale, |s| s > 0.0, "a positive factor")?;
            let path = self.base_dir.join(obj);
            let obj = read_obj(&path).map_err(|source| SceneError::Obj {
                origin: self.origin.to_owned(),
                garment: format!("collider {name}"),
                source,
            })?;
            let vertices = obj.mesh.positions.iter().map(|p| p * *scale).collect();
            return Ok(SceneCollider::Mesh(MeshCollider {
                name,
                vertices,
                triangles: obj.mesh.triangles,
                placement,
                friction,
                animation: None,
            }));
        }
        Ok(SceneCollider::Analytic(Collider { name, shape: self.shape(&spec.shape, &what)?, placement, friction }))
    }

    /// An analytic shape with every dimension checked.
    fn shape(&self, spec: &ShapeSpec, what: &str) -> Result<Shape, SceneError> {
        let length =
            |v: f64, name: &str| self.check(&format!("{what}: {name}"), v, |v| v > 0.0, "a positive length in m");
        Ok(match spec {
            ShapeSpec::Plane => Shape::Plane,
            ShapeSpec::Sphere { radius_m } => {
                length(*radius_m, "radius_m")?;
                Shape::Sphere { radius: *radius_m }
            }
            ShapeSpec::Box { size_m } => {
                for s in size_m {
                    length(*s, "size_m")?;
                }
                Shape::Box { half_extents: Vector3::from(*size_m) / 2.0 }
            }
            ShapeSpec::Cylinder { radius_m, height_m } => {
                length(*radius_m, "radius_m")?;
                length(*height_m, "height_m")?;
                Shape::Cylinder { radius: *radius_m, half_height: height_m / 2.0 }
            }
            ShapeSpec::Cone { radius_m, height_m } => {
                length(*radius_m, "radius_m")?;
                length(*height_m, "height_m")?;
                Shape::Cone { radius: *radius_m, half_height: height_m / 2.0 }
            }
            ShapeSpec::Prism { side_m, height_m } => {
                length(*side_m, "side_m")?;
                length(*height_m, "height_m")?;
                Shape::Prism { side: *side_m, half_height: height_m / 2.0 }
            }
            ShapeSpec::Mesh { .. } => return Err(self.invalid(what, "a mesh is not an analytic shape")),
        })
    }

    fn collision(&self, c: &file::CollisionSettings) -> Result<CollisionSettings, SceneError> {
        let what = |field: &str| format!("collision.{field}");
        if c.passes == 0 {
            return Err(self.invalid(what("passes"), "must be at least 1"));
        }
        if c.zone_rounds == 0 {
            return Err(self.invalid(what("zone_rounds"), "must be at least 1"));
        }
        self.check(&what("pass_progress"), c.pass_progress, |p| (0.0..1.0).contains(&p), "0 ≤ p < 1")?;
        self.check(&what("influence_decay"), c.influence_decay, |a| a > 0.0 && a < 1.0, "0 < a < 1")?;
        self.check(&what("influence_threshold"), c.influence_threshold, |t| t > 0.0, "a positive influence")?;
        self.check(&what("repulsion_stiffness_n_per_m"), c.repulsion_stiffness_n_per_m, |k| k >= 0.0, "k ≥ 0 N/m")?;
        let feature_stiffness = c.feature_repulsion_stiffness_n_per_m;
        self.check(&what("feature_repulsion_stiffness_n_per_m"), feature_stiffness, |k| k >= 0.0, "k ≥ 0 N/m")?;
        let tip_stiffness = c.tip_repulsion_stiffness_n_per_m;
        self.check(&what("tip_repulsion_stiffness_n_per_m"), tip_stiffness, |k| k >= 0.0, "k ≥ 0 N/m")?;
        self.check(&what("repulsion_band"), c.repulsion_band, |b| b > 0.0 && b < 1.0, "0 < b < 1")?;
        Ok(c.pipeline())
    }
}

/// A resolved collider: analytic or a triangle mesh.
enum SceneCollider {
    Analytic(Collider),
    Mesh(MeshCollider),
}

/// Rotation about X, then Y, then Z (fixed axes), from degrees.
pub(super) fn rotation(degrees: [f64; 3]) -> UnitQuaternion<f64> {
    let [x, y, z] = degrees.map(f64::to_radians);
    UnitQuaternion::from_euler_angles(x, y, z)
}
