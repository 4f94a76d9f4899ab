//! The wgpu device. Headless rendering needs no window and no GPU: on a
//! machine without one, wgpu finds Mesa's lavapipe (software Vulkan).

/// Why rendering could not start or finish.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// No adapter (GPU or software rasteriser) is available.
    #[error(
        "no graphics adapter: {0}. On Debian without a GPU install Mesa's software Vulkan \
         (apt-get install mesa-vulkan-drivers libvulkan1)"
    )]
    NoAdapter(String),
    /// The adapter refused to create a device.
    #[error("cannot open the graphics device: {0}")]
    Device(#[from] wgpu::RequestDeviceError),
    /// Reading the image back failed.
    #[error("cannot read the rendered image back: {0}")]
    Readback(String),
    /// A texture file could not be loaded.
    #[error("cannot load texture {path}: {problem}")]
    Texture {
        /// The image file.
        path: std::path::PathBuf,
        /// What went wrong.
        problem: String,
    },
}

/// An open device and its queue.
#[derive(Clone, Debug)]
pub struct Gpu {
    /// The device.
    pub device: wgpu::Device,
    /// Its queue.
    pub queue: wgpu::Queue,
    /// What it runs on (e.g. "llvmpipe (LLVM 15.0.6, 256 bits)"), for reports.
    pub adapter_name: String,
}

impl Gpu {
    /// Opens a device without a window (honours `WGPU_BACKEND` and
    /// `WGPU_ADAPTER_NAME`).
    pub fn headless() -> Result<Gpu, RenderError> {
        let instance = wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
        let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            ..Default::default()
        }))
        .map_err(|e| RenderError::NoAdapter(e.to_string()))?;
        Gpu::open(&adapter)
    }

    /// Opens a device on `adapter` (e.g. one compatible with a window's surface).
    pub fn open(adapter: &wgpu::Adapter) -> Result<Gpu, RenderError> {
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("drape"),
            required_limits: wgpu::Limits::downlevel_defaults().using_resolution(adapter.limits()),
            ..Default::default()
        }))?;
        Ok(Gpu { device, queue, adapter_name: adapter.get_info().name })
    }
}
