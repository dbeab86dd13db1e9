//! The VEM renderer's textures and samplers: the canvas (depth, objects' layer, receivers'
//! ratio), the shadow-map atlas, the footage-grid inputs (background, lens warp) and outputs
//! (HDR composite, sRGB frame).

use super::shading::{DEPTH_FORMAT, RATIO_FORMAT};
use super::shadow_atlas::{ATLAS_FORMAT, tiles_per_side};
use super::tonemap::SRGB_FORMAT;
use super::VemRenderConfig;
use crate::gpu::canvas::Canvas;
use crate::gpu::texture::Tex;
use crate::gpu::{Gpu, GpuError, LAYER_FORMAT};

/// Every texture and sampler of the VEM renderer.
pub struct Targets {
    /// Canvas depth (reversed, no stencil).
    pub depth: Tex,
    /// The objects' premultiplied radiance.
    pub virtual_layer: Tex,
    /// The receivers' darkening ratio.
    pub ratio_layer: Tex,
    /// The shadow-map atlas.
    pub atlas: Tex,
    /// The background, linear (`Rgba32Float`, footage grid).
    pub background: Tex,
    /// The lens warp (canvas coordinates per footage pixel).
    pub warp: Tex,
    /// The HDR composite (output format).
    pub hdr: Tex,
    /// The tone-mapped frame.
    pub srgb: Tex,
    /// Bilinear sampler of the canvas layers.
    pub sampler: wgpu::Sampler,
    /// Nearest-texel comparison sampler of the atlas.
    pub shadow_sampler: wgpu::Sampler,
}

impl Targets {
    /// The textures for `canvas` and an atlas of `cfg.shadow_slots` tiles of `cfg.tile`² (which
    /// must fit the device's largest texture); the warp is uploaded.
    pub fn new(gpu: &Gpu, canvas: &Canvas, cfg: &VemRenderConfig) -> Result<Self, GpuError> {
        let device = &gpu.device;
        let cs = (canvas.intrinsics.width, canvas.intrinsics.height);
        let os = (canvas.out_width, canvas.out_height);
        let rt = wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING;
        let input = wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST;
        let side = tiles_per_side(cfg.shadow_slots) * cfg.tile.max(1);
        let limit = device.limits().max_texture_dimension_2d;
        if side > limit {
            return Err(GpuError::TooLarge { what: format!("a {side}² shadow atlas"), bytes: side as u64 * side as u64 * 4, limit: limit as u64 * limit as u64 * 4 });
        }
        let warp = Tex::new(device, "vem warp", os, wgpu::TextureFormat::Rg32Float, 1, input);
        warp.write(&gpu.queue, &canvas.warp);
        Ok(Self {
            depth: Tex::new(device, "vem depth", cs, DEPTH_FORMAT, 1, wgpu::TextureUsages::RENDER_ATTACHMENT),
            virtual_layer: Tex::new(device, "vem objects", cs, LAYER_FORMAT, 1, rt),
            ratio_layer: Tex::new(device, "vem ratio", cs, RATIO_FORMAT, 1, rt),
            atlas: Tex::new(device, "vem shadow atlas", (side, side), ATLAS_FORMAT, 1, rt),
            background: Tex::new(device, "vem background", os, wgpu::TextureFormat::Rgba32Float, 1, input),
            warp,
            hdr: Tex::new(device, "vem hdr", os, gpu.output_format, 1, rt | wgpu::TextureUsages::COPY_SRC),
            srgb: Tex::new(device, "vem srgb", os, SRGB_FORMAT, 1, wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC),
            sampler: device.create_sampler(&wgpu::SamplerDescriptor {
                label: Some("vem canvas"),
                mag_filter: wgpu::FilterMode::Linear,
                min_filter: wgpu::FilterMode::Linear,
                ..Default::default()
            }),
            shadow_sampler: device.create_sampler(&wgpu::SamplerDescriptor {
                label: Some("vem shadow atlas"),
                mag_filter: wgpu::FilterMode::Nearest,
                min_filter: wgpu::FilterMode::Nearest,
                compare: Some(wgpu::CompareFunction::LessEqual),
                ..Default::default()
            }),
        })
    }
}
