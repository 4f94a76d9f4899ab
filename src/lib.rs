//! drape: cloth animation authoring.
//!
//! A garment (OBJ or generated) and a fabric preset go in; an implicit
//! mass-spring solver with exact contact handling simulates it against
//! colliders; the baked frames come out as OBJ sequences and point caches.
//! The physics in [`sim`] is pure and deterministic: the same scene and
//! settings give the same bake, bit for bit, at any thread count.
//!
//! Layers (arrows point down): the `drape` binary → [`app`] (the editor),
//! [`bench`], [`bake`], [`fabric_lab`] →
//! [`scene`] → [`io`], [`sim`] → [`mesh`].

pub mod app;
pub mod bake;
pub mod bench;
pub mod body;
pub mod export;
pub mod fabric_lab;
pub mod farm;
pub mod io;
pub mod mesh;
pub mod metrics;
pub mod render;
pub mod scene;
pub mod sim;
pub mod stage;
pub mod untrusted;
