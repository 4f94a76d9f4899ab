//! A skeleton: every node of a file's hierarchy in parents-first order,
//! each with its static local transform, and their world matrices as the
//! FBX SDK composes them (with each node's way of inheriting scale).

use nalgebra::{Matrix4, Vector3};

use super::transform::{Inherit, NodeTransform};

/// One node of the hierarchy (a bone, a mesh's node, or a plain transform).
#[derive(Clone, Debug, PartialEq)]
pub struct Bone {
    /// Name (motions from other files find bones by it).
    pub name: String,
    /// Index of the parent bone; parents come before their children.
    pub parent: Option<usize>,
    /// Local transform from the file's static values.
    pub rest: NodeTransform,
    /// `file_from_bone` at bind time, where the file gives one (a skin
    /// cluster's `TransformLink` or the bind pose).
    pub bind: Option<Matrix4<f64>>,
}

/// Bones ordered parents first.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Skeleton {
    /// The bones.
    pub bones: Vec<Bone>,
}

/// Whether two bone names name the same bone once their namespaces (the
/// text up to the last `:`, as in Mixamo's `mixamorig:Hips`) are set aside.
pub fn same_bone_name(a: &str, b: &str) -> bool {
    fn bare(name: &str) -> &str {
        name.rsplit(':').next().unwrap_or(name)
    }
    bare(a) == bare(b)
}

/// What a child needs of its parent's world transform.
#[derive(Clone, Copy)]
struct Inherited {
    /// `file_from_bone`.
    world: Matrix4<f64>,
    /// The world matrix without this node's own scale.
    unscaled: Matrix4<f64>,
    /// This node's scale per component, with what it carried from above.
    scale: Vector3<f64>,
    /// The scale carried down to this node per component (1 for a normal
    /// node): what a child that ignores this node's own scale still keeps.
    carried: Vector3<f64>,
}

impl Inherited {
    /// The scene's root.
    fn root() -> Inherited {
        let one = Vector3::repeat(1.0);
        Inherited { world: Matrix4::identity(), unscaled: Matrix4::identity(), scale: one, carried: one }
    }
}

impl Skeleton {
    /// Index of the first bone called `name`, or else of the first whose name
    /// is the same without its namespace (`mixamorig:Hips` is `Hips`).
    pub fn find(&self, name: &str) -> Option<usize> {
        let exact = self.bones.iter().position(|b| b.name == name);
        exact.or_else(|| self.bones.iter().position(|b| same_bone_name(&b.name, name)))
    }

    /// The static local transforms.
    pub fn rest_pose(&self) -> Vec<NodeTransform> {
        self.bones.iter().map(|b| b.rest.clone()).collect()
    }

    /// `file_from_bone` of every bone at bind time: the file's bind matrix
    /// where it gives one, else the static pose under the parent's bind.
    pub fn bind_matrices(&self) -> Vec<Matrix4<f64>> {
        let rest = self.world_matrices(&self.rest_pose());
        let mut bind: Vec<Matrix4<f64>> = Vec::with_capacity(self.bones.len());
        for (i, bone) in self.bones.iter().enumerate() {
            let derived = || {
                let parent = bone.parent.and_then(|p| Some((bind.get(p)?, rest.get(p)?.try_inverse()?)));
                let own = rest[i];
                parent.map_or(own, |(parent_bind, parent_rest_inverse)| parent_bind * parent_rest_inverse * own)
            };
            bind.push(bone.bind.unwrap_or_else(derived));
        }
        bind
    }

    /// `file_from_bone` of every bone for the local transforms `locals`.
    ///
    /// A normal node takes its parent's whole matrix. A component-scale
    /// node (RrSs) and a node that ignores its parent's scale (Rrs) hang
    /// from the parent's matrix without the parent's own scale, move by
    /// their translation scaled by it, and scale by their own scale times
    /// the scale carried down to them per component: all of it for RrSs,
    /// none of the parent's own for Rrs.
    pub fn world_matrices(&self, locals: &[NodeTransform]) -> Vec<Matrix4<f64>> {
        let mut inherited: Vec<Inherited> = Vec::with_capacity(self.bones.len());
        for (bone, local) in self.bones.iter().zip(locals) {
            let parent = bone.parent.and_then(|p| inherited.get(p)).copied();
            inherited.push(compose(parent, local));
        }
        inherited.into_iter().map(|i| i.world).collect()
    }
}

