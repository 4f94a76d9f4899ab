//! A node's local transform as FBX defines it (translation, rotation with its
//! Euler order, pre- and post-rotation, pivots and offsets, scaling), how it
//! inherits its parent's scale, and the geometric transform a mesh node
//! applies to its geometry alone.

use nalgebra::{Matrix3, Matrix4, Rotation3, UnitQuaternion, Vector3};

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
    /// FBX's `RotationOrder` enum (0..=5); `None` for eSphericXYZ (6) and unknown values.
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

    /// Euler angles, degrees, whose rotation in this order is `rotation`.
    pub fn angles(self, rotation: &Rotation3<f64>) -> Vector3<f64> {
        // Re-express in XYZ order by permuting axes: the angles of the
        // turn about the first, second and third axes of this order.
        let (first, second, third) = self.axes();
        let m = rotation.matrix();
        // R = R_third · R_second · R_first; for a permutation (i, j, k) with
        // parity p, m[k][i] = -p sin(b), as in the XYZ case.
        let parity = if (first + 1) % 3 == second { 1.0 } else { -1.0 };
        let sin_b = (-parity * m[(third, first)]).clamp(-1.0, 1.0);
        let b = sin_b.asin();
        let (a, c) = if sin_b.abs() < 1.0 - 1e-12 {
            (
                (parity * m[(third, second)]).atan2(m[(third, third)]),
                (parity * m[(second, first)]).atan2(m[(first, first)]),
            )
        } else {
            // Gimbal lock: only a + c (or a - c) is defined; put it all in a.
            ((-parity * m[(second, third)]).atan2(m[(second, second)]), 0.0)
        };
        let mut out = Vector3::zeros();
        out[first] = a.to_degrees();
        out[second] = b.to_degrees();
        out[third] = c.to_degrees();
        out
    }

    /// The axes (0 = X) in the order they turn.
    fn axes(self) -> (usize, usize, usize) {
        match self {
            EulerOrder::Xyz => (0, 1, 2),
            EulerOrder::Xzy => (0, 2, 1),
            EulerOrder::Yzx => (1, 2, 0),
            EulerOrder::Yxz => (1, 0, 2),
            EulerOrder::Zxy => (2, 0, 1),
            EulerOrder::Zyx => (2, 1, 0),
        }
    }
}

/// How a node takes its parent's scale (FBX `InheritType`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Inherit {
    /// eInheritRSrs (1): the parent's whole matrix, scale and shear included.
    #[default]
    Normal,
    /// eInheritRrSs (0): the parent's scale re-applied per component after
    /// the node's own rotation (no shear).
    ComponentScale,
    /// eInheritRrs (2): the parent's own scale left out (Maya's segment
    /// scale compensate); translations still follow it.
    IgnoreParentScale,
}

impl Inherit {
    /// FBX's `InheritType` enum; unknown values are `Normal`.
    pub fn from_fbx(value: i64) -> Inherit {
        match value {
            0 => Inherit::ComponentScale,
            2 => Inherit::IgnoreParentScale,
            _ => Inherit::Normal,
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
    /// `RotationOrder` of `rotation_deg` (only with `rotation_active`).
    pub order: EulerOrder,
    /// `RotationActive`: the order and the pre- and post-rotation count.
    pub rotation_active: bool,
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
    /// How the parent's scale reaches this node.
    pub inherit: Inherit,
}

impl Default for NodeTransform {
    fn default() -> Self {
        NodeTransform {
            translation: Vector3::zeros(),
            rotation_deg: Vector3::zeros(),
            scaling: Vector3::repeat(1.0),
            order: EulerOrder::Xyz,
            rotation_active: true,
            pre_rotation_deg: Vector3::zeros(),
            post_rotation_deg: Vector3::zeros(),
            rotation_offset: Vector3::zeros(),
            rotation_pivot: Vector3::zeros(),
            scaling_offset: Vector3::zeros(),
            scaling_pivot: Vector3::zeros(),
            inherit: Inherit::Normal,
        }
    }
}

/// A local transform as translation, rotation and scale: `T(τ) · R · S(s)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Trs {
    /// τ, file units.
    pub translation: Vector3<f64>,
    /// R.
    pub rotation: Matrix3<f64>,
    /// s.
    pub scale: Vector3<f64>,
}

fn translation(v: &Vector3<f64>) -> Matrix4<f64> {
    Matrix4::new_translation(v)
}

impl NodeTransform {
    /// The rotation the node's own angles, order and pre- and
    /// post-rotation make: `Rpre · R · Rpost⁻¹`, or `R` in XYZ order alone
    /// when `RotationActive` is off (the FBX SDK's rule).
    pub fn rotation(&self) -> Rotation3<f64> {
        if !self.rotation_active {
            return EulerOrder::Xyz.rotation(&self.rotation_deg);
        }
        let pre = EulerOrder::Xyz.rotation(&self.pre_rotation_deg);
        let post = EulerOrder::Xyz.rotation(&self.post_rotation_deg);
        pre * self.order.rotation(&self.rotation_deg) * post.inverse()
    }

