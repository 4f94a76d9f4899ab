//! Skeletal motion, separate from any body: curves per bone name, so one
//! motion drives every skeleton with the same bone names (PAPER Experiment 1).

use std::collections::BTreeMap;

use nalgebra::{Matrix3, Matrix4, Rotation3, Vector3};

use super::curve::Curve;
use super::skeleton::{Skeleton, same_bone_name};
use super::transform::NodeTransform;

/// The animated channels of one bone; a missing curve keeps the rest value.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BoneChannels {
    /// `Lcl Translation` X, Y, Z, in the file's units.
    pub translation: [Option<Curve>; 3],
    /// `Lcl Rotation` X, Y, Z, degrees.
    pub rotation: [Option<Curve>; 3],
    /// `Lcl Scaling` X, Y, Z.
    pub scaling: [Option<Curve>; 3],
}

impl BoneChannels {
    fn apply(curves: &[Option<Curve>; 3], t_s: f64, value: &mut Vector3<f64>) {
        for (k, curve) in curves.iter().enumerate() {
            if let Some(v) = curve.as_ref().and_then(|c| c.value_at(t_s)) {
                value[k] = v;
            }
        }
    }

    /// Whether any translation curve moves (more than 1 µm in file units).
    fn translation_varies(&self) -> bool {
        self.translation.iter().flatten().any(|c| {
            let (low, high) =
                c.values.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &v| (l.min(v), h.max(v)));
            high - low > 1e-6
        })
    }
}

/// A motion: channels by bone name over a time range.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Motion {
    /// Channels of each animated bone, by name.
    pub bones: BTreeMap<String, BoneChannels>,
    /// First time of the motion, s.
    pub start_s: f64,
    /// Last time of the motion, s.
    pub end_s: f64,
    /// Height of the skeleton the motion was made on (vertical extent of its
    /// bones at rest, file units): reused on another skeleton, root
    /// translations scale by the ratio of heights.
    pub reference_height: f64,
    /// The skeleton the motion was made on, at rest: reused on another
    /// skeleton, each bone turns by as much as it turned on this one.
    pub source: Skeleton,
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

/// Vertical extent of a skeleton's bone origins at rest (file units, along `up`).
pub fn skeleton_height(skeleton: &Skeleton, up: &Vector3<f64>) -> f64 {
    let world = skeleton.world_matrices(&skeleton.rest_pose());
    let heights = world.iter().map(|m| m.fixed_view::<3, 1>(0, 3).dot(up));
    let (low, high) = heights.fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), y| (l.min(y), h.max(y)));
    if high > low { high - low } else { 0.0 }
}

impl Motion {
    /// Which animated bones `skeleton` has.
    pub fn bone_match(&self, skeleton: &Skeleton) -> BoneMatch {
        let mut m = BoneMatch::default();
        for name in self.bones.keys() {
            match skeleton.find(name) {
                Some(_) => m.matched.push(name.clone()),
                None => m.missing_in_skeleton.push(name.clone()),
            }
        }
        m
    }

    /// The channels of the bone called `bone`, or else of the one whose name
    /// is the same without its namespace (a Mixamo motion on a plain rig).
    fn channels(&self, bone: &str) -> Option<&BoneChannels> {
        let exact = self.bones.get(bone);
        exact.or_else(|| self.bones.iter().find(|(name, _)| same_bone_name(name, bone)).map(|(_, c)| c))
    }

    /// Duration, s.
    pub fn duration_s(&self) -> f64 {
        (self.end_s - self.start_s).max(0.0)
    }

