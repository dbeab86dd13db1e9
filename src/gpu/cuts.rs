//! The compute pass of the visibility cuts' per-vertex sum (`shaders/cuts/eval.wgsl`; issue 15
//! §2, "evaluation … on the CPU (rayon) or in a compute pass": `crate::cuts` lays out the arrays,
//! `cuts::flat` says what each holds; this module only moves them).
//!
//! The banks and the node directions are uploaded once ([`CutsPass::new`]); a frame writes the
//! lighting, the vertices' records and their operands, dispatches a thread per vertex, lighting
//! part and segment of the tree (`cuts::flat`, "Segments"), a second dispatch adds the segments,
//! and six `vec4` per vertex come back ([`CutsPass::run`]). Every buffer is a read-only storage buffer
//! except the output (no uniform steers a branch, `tests/suite/uniform_branches.rs`).

use super::{Gpu, GpuError, readback, shaders};
use shaders::compute_storage as storage;
use wgpu::util::DeviceExt;

/// Threads per workgroup (matches `@workgroup_size` in the shader).
const WORKGROUP: u32 = 64;

/// Output bytes per vertex: six `vec4` (`E_n`, `E_r` of each of the three lighting parts).
const ROW_BYTES: u64 = 96;

/// Mirrors `Params` in `shaders/cuts/eval.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
struct Params {
    levels: u32,
    nodes: u32,
    vertices: u32,
    lights: u32,
    segments: u32,
    segment_height: u32,
    pad: [u32; 2],
}

/// Largest workgroup count along one dimension (WebGPU's default limit); more go along `y`.
const MAX_GROUPS_X: u32 = 65_535;

/// Workgroups `(x, y)` for `threads` threads (the shader folds `y` back into one index).
fn groups(threads: u32) -> (u32, u32) {
    let n = threads.div_ceil(WORKGROUP);
    if n <= MAX_GROUPS_X { (n.max(1), 1) } else { (MAX_GROUPS_X, n.div_ceil(MAX_GROUPS_X)) }
}

/// A storage buffer that grows to the largest frame seen.
struct Growing {
    buffer: wgpu::Buffer,
    label: &'static str,
    usage: wgpu::BufferUsages,
}

impl Growing {
    fn new(device: &wgpu::Device, label: &'static str, usage: wgpu::BufferUsages) -> Self {
        Self { buffer: Self::make(device, label, usage, 16), label, usage }
    }

    fn make(device: &wgpu::Device, label: &'static str, usage: wgpu::BufferUsages, size: u64) -> wgpu::Buffer {
        device.create_buffer(&wgpu::BufferDescriptor { label: Some(label), size: size.max(16).next_multiple_of(16), usage, mapped_at_creation: false })
    }

    /// Makes room for `size` bytes; true when the buffer was replaced (the bind group must be
    /// made again).
    fn reserve(&mut self, device: &wgpu::Device, size: u64) -> bool {
        if self.buffer.size() >= size {
            return false;
        }
        self.buffer = Self::make(device, self.label, self.usage, size.next_power_of_two());
        true
    }

    fn write(&self, queue: &wgpu::Queue, bytes: &[u8]) {
        if !bytes.is_empty() {
            queue.write_buffer(&self.buffer, 0, bytes);
        }
    }
}

/// The pipeline, the static buffers and the per-frame ones.
pub struct CutsPass {
    walk: wgpu::ComputePipeline,
    add: wgpu::ComputePipeline,
    layout: wgpu::BindGroupLayout,
    levels: u32,
    segments: u32,
    nodes: u32,
    params: wgpu::Buffer,
    words: wgpu::Buffer,
    dirs: wgpu::Buffer,
    lights: Growing,
    vertices: Growing,
    ops: Growing,
    out: Growing,
    partial: Growing,
    bind_group: Option<wgpu::BindGroup>,
}

