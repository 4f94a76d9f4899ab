//! What the linear solve may change in each particle's row: everything, a
//! plane (a contact's normal held), or nothing (a pin). The filter `S` of the
//! constrained solve (PAPER eq. 9), shared by the solver, its
//! preconditioners and the strain limits.

use nalgebra::{Matrix3, Vector3};

/// What the solve may change in one particle's row.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum Constraint {
    /// All three components.
    #[default]
    Free,
    /// Nothing: the row keeps its starting value.
    Fixed,
    /// Everything but the component along this unit normal.
    Normal(Vector3<f64>),
}

impl Constraint {
    /// The projector `S` onto the directions the solve may change.
    pub fn filter_matrix(&self) -> Matrix3<f64> {
        match self {
            Constraint::Free => Matrix3::identity(),
            Constraint::Fixed => Matrix3::zeros(),
            Constraint::Normal(n) => Matrix3::identity() - n * n.transpose(),
        }
    }

    /// This constraint with motion along unit normal `n` taken away too: a
    /// free particle keeps the plane across `n`; one already held along
    /// another normal, or fixed, is fixed.
    pub fn held_along(self, n: Vector3<f64>) -> Constraint {
        match self {
            Constraint::Free => Constraint::Normal(n),
            Constraint::Normal(_) | Constraint::Fixed => Constraint::Fixed,
        }
    }

    /// Projects `v` onto the directions the solve may change.
    pub fn filter(&self, v: Vector3<f64>) -> Vector3<f64> {
        match self {
            Constraint::Free => v,
            Constraint::Fixed => Vector3::zeros(),
            Constraint::Normal(n) => v - n * n.dot(&v),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_filter_keeps_the_plane_across_a_held_normal() {
        let n = Vector3::new(0.0, 1.0, 0.0);
        let held = Constraint::Free.held_along(n);
        assert_eq!(held.filter(Vector3::new(1.0, 2.0, 3.0)), Vector3::new(1.0, 0.0, 3.0));
        assert_eq!(held.filter_matrix() * Vector3::new(1.0, 2.0, 3.0), Vector3::new(1.0, 0.0, 3.0));
        assert_eq!(held.held_along(Vector3::x()), Constraint::Fixed, "two normals: fixed");
        assert_eq!(Constraint::Fixed.filter(Vector3::new(1.0, 2.0, 3.0)), Vector3::zeros());
    }
}
