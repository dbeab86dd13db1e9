//! The VEM composite (`shaders/vem/composite.wgsl`): in the footage's pixel grid, the canvas
//! layers through the lens warp over the background, darkened by the receivers' ratio.

use crate::render::RenderError;
use crate::gpu::shaders;

/// The composite pipeline and its layout.
pub struct CompositePass {
    /// Writes linear radiance in the output format.
    pub pipeline: wgpu::RenderPipeline,
    /// Group 0: background, warp, virtual layer, ratio layer, sampler.
    pub layout: wgpu::BindGroupLayout,
}

fn texture_entry(binding: u32, filterable: bool) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::FRAGMENT,
        ty: wgpu::BindingType::Texture { sample_type: wgpu::TextureSampleType::Float { filterable }, view_dimension: wgpu::TextureViewDimension::D2, multisampled: false },
        count: None,
    }
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
