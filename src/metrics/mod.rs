//! Measurements of a simulation's output that do not trust the solver: the
//! independent intersection checker, for one frame or a whole OBJ sequence;
//! and how far an evaluated body is from another application's export of it.

pub mod intersections;
pub mod pose_error;
pub mod sequence;
pub mod triangles;
