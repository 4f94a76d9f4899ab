//! Skeletal motion, separate from any body: the animated values of a file's
//! nodes and blend-shape channels over one animation stack. On the skeleton
//! it was made on a motion drives each node by index; on another skeleton
//! it drives the bones of the same names (PAPER Experiment 1).

use nalgebra::{Matrix3, Matrix4, Rotation3, UnitQuaternion, Vector3};

use super::curve::Curve;
use super::skeleton::{Skeleton, same_bone_name};
use super::transform::{EulerOrder, NodeTransform};

/// How an animation layer combines with the layers below it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum LayerBlend {
    /// Adds its weighted value (multiplies scales, composes rotations).
    #[default]
    Additive,
    /// Replaces the value below.
    Override,
    /// Blends from the value below towards its own by its weight.
    Passthrough,
}

/// One layer's value of a property: a curve or a constant per component.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LayerValue {
    /// How it combines with the layers below (the first layer replaces the
    /// static value whatever it says).
    pub blend: LayerBlend,
    /// Its weight, 0..1.
    pub weight: f64,
    /// Rotations add per Euler component instead of as turns.
    pub rotation_by_channel: bool,
    /// Scales add instead of multiplying.
    pub scale_additive: bool,
    /// Per component, its curve (if any) and the value without one.
    pub components: Vec<(Option<Curve>, f64)>,
}

impl LayerValue {
    /// This layer's own value at `t_s` (file time).
    fn at(&self, t_s: f64) -> Vec<f64> {
        self.components
            .iter()
            .map(|(curve, default)| curve.as_ref().and_then(|c| c.value_at(t_s)).unwrap_or(*default))
            .collect()
    }
}

/// What kind of value a property holds (how layers combine it).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PropertyKind {
    /// A translation or any plain number: layers add.
    Plain,
    /// Euler angles in this order: additive layers compose turns.
    Rotation(EulerOrder),
    /// Scale factors: additive layers multiply.
    Scale,
}

/// An animated property: its layers in stack order.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Animated {
    /// The layers that animate it, bottom first.
    pub layers: Vec<LayerValue>,
}

impl Animated {
    /// The value at `t_s` (file time) over the static value `base`, layers
    /// combined as the FBX SDK does.
    pub fn value(&self, base: &[f64], t_s: f64, kind: PropertyKind) -> Vec<f64> {
        let mut result = base.to_vec();
        for (i, layer) in self.layers.iter().enumerate() {
            let v = layer.at(t_s);
            result = match (i, layer.blend) {
                (0, _) | (_, LayerBlend::Override) => v,
                (_, blend) => combine(&result, &v, layer, blend, kind),
            };
        }
        result
    }

    /// Lowest and highest key of every curve of component `c`.
    fn component_range(&self, c: usize) -> Option<(f64, f64)> {
        self.layers
            .iter()
            .filter_map(|l| l.components.get(c))
            .filter_map(|(curve, default)| curve.as_ref().and_then(Curve::value_range).or(Some((*default, *default))))
            .reduce(|a, b| (a.0.min(b.0), a.1.max(b.1)))
    }
}

/// `below` combined with an additive or passthrough layer's value `v`.
fn combine(below: &[f64], v: &[f64], layer: &LayerValue, blend: LayerBlend, kind: PropertyKind) -> Vec<f64> {
    let w = layer.weight.clamp(0.0, 1.0);
    let additive = blend == LayerBlend::Additive;
    match kind {
        PropertyKind::Rotation(order) if !layer.rotation_by_channel && below.len() == 3 && v.len() == 3 => {
            let quat =
                |a: &[f64]| UnitQuaternion::from_rotation_matrix(&order.rotation(&Vector3::new(a[0], a[1], a[2])));
            let (r, q) = (quat(below), quat(v));
            let turned = match additive {
                true => r * UnitQuaternion::identity().slerp(&q, w),
                false => r.slerp(&q, w),
            };
            order.angles(&turned.to_rotation_matrix()).iter().copied().collect()
        }
        PropertyKind::Scale if !layer.scale_additive => {
            let power = |x: f64, e: f64| {
                if e <= 0.0 {
                    1.0
                } else if e >= 1.0 {
                    x
                } else {
                    x.signum() * x.abs().powf(e)
                }
            };
            below
                .iter()
                .zip(v)
                .map(|(&r, &x)| if additive { r * power(x, w) } else { power(r, 1.0 - w) * power(x, w) })
                .collect()
        }
        _ => below.iter().zip(v).map(|(&r, &x)| if additive { r + w * x } else { (1.0 - w) * r + w * x }).collect(),
    }
}

