//! Pass 4 (`shaders/shadow_mask.wgsl`): stencil classes into a coverage mask on the canvas.
//!
//! `r`: virtual shadow on a real surface where no real shadow is, the samples the composite
//! darkens; `g`: a real surface in real shadow; `b`: a virtual surface in some shadow, and `a`: a
//! virtual surface (the debug masks; the shading pass tests the stencil per sample itself). The MSAA resolve
//! turns per-sample classes into per-pixel coverage; tests compare all four with ray-traced
//! references. The composite's differential model divides `r` by the real-surface samples out
//! of real shadow, `1 − a − g`: the share of the pixel's sunlit real surface that the virtual
//! shadow covers, counted on the same samples (and through the same lens-warp interpolation) as
//! `r` itself, so a pixel both shadows cover loses all of its sun even where the GPU's samples
//! and the receivers' sub-pixel rays see the real shadow's edge a little differently.

use super::RenderError;
use crate::gpu::MASK_FORMAT;
use crate::gpu::shaders;
use super::stencil::{REAL_SHADOW, VIRTUAL_SHADOW, VIRTUAL_SURFACE, test};

/// One mask pipeline: a stencil test and the channel it writes.
pub struct MaskDraw {
    /// The pipeline.
    pub pipeline: wgpu::RenderPipeline,
    /// Its stencil reference.
    pub reference: u32,
}

/// The mask pipelines.
pub struct ShadowMask {
    /// `r`: exactly [`VIRTUAL_SHADOW`].
    pub virtual_on_real: MaskDraw,
    /// `g`: [`REAL_SHADOW`] on a real surface.
    pub real_on_real: MaskDraw,
    /// `b` (two draws) and `a`.
    pub virtual_surface: Vec<MaskDraw>,
}

impl ShadowMask {
    /// Builds the pipelines.
    pub fn new(device: &wgpu::Device, depth_format: wgpu::TextureFormat, samples: u32) -> Result<Self, RenderError> {
        let module = shaders::module(device, "shadow_mask.wgsl")?;
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor { label: Some("shadow mask"), bind_group_layouts: &[], immediate_size: 0 });
        let make = |label: &str, read_mask: u32, reference: u32, channel: wgpu::ColorWrites| MaskDraw {
            pipeline: device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(label),
                layout: Some(&layout),
                vertex: wgpu::VertexState { module: &module, entry_point: Some("vs_main"), compilation_options: Default::default(), buffers: &[] },
                primitive: wgpu::PrimitiveState::default(),
                depth_stencil: Some(wgpu::DepthStencilState {
                    format: depth_format,
                    depth_write_enabled: Some(false),
                    depth_compare: Some(wgpu::CompareFunction::Always),
                    stencil: wgpu::StencilState {
                        front: test(wgpu::CompareFunction::Equal),
                        back: test(wgpu::CompareFunction::Equal),
                        read_mask,
                        write_mask: 0,
                    },
                    bias: Default::default(),
                }),
                multisample: wgpu::MultisampleState { count: samples, ..Default::default() },
                fragment: Some(wgpu::FragmentState {
                    module: &module,
                    entry_point: Some("fs_main"),
                    compilation_options: Default::default(),
                    targets: &[Some(wgpu::ColorTargetState { format: MASK_FORMAT, blend: None, write_mask: channel })],
                }),
                multiview_mask: None,
                cache: None,
            }),
            reference,
        };
        Ok(Self {
            virtual_on_real: make("mask virtual shadow on real", 0xff, VIRTUAL_SHADOW, wgpu::ColorWrites::RED),
            virtual_surface: vec![
                make("mask virtual surface in real shadow", VIRTUAL_SURFACE | REAL_SHADOW, VIRTUAL_SURFACE | REAL_SHADOW, wgpu::ColorWrites::BLUE),
                make("mask virtual surface in virtual shadow", VIRTUAL_SURFACE | VIRTUAL_SHADOW, VIRTUAL_SURFACE | VIRTUAL_SHADOW, wgpu::ColorWrites::BLUE),
                make("mask virtual surface", VIRTUAL_SURFACE, VIRTUAL_SURFACE, wgpu::ColorWrites::ALPHA),
            ],
            real_on_real: make("mask real shadow on real", VIRTUAL_SURFACE | REAL_SHADOW, REAL_SHADOW, wgpu::ColorWrites::GREEN),
        })
    }

    /// Records the draws.
    pub fn record(&self, pass: &mut wgpu::RenderPass<'_>) {
        let draws = [&self.virtual_on_real, &self.real_on_real].into_iter().chain(&self.virtual_surface);
        for d in draws {
            pass.set_pipeline(&d.pipeline);
            pass.set_stencil_reference(d.reference);
            pass.draw(0..3, 0..1);
        }
    }
}
