//! Measurements of a simulation's output that do not trust the solver: the
//! independent intersection checker.

pub mod intersections;
pub mod triangles;
