//! Measurements of a simulation's output that do not trust the solver: the
//! independent intersection checker, for one frame or a whole OBJ sequence.

pub mod intersections;
pub mod sequence;
pub mod triangles;
