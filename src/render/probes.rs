//! Ambient light for the virtual objects: the irradiance-probe grid on the GPU, and the hook
//! where relighting plugs in.
//!
//! The compositor reads a [`ProbeGrid`] (order-2 SH irradiance per probe, Jensen §3.3) per pixel
//! in `shaders/virtual_shading.wgsl`. Where the grid comes from is a [`ProbeSource`]: it is asked
//! for a new grid only on frames whose estimate says `relight` (the lighting moved enough), the
//! place where "relight the environment map → update the probes" (Jensen §3.4, §4.2) plugs in.
//!
//! Two sources exist:
//! - [`VolumeProbes`], the product path: the scene's bake (albedo, normal and weighted-ambient
//!   environment maps) relit for the frame's sun and sky, folded into the probes through the
//!   precomputed transfer of [`crate::irradiance::transfer`] (the linear path: one response per
//!   unit `Pa` and one per unit `Pd`, the latter rebuilt only when the sun has moved more than
//!   `[bake.relight] sun_rebuild_deg`).
//! - [`UniformSky`], for scenes without an `[envmap]`: every probe holds the closed form of an
//!   unoccluded uniform sky of the frame's `Pa` (`E(n) = Pa·(1 + n_y)/2`), so real surfaces
//!   neither hide sky nor bounce light.

use crate::envmap::bake::Baked;
use crate::envmap::relight::Relighter;
use crate::estimate::FrameEstimate;
use crate::geometry::raycast::RayScene;
use crate::irradiance::transfer::{LinearBasis, ProbeTransfer, TransferStats};
use crate::irradiance::{ProbeGrid, sh};
use crate::scene::Scene;
use glam::Vec3;
use std::sync::Arc;

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
    /// The grid is the source's own, updated in place (no copy per relight).
    fn relight(&mut self, estimate: &FrameEstimate, pd: Vec3, pa: Vec3) -> &ProbeGrid;
    /// Short name for reports.
    fn name(&self) -> &'static str;
}

/// Every probe holds the irradiance of an unoccluded uniform sky of the frame's `Pa` (for
/// scenes without an `[envmap]`, or `--ambient uniform`).
#[derive(Clone, Debug)]
pub struct UniformSky {
    grid: ProbeGrid,
}

impl ProbeSource for UniformSky {
    fn relight(&mut self, _estimate: &FrameEstimate, _pd: Vec3, pa: Vec3) -> &ProbeGrid {
        self.grid.coeffs.fill(sh::uniform_upper_sky(pa));
        &self.grid
    }
    fn name(&self) -> &'static str {
        "uniform_sky"
    }
}

/// Probe-grid bounds and spacing: the manifest's `[irradiance]`, else the virtual objects'
/// bounds grown by a metre at 1 m spacing (or a unit box at the origin without objects).
pub fn grid_bounds(scene: &Scene) -> (Vec3, Vec3, f32) {
    match &scene.manifest.irradiance {
        Some(g) => (glam::DVec3::from(g.min).as_vec3(), glam::DVec3::from(g.max).as_vec3(), g.spacing_m as f32),
        None => {
            let b = scene.virtual_objects.iter().filter_map(|o| o.mesh.bounds()).reduce(|(a, b), (c, d)| (a.min(c), b.max(d)));
            let (lo, hi) = b.unwrap_or((Vec3::ZERO, Vec3::ONE));
            (lo - Vec3::ONE, hi + Vec3::ONE, 1.0)
        }
    }
}

impl UniformSky {
    /// The stand-in over the scene's probe-grid bounds ([`grid_bounds`]).
    pub fn for_scene(scene: &Scene) -> Self {
        let (min, max, spacing) = grid_bounds(scene);
        Self::new(min, max, spacing)
    }

    /// The stand-in over `[min, max]` with probes `spacing` apart.
    pub fn new(min: Vec3, max: Vec3, spacing: f32) -> Self {
        Self { grid: ProbeGrid::filled(min, max, spacing, [[0.0; 3]; sh::N]) }
    }
}

/// The irradiance volume relit every time the estimate says the lighting moved (Jensen §3.3,
/// §4.2): relit environment map → probe SH by the linear path of the precomputed transfer.
pub struct VolumeProbes {
    relighter: Relighter,
    transfer: ProbeTransfer,
    basis: LinearBasis,
    grid: ProbeGrid,
    /// Sun-response rebuilds so far (sun visibility and bounce per texel, then the probes'
    /// per-unit-`Pd` response).
    pub sun_rebuilds: usize,
    /// Time of the last sun-response rebuild, ms (0 when the last update reused it).
    pub last_rebuild_ms: f64,
}

impl VolumeProbes {
    /// Builds the transfer from the probes over the scene's grid ([`grid_bounds`]) to the baked
    /// maps' texels (`[bake] probe_directions` rays per probe) and the ambient response.
    pub fn new(scene: &Scene, ray: Arc<RayScene>, baked: &Baked) -> Self {
        let (min, max, spacing) = grid_bounds(scene);
        let transfer = ProbeTransfer::build(min, max, spacing, baked, &ray, scene.bake.probe_directions);
        let relighter = Relighter::new(baked, ray, scene.bake.relight.clone());
        let basis = LinearBasis { ambient: transfer.ambient_response(&relighter), direct: Vec::new() };
        let grid = transfer.grid();
        Self { relighter, transfer, basis, grid, sun_rebuilds: 0, last_rebuild_ms: 0.0 }
    }

    /// The transfer's counts (probes, invalid probes, directions, build time).
    pub fn stats(&self) -> TransferStats {
        self.transfer.stats
    }

    /// The grid for sun direction `sun` (toward the sun; `sun_up` false leaves the sun out), sun
    /// irradiance `pd` and sky irradiance `pa`.
    pub fn update(&mut self, sun: Vec3, sun_up: bool, pd: Vec3, pa: Vec3) -> &ProbeGrid {
        self.last_rebuild_ms = 0.0;
        let pd = if sun_up && pd.max_element() > 0.0 {
            let t = std::time::Instant::now();
            let u = self.relighter.update_sun(sun);
            if u.rebuilt || self.basis.direct.is_empty() {
                self.basis.direct = self.transfer.direct_response(&self.relighter);
                self.sun_rebuilds += 1;
                self.last_rebuild_ms = t.elapsed().as_secs_f64() * 1e3;
            }
            pd
        } else {
            Vec3::ZERO
        };
        self.transfer.linear_into(&self.basis, pd, pa, &mut self.grid);
        &self.grid
    }
}

impl ProbeSource for VolumeProbes {
    fn relight(&mut self, estimate: &FrameEstimate, pd: Vec3, pa: Vec3) -> &ProbeGrid {
        self.update(Vec3::from(estimate.sun.dir_world), estimate.sun.above_horizon, pd, pa)
    }
    fn name(&self) -> &'static str {
        "irradiance_volume"
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
