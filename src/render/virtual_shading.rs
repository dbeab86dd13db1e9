//! Pass 5 (`shaders/virtual_shading.wgsl`): the virtual objects, shaded, into the canvas layer
//! (Jensen §3.2 step 4 with the ambient of §3.3).
//!
//! One draw of the objects: depth `GreaterEqual` against the prepass with the same invariant
//! position computation, so each visible sample is shaded once and real geometry in front hides
//! the object. The sun's visibility is per sample, as a path tracer's shadow ray per sample of a
//! pixel: the objects are drawn twice, once on the samples whose stencil shows a virtual surface
//! in no shadow volume (`fs_lit`, the sun at full strength) and once on those inside one
//! (`fs_shadowed`, no direct sun), and the MSAA resolve averages them. A pixel where two faces
//! meet, one in the sun and one turned away from it (a box's corner seen at a grazing angle, a
//! faceted sphere's terminator), thus gets each face's own visibility; weighting each fragment by
//! the whole pixel's lit fraction, as before, darkened the lit face's share by the fraction of
//! the other face's samples (measured on the winter scene's pedestal at a 10° sun: −37% on the
//! column where its sunlit front meets its shaded side). Fragment work grows only on pixels that
//! hold both kinds of samples. The ambient comes from the per-vertex ambient of the visibility cuts where it is set
//! (objects that moved, issue 15 §2), else the per-pixel transfer, else the probes times ambient
//! occlusion. Closed meshes are drawn with back faces culled, open ones two-sided. The layer is
//! premultiplied linear radiance, alpha 1 where covered.

use super::RenderError;
use crate::gpu::canvas::{storage_entry, texture_entry, uniform_entry};
use crate::gpu::LAYER_FORMAT;
use crate::gpu::mesh::{VirtualBuffers, VirtualVertex};
use crate::gpu::shaders;
use super::stencil::{REAL_SHADOW, VIRTUAL_SHADOW, VIRTUAL_SURFACE, test};

/// The stencil's flag bits (virtual surface, virtual and real shadow), which the draws test.
const FLAGS: u32 = VIRTUAL_SURFACE | VIRTUAL_SHADOW | REAL_SHADOW;

/// One sun visibility's pipelines: closed meshes (back faces culled) and open ones (two-sided).
pub struct ShadingPipelines {
    /// Back faces culled (closed meshes).
    pub closed: wgpu::RenderPipeline,
    /// Two-sided (open meshes).
    pub open: wgpu::RenderPipeline,
}

/// The shading pipelines, for the samples in the sun and those in shadow, and their frame layout.
pub struct VirtualShading {
    /// Samples showing a virtual surface in no shadow volume (stencil [`VIRTUAL_SURFACE`] exactly).
    pub lit: ShadingPipelines,
    /// Samples showing a virtual surface inside a real or virtual shadow volume.
    pub shadowed: ShadingPipelines,
    /// Group 0: camera, lighting, probe header, coefficients, validity, ambient occlusion,
    /// the transfer's `R_a`, `R_d`, points and normals, and the per-vertex ambient of the
    /// visibility cuts (`crate::cuts::frame`).
    pub frame_layout: wgpu::BindGroupLayout,
}

