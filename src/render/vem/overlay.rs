//! The VEM composite (`shaders/vem/overlay.wgsl`): in the footage's pixel grid, the canvas
//! layers through the lens warp over the background, darkened by the receivers' ratio. A unit
//! that runs every frame (without objects the background passes through).

use super::frame::VemFrame;
use super::pass;
use super::targets::Targets;
use crate::gpu::canvas::texture_entry;
use crate::gpu::shaders;
use crate::render::RenderError;
use crate::render::plan::{Pass, Plan};

/// The composite pipeline and its layout.
pub struct CompositePass {
    /// Writes linear radiance in the output format.
    pub pipeline: wgpu::RenderPipeline,
    /// Group 0: background, warp, virtual layer, ratio layer, sampler.
    pub layout: wgpu::BindGroupLayout,
}

impl CompositePass {
    /// Builds the pipeline writing `format`.
    pub fn new(device: &wgpu::Device, format: wgpu::TextureFormat) -> Result<Self, RenderError> {
        let module = shaders::module(device, "vem/overlay.wgsl")?;
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("vem composite"),
            entries: &[
                texture_entry(0, false),
                texture_entry(1, false),
                texture_entry(2, true),
                texture_entry(3, true),
                wgpu::BindGroupLayoutEntry { binding: 4, visibility: wgpu::ShaderStages::FRAGMENT, ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering), count: None },
            ],
        });
        let pipeline = fullscreen_pipeline(device, &module, &layout, format, "vem composite");
        Ok(Self { pipeline, layout })
    }

    /// Group 0 over the renderer's textures.
    pub fn bind_group(&self, device: &wgpu::Device, t: &Targets) -> wgpu::BindGroup {
        fn view(binding: u32, v: &wgpu::TextureView) -> wgpu::BindGroupEntry<'_> {
            wgpu::BindGroupEntry { binding, resource: wgpu::BindingResource::TextureView(v) }
        }
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("vem composite"),
            layout: &self.layout,
            entries: &[
                view(0, &t.background.view),
                view(1, &t.warp.view),
                view(2, &t.virtual_layer.view),
                view(3, &t.ratio_layer.view),
                wgpu::BindGroupEntry { binding: 4, resource: wgpu::BindingResource::Sampler(&t.sampler) },
            ],
        })
    }

    /// Records the composite into `target` (cleared first).
    pub fn record(&self, encoder: &mut wgpu::CommandEncoder, bind_group: &wgpu::BindGroup, target: &wgpu::TextureView) {
        record_fullscreen(encoder, "vem composite", &self.pipeline, bind_group, target);
    }
}

impl Pass<VemFrame> for CompositePass {
    const NAME: &'static str = pass::COMPOSITE;

    fn plan(&self, _: &VemFrame) -> Plan {
        Plan::Run
    }
}

/// Records one full-screen triangle of `pipeline` with group 0 `bind_group` into `target`,
/// cleared to black first.
pub fn record_fullscreen(encoder: &mut wgpu::CommandEncoder, label: &str, pipeline: &wgpu::RenderPipeline, bind_group: &wgpu::BindGroup, target: &wgpu::TextureView) {
    let mut pa = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some(label),
        color_attachments: &[Some(wgpu::RenderPassColorAttachment {
            view: target,
            depth_slice: None,
            resolve_target: None,
            ops: wgpu::Operations { load: wgpu::LoadOp::Clear(wgpu::Color::BLACK), store: wgpu::StoreOp::Store },
        })],
        ..Default::default()
    });
    pa.set_pipeline(pipeline);
    pa.set_bind_group(0, bind_group, &[]);
    pa.draw(0..3, 0..1);
}

/// A full-screen-triangle pipeline (`vs_main`, `fs_main`) writing `format`.
pub fn fullscreen_pipeline(device: &wgpu::Device, module: &wgpu::ShaderModule, layout: &wgpu::BindGroupLayout, format: wgpu::TextureFormat, label: &str) -> wgpu::RenderPipeline {
    let pl = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor { label: Some(label), bind_group_layouts: &[Some(layout)], immediate_size: 0 });
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some(label),
        layout: Some(&pl),
        vertex: wgpu::VertexState { module, entry_point: Some("vs_main"), compilation_options: Default::default(), buffers: &[] },
        primitive: wgpu::PrimitiveState::default(),
        depth_stencil: None,
        multisample: wgpu::MultisampleState::default(),
        fragment: Some(wgpu::FragmentState {
            module,
            entry_point: Some("fs_main"),
            compilation_options: Default::default(),
            targets: &[Some(wgpu::ColorTargetState { format, blend: None, write_mask: wgpu::ColorWrites::ALL })],
        }),
        multiview_mask: None,
        cache: None,
    })
}