impl CutsPass {
    /// Uploads the banks (`words`, `crate::cuts::flat::FlatBanks`, laid out for `segments`
    /// segments per walk, a power of two) and the node directions of a tree of `levels`
    /// (`dirs`, one `vec4` per heap node).
    pub fn new(gpu: &Gpu, levels: u32, segments: u32, words: &[u32], dirs: &[[f32; 4]]) -> Result<Self, GpuError> {
        let device = &gpu.device;
        let limit = device.limits().max_storage_buffer_binding_size as u64;
        let bytes = std::mem::size_of_val(words) as u64;
        if bytes > limit {
            return Err(GpuError::TooLarge { what: "the visibility cuts' banks".into(), bytes, limit });
        }
        let module = shaders::module(device, "cuts/eval.wgsl")?;
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("cuts eval"),
            entries: &[storage(0, true), storage(1, true), storage(2, true), storage(3, true), storage(4, true), storage(5, true), storage(6, false), storage(7, false)],
        });
        let pl = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor { label: Some("cuts eval"), bind_group_layouts: &[Some(&layout)], immediate_size: 0 });
        let make = |entry: &str| shaders::compute_pipeline(device, &pl, &module, entry);
        let s = wgpu::BufferUsages::STORAGE;
        let init = |label: &str, bytes: &[u8], usage| device.create_buffer_init(&wgpu::util::BufferInitDescriptor { label: Some(label), contents: bytes, usage });
        let pad = |b: &[u8]| if b.is_empty() { vec![0u8; 16] } else { b.to_vec() };
        let dst = s | wgpu::BufferUsages::COPY_DST;
        Ok(Self {
            walk: make("walk_segments"),
            add: make("add_segments"),
            layout,
            levels,
            segments: segments.max(1),
            nodes: dirs.len() as u32,
            params: Growing::make(device, "cuts params", dst, std::mem::size_of::<Params>() as u64),
            words: init("cuts banks", &pad(bytemuck::cast_slice(words)), s),
            dirs: init("cuts node directions", &pad(bytemuck::cast_slice(dirs)), s),
            lights: Growing::new(device, "cuts lighting", dst),
            vertices: Growing::new(device, "cuts vertices", dst),
            ops: Growing::new(device, "cuts operands", dst),
            out: Growing::new(device, "cuts output", s | wgpu::BufferUsages::COPY_SRC),
            partial: Growing::new(device, "cuts segment sums", s),
            bind_group: None,
        })
    }

    /// One frame: the lighting (three parts of one `vec4` per node, present ones in `mask`), the
    /// vertices' records and their operands (`crate::cuts::flat`'s `VertexRecord`s and
    /// `OpRecord`s as bytes, `count` vertices); six `vec4` per vertex back (a thread per vertex, lighting part and
    /// segment, then one per vertex and part adding the segments, `shaders/cuts/eval.wgsl`).
    pub fn run(&mut self, gpu: &Gpu, lights: &[[f32; 4]], mask: u32, vertices: &[u8], count: u32, ops: &[u8]) -> Result<Vec<[f32; 4]>, GpuError> {
        if count == 0 {
            return Ok(Vec::new());
        }
        let device = &gpu.device;
        let out_bytes = count as u64 * ROW_BYTES;
        let lights_b: &[u8] = bytemuck::cast_slice(lights);
        let mut stale = self.bind_group.is_none();
        stale |= self.lights.reserve(device, lights_b.len() as u64);
        stale |= self.vertices.reserve(device, vertices.len() as u64);
        stale |= self.ops.reserve(device, ops.len() as u64);
        stale |= self.out.reserve(device, out_bytes);
        let threads = count as u64 * 3 * self.segments as u64;
        if threads > u32::MAX as u64 / 2 {
            return Err(GpuError::TooLarge { what: "the cuts' walks (threads)".into(), bytes: threads, limit: u32::MAX as u64 / 2 });
        }
        stale |= self.partial.reserve(device, threads * 32);
        if stale {
            self.bind_group = Some(self.bind_group(device));
        }
        let segment_height = self.levels - self.segments.trailing_zeros();
        let params = Params { levels: self.levels, nodes: self.nodes, vertices: count, lights: mask, segments: self.segments, segment_height, pad: [0; 2] };
        gpu.queue.write_buffer(&self.params, 0, bytemuck::bytes_of(&params));
        self.lights.write(&gpu.queue, lights_b);
        self.vertices.write(&gpu.queue, vertices);
        self.ops.write(&gpu.queue, ops);
        let mut enc = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("cuts eval") });
        {
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("cuts eval"), timestamp_writes: None });
            pass.set_bind_group(0, self.bind_group.as_ref(), &[]);
            pass.set_pipeline(&self.walk);
            let (x, y) = groups(threads as u32);
            pass.dispatch_workgroups(x, y, 1);
            pass.set_pipeline(&self.add);
            let (x, y) = groups(3 * count);
            pass.dispatch_workgroups(x, y, 1);
        }
        gpu.queue.submit([enc.finish()]);
        let bytes = readback::read_buffer_bytes(gpu, &self.out.buffer, out_bytes)?;
        Ok(bytemuck::pod_collect_to_vec(&bytes[..out_bytes as usize]))
    }

    fn bind_group(&self, device: &wgpu::Device) -> wgpu::BindGroup {
        let buffers = [&self.params, &self.words, &self.dirs, &self.lights.buffer, &self.vertices.buffer, &self.ops.buffer, &self.out.buffer, &self.partial.buffer];
        let entries: Vec<wgpu::BindGroupEntry> = buffers.iter().enumerate().map(|(i, b)| wgpu::BindGroupEntry { binding: i as u32, resource: b.as_entire_binding() }).collect();
        device.create_bind_group(&wgpu::BindGroupDescriptor { label: Some("cuts eval"), layout: &self.layout, entries: &entries })
    }
}