impl VirtualShading {
    /// Builds the pipelines.
    pub fn new(device: &wgpu::Device, material_layout: &wgpu::BindGroupLayout, depth_format: wgpu::TextureFormat, samples: u32) -> Result<Self, RenderError> {
        let module = shaders::module(device, "virtual_shading.wgsl")?;
        let frame_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("shading frame"),
            entries: &[
                uniform_entry(0, wgpu::ShaderStages::VERTEX_FRAGMENT),
                storage_entry(1),
                storage_entry(2),
                storage_entry(3),
                storage_entry(4),
                texture_entry(5, false),
                texture_entry(7, false),
                texture_entry(8, false),
                texture_entry(9, false),
                texture_entry(10, false),
                // The objects' per-vertex ambient from the visibility cuts, read by the vertex stage.
                wgpu::BindGroupLayoutEntry { visibility: wgpu::ShaderStages::VERTEX, ..storage_entry(11) },
                // The lamps' bounce per canvas pixel (`render::object_transfer::lamps`).
                texture_entry(12, false),
            ],
        });
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("virtual shading"),
            bind_group_layouts: &[Some(&frame_layout), Some(material_layout)],
            immediate_size: 0,
        });
        let attrs = wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3, 2 => Float32x2];
        // Both draws take the reference VIRTUAL_SURFACE and read the flag bits (the counter bits
        // are clear after the volumes' resolve): `Equal` passes the virtual surfaces in no volume;
        // `Less` (reference < stencil) those with a shadow flag as well, and flags alone on real
        // surfaces, where the depth test against the prepass fails for the objects.
        let make = |label: &str, cull_mode: Option<wgpu::Face>, compare: wgpu::CompareFunction, entry: &str| {
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(label),
                layout: Some(&layout),
                vertex: wgpu::VertexState {
                    module: &module,
                    entry_point: Some("vs_shade"),
                    compilation_options: Default::default(),
                    buffers: &[Some(wgpu::VertexBufferLayout {
                        array_stride: std::mem::size_of::<VirtualVertex>() as u64,
                        step_mode: wgpu::VertexStepMode::Vertex,
                        attributes: &attrs,
                    })],
                },
                primitive: wgpu::PrimitiveState { cull_mode, ..Default::default() },
                depth_stencil: Some(wgpu::DepthStencilState {
                    format: depth_format,
                    depth_write_enabled: Some(false),
                    depth_compare: Some(wgpu::CompareFunction::GreaterEqual),
                    stencil: wgpu::StencilState { front: test(compare), back: test(compare), read_mask: FLAGS, write_mask: 0 },
                    bias: Default::default(),
                }),
                multisample: wgpu::MultisampleState { count: samples, ..Default::default() },
                fragment: Some(wgpu::FragmentState {
                    module: &module,
                    entry_point: Some(entry),
                    compilation_options: Default::default(),
                    targets: &[Some(wgpu::ColorTargetState { format: LAYER_FORMAT, blend: None, write_mask: wgpu::ColorWrites::ALL })],
                }),
                multiview_mask: None,
                cache: None,
            })
        };
        let pipelines = |compare, entry, closed: &str, open: &str| ShadingPipelines { closed: make(closed, Some(wgpu::Face::Back), compare, entry), open: make(open, None, compare, entry) };
        Ok(Self {
            lit: pipelines(wgpu::CompareFunction::Equal, "fs_lit", "virtual shading lit closed", "virtual shading lit open"),
            shadowed: pipelines(wgpu::CompareFunction::Less, "fs_shadowed", "virtual shading shadowed closed", "virtual shading shadowed open"),
            frame_layout,
        })
    }

    /// Stencil reference of all pipelines (samples showing a virtual surface).
    pub const REFERENCE: u32 = VIRTUAL_SURFACE;

    /// Draws the objects with the frame bind group `frame` (group 0) and each draw's material,
    /// once on their sunlit samples and once on their shadowed ones.
    pub fn record(&self, pass: &mut wgpu::RenderPass<'_>, frame: &wgpu::BindGroup, objects: &VirtualBuffers) {
        pass.set_bind_group(0, frame, &[]);
        pass.set_vertex_buffer(0, objects.vertices.slice(..));
        pass.set_index_buffer(objects.indices.slice(..), wgpu::IndexFormat::Uint32);
        pass.set_stencil_reference(Self::REFERENCE);
        for pipelines in [&self.lit, &self.shadowed] {
            for d in &objects.draws {
                pass.set_pipeline(if d.closed { &pipelines.closed } else { &pipelines.open });
                pass.set_bind_group(1, &d.bind_group, &[]);
                pass.draw_indexed(d.indices.clone(), 0, 0..1);
            }
        }
    }
}
