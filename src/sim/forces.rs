//! Element forces and their Jacobians.
//!
//! **Springs** (stretch and shear): a linear spring between two particles with
//! damping along its axis. With `d = x₀ − x₁`, `l = |d|`, `u = d/l`, rest length
//! `L`, stiffness `k` and damping `c`, the force on particle 0 is
//!
//! ```text
//! f₀ = −k (l − L) u − c (u·(v₀ − v₁)) u,       f₁ = −f₀
//! ∂f₀/∂x₀ = −k [u uᵀ + (1 − L/l)(I − u uᵀ)]    (elastic part)
//! ∂f₀/∂v₀ = −c u uᵀ
//! ```
//!
//! The stiffness is [`SpringStiffness::tension`] while the spring is longer than
//! its rest length and [`SpringStiffness::compression`] while shorter: fabric
//! buckles into folds long before it shortens in its own plane, so stretch
//! springs resist compression only weakly. (A mesh can only fold at its own
//! resolution; full compression stiffness makes a coarse mesh stand off where
//! a fine one gathers, and the drape would depend on the mesh.)
//!
//! Under compression `1 − L/l < 0` makes the elastic Jacobian indefinite; the
//! system matrix uses [`spring_stiffness_definite`], which drops the negative
//! transverse term (Choi and Ko 2002), so the backward-Euler matrix stays
//! symmetric positive definite. The damping force's position derivative is not
//! symmetric and is left out of the system, as in Baraff and Witkin 1998; its
//! exact form is kept next to the tests that check it.
//!
//! **Bending** uses the hinge of each interior edge (the edge's two vertices and
//! the two vertices opposite it) with the quadratic isometric bending energy of
//! Bergou et al. 2006: `E = ½ B |Σᵢ wᵢ xᵢ|²` with constant weights `wᵢ` from the
//! rest shape ([`hinge_weights`]), so force `fᵢ = −B wᵢ Σⱼ wⱼ xⱼ` is linear and
//! its Jacobian `−B wᵢ wⱼ I` is constant. `B` is the fabric's flexural rigidity
//! (N·m): a spring between the opposite vertices, as the paper has it, has zero
//! stiffness at the flat state (its length changes only to second order in the
//! fold angle), so its bending response could not be made independent of the
//! mesh resolution; the hinge on the same four vertices can.

use nalgebra::{Matrix3, Vector3};

/// Stiffness of a spring, N/m, by whether it is stretched or compressed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpringStiffness {
    /// While longer than the rest length.
    pub tension: f64,
    /// While shorter than the rest length.
    pub compression: f64,
}

impl SpringStiffness {
    /// The same stiffness both ways.
    pub fn symmetric(k: f64) -> Self {
        SpringStiffness { tension: k, compression: k }
    }

    /// The stiffness that applies at length `length` for rest length `rest`.
    fn at(&self, length: f64, rest: f64) -> f64 {
        if length < rest { self.compression } else { self.tension }
    }
}

/// Force of a spring on its first particle, N. `d = x₀ − x₁` (m), `dv = v₀ − v₁`
/// (m/s), `rest` length (m), stiffness `k` (N/m), damping `c` (N·s/m).
pub fn spring_force(d: &Vector3<f64>, dv: &Vector3<f64>, rest: f64, k: SpringStiffness, c: f64) -> Vector3<f64> {
    let length = d.norm();
    if length == 0.0 {
        return Vector3::zeros();
    }
    let u = d / length;
    -u * (k.at(length, rest) * (length - rest) + c * u.dot(dv))
}

/// Exact elastic Jacobian `∂f₀/∂x₀` of a spring, N/m (away from the rest
/// length, where the stiffness changes).
pub fn spring_stiffness_jacobian(d: &Vector3<f64>, rest: f64, k: SpringStiffness) -> Matrix3<f64> {
    elastic_jacobian(d, rest, k, |transverse| transverse)
}

/// The positive semi-definite part of `−∂f₀/∂x₀` used in the system matrix: the
/// transverse term is kept only while the spring is stretched. N/m.
pub fn spring_stiffness_definite(d: &Vector3<f64>, rest: f64, k: SpringStiffness) -> Matrix3<f64> {
    -elastic_jacobian(d, rest, k, |transverse| transverse.max(0.0))
}

