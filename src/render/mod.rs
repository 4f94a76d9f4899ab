//! The renderer: wgpu, physically based, headless or in a window.
//!
//! It draws what it is given ([`DrawMesh`]es: vertices, a [`Material`], a
//! placement) under a [`LightRig`] through an [`OrbitCamera`]; it knows nothing
//! of the solver. Shading is metallic-roughness Cook-Torrance with a fabric
//! sheen lobe (glTF KHR_materials_sheen), two-sided; the key light casts a
//! PCF-filtered shadow map; output is exposed (EV100), ACES-filmic tone mapped
//! and sRGB encoded, with 4× MSAA (or one sample, for the editor's viewport
//! on a software rasteriser while it moves). WGSL lives in `shaders/`.

pub mod camera;
pub mod draw;
pub mod gpu;
pub mod lights;
pub mod renderer;
pub mod sheen;
pub mod target;

pub use camera::{Bounds, OrbitCamera};
pub use draw::{DrawMesh, Material, Vertex};
pub use gpu::{Gpu, RenderError};
pub use lights::{LightRig, LightRigError};
pub use renderer::{Renderer, View};
pub use target::{OffscreenTarget, TextureTarget};
