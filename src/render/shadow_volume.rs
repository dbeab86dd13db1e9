//! Pass 2 (`shaders/shadow_volume.wgsl`): shadow volumes into the stencil with z-fail counting
//! (Carmack's reverse; Everitt & Kilgard 2002), Jensen §3.2 steps 1–2.
//!
//! A sample is inside a closed volume when, behind its visible surface, more of the volume's
//! faces turn away from the camera than toward it. Counting the faces that *fail* the depth test
//! (lie behind the surface) gives that number whether or not the camera itself is inside a
//! volume, and the infinite far plane of the canvas projection means no volume face is ever
//! clipped away behind the scene. Virtual occluders count up on back faces and down on front
//! faces; real occluders the other way round (the paper's increment/decrement), each in its own
//! volume pass followed by a resolve (see [`super::stencil`]). No culling, no colour, no depth
//! writes; the volume vertex buffers are homogeneous (`vec4`, see [`super::volume`]).

use super::RenderError;
use crate::gpu::shaders;
use super::stencil::{COUNT_MASK, zfail};

/// The two volume pipelines.
pub struct ShadowVolumePass {
    /// Virtual occluders: back faces that fail the depth test increment.
    pub virtual_: wgpu::RenderPipeline,
    /// Real occluders: back faces that fail the depth test decrement.
    pub real: wgpu::RenderPipeline,
}

impl ShadowVolumePass {
    /// Builds the pipelines.
    pub fn new(device: &wgpu::Device, camera_layout: &wgpu::BindGroupLayout, depth_format: wgpu::TextureFormat, samples: u32) -> Result<Self, RenderError> {
        use wgpu::StencilOperation::{DecrementWrap, IncrementWrap};
        let module = shaders::module(device, "shadow_volume.wgsl")?;
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("shadow volumes"),
            bind_group_layouts: &[Some(camera_layout)],
            immediate_size: 0,
        });
        let make = |label: &str, front: wgpu::StencilOperation, back: wgpu::StencilOperation| {
            let attrs = [wgpu::VertexAttribute { format: wgpu::VertexFormat::Float32x4, offset: 0, shader_location: 0 }];
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(label),
                layout: Some(&layout),
                vertex: wgpu::VertexState {
                    module: &module,
                    entry_point: Some("vs_main"),
                    compilation_options: Default::default(),
                    buffers: &[Some(wgpu::VertexBufferLayout { array_stride: 16, step_mode: wgpu::VertexStepMode::Vertex, attributes: &attrs })],
                },
                primitive: wgpu::PrimitiveState { cull_mode: None, front_face: wgpu::FrontFace::Ccw, ..Default::default() },
                depth_stencil: Some(wgpu::DepthStencilState {
                    format: depth_format,
                    depth_write_enabled: Some(false),
                    depth_compare: Some(wgpu::CompareFunction::Greater),
                    stencil: wgpu::StencilState { front: zfail(front), back: zfail(back), read_mask: 0, write_mask: COUNT_MASK },
                    bias: Default::default(),
                }),
                multisample: wgpu::MultisampleState { count: samples, ..Default::default() },
                fragment: None,
                multiview_mask: None,
                cache: None,
            })
        };
        Ok(Self {
            virtual_: make("shadow volumes virtual", DecrementWrap, IncrementWrap),
            real: make("shadow volumes real", IncrementWrap, DecrementWrap),
        })
    }
}