fn elastic_jacobian(d: &Vector3<f64>, rest: f64, k: SpringStiffness, transverse: impl Fn(f64) -> f64) -> Matrix3<f64> {
    let length = d.norm();
    if length == 0.0 {
        return Matrix3::zeros();
    }
    let u = d / length;
    let axial = u * u.transpose();
    -k.at(length, rest) * (axial + (Matrix3::identity() - axial) * transverse(1.0 - rest / length))
}

/// Damping Jacobian `−∂f₀/∂v₀ = c u uᵀ` of a spring, N·s/m.
pub fn spring_damping_matrix(d: &Vector3<f64>, c: f64) -> Matrix3<f64> {
    let length = d.norm();
    if length == 0.0 {
        return Matrix3::zeros();
    }
    let u = d / length;
    c * u * u.transpose()
}

/// Bending weights of a hinge, 1/m, scaled so that `½ B |Σ wᵢ xᵢ|²` is the
/// bending energy (J) for flexural rigidity `B` (N·m).
///
/// `x[0] → x[1]` is the shared edge, `x[2]` the vertex opposite it in the first
/// triangle, `x[3]` in the second. The weights are cotangent weights (Bergou et
/// al. 2006): they sum to zero (translations cost nothing), `Σ wᵢ xᵢ = 0` for any
/// flat rest hinge, and for a small fold by angle θ, `|Σ wᵢ xᵢ|² ≈ θ² |e|² s`
/// with `s` the scale below.
///
/// Scale: `s = 1 / (A₀ + A₁)` (triangle areas). On a regular grid bent into a
/// cylinder of curvature κ this gives the continuum plate energy `½ B κ² A`
/// (checked in the tests on two triangulations and two resolutions).
pub fn hinge_weights(x: &[Vector3<f64>; 4]) -> [f64; 4] {
    let e0 = x[1] - x[0];
    let cot = |a: Vector3<f64>, b: Vector3<f64>| a.dot(&b) / a.cross(&b).norm().max(f64::MIN_POSITIVE);
    let c01 = cot(e0, x[2] - x[0]);
    let c02 = cot(e0, x[3] - x[0]);
    let c03 = cot(-e0, x[2] - x[1]);
    let c04 = cot(-e0, x[3] - x[1]);
    let areas = 0.5 * (e0.cross(&(x[2] - x[0])).norm() + e0.cross(&(x[3] - x[0])).norm());
    let root_scale = (1.0 / areas).sqrt();
    [c03 + c04, c01 + c02, -c01 - c03, -c02 - c04].map(|k| k * root_scale)
}