/// The animated properties of one node.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct NodeAnimation {
    /// Index of the node in the motion's source skeleton.
    pub bone: usize,
    /// `Lcl Translation`, file units.
    pub translation: Option<Animated>,
    /// `Lcl Rotation`, degrees.
    pub rotation: Option<Animated>,
    /// `Lcl Scaling`.
    pub scaling: Option<Animated>,
}

impl NodeAnimation {
    /// `local` with this node's animated values at `t_s` (file time).
    fn apply(&self, t_s: f64, local: &mut NodeTransform) {
        let vector = |v: Vec<f64>| Vector3::new(v[0], v[1], v[2]);
        if let Some(a) = &self.translation {
            local.translation = vector(a.value(local.translation.as_slice(), t_s, PropertyKind::Plain));
        }
        if let Some(a) = &self.rotation {
            let kind = PropertyKind::Rotation(local.order);
            local.rotation_deg = vector(a.value(local.rotation_deg.as_slice(), t_s, kind));
        }
        if let Some(a) = &self.scaling {
            local.scaling = vector(a.value(local.scaling.as_slice(), t_s, PropertyKind::Scale));
        }
    }

    /// Whether its translation moves (more than 1 µm in file units).
    fn translation_varies(&self) -> bool {
        self.translation
            .as_ref()
            .is_some_and(|a| (0..3).filter_map(|c| a.component_range(c)).any(|(l, h)| h - l > 1e-6))
    }
}

/// The animated weight of one blend-shape channel.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ShapeAnimation {
    /// The channel's name.
    pub channel: String,
    /// Its `DeformPercent`, percent.
    pub percent: Animated,
}

/// A motion: the animated nodes and blend-shape channels of one stack.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Motion {
    /// The stack's name.
    pub name: String,
    /// The skeleton the motion was made on: its static and bind poses.
    pub source: Skeleton,
    /// Animated nodes, in the source skeleton's order.
    pub nodes: Vec<NodeAnimation>,
    /// Animated blend-shape channels, in file order.
    pub shapes: Vec<ShapeAnimation>,
    /// First time of the motion on the file's timeline, s.
    pub start_s: f64,
    /// Last time of the motion on the file's timeline, s.
    pub end_s: f64,
    /// Height of the source skeleton (vertical extent of its bones at bind,
    /// file units): reused on another skeleton, root translations scale by
    /// the ratio of heights.
    pub reference_height: f64,
}

/// How a motion's bone names meet a skeleton's.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BoneMatch {
    /// Animated bones the skeleton has.
    pub matched: Vec<String>,
    /// Animated bones the skeleton lacks (their motion is dropped).
    pub missing_in_skeleton: Vec<String>,
}

impl BoneMatch {
    /// Whether every animated bone was found.
    pub fn is_complete(&self) -> bool {
        self.missing_in_skeleton.is_empty()
    }
}

/// The rotation part of a transform (columns normalised: no scale).
fn rotation_of(m: &Matrix4<f64>) -> Matrix3<f64> {
    let mut r = m.fixed_view::<3, 3>(0, 0).into_owned();
    for mut column in r.column_iter_mut() {
        let n = column.norm();
        if n > 0.0 {
            column /= n;
        }
    }
    r
}

