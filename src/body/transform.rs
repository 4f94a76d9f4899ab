//! A skeleton node's local transform as FBX defines it (translation, rotation
//! with its Euler order, pre- and post-rotation, pivots and offsets, scaling),
//! composed into a matrix.

use nalgebra::{Matrix4, Rotation3, Vector3};

/// Order in which Euler angles apply (the first letter turns first).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum EulerOrder {
    /// X, then Y, then Z (FBX eEulerXYZ, the default).
    #[default]
    Xyz,
    /// X, then Z, then Y.
    Xzy,
    /// Y, then Z, then X.
    Yzx,
    /// Y, then X, then Z.
    Yxz,
    /// Z, then X, then Y.
    Zxy,
    /// Z, then Y, then X.
    Zyx,
}

impl EulerOrder {
    /// FBX's `RotationOrder` enum (0..=5); `None` for eSphericXYZ and unknown values.
    pub fn from_fbx(value: i64) -> Option<EulerOrder> {
        [EulerOrder::Xyz, EulerOrder::Xzy, EulerOrder::Yzx, EulerOrder::Yxz, EulerOrder::Zxy, EulerOrder::Zyx]
            .get(usize::try_from(value).ok()?)
            .copied()
    }

    /// The rotation of Euler angles `degrees` (about X, Y, Z) in this order.
    pub fn rotation(self, degrees: &Vector3<f64>) -> Rotation3<f64> {
        let r = degrees.map(f64::to_radians);
        let (x, y, z) = (
            Rotation3::from_axis_angle(&Vector3::x_axis(), r.x),
            Rotation3::from_axis_angle(&Vector3::y_axis(), r.y),
            Rotation3::from_axis_angle(&Vector3::z_axis(), r.z),
        );
        match self {
            EulerOrder::Xyz => z * y * x,
            EulerOrder::Xzy => y * z * x,
            EulerOrder::Yzx => x * z * y,
            EulerOrder::Yxz => z * x * y,
            EulerOrder::Zxy => y * x * z,
            EulerOrder::Zyx => x * y * z,
        }
    }
}

/// The local transform of a node relative to its parent, in the file's units.
#[derive(Clone, Debug, PartialEq)]
pub struct NodeTransform {
    /// `Lcl Translation`.
    pub translation: Vector3<f64>,
    /// `Lcl Rotation`, degrees.
    pub rotation_deg: Vector3<f64>,
    /// `Lcl Scaling`.
    pub scaling: Vector3<f64>,
    /// `RotationOrder` of `rotation_deg`.
    pub order: EulerOrder,
    /// `PreRotation`, degrees (always XYZ).
    pub pre_rotation_deg: Vector3<f64>,
    /// `PostRotation`, degrees (always XYZ).
    pub post_rotation_deg: Vector3<f64>,
    /// `RotationOffset`.
    pub rotation_offset: Vector3<f64>,
    /// `RotationPivot`.
    pub rotation_pivot: Vector3<f64>,
    /// `ScalingOffset`.
    pub scaling_offset: Vector3<f64>,
    /// `ScalingPivot`.
    pub scaling_pivot: Vector3<f64>,
}

impl Default for NodeTransform {
    fn default() -> Self {
        NodeTransform {
            translation: Vector3::zeros(),
            rotation_deg: Vector3::zeros(),
            scaling: Vector3::repeat(1.0),
            order: EulerOrder::Xyz,
            pre_rotation_deg: Vector3::zeros(),
            post_rotation_deg: Vector3::zeros(),
            rotation_offset: Vector3::zeros(),
            rotation_pivot: Vector3::zeros(),
            scaling_offset: Vector3::zeros(),
            scaling_pivot: Vector3::zeros(),
        }
    }
}

fn translation(v: &Vector3<f64>) -> Matrix4<f64> {
    Matrix4::new_translation(v)
}

