//! The editor: a winit window with an egui UI around the PBR viewport.
//!
//! A designer opens a scene (the skirt on the walking body by default), tunes
//! the fabric while the cloth simulates, bakes, plays back and exports. The UI
//! thread owns no physics: a [`worker`] thread owns the simulation and
//! streams whole frames back ([`worker::Command`] in, [`worker::Event`] out),
//! so the window stays responsive at any cloth size. [`editor::Editor`] is the
//! UI's state and behaviour without a window (UI tests drive it directly);
//! [`panels`] lays it out; [`viewport`] renders the 3D view into a texture
//! that [`blit`] copies into the window; [`window`] is the winit / wgpu / egui
//! glue.

pub mod blit;
mod bottom_bar;
pub mod browse;
pub mod dialog;
pub mod editor;
pub mod examples;
pub mod export;
mod export_panel;
pub mod fabric_panel;
pub mod job;
pub mod menu;
pub mod orbit;
pub mod panels;
pub mod rasteriser;
pub mod reference;
pub mod shortcuts;
pub mod stats;
pub mod timeline;
pub mod timeline_bar;
pub mod viewport;
pub mod viewport_panel;
pub mod window;
pub mod worker;

pub use editor::{Editor, Quality};
pub use window::{Screenshot, run};

/// Why the editor could not open or keep its window.
#[derive(Debug, thiserror::Error)]
pub enum AppError {
    /// No display or the window could not be created.
    #[error(
        "cannot open a window: {0}. Without a display, run the editor under a virtual one \
         (apt-get install xvfb; xvfb-run -s '-screen 0 1600x1000x24' drape) or bake headless with `drape bake`"
    )]
    Window(String),
    /// The graphics device or the window's surface failed.
    #[error("graphics: {0}")]
    Graphics(String),
}