/// Vertical extent of a skeleton's bone origins at bind (file units, along `up`).
pub fn skeleton_height(skeleton: &Skeleton, up: &Vector3<f64>) -> f64 {
    let world = skeleton.bind_matrices();
    let heights = world.iter().map(|m| m.fixed_view::<3, 1>(0, 3).dot(up));
    let (low, high) = heights.fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), y| (l.min(y), h.max(y)));
    if high > low { high - low } else { 0.0 }
}

impl Motion {
    /// The name of the source bone an animation drives.
    fn bone_name(&self, node: &NodeAnimation) -> &str {
        self.source.bones.get(node.bone).map_or("", |b| b.name.as_str())
    }

    /// The names of the animated bones, in the source skeleton's order.
    pub fn animated_bones(&self) -> impl Iterator<Item = &str> {
        self.nodes.iter().map(|n| self.bone_name(n))
    }

    /// Which animated bones `skeleton` has (by name).
    pub fn bone_match(&self, skeleton: &Skeleton) -> BoneMatch {
        let mut m = BoneMatch::default();
        for node in &self.nodes {
            let name = self.bone_name(node).to_owned();
            match skeleton.find(&name) {
                Some(_) => m.matched.push(name),
                None => m.missing_in_skeleton.push(name),
            }
        }
        m
    }

    /// Duration, s.
    pub fn duration_s(&self) -> f64 {
        (self.end_s - self.start_s).max(0.0)
    }

    /// Whether `skeleton` is the one this motion was made on.
    fn is_source(&self, skeleton: &Skeleton) -> bool {
        skeleton.bones.len() == self.source.bones.len()
            && skeleton.bones.iter().zip(&self.source.bones).all(|(a, b)| a.name == b.name && a.parent == b.parent)
    }

    /// Per bone of `skeleton`, the animation that drives it: by index on the
    /// source skeleton, else the first of the same name (or the same name
    /// without its namespace: a Mixamo motion on a plain rig).
    fn drivers<'a>(&'a self, skeleton: &Skeleton) -> Vec<Option<&'a NodeAnimation>> {
        let mut drivers = vec![None; skeleton.bones.len()];
        if self.is_source(skeleton) {
            for node in &self.nodes {
                if let Some(slot) = drivers.get_mut(node.bone) {
                    *slot = Some(node);
                }
            }
            return drivers;
        }
        for (slot, bone) in drivers.iter_mut().zip(&skeleton.bones) {
            let exact = self.nodes.iter().find(|n| self.bone_name(n) == bone.name);
            *slot = exact.or_else(|| self.nodes.iter().find(|n| same_bone_name(self.bone_name(n), &bone.name)));
        }
        drivers
    }

    /// The percent of blend-shape channel `name` at `t_s` from the
    /// motion's start, over its static `percent`; `None` if not animated.
    pub fn shape_percent(&self, name: &str, percent: f64, t_s: f64) -> Option<f64> {
        let shape = self.shapes.iter().find(|s| s.channel == name)?;
        shape.percent.value(&[percent], self.start_s + t_s, PropertyKind::Plain).first().copied()
    }

    /// The local transforms of `skeleton` at time `t_s` (from the motion's
    /// start). On a skeleton of the same height every channel applies as
    /// stored. On another it is retargeted: each bone of the same name
    /// turns, in world space, by as much as it turned from its bind pose on
    /// the source skeleton; translations stay the body's own except the root
    /// motion (the topmost bones whose translation moves), scaled by the
    /// ratio of heights. The body keeps its proportions.
    pub fn pose(&self, skeleton: &Skeleton, t_s: f64, target_height: f64) -> Vec<NodeTransform> {
        let scale = match self.reference_height > 0.0 && target_height > 0.0 {
            true => target_height / self.reference_height,
            false => 1.0,
        };
        let drivers = self.drivers(skeleton);
        if (scale - 1.0).abs() < 1e-9 || self.source.bones.is_empty() {
            return self.pose_as_stored(skeleton, &drivers, t_s);
        }
        let source_drivers = self.drivers(&self.source);
        let source_now = self.source.world_matrices(&self.pose_as_stored(&self.source, &source_drivers, t_s));
        let source_bind = self.source.bind_matrices();
        let target_bind = skeleton.bind_matrices();
        let root_motion = root_motion_bones(skeleton, &drivers);
        let mut locals = skeleton.rest_pose();
        let mut world: Vec<Matrix4<f64>> = Vec::with_capacity(skeleton.bones.len());
        for (i, bone) in skeleton.bones.iter().enumerate() {
            let parent = bone.parent.and_then(|p| world.get(p).copied()).unwrap_or_else(Matrix4::identity);
            let local = &mut locals[i];
            if let Some(j) = drivers[i].map(|d| d.bone) {
                let turn = rotation_of(&source_now[j]) * rotation_of(&source_bind[j]).transpose();
                let wanted = turn * rotation_of(&target_bind[i]);
                let in_parent = Rotation3::from_matrix_unchecked(rotation_of(&parent).transpose() * wanted);
                local.rotation_deg = EulerOrder::Xyz.angles(&in_parent);
                local.order = EulerOrder::Xyz;
                local.pre_rotation_deg = Vector3::zeros();
                local.post_rotation_deg = Vector3::zeros();
            }
            if let Some(driver) = drivers[i].filter(|_| root_motion[i]) {
                let mut moved = local.clone();
                moved.translation /= scale;
                driver.apply(self.start_s + t_s, &mut moved);
                local.translation = moved.translation * scale;
            }
            world.push(parent * local.matrix());
        }
        locals
    }

    /// Every animated value applied as stored.
    fn pose_as_stored(&self, skeleton: &Skeleton, drivers: &[Option<&NodeAnimation>], t_s: f64) -> Vec<NodeTransform> {
        let t = self.start_s + t_s;
        let mut locals = skeleton.rest_pose();
        for (local, driver) in locals.iter_mut().zip(drivers) {
            if let Some(node) = driver {
                node.apply(t, local);
            }
        }
        locals
    }
}

