//! Tone mapping on the GPU (`shaders/vem/tonemap.wgsl`): global Reinhard with the temporally
//! smoothed parameters of [`crate::vem::reinhard`] (Havran §5.1), into an sRGB 8-bit target.

use super::overlay::fullscreen_pipeline;
use crate::render::RenderError;
use crate::gpu::canvas::uniform_entry;
use crate::gpu::shaders;
use crate::vem::reinhard::{LOG_DELTA, ToneParams};

/// The output format: 8-bit sRGB (the hardware applies the transfer).
pub const SRGB_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8UnormSrgb;

/// Mirrors `Tone` in `shaders/vem/tonemap.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ToneUniform {
    /// `a/L̄`, `L_white·a/L̄`, unused, unused.
    pub params: [f32; 4],
}

impl ToneUniform {
    /// The uniform of `p` (the same scaling as [`ToneParams::display`]).
    pub fn new(p: &ToneParams) -> Self {
        let scale = p.key / p.log_average.max(LOG_DELTA);
        Self { params: [scale as f32, (p.white * scale).max(1e-12) as f32, 0.0, 0.0] }
    }
}

/// The tone-mapping pipeline and its layout.
pub struct TonemapPass {
    /// HDR texture → sRGB target.
    pub pipeline: wgpu::RenderPipeline,
    /// Group 0: the HDR texture, the uniform.
    pub layout: wgpu::BindGroupLayout,
}

impl TonemapPass {
    /// Builds the pipeline.
    pub fn new(device: &wgpu::Device) -> Result<Self, RenderError> {
        let module = shaders::module(device, "vem/tonemap.wgsl")?;
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("vem tonemap"),
            entries: &[
                wgpu::BindGroupLayoutEntry {
                    binding: 0,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Texture { sample_type: wgpu::TextureSampleType::Float { filterable: false }, view_dimension: wgpu::TextureViewDimension::D2, multisampled: false },
                    count: None,
                },
                uniform_entry(1, wgpu::ShaderStages::FRAGMENT),
            ],
        });
        Ok(Self { pipeline: fullscreen_pipeline(device, &module, &layout, SRGB_FORMAT, "vem tonemap"), layout })
    }
}