    /// The local transforms of `skeleton` at time `t_s` (from the motion's
    /// start). On the skeleton it was made on (same height) every channel
    /// applies as stored. On another skeleton it is retargeted: each bone of
    /// the same name turns, in world space, by as much as it turned from its
    /// rest pose on the source skeleton; translations stay the body's own
    /// except the root motion (the topmost bones whose translation moves),
    /// scaled by the ratio of heights. The body keeps its proportions.
    pub fn pose(&self, skeleton: &Skeleton, t_s: f64, target_height: f64) -> Vec<NodeTransform> {
        let scale = match self.reference_height > 0.0 && target_height > 0.0 {
            true => target_height / self.reference_height,
            false => 1.0,
        };
        if (scale - 1.0).abs() < 1e-9 || self.source.bones.is_empty() {
            return self.pose_as_stored(skeleton, t_s);
        }
        let source_now = self.source.world_matrices(&self.pose_as_stored(&self.source, t_s));
        let source_rest = self.source.world_matrices(&self.source.rest_pose());
        let target_rest = skeleton.world_matrices(&skeleton.rest_pose());
        let root_motion = self.root_motion_bones(skeleton);
        let mut locals = skeleton.rest_pose();
        let mut world: Vec<Matrix4<f64>> = Vec::with_capacity(skeleton.bones.len());
        for (i, bone) in skeleton.bones.iter().enumerate() {
            let parent = bone.parent.and_then(|p| world.get(p).copied()).unwrap_or_else(Matrix4::identity);
            let local = &mut locals[i];
            let source = self.source.find(&bone.name).filter(|_| self.channels(&bone.name).is_some());
            if let Some(j) = source {
                let turn = rotation_of(&source_now[j]) * rotation_of(&source_rest[j]).transpose();
                let wanted = turn * rotation_of(&target_rest[i]);
                let in_parent = Rotation3::from_matrix(&(rotation_of(&parent).transpose() * wanted));
                let (x, y, z) = in_parent.euler_angles();
                local.rotation_deg = Vector3::new(x, y, z).map(f64::to_degrees);
                local.order = super::transform::EulerOrder::Xyz;
                local.pre_rotation_deg = Vector3::zeros();
                local.post_rotation_deg = Vector3::zeros();
            }
            if let Some(channels) = self.channels(&bone.name).filter(|_| root_motion[i]) {
                let mut moved = local.translation / scale;
                BoneChannels::apply(&channels.translation, self.start_s + t_s, &mut moved);
                local.translation = moved * scale;
            }
            world.push(parent * local.matrix());
        }
        locals
    }

    /// Every channel applied as stored, on the bones of the same name.
    fn pose_as_stored(&self, skeleton: &Skeleton, t_s: f64) -> Vec<NodeTransform> {
        let t = self.start_s + t_s;
        let mut locals = skeleton.rest_pose();
        for (bone, local) in skeleton.bones.iter().zip(locals.iter_mut()) {
            let Some(channels) = self.channels(&bone.name) else { continue };
            BoneChannels::apply(&channels.rotation, t, &mut local.rotation_deg);
            BoneChannels::apply(&channels.scaling, t, &mut local.scaling);
            BoneChannels::apply(&channels.translation, t, &mut local.translation);
        }
        locals
    }

    /// Per bone of `skeleton`, whether it carries the root motion: its
    /// translation moves and no ancestor's does.
    fn root_motion_bones(&self, skeleton: &Skeleton) -> Vec<bool> {
        let mut moving = vec![false; skeleton.bones.len()];
        let mut root = vec![false; skeleton.bones.len()];
        for (i, bone) in skeleton.bones.iter().enumerate() {
            let above = bone.parent.is_some_and(|p| moving[p]);
            let varies = self.channels(&bone.name).is_some_and(BoneChannels::translation_varies);
            moving[i] = above || varies;
            root[i] = varies && !above;
        }
        root
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::body::curve::Interpolation;
    use crate::body::skeleton::Bone;

    fn ramp(from: f64, to: f64) -> Option<Curve> {
        Some(Curve { times_s: vec![0.0, 1.0], values: vec![from, to], interpolation: vec![Interpolation::Linear; 2] })
    }

    fn skeleton(leg: f64) -> Skeleton {
        let at = |y: f64| NodeTransform { translation: Vector3::new(0.0, y, 0.0), ..Default::default() };
        Skeleton {
            bones: vec![
                Bone { name: "root".into(), parent: None, rest: at(0.0) },
                Bone { name: "hip".into(), parent: Some(0), rest: at(leg) },
                Bone { name: "head".into(), parent: Some(1), rest: at(leg) },
            ],
        }
    }

    fn walk() -> Motion {
        let mut bones = BTreeMap::new();
        bones.insert("root".into(), BoneChannels { translation: [None, None, ramp(0.0, 2.0)], ..Default::default() });
        let hip = BoneChannels {
            translation: [None, ramp(1.0, 1.0), None],
            rotation: [ramp(0.0, 30.0), None, None],
            ..Default::default()
        };
        bones.insert("hip".into(), hip);
        bones.insert("tail".into(), BoneChannels { rotation: [ramp(0.0, 90.0), None, None], ..Default::default() });
        Motion { bones, start_s: 0.0, end_s: 1.0, reference_height: 2.0, source: skeleton(1.0) }
    }

    #[test]
    fn on_its_own_skeleton_every_channel_applies() {
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
        assert_eq!(m.matched, ["hip", "root"]);
        assert_eq!(m.missing_in_skeleton, ["tail"]);
        assert!(!m.is_complete());
    }
}