/// Per bone, whether it carries the root motion: its translation moves and
/// no ancestor's does.
fn root_motion_bones(skeleton: &Skeleton, drivers: &[Option<&NodeAnimation>]) -> Vec<bool> {
    let mut moving = vec![false; skeleton.bones.len()];
    let mut root = vec![false; skeleton.bones.len()];
    for (i, bone) in skeleton.bones.iter().enumerate() {
        let above = bone.parent.is_some_and(|p| moving[p]);
        let varies = drivers[i].is_some_and(NodeAnimation::translation_varies);
        moving[i] = above || varies;
        root[i] = varies && !above;
    }
    root
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::body::curve::Interpolation;
    use crate::body::skeleton::Bone;

    fn ramp(from: f64, to: f64) -> Option<Curve> {
        Some(Curve::through(&[(0.0, from), (1.0, to)], Interpolation::Linear))
    }

    fn animated(components: [(Option<Curve>, f64); 3]) -> Option<Animated> {
        Some(Animated {
            layers: vec![LayerValue { weight: 1.0, components: components.to_vec(), ..Default::default() }],
        })
    }

    fn skeleton(leg: f64) -> Skeleton {
        let at = |y: f64| NodeTransform { translation: Vector3::new(0.0, y, 0.0), ..Default::default() };
        let bone = |name: &str, parent, y| Bone { name: String::from(name), parent, rest: at(y), bind: None };
        Skeleton { bones: vec![bone("root", None, 0.0), bone("hip", Some(0), leg), bone("head", Some(1), leg)] }
    }

    fn walk() -> Motion {
        let root = NodeAnimation {
            bone: 0,
            translation: animated([(None, 0.0), (None, 0.0), (ramp(0.0, 2.0), 0.0)]),
            ..Default::default()
        };
        let hip = NodeAnimation {
            bone: 1,
            translation: animated([(None, 0.0), (ramp(1.0, 1.0), 0.0), (None, 0.0)]),
            rotation: animated([(ramp(0.0, 30.0), 0.0), (None, 0.0), (None, 0.0)]),
            ..Default::default()
        };
        let mut source = skeleton(1.0);
        source.bones.push(Bone { name: "tail".into(), parent: Some(0), rest: NodeTransform::default(), bind: None });
        let tail = NodeAnimation {
            bone: 3,
            rotation: animated([(ramp(0.0, 90.0), 0.0), (None, 0.0), (None, 0.0)]),
            ..Default::default()
        };
        Motion {
            nodes: vec![root, hip, tail],
            start_s: 0.0,
            end_s: 1.0,
            reference_height: 2.0,
            source,
            ..Default::default()
        }
    }

    #[test]
    fn on_a_skeleton_of_its_height_every_channel_applies() {
        let pose = walk().pose(&skeleton(1.0), 0.5, 2.0);
        assert_eq!(pose[0].translation.z, 1.0);
        assert_eq!(pose[1].rotation_deg.x, 15.0);
    }

    #[test]
    fn reused_on_a_taller_skeleton_it_keeps_the_bodys_proportions() {
        let tall = skeleton(1.5);
        let height = skeleton_height(&tall, &Vector3::y());
        assert_eq!(height, 3.0);
        let pose = walk().pose(&tall, 0.5, height);
        assert_eq!(pose[1].translation.y, 1.5, "the hip keeps the taller body's offset");
        assert!((pose[1].rotation_deg.x - 15.0).abs() < 1e-9, "rotations carry over");
        assert!((pose[0].translation.z - 1.5).abs() < 1e-12, "the root travels in proportion to the height");
    }

    #[test]
    fn bones_the_skeleton_lacks_are_reported() {
        let m = walk().bone_match(&skeleton(1.0));
        assert_eq!(m.matched, ["root", "hip"]);
        assert_eq!(m.missing_in_skeleton, ["tail"]);
        assert!(!m.is_complete());
    }

    #[test]
    fn a_missing_curve_takes_its_curve_nodes_default_not_the_static_value() {
        let a = Animated {
            layers: vec![LayerValue {
                weight: 1.0,
                components: vec![(None, 5.0), (ramp(0.0, 1.0), 0.0)],
                ..Default::default()
            }],
        };
        assert_eq!(a.value(&[9.0, 9.0], 0.5, PropertyKind::Plain), vec![5.0, 0.5]);
    }

    #[test]
    fn layers_add_multiply_compose_and_override() {
        let layer = |blend, weight: f64, value: f64| LayerValue {
            blend,
            weight,
            components: vec![(None, value); 3],
            ..Default::default()
        };
        let two = |blend, weight, value| Animated {
            layers: vec![layer(LayerBlend::Additive, 0.0, 2.0), layer(blend, weight, value)],
        };
        let base = [7.0; 3];
        assert_eq!(two(LayerBlend::Additive, 0.5, 4.0).value(&base, 0.0, PropertyKind::Plain), vec![4.0; 3]);
        assert_eq!(two(LayerBlend::Override, 0.5, 4.0).value(&base, 0.0, PropertyKind::Plain), vec![4.0; 3]);
        assert_eq!(two(LayerBlend::Passthrough, 0.25, 4.0).value(&base, 0.0, PropertyKind::Plain), vec![2.5; 3]);
        assert_eq!(two(LayerBlend::Additive, 1.0, 3.0).value(&base, 0.0, PropertyKind::Scale), vec![6.0; 3]);
        // Two turns about X compose: 2° + half of 40°.
        let rotation = Animated {
            layers: vec![
                LayerValue {
                    weight: 1.0,
                    components: vec![(None, 2.0), (None, 0.0), (None, 0.0)],
                    ..Default::default()
                },
                LayerValue {
                    weight: 0.5,
                    components: vec![(None, 40.0), (None, 0.0), (None, 0.0)],
                    ..Default::default()
                },
            ],
        };
        let angles = rotation.value(&base, 0.0, PropertyKind::Rotation(EulerOrder::Xyz));
        assert!((angles[0] - 22.0).abs() < 1e-9 && angles[1].abs() < 1e-9, "{angles:?}");
    }
}