/// `Σ wᵢ xᵢ` of a hinge (its bending "curvature vector"), unitless.
pub fn hinge_curvature(w: &[f64; 4], x: &[Vector3<f64>; 4]) -> Vector3<f64> {
    (0..4).map(|i| x[i] * w[i]).sum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Exact `∂f₀/∂x₀` of the damping force, N/m. Not symmetric; the solver
    /// leaves it out (see the module documentation).
    fn damping_position_jacobian(d: &Vector3<f64>, dv: &Vector3<f64>, c: f64) -> Matrix3<f64> {
        let l = d.norm();
        let u = d / l;
        let transverse = Matrix3::identity() - u * u.transpose();
        -(c / l) * (transverse * u.dot(dv) + u * dv.transpose() * transverse)
    }

    /// Central-difference Jacobian of `f` at `x`.
    fn numeric_jacobian(f: impl Fn(&Vector3<f64>) -> Vector3<f64>, x: &Vector3<f64>) -> Matrix3<f64> {
        let h = 1e-6;
        let mut jac = Matrix3::zeros();
        for k in 0..3 {
            let step = Vector3::ith(k, h);
            jac.set_column(k, &((f(&(x + step)) - f(&(x - step))) / (2.0 * h)));
        }
        jac
    }

    fn vec3() -> impl Strategy<Value = Vector3<f64>> {
        (-1.0..1.0f64, -1.0..1.0f64, -1.0..1.0f64).prop_map(|(x, y, z)| Vector3::new(x, y, z))
    }

    proptest! {
        #[test]
        fn spring_stiffness_jacobian_matches_finite_differences(d in vec3(), rest in 0.1..1.5f64) {
            prop_assume!(d.norm() > 0.05 && (d.norm() - rest).abs() > 1e-4);
            let (k, c) = (SpringStiffness { tension: 700.0, compression: 70.0 }, 0.0);
            let numeric = numeric_jacobian(|d| spring_force(d, &Vector3::zeros(), rest, k, c), &d);
            let exact = spring_stiffness_jacobian(&d, rest, k);
            prop_assert!((numeric - exact).norm() < 1e-5 * k.tension, "{numeric} vs {exact}");
        }

        #[test]
        fn spring_damping_jacobians_match_finite_differences(d in vec3(), dv in vec3()) {
            prop_assume!(d.norm() > 0.05);
            let c = 3.0;
            let none = SpringStiffness::symmetric(0.0);
            let damping_force = |d: &Vector3<f64>, dv: &Vector3<f64>| spring_force(d, dv, d.norm(), none, c);
            let by_velocity = numeric_jacobian(|v| damping_force(&d, v), &dv);
            prop_assert!((by_velocity + spring_damping_matrix(&d, c)).norm() < 1e-6);
            let by_position = numeric_jacobian(|x| spring_force(x, &dv, 1.0, none, c), &d);
            prop_assert!((by_position - damping_position_jacobian(&d, &dv, c)).norm() < 1e-4);
        }

        #[test]
        fn definite_stiffness_is_positive_semidefinite(d in vec3(), rest in 0.1..1.5f64) {
            prop_assume!(d.norm() > 0.05);
            let k = SpringStiffness { tension: 500.0, compression: 50.0 };
            let eigen = spring_stiffness_definite(&d, rest, k).symmetric_eigenvalues();
            prop_assert!(eigen.iter().all(|&e| e >= -1e-9), "{eigen}");
            if d.norm() >= rest {
                let exact = spring_stiffness_jacobian(&d, rest, k);
                prop_assert!((spring_stiffness_definite(&d, rest, k) + exact).norm() < 1e-9);
            }
        }

        #[test]
        fn hinge_weights_give_zero_force_for_rigid_motions(
            angle in -3.0..3.0f64, axis in vec3(), shift in vec3(), lift in -0.3..0.3f64
        ) {
            prop_assume!(axis.norm() > 0.1);
            let rest = [
                Vector3::new(0.0, 0.0, 0.0), Vector3::new(1.0, 0.0, 0.0),
                Vector3::new(0.3, 0.0, 0.8), Vector3::new(0.6, lift, -0.7),
            ];
            let w = hinge_weights(&rest);
            prop_assert!(w.iter().sum::<f64>().abs() < 1e-12);
            let rotation = nalgebra::Rotation3::new(axis.normalize() * angle);
            let moved = rest.map(|p| rotation * p + shift);
            let before = hinge_curvature(&w, &rest);
            let after = hinge_curvature(&w, &moved);
            prop_assert!((after.norm() - before.norm()).abs() < 1e-9);
        }
    }

    #[test]
    fn spring_force_pulls_ends_together_when_stretched_and_pushes_weakly_when_compressed() {
        let k = SpringStiffness { tension: 10.0, compression: 1.0 };
        let f = spring_force(&Vector3::new(2.0, 0.0, 0.0), &Vector3::zeros(), 1.5, k, 0.0);
        assert_eq!(f, Vector3::new(-5.0, 0.0, 0.0));
        let pushed = spring_force(&Vector3::new(1.0, 0.0, 0.0), &Vector3::zeros(), 1.5, k, 0.0);
        assert_eq!(pushed, Vector3::new(0.5, 0.0, 0.0));
        let damped = spring_force(&Vector3::new(1.5, 0.0, 0.0), &Vector3::new(2.0, 1.0, 0.0), 1.5, k, 0.5);
        assert_eq!(damped, Vector3::new(-1.0, 0.0, 0.0), "damping acts along the axis only");
    }

    #[test]
    fn small_fold_costs_theta_squared_edge_squared_over_area() {
        let theta: f64 = 1e-3;
        let flat = [
            Vector3::new(0.0, 0.0, 0.0),
            Vector3::new(1.0, 0.0, 0.0),
            Vector3::new(0.4, 0.0, 0.5),
            Vector3::new(0.7, 0.0, -0.6),
        ];
        let w = hinge_weights(&flat);
        assert!(hinge_curvature(&w, &flat).norm() < 1e-12, "flat rest hinge is unbent");
        let mut folded = flat;
        let rotation = nalgebra::Rotation3::new(Vector3::x() * theta);
        folded[3] = rotation * flat[3];
        let areas = 0.5 * (0.5 + 0.6);
        let expected = theta * theta / areas;
        let energy = hinge_curvature(&w, &folded).norm_squared();
        assert!((energy / expected - 1.0).abs() < 1e-3, "{energy} vs {expected}");
    }
}