impl NodeTransform {
    /// The translation, XYZ Euler rotation and scaling whose product is
    /// `matrix` (no shear, positive scales); `None` for a singular matrix.
    pub fn from_matrix(matrix: &Matrix4<f64>) -> Option<NodeTransform> {
        let linear = matrix.fixed_view::<3, 3>(0, 0).into_owned();
        let scaling = Vector3::new(linear.column(0).norm(), linear.column(1).norm(), linear.column(2).norm());
        if scaling.iter().any(|s| !(s.is_finite() && *s > 1e-12)) {
            return None;
        }
        let rotation = Rotation3::from_matrix(&(linear * nalgebra::Matrix3::from_diagonal(&scaling.map(|s| 1.0 / s))));
        // nalgebra's euler_angles are (roll, pitch, yaw) with R = Rz(yaw) Ry(pitch) Rx(roll): FBX XYZ.
        let (x, y, z) = rotation.euler_angles();
        Some(NodeTransform {
            translation: matrix.fixed_view::<3, 1>(0, 3).into_owned(),
            rotation_deg: Vector3::new(x, y, z).map(f64::to_degrees),
            scaling,
            ..Default::default()
        })
    }

    /// `parent_from_node` = T · Roff · Rp · Rpre · R · Rpost⁻¹ · Rp⁻¹ · Soff · Sp · S · Sp⁻¹
    /// (the FBX SDK's definition).
    pub fn matrix(&self) -> Matrix4<f64> {
        let rotation = self.order.rotation(&self.rotation_deg).to_homogeneous();
        let pre = EulerOrder::Xyz.rotation(&self.pre_rotation_deg).to_homogeneous();
        let post_inverse = EulerOrder::Xyz.rotation(&self.post_rotation_deg).inverse().to_homogeneous();
        translation(&self.translation)
            * translation(&self.rotation_offset)
            * translation(&self.rotation_pivot)
            * pre
            * rotation
            * post_inverse
            * translation(&-self.rotation_pivot)
            * translation(&self.scaling_offset)
            * translation(&self.scaling_pivot)
            * Matrix4::new_nonuniform_scaling(&self.scaling)
            * translation(&-self.scaling_pivot)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn xyz_order_turns_about_x_first() {
        let r = EulerOrder::Xyz.rotation(&Vector3::new(90.0, 90.0, 0.0));
        // X first takes +Y to +Z, then Y takes +Z to +X.
        assert!((r * Vector3::y() - Vector3::x()).norm() < 1e-12);
        let r = EulerOrder::Yxz.rotation(&Vector3::new(90.0, 90.0, 0.0));
        // Y first leaves +Y, then X takes it to +Z.
        assert!((r * Vector3::y() - Vector3::z()).norm() < 1e-12);
    }

    #[test]
    fn matrices_decompose_into_transforms_that_rebuild_them() {
        let node = NodeTransform {
            translation: Vector3::new(1.0, -2.0, 3.0),
            rotation_deg: Vector3::new(20.0, -35.0, 110.0),
            scaling: Vector3::new(2.0, 2.0, 2.0),
            ..Default::default()
        };
        let again = NodeTransform::from_matrix(&node.matrix()).unwrap();
        assert!((again.matrix() - node.matrix()).norm() < 1e-9);
        assert!(NodeTransform::from_matrix(&Matrix4::zeros()).is_none());
    }

    #[test]
    fn rotation_turns_about_the_pivot() {
        let node = NodeTransform {
            rotation_deg: Vector3::new(0.0, 0.0, 90.0),
            rotation_pivot: Vector3::new(1.0, 0.0, 0.0),
            ..Default::default()
        };
        // The pivot stays put; the origin swings around it.
        let m = node.matrix();
        assert!(
            (m.transform_point(&Vector3::new(1.0, 0.0, 0.0).into()).coords - Vector3::new(1.0, 0.0, 0.0)).norm()
                < 1e-12
        );
        assert!((m.transform_point(&Vector3::zeros().into()).coords - Vector3::new(1.0, -1.0, 0.0)).norm() < 1e-12);
    }

    #[test]
    fn pre_and_post_rotation_wrap_the_animated_rotation() {
        let node = NodeTransform {
            pre_rotation_deg: Vector3::new(0.0, 0.0, 30.0),
            post_rotation_deg: Vector3::new(0.0, 0.0, 30.0),
            rotation_deg: Vector3::new(0.0, 0.0, 10.0),
            ..Default::default()
        };
        // About one axis they add: 30 + 10 - 30.
        let expected = EulerOrder::Xyz.rotation(&Vector3::new(0.0, 0.0, 10.0)).to_homogeneous();
        assert!((node.matrix() - expected).norm() < 1e-12);
    }
}
