//! Shadow volumes built by a compute pass (`shaders/shadow_volume/extrude.wgsl`), the GPU
//! alternative to [`super::volume::build`].
//!
//! The occluder's welded positions, faces, face normals and closed-component edges are uploaded
//! once; each time the sun moves, three dispatches (silhouette edges, dark caps, per-triangle
//! prisms) append the same triangles the CPU builder produces into a vertex buffer, through an
//! atomic counter that is also the vertex count of an indirect draw, so nothing comes back to
//! the CPU. `benches/bench_render.rs` compares the two builders.

use super::RenderError;
use super::occluder::Occluder;
use crate::gpu::shaders;
use shaders::compute_storage as storage;
use super::volume::max_triangles;
use glam::Vec3;
use wgpu::util::DeviceExt;

/// Threads per workgroup (matches `@workgroup_size` in the shader).
const WORKGROUP: u32 = 64;

/// Mirrors `Params` in `shaders/shadow_volume/extrude.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
struct Params {
    sun: [f32; 4],
    counts: [u32; 4],
}

/// The compute pipelines.
pub struct ComputeVolumes {
    layout: wgpu::BindGroupLayout,
    silhouettes: wgpu::ComputePipeline,
    caps: wgpu::ComputePipeline,
    triangles: wgpu::ComputePipeline,
}

/// One occluder's buffers on the GPU.
pub struct GpuOccluder {
    params: wgpu::Buffer,
    /// Output vertices (`vec4`), a vertex buffer for the volume pass.
    pub vertices: wgpu::Buffer,
    /// `DrawIndirectArgs` whose vertex count the dispatches fill.
    pub draw_args: wgpu::Buffer,
    bind_group: wgpu::BindGroup,
    edges: u32,
    closed_faces: u32,
    open_faces: u32,
    capacity: u32,
}

impl ComputeVolumes {
    /// Builds the pipelines.
    pub fn new(device: &wgpu::Device) -> Result<Self, RenderError> {
        let module = shaders::module(device, "shadow_volume/extrude.wgsl")?;
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("volume compute"),
            entries: &[
                wgpu::BindGroupLayoutEntry {
                    binding: 0,
                    visibility: wgpu::ShaderStages::COMPUTE,
                    ty: wgpu::BindingType::Buffer { ty: wgpu::BufferBindingType::Uniform, has_dynamic_offset: false, min_binding_size: None },
                    count: None,
                },
                storage(1, true),
                storage(2, true),
                storage(3, true),
                storage(4, true),
                storage(5, false),
                storage(6, false),
            ],
        });
        let pl = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor { label: Some("volume compute"), bind_group_layouts: &[Some(&layout)], immediate_size: 0 });
        let make = |entry: &str| shaders::compute_pipeline(device, &pl, &module, entry);
        Ok(Self { silhouettes: make("silhouettes"), caps: make("caps"), triangles: make("triangles"), layout })
    }

    /// Uploads `occ`. Fails when its worst-case output does not fit one storage binding.
    pub fn upload(&self, device: &wgpu::Device, occ: &Occluder) -> Result<GpuOccluder, RenderError> {
        let capacity = (max_triangles(occ) * 3).max(3);
        let out_bytes = capacity as u64 * 16;
        let limit = device.limits().max_storage_buffer_binding_size as u64;
        if out_bytes > limit {
            return Err(crate::gpu::GpuError::TooLarge { what: format!("{}: compute-built shadow volume", occ.name), bytes: out_bytes, limit }.into());
        }
        let init = |label: &str, bytes: &[u8], usage: wgpu::BufferUsages| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor { label: Some(label), contents: bytes, usage })
        };
        let positions: Vec<[f32; 4]> = occ.positions.iter().map(|p| [p.x, p.y, p.z, 1.0]).collect();
        let faces: Vec<[u32; 4]> = occ.faces.iter().map(|f| [f[0], f[1], f[2], 0]).collect();
        let normals: Vec<[f32; 4]> = occ.normals.iter().map(|n| [n.x, n.y, n.z, 0.0]).collect();
        let pad4 = |v: &[u8]| if v.is_empty() { vec![0u8; 16] } else { v.to_vec() };
        let s = wgpu::BufferUsages::STORAGE;
        let positions = init("occluder positions", &pad4(bytemuck::cast_slice(&positions)), s);
        let faces_b = init("occluder faces", &pad4(bytemuck::cast_slice(&faces)), s);
        let normals = init("occluder normals", &pad4(bytemuck::cast_slice(&normals)), s);
        let edges = init("occluder edges", &pad4(bytemuck::cast_slice(&occ.edges)), s);
        let params = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("volume params"),
            size: std::mem::size_of::<Params>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let vertices = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("volume vertices (compute)"),
            size: out_bytes,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let draw_args = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("volume draw args"),
            size: 16,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::INDIRECT | wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("volume compute"),
            layout: &self.layout,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: params.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 1, resource: positions.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 2, resource: faces_b.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 3, resource: normals.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 4, resource: edges.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 5, resource: vertices.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 6, resource: draw_args.as_entire_binding() },
            ],
        });
        Ok(GpuOccluder {
            params,
            vertices,
            draw_args,
            bind_group,
            edges: occ.edges.len() as u32,
            closed_faces: occ.closed_faces as u32,
            open_faces: (occ.faces.len() - occ.closed_faces) as u32,
            capacity: capacity as u32,
        })
    }

    /// Resets the counter and records the three dispatches for the sun direction `sun`.
    pub fn record(&self, queue: &wgpu::Queue, encoder: &mut wgpu::CommandEncoder, occ: &GpuOccluder, sun: Vec3, cap_offset_m: f32) {
        let params = Params { sun: [sun.x, sun.y, sun.z, cap_offset_m], counts: [occ.edges, occ.closed_faces, occ.open_faces, occ.capacity] };
        queue.write_buffer(&occ.params, 0, bytemuck::bytes_of(&params));
        queue.write_buffer(&occ.draw_args, 0, bytemuck::cast_slice(&[0u32, 1, 0, 0]));
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("shadow volume build"), timestamp_writes: None });
        pass.set_bind_group(0, &occ.bind_group, &[]);
        for (pipeline, n) in [(&self.silhouettes, occ.edges), (&self.caps, occ.closed_faces), (&self.triangles, occ.open_faces)] {
            if n > 0 {
                pass.set_pipeline(pipeline);
                pass.dispatch_workgroups(n.div_ceil(WORKGROUP), 1, 1);
            }
        }
    }
}
