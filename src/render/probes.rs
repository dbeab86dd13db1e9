//! Ambient light for the virtual objects: the irradiance-probe grid on the GPU, and the hook
//! where relighting plugs in.
//!
//! The compositor reads a [`ProbeGrid`] (order-2 SH irradiance per probe, Jensen §3.3) per pixel
//! in `shaders/virtual_shading.wgsl`. Where the grid comes from is a [`ProbeSource`]: it is asked
//! for a new grid only on frames whose estimate says `relight` (the lighting moved enough), the
//! place where "relight the environment map → update the probes" (Jensen §3.4, §4.2) plugs in.
//! Until the irradiance volume is baked, [`UniformSky`] fills every probe with the closed form of
//! an unoccluded uniform sky of the frame's `Pa` (`E(n) = Pa·(1 + n_y)/2`).

use crate::estimate::FrameEstimate;
use crate::irradiance::{ProbeGrid, sh};
use glam::Vec3;

/// Mirrors `ProbeGridHeader` in `shaders/common/sh.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ProbeGridHeader {
    /// Position of probe (0, 0, 0) and the spacing.
    pub origin: [f32; 4],
    /// Probes per axis and in total.
    pub dims: [u32; 4],
}

/// Where the probe grid comes from.
pub trait ProbeSource {
    /// A grid for the lighting of `estimate` (called only when `estimate.relight` is true, and
    /// for the first frame). `pd`, `pa` are the values the compositor uses for the frame.
    fn relight(&mut self, estimate: &FrameEstimate, pd: Vec3, pa: Vec3) -> ProbeGrid;
    /// Short name for reports.
    fn name(&self) -> &'static str;
}

/// Every probe holds the irradiance of an unoccluded uniform sky of the frame's `Pa` (the
/// stand-in until the irradiance volume is baked).
#[derive(Clone, Copy, Debug)]
pub struct UniformSky {
    /// Grid minimum corner (the scene's `[irradiance]` bounds).
    pub min: Vec3,
    /// Grid maximum corner.
    pub max: Vec3,
    /// Spacing, metres.
    pub spacing: f32,
}

impl ProbeSource for UniformSky {
    fn relight(&mut self, _estimate: &FrameEstimate, _pd: Vec3, pa: Vec3) -> ProbeGrid {
        ProbeGrid::filled(self.min, self.max, self.spacing, sh::uniform_upper_sky(pa))
    }
    fn name(&self) -> &'static str {
        "uniform_sky"
    }
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
            header: mk("probe header", std::mem::size_of::<ProbeGridHeader>() as u64, wgpu::BufferUsages::UNIFORM),
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