/// A node's world transform from its parent's (`None`: the scene root).
fn compose(parent: Option<Inherited>, local: &NodeTransform) -> Inherited {
    let parent = parent.unwrap_or_else(Inherited::root);
    let trs = local.trs();
    let turn = trs.rotation.to_homogeneous();
    let (base, translation, carried) = match local.inherit {
        Inherit::Normal => (parent.world, trs.translation, Vector3::repeat(1.0)),
        Inherit::ComponentScale => (parent.unscaled, trs.translation.component_mul(&parent.scale), parent.scale),
        Inherit::IgnoreParentScale => (parent.unscaled, trs.translation.component_mul(&parent.scale), parent.carried),
    };
    let scale = trs.scale.component_mul(&carried);
    let unscaled = base * Matrix4::new_translation(&translation) * turn;
    Inherited { world: unscaled * Matrix4::new_nonuniform_scaling(&scale), unscaled, scale, carried }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bone(name: &str, parent: Option<usize>, rest: NodeTransform) -> Bone {
        Bone { name: name.into(), parent, rest, bind: None }
    }

    #[test]
    fn children_compose_their_parents_transforms() {
        let arm = NodeTransform { translation: Vector3::new(1.0, 0.0, 0.0), ..Default::default() };
        let turned = NodeTransform { rotation_deg: Vector3::new(0.0, 0.0, 90.0), ..Default::default() };
        let skeleton = Skeleton { bones: vec![bone("shoulder", None, turned), bone("elbow", Some(0), arm)] };
        let world = skeleton.world_matrices(&skeleton.rest_pose());
        let elbow = world[1].transform_point(&Vector3::zeros().into());
        assert!((elbow.coords - Vector3::new(0.0, 1.0, 0.0)).norm() < 1e-12);
        assert_eq!(skeleton.find("elbow"), Some(1));
        assert_eq!(skeleton.find("mixamorig:elbow"), Some(1), "a namespace is set aside");
        assert_eq!(skeleton.find("rig:wrist"), None);
    }

    fn scaled_parent_and_turned_child(inherit: Inherit) -> Vec<Matrix4<f64>> {
        let parent = NodeTransform { scaling: Vector3::new(2.0, 1.0, 1.0), ..Default::default() };
        let child = NodeTransform {
            translation: Vector3::new(1.0, 0.0, 0.0),
            rotation_deg: Vector3::new(0.0, 0.0, 90.0),
            inherit,
            ..Default::default()
        };
        let skeleton = Skeleton { bones: vec![bone("parent", None, parent), bone("child", Some(0), child)] };
        skeleton.world_matrices(&skeleton.rest_pose())
    }

    #[test]
    fn each_inherit_type_takes_the_parents_scale_its_own_way() {
        let at = |m: &Matrix4<f64>, v: Vector3<f64>| m.transform_vector(&v);
        // Every child sits where the parent's scale puts its translation.
        for inherit in [Inherit::Normal, Inherit::ComponentScale, Inherit::IgnoreParentScale] {
            let child = scaled_parent_and_turned_child(inherit)[1];
            assert!((child.column(3).xyz() - Vector3::new(2.0, 0.0, 0.0)).norm() < 1e-12, "{inherit:?}");
        }
        // RSrs: the parent's X scale stretches the child's turned Y axis (world X).
        let normal = scaled_parent_and_turned_child(Inherit::Normal)[1];
        assert!((at(&normal, Vector3::y()) - Vector3::new(-2.0, 0.0, 0.0)).norm() < 1e-12);
        // RrSs: the scale applies along the child's own X (turned to world Y): no shear.
        let component = scaled_parent_and_turned_child(Inherit::ComponentScale)[1];
        assert!((at(&component, Vector3::x()) - Vector3::new(0.0, 2.0, 0.0)).norm() < 1e-12);
        assert!((at(&component, Vector3::y()) - Vector3::new(-1.0, 0.0, 0.0)).norm() < 1e-12);
        // Rrs: the parent's scale is left out altogether.
        let ignore = scaled_parent_and_turned_child(Inherit::IgnoreParentScale)[1];
        assert!((at(&ignore, Vector3::x()) - Vector3::new(0.0, 1.0, 0.0)).norm() < 1e-12);
    }
}
