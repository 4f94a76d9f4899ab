//! The commands of the `drape` binary, one module each (the rest still in
//! `main.rs`).

pub mod bake;
pub mod body;
pub mod export;
pub mod farm;
pub mod render;
