//! Files in and out: OBJ garments and frames, PC2 point caches, atomic writes.

pub mod atomic;
pub mod fbx;
pub mod mdd;
pub mod motion_cache;
pub mod obj;
pub mod pc2;
