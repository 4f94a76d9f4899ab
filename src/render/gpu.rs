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
    /// The adapter cannot run the renderer's shaders or pipelines.
    #[error(
        "the graphics adapter {adapter} cannot run drape's renderer: {problem}. drape renders with \
         Vulkan, Metal or DirectX 12; on Linux without a GPU install Mesa's software Vulkan \
         (apt-get install mesa-vulkan-drivers libvulkan1)"
    )]
    Unsupported {
        /// The adapter's name and backend.
        adapter: String,
        /// What it refused.
        problem: String,
    },
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
    /// The backend it runs on (Vulkan, Metal, Dx12; Gl only when asked for
    /// with `WGPU_BACKEND`).
    pub backend: wgpu::Backend,
    /// Whether it rasterises on the CPU (lavapipe, llvmpipe), sharing the
    /// cores with the solver.
    pub software: bool,
}

/// The graphics APIs the renderer's shaders run on: Vulkan, Metal and DirectX
/// 12 (their soft-shadow search reads depth texels, which OpenGL cannot), or
/// what `WGPU_BACKEND` names.
pub fn supported_backends() -> wgpu::Backends {
    wgpu::Backends::PRIMARY.with_env()
}

impl Gpu {
    /// Opens a device without a window (honours `WGPU_BACKEND` and
    /// `WGPU_ADAPTER_NAME`).
    pub fn headless() -> Result<Gpu, RenderError> {
        let descriptor = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
        let instance = wgpu::Instance::new(wgpu::InstanceDescriptor { backends: supported_backends(), ..descriptor });
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
        let info = adapter.get_info();
        let software = info.device_type == wgpu::DeviceType::Cpu;
        Ok(Gpu { device, queue, adapter_name: info.name, backend: info.backend, software })
    }

    /// Runs `create` with the device's validation and internal errors
    /// captured: a pipeline or shader the adapter cannot build becomes
    /// [`RenderError::Unsupported`] instead of wgpu's panic.
    pub fn validated<T>(&self, create: impl FnOnce(&wgpu::Device) -> T) -> Result<T, RenderError> {
        let validation = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let internal = self.device.push_error_scope(wgpu::ErrorFilter::Internal);
        let created = create(&self.device);
        let internal = pollster::block_on(internal.pop());
        match internal.or(pollster::block_on(validation.pop())) {
            None => Ok(created),
            Some(error) => Err(RenderError::Unsupported {
                adapter: format!("{} ({:?})", self.adapter_name, self.backend),
                problem: on_one_line(&error),
            }),
        }
    }
}

/// wgpu's multi-line error report on one line: "Validation Error: In
/// Device::create_render_pipeline, label = 'pbr': Internal error in ...".
fn on_one_line(error: &wgpu::Error) -> String {
    let text = error.to_string();
    let lines = text.lines().map(str::trim).filter(|line| !line.is_empty() && *line != "Caused by:");
    lines.collect::<Vec<_>>().join(": ")
}
