//! The wgpu device the renderers run on.
//!
//! Headless by default: Vulkan or GL, whichever adapter wgpu prefers (with Mesa installed that
//! is lavapipe through Vulkan, else llvmpipe through GL/EGL; a hardware GPU when there is one).
//! `WGPU_BACKEND=gl` or `WGPU_BACKEND=vulkan` picks one. The device asks only for what the
//! compositor uses: a stencil format (32-bit float depth when the adapter has it), storage
//! buffers, compute, indirect draws; MSAA is used when every multisampled format supports 4×.

use super::GpuError;

/// The depth-stencil formats in order of preference.
const DEPTH_FORMATS: [wgpu::TextureFormat; 2] = [wgpu::TextureFormat::Depth32FloatStencil8, wgpu::TextureFormat::Depth24PlusStencil8];
/// Colour format of the virtual-object layer (premultiplied linear radiance).
pub const LAYER_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
/// Colour format of the shadow masks (coverage per class).
pub const MASK_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;
/// Formats of the composited output read back for files (linear), best first: full float where
/// the adapter can render to it, half float otherwise (GL).
const OUTPUT_FORMATS: [wgpu::TextureFormat; 2] = [wgpu::TextureFormat::Rgba32Float, wgpu::TextureFormat::Rgba16Float];
/// MSAA sample count used when the adapter supports it for every multisampled format.
pub const PREFERRED_SAMPLES: u32 = 4;

/// Device choices.
#[derive(Clone, Copy, Debug)]
pub struct GpuOptions {
    /// MSAA samples wanted (1 or 4); reduced to 1 when the adapter cannot.
    pub samples: u32,
}

impl Default for GpuOptions {
    fn default() -> Self {
        Self { samples: PREFERRED_SAMPLES }
    }
}

/// An adapter, its device and queue, and the formats the passes use.
pub struct Gpu {
    /// The instance (kept for creating window surfaces).
    pub instance: wgpu::Instance,
    /// The adapter.
    pub adapter: wgpu::Adapter,
    /// The device.
    pub device: wgpu::Device,
    /// Its queue.
    pub queue: wgpu::Queue,
    /// Depth-stencil format of the canvas.
    pub depth_format: wgpu::TextureFormat,
    /// MSAA samples of the canvas passes (1 or 4).
    pub samples: u32,
    /// Format of the offscreen output.
    pub output_format: wgpu::TextureFormat,
}

/// The value of an IEEE 754 half float.
pub fn f32_from_f16(h: u16) -> f32 {
    let sign = if h & 0x8000 != 0 { -1.0 } else { 1.0 };
    let exp = ((h >> 10) & 0x1f) as i32;
    let frac = (h & 0x3ff) as f32;
    sign * match exp {
        0 => frac * (2f32).powi(-24),
        31 => if frac == 0.0 { f32::INFINITY } else { f32::NAN },
        e => (1.0 + frac / 1024.0) * (2f32).powi(e - 15),
    }
}

impl std::fmt::Debug for Gpu {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Gpu")
            .field("adapter", &self.describe())
            .field("depth_format", &self.depth_format)
            .field("samples", &self.samples)
            .field("output_format", &self.output_format)
            .finish()
    }
}

impl Gpu {
    /// Opens a headless device.
    pub fn new(options: GpuOptions) -> Result<Self, GpuError> {
        let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
        desc.backends = wgpu::Backends::VULKAN | wgpu::Backends::GL;
        let desc = desc.with_env();
        let instance = wgpu::Instance::new(desc);
        let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions::default()))
            .map_err(|e| GpuError::NoAdapter(e.to_string()))?;
        Self::from_adapter(instance, adapter, options)
    }

    /// Opens a device on a given adapter (a window's compatible adapter, for instance).
    pub fn from_adapter(instance: wgpu::Instance, adapter: wgpu::Adapter, options: GpuOptions) -> Result<Self, GpuError> {
        let features = adapter.features();
        let depth_format = DEPTH_FORMATS
            .into_iter()
            .find(|f| f.required_features().is_empty() || features.contains(f.required_features()))
            .unwrap_or(wgpu::TextureFormat::Depth24PlusStencil8);
        let samples = if options.samples > 1
            && [depth_format, LAYER_FORMAT, MASK_FORMAT].iter().all(|f| {
                let flags = adapter.get_texture_format_features(*f).flags;
                flags.sample_count_supported(PREFERRED_SAMPLES)
                    && (f.is_depth_stencil_format() || flags.contains(wgpu::TextureFormatFeatureFlags::MULTISAMPLE_RESOLVE))
            }) {
            PREFERRED_SAMPLES
        } else {
            1
        };
        let output_format = OUTPUT_FORMATS
            .into_iter()
            .find(|f| adapter.get_texture_format_features(*f).allowed_usages.contains(wgpu::TextureUsages::RENDER_ATTACHMENT))
            .unwrap_or(wgpu::TextureFormat::Rgba16Float);
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("heliar compositor"),
            required_features: depth_format.required_features(),
            required_limits: adapter.limits(),
            ..Default::default()
        }))
        .map_err(|e| GpuError::NoDevice(e.to_string()))?;
        Ok(Self { instance, adapter, device, queue, depth_format, samples, output_format })
    }

    /// "name (backend, device type)", for reports.
    pub fn describe(&self) -> String {
        let i = self.adapter.get_info();
        format!("{} ({:?}, {:?})", i.name, i.backend, i.device_type)
    }

    /// The backend in use.
    pub fn backend(&self) -> wgpu::Backend {
        self.adapter.get_info().backend
    }

    /// Bytes per texel of the output format.
    pub fn output_texel_bytes(&self) -> u32 {
        if self.output_format == wgpu::TextureFormat::Rgba32Float { 16 } else { 8 }
    }

    /// Waits until the queue is idle.
    pub fn wait(&self) -> Result<(), GpuError> {
        self.device.poll(wgpu::PollType::wait_indefinitely()).map(|_| ()).map_err(|e| GpuError::Device(e.to_string()))
    }
}
