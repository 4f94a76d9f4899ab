//! A skeleton: named nodes in a hierarchy, each with its rest local transform.

use nalgebra::Matrix4;

use super::transform::NodeTransform;

/// One node of the hierarchy (a bone, or a plain transform above the bones).
#[derive(Clone, Debug, PartialEq)]
pub struct Bone {
    /// Name, unique within the skeleton (motions find bones by it).
    pub name: String,
    /// Index of the parent bone; parents come before their children.
    pub parent: Option<usize>,
    /// Local transform in the rest (bind) pose.
    pub rest: NodeTransform,
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

impl Skeleton {
    /// Index of the bone called `name`, or else of the one whose name is
    /// the same without its namespace (`mixamorig:Hips` is `Hips`).
    pub fn find(&self, name: &str) -> Option<usize> {
        let exact = self.bones.iter().position(|b| b.name == name);
        exact.or_else(|| self.bones.iter().position(|b| same_bone_name(&b.name, name)))
    }

    /// The rest local transforms.
    pub fn rest_pose(&self) -> Vec<NodeTransform> {
        self.bones.iter().map(|b| b.rest.clone()).collect()
    }

    /// `file_from_bone` of every bone for the local transforms `locals`.
    pub fn world_matrices(&self, locals: &[NodeTransform]) -> Vec<Matrix4<f64>> {
        let mut world: Vec<Matrix4<f64>> = Vec::with_capacity(self.bones.len());
        for (bone, local) in self.bones.iter().zip(locals) {
            let parent = bone.parent.and_then(|p| world.get(p).copied()).unwrap_or_else(Matrix4::identity);
            world.push(parent * local.matrix());
        }
        world
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::Vector3;

    use super::*;

    #[test]
    fn children_compose_their_parents_transforms() {
        let arm = NodeTransform { translation: Vector3::new(1.0, 0.0, 0.0), ..Default::default() };
        let turned = NodeTransform { rotation_deg: Vector3::new(0.0, 0.0, 90.0), ..Default::default() };
        let skeleton = Skeleton {
            bones: vec![
                Bone { name: "shoulder".into(), parent: None, rest: turned },
                Bone { name: "elbow".into(), parent: Some(0), rest: arm },
            ],
        };
        let world = skeleton.world_matrices(&skeleton.rest_pose());
        let elbow = world[1].transform_point(&Vector3::zeros().into());
        assert!((elbow.coords - Vector3::new(0.0, 1.0, 0.0)).norm() < 1e-12);
        assert_eq!(skeleton.find("elbow"), Some(1));
        assert_eq!(skeleton.find("mixamorig:elbow"), Some(1), "a namespace is set aside");
        assert_eq!(skeleton.find("rig:wrist"), None);
    }
}
