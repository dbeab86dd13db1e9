//! Tone mapping on the GPU (`shaders/vem/tonemap.wgsl`): global Reinhard with the temporally
//! smoothed parameters of [`crate::vem::reinhard`] (Havran §5.1), into an sRGB 8-bit target.
//! A unit that runs every frame and keeps the smoothing state ([`ToneMapper`]) between frames.

use super::frame::VemFrame;
use super::overlay::{fullscreen_pipeline, record_fullscreen};
use super::pass;
use crate::gpu::canvas::{texture_entry, uniform_entry};
use crate::gpu::shaders;
use crate::io::image::LinearImage;
use crate::render::RenderError;
use crate::render::plan::{Pass, Plan};
use crate::vem::polar::luminance;
use crate::vem::reinhard::{LOG_DELTA, ToneMapper, ToneParams};
use wgpu::util::DeviceExt;

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

/// The tone-mapping pipeline, its layout and the smoothed parameters.
pub struct TonemapPass {
    /// HDR texture → sRGB target.
    pub pipeline: wgpu::RenderPipeline,
    /// Group 0: the HDR texture, the uniform.
    pub layout: wgpu::BindGroupLayout,
    /// The temporally smoothed parameters.
    tone: ToneMapper,
}

impl TonemapPass {
    /// Builds the pipeline.
    pub fn new(device: &wgpu::Device) -> Result<Self, RenderError> {
        let module = shaders::module(device, "vem/tonemap.wgsl")?;
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("vem tonemap"),
            entries: &[
                texture_entry(0, false),
                uniform_entry(1, wgpu::ShaderStages::FRAGMENT),
            ],
        });
        Ok(Self { pipeline: fullscreen_pipeline(device, &module, &layout, SRGB_FORMAT, "vem tonemap"), layout, tone: ToneMapper::new() })
    }

    /// This frame's parameters from its HDR composite, `dt_s` after the previous frame (a frame
    /// without any usable luminance gets the neutral `L̄ = 1, a = 0.18, L_white = 1`).
    pub fn params(&mut self, hdr: &LinearImage, dt_s: f64) -> ToneParams {
        let lum: Vec<f32> = hdr.data.iter().map(|p| luminance(*p)).collect();
        self.tone.update(&lum, dt_s).unwrap_or(ToneParams { log_average: 1.0, key: 0.18, white: 1.0 })
    }

    /// Records the tone mapping of `hdr` with `params` into `target` (cleared first).
    pub fn record(&self, device: &wgpu::Device, encoder: &mut wgpu::CommandEncoder, hdr: &wgpu::TextureView, target: &wgpu::TextureView, params: &ToneParams) {
        let u = ToneUniform::new(params);
        let ubuf = device.create_buffer_init(&wgpu::util::BufferInitDescriptor { label: Some("vem tone"), contents: bytemuck::bytes_of(&u), usage: wgpu::BufferUsages::UNIFORM });
        let bg = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("vem tonemap"),
            layout: &self.layout,
            entries: &[wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(hdr) }, wgpu::BindGroupEntry { binding: 1, resource: ubuf.as_entire_binding() }],
        });
        record_fullscreen(encoder, "vem tonemap", &self.pipeline, &bg, target);
    }
}

impl Pass<VemFrame> for TonemapPass {
    const NAME: &'static str = pass::TONEMAP;

    fn plan(&self, _: &VemFrame) -> Plan {
        Plan::Run
    }
}
