//! The irradiance-probe grid on the GPU: the compositor reads a
//! [`ProbeGrid`] (order-2 SH irradiance per probe, Jensen §3.3) per pixel in
//! `shaders/virtual_shading.wgsl`. Where the grid comes from is the lighting stage's business
//! ([`crate::irradiance::sources`]).

use crate::irradiance::ProbeGrid;

/// Mirrors `ProbeGridHeader` in `shaders/common/sh.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ProbeGridHeader {
    /// Position of probe (0, 0, 0) and the spacing.
    pub origin: [f32; 4],
    /// Probes per axis and in total.
    pub dims: [u32; 4],
}

/// A probe grid's GPU buffers.
pub struct GpuProbes {
    /// The header uniform.
    pub header: wgpu::Buffer,
    /// 9 `vec4` per probe.
    pub coeffs: wgpu::Buffer,
    /// One `u32` per probe.
    pub valid: wgpu::Buffer,
    probes: u64,
}

impl GpuProbes {
    /// Buffers for `grid`.
    pub fn new(device: &wgpu::Device, queue: &wgpu::Queue, grid: &ProbeGrid) -> Self {
        let probes = grid.coeffs.len().max(1) as u64;
        let mk = |label: &str, size: u64, usage: wgpu::BufferUsages| {
            device.create_buffer(&wgpu::BufferDescriptor { label: Some(label), size, usage: usage | wgpu::BufferUsages::COPY_DST, mapped_at_creation: false })
        };
        let g = Self {
            header: mk("probe header", std::mem::size_of::<ProbeGridHeader>() as u64, wgpu::BufferUsages::STORAGE),
            coeffs: mk("probe coefficients", probes * 9 * 16, wgpu::BufferUsages::STORAGE),
            valid: mk("probe validity", probes * 4, wgpu::BufferUsages::STORAGE),
            probes,
        };
        g.write(queue, grid);
        g
    }

    /// True when `grid` fits these buffers.
    pub fn fits(&self, grid: &ProbeGrid) -> bool {
        grid.coeffs.len().max(1) as u64 == self.probes
    }

    /// Uploads `grid` (which must fit).
    pub fn write(&self, queue: &wgpu::Queue, grid: &ProbeGrid) {
        let header = ProbeGridHeader {
            origin: [grid.min.x, grid.min.y, grid.min.z, grid.spacing],
            dims: [grid.dims.x, grid.dims.y, grid.dims.z, grid.coeffs.len() as u32],
        };
        queue.write_buffer(&self.header, 0, bytemuck::bytes_of(&header));
        let coeffs: Vec<[f32; 4]> = grid.coeffs.iter().flat_map(|c| c.iter().map(|k| [k[0], k[1], k[2], 0.0])).collect();
        if !coeffs.is_empty() {
            queue.write_buffer(&self.coeffs, 0, bytemuck::cast_slice(&coeffs));
        }
        let valid: Vec<u32> = grid.valid.iter().map(|&v| v as u32).collect();
        if !valid.is_empty() {
            queue.write_buffer(&self.valid, 0, bytemuck::cast_slice(&valid));
        }
    }
}
