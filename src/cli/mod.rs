//! The commands of the `drape` binary, one module each (`main.rs` keeps the
//! command line, the dispatch, `edit` and `check`).

pub mod bake;
pub mod bench;
pub mod body;
pub mod export;
pub mod fabric;
pub mod farm;
pub mod render;