    /// `parent_from_node` = T · Roff · Rp · Rpre · R · Rpost⁻¹ · Rp⁻¹ · Soff · Sp · S · Sp⁻¹
    /// (the FBX SDK's definition).
    pub fn matrix(&self) -> Matrix4<f64> {
        translation(&self.translation)
            * translation(&self.rotation_offset)
            * translation(&self.rotation_pivot)
            * self.rotation().to_homogeneous()
            * translation(&-self.rotation_pivot)
            * translation(&self.scaling_offset)
            * translation(&self.scaling_pivot)
            * Matrix4::new_nonuniform_scaling(&self.scaling)
            * translation(&-self.scaling_pivot)
    }

    /// The same transform as `T(τ) · R · S(s)`: scaling comes before any
    /// rotation, so pivots and offsets only move the origin.
    pub fn trs(&self) -> Trs {
        let m = self.matrix();
        Trs {
            translation: m.fixed_view::<3, 1>(0, 3).into_owned(),
            rotation: *self.rotation().matrix(),
            scale: self.scaling,
        }
    }

    /// The translation, XYZ Euler rotation and scaling whose product is
    /// `matrix`, without shear; a mirroring matrix gets a negative X scale.
    /// `None` for a singular or non-finite matrix.
    pub fn from_matrix(matrix: &Matrix4<f64>) -> Option<NodeTransform> {
        let (rotation, scaling) = rotation_and_scale(&matrix.fixed_view::<3, 3>(0, 0).into_owned())?;
        Some(NodeTransform {
            translation: matrix.fixed_view::<3, 1>(0, 3).into_owned(),
            rotation_deg: EulerOrder::Xyz.angles(&rotation),
            scaling,
            ..Default::default()
        })
    }
}

/// A 3×3 matrix split into a rotation and per-axis scales without iteration:
/// scales are the columns' lengths, the first negated when the matrix
/// mirrors, and the rotation is the nearest one to the scaled-out columns
/// (a quaternion from them, normalised). `None` when a column is (near)
/// zero or a number is not finite.
pub fn rotation_and_scale(linear: &Matrix3<f64>) -> Option<(Rotation3<f64>, Vector3<f64>)> {
    let mut scale = Vector3::new(linear.column(0).norm(), linear.column(1).norm(), linear.column(2).norm());
    if !scale.iter().all(|s| s.is_finite() && *s > 1e-12) {
        return None;
    }
    if linear.determinant() < 0.0 {
        scale.x = -scale.x;
    }
    let columns = linear * Matrix3::from_diagonal(&scale.map(|s| 1.0 / s));
    let rotation = UnitQuaternion::from_quaternion(quaternion_of(&columns)).to_rotation_matrix();
    Some((rotation, scale))
}

/// The quaternion of a rotation matrix (Shepperd's method: the largest of
/// the trace and the diagonal picks the stable branch), not normalised.
fn quaternion_of(m: &Matrix3<f64>) -> nalgebra::Quaternion<f64> {
    use nalgebra::Quaternion;
    let trace = m[(0, 0)] + m[(1, 1)] + m[(2, 2)];
    if trace > m[(0, 0)].max(m[(1, 1)]).max(m[(2, 2)]) {
        let s = (1.0 + trace).max(0.0).sqrt() * 2.0;
        Quaternion::new(0.25 * s, (m[(2, 1)] - m[(1, 2)]) / s, (m[(0, 2)] - m[(2, 0)]) / s, (m[(1, 0)] - m[(0, 1)]) / s)
    } else if m[(0, 0)] >= m[(1, 1)] && m[(0, 0)] >= m[(2, 2)] {
        let s = (1.0 + m[(0, 0)] - m[(1, 1)] - m[(2, 2)]).max(0.0).sqrt() * 2.0;
        Quaternion::new((m[(2, 1)] - m[(1, 2)]) / s, 0.25 * s, (m[(0, 1)] + m[(1, 0)]) / s, (m[(0, 2)] + m[(2, 0)]) / s)
    } else if m[(1, 1)] >= m[(2, 2)] {
        let s = (1.0 + m[(1, 1)] - m[(0, 0)] - m[(2, 2)]).max(0.0).sqrt() * 2.0;
        Quaternion::new((m[(0, 2)] - m[(2, 0)]) / s, (m[(0, 1)] + m[(1, 0)]) / s, 0.25 * s, (m[(1, 2)] + m[(2, 1)]) / s)
    } else {
        let s = (1.0 + m[(2, 2)] - m[(0, 0)] - m[(1, 1)]).max(0.0).sqrt() * 2.0;
        Quaternion::new((m[(1, 0)] - m[(0, 1)]) / s, (m[(0, 2)] + m[(2, 0)]) / s, (m[(1, 2)] + m[(2, 1)]) / s, 0.25 * s)
    }
}

/// A mesh node's geometric transform (`GeometricTranslation`, `…Rotation`
/// in XYZ order, `…Scaling`): `node_from_geometry`, applied to its geometry
/// only, never inherited by children.
pub fn geometric_matrix(
    translation_: &Vector3<f64>,
    rotation_deg: &Vector3<f64>,
    scaling: &Vector3<f64>,
) -> Matrix4<f64> {
    translation(translation_)
        * EulerOrder::Xyz.rotation(rotation_deg).to_homogeneous()
        * Matrix4::new_nonuniform_scaling(scaling)
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
    fn angles_of_every_order_rebuild_their_rotation() {
        let orders =
            [EulerOrder::Xyz, EulerOrder::Xzy, EulerOrder::Yzx, EulerOrder::Yxz, EulerOrder::Zxy, EulerOrder::Zyx];
        for order in orders {
            for angles in
                [Vector3::new(20.0, -35.0, 110.0), Vector3::new(-170.0, 80.0, 5.0), Vector3::new(0.0, 90.0, 30.0)]
            {
                let r = order.rotation(&angles);
                let again = order.rotation(&order.angles(&r));
                assert!((again.matrix() - r.matrix()).norm() < 1e-9, "{order:?} {angles}");
            }
        }
    }

    #[test]
    fn matrices_decompose_into_transforms_that_rebuild_them() {
        let node = NodeTransform {
            translation: Vector3::new(1.0, -2.0, 3.0),
            rotation_deg: Vector3::new(20.0, -35.0, 110.0),
            scaling: Vector3::new(2.0, 0.5, 3.0),
            ..Default::default()
        };
        let again = NodeTransform::from_matrix(&node.matrix()).unwrap();
        assert!((again.matrix() - node.matrix()).norm() < 1e-9);
        assert!(NodeTransform::from_matrix(&Matrix4::zeros()).is_none());
    }

    #[test]
    fn mirroring_matrices_decompose_without_iterating() {
        // A reflection has no nearest rotation by iteration (the method
        // that hung on two files); here it gets a negative X scale.
        let mirrored = EulerOrder::Xyz.rotation(&Vector3::new(0.0, 0.0, 30.0)).to_homogeneous()
            * Matrix4::new_nonuniform_scaling(&Vector3::new(1.0, -2.0, 1.0));
        let node = NodeTransform::from_matrix(&mirrored).unwrap();
        assert!(node.scaling.x < 0.0);
        assert!((node.matrix() - mirrored).norm() < 1e-9);
        let nan = Matrix4::from_element(f64::NAN);
        assert!(NodeTransform::from_matrix(&nan).is_none());
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
        // As translation, rotation and scale it is the same matrix.
        let trs = node.trs();
        let rebuilt =
            translation(&trs.translation) * trs.rotation.to_homogeneous() * Matrix4::new_nonuniform_scaling(&trs.scale);
        assert!((rebuilt - m).norm() < 1e-12);
    }

    #[test]
    fn pre_and_post_rotation_wrap_the_animated_rotation_only_when_active() {
        let mut node = NodeTransform {
            pre_rotation_deg: Vector3::new(0.0, 0.0, 30.0),
            post_rotation_deg: Vector3::new(0.0, 0.0, 20.0),
            rotation_deg: Vector3::new(0.0, 0.0, 10.0),
            ..Default::default()
        };
        // About one axis they add: 30 + 10 - 20.
        let expected = EulerOrder::Xyz.rotation(&Vector3::new(0.0, 0.0, 20.0)).to_homogeneous();
        assert!((node.matrix() - expected).norm() < 1e-12);
        // RotationActive off: pre, post and the order are ignored.
        node.rotation_active = false;
        node.order = EulerOrder::Zyx;
        let expected = EulerOrder::Xyz.rotation(&Vector3::new(0.0, 0.0, 10.0)).to_homogeneous();
        assert!((node.matrix() - expected).norm() < 1e-12);
    }

    #[test]
    fn geometric_transforms_scale_then_turn_then_move() {
        let g =
            geometric_matrix(&Vector3::new(0.0, 0.0, 5.0), &Vector3::new(0.0, 0.0, 90.0), &Vector3::new(2.0, 1.0, 1.0));
        let p = g.transform_point(&Vector3::new(1.0, 0.0, 0.0).into());
        assert!((p.coords - Vector3::new(0.0, 2.0, 5.0)).norm() < 1e-12);
    }
}
