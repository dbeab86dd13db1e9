//! Pass 6 (`shaders/composite.wgsl`): the output frame in the footage's pixel grid.
//!
//! Reads the footage (linear), the proxy data per pixel ([`super::receivers`]), the lens warp
//! ([`crate::gpu::canvas`]) and the two canvas layers, and writes linear radiance (times the
//! lighting's output scale). The same pipeline code serves an offscreen float target and a
//! window surface; only the target format differs.

use super::RenderError;
use crate::gpu::canvas::{storage_entry, texture_entry};
use crate::gpu::shaders;

/// Texture bindings of the composite pass before its sampler, in `shaders/composite.wgsl` order.
const TEXTURE_BINDINGS: u32 = 10;
/// The proxy point per footage pixel (after the sampler and the lighting).
const POINT_BINDING: u32 = TEXTURE_BINDINGS + 2;
/// The first of the bindings sampled bilinearly (the canvas layers).
const FIRST_FILTERED: u32 = 8;
/// The lamps' bounce at the real receivers, without and with the objects (after the point;
/// `render::lamps::ground_bounce`).
const LAMP_BOUNCE_BINDINGS: [u32; 2] = [POINT_BINDING + 1, POINT_BINDING + 2];

/// The composite pipelines for one target format.
pub struct Composite {
    /// Output radiance.
    pub composite: wgpu::RenderPipeline,
    /// The canvas masks warped to the output grid (debug).
    pub masks: Option<wgpu::RenderPipeline>,
}

/// Layout of the composite bind group.
pub fn layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    // The footage-sized inputs are read with textureLoad (float formats that need not be
    // filterable); the canvas layers are sampled bilinearly.
    let mut entries: Vec<wgpu::BindGroupLayoutEntry> = (0..TEXTURE_BINDINGS).map(|binding| texture_entry(binding, binding >= FIRST_FILTERED)).collect();
    entries.push(wgpu::BindGroupLayoutEntry {
        binding: TEXTURE_BINDINGS,
        visibility: wgpu::ShaderStages::FRAGMENT,
        ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
        count: None,
    });
    entries.push(storage_entry(TEXTURE_BINDINGS + 1));
    entries.push(texture_entry(POINT_BINDING, false));
    entries.extend(LAMP_BOUNCE_BINDINGS.map(|b| texture_entry(b, false)));
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor { label: Some("composite"), entries: &entries })
}

impl Composite {
    /// Pipelines writing `format` (and, with `masks_format`, the debug mask pipeline);
    /// `lamp_layout` is the lamps' data group ([`crate::render::lamps::ground::data_layout`]).
    pub fn new(
        device: &wgpu::Device,
        layout: &wgpu::BindGroupLayout,
        lamp_layout: &wgpu::BindGroupLayout,
        format: wgpu::TextureFormat,
        masks_format: Option<wgpu::TextureFormat>,
    ) -> Result<Self, RenderError> {
        let module = shaders::module(device, "composite.wgsl")?;
        let pl = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor { label: Some("composite"), bind_group_layouts: &[Some(layout), None, Some(lamp_layout)], immediate_size: 0 });
        let make = |entry: &str, format: wgpu::TextureFormat| {
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(entry),
                layout: Some(&pl),
                vertex: wgpu::VertexState { module: &module, entry_point: Some("vs_main"), compilation_options: Default::default(), buffers: &[] },
                primitive: wgpu::PrimitiveState::default(),
                depth_stencil: None,
                multisample: wgpu::MultisampleState::default(),
                fragment: Some(wgpu::FragmentState {
                    module: &module,
                    entry_point: Some(entry),
                    compilation_options: Default::default(),
                    targets: &[Some(wgpu::ColorTargetState { format, blend: None, write_mask: wgpu::ColorWrites::ALL })],
                }),
                multiview_mask: None,
                cache: None,
            })
        };
        Ok(Self { composite: make("fs_composite", format), masks: masks_format.map(|f| make("fs_masks", f)) })
    }

    /// Records the composite into `target` (cleared first) and, with `masks` (a target of the
    /// mask format) and the mask pipeline, the warped debug masks; `bind_group` is the
    /// composite's group 0, `lamps` the lamps' data group (an empty one without lamps).
    pub fn record(&self, encoder: &mut wgpu::CommandEncoder, bind_group: &wgpu::BindGroup, lamps: &wgpu::BindGroup, target: &wgpu::TextureView, masks: Option<&wgpu::TextureView>) {
        let fullscreen = |encoder: &mut wgpu::CommandEncoder, label: &str, view: &wgpu::TextureView, clear: wgpu::Color, pipeline: &wgpu::RenderPipeline| {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some(label),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations { load: wgpu::LoadOp::Clear(clear), store: wgpu::StoreOp::Store },
                })],
                ..Default::default()
            });
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, bind_group, &[]);
            pass.set_bind_group(crate::render::lamps::ground::GROUP, lamps, &[]);
            pass.draw(0..3, 0..1);
        };
        fullscreen(encoder, "composite", target, wgpu::Color::BLACK, &self.composite);
        if let (Some(view), Some(pipeline)) = (masks, &self.masks) {
            fullscreen(encoder, "warped masks", view, wgpu::Color::TRANSPARENT, pipeline);
        }
    }
}
