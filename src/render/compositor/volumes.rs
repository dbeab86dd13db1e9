//! The compositor's shadow volumes as units: the volume build (the prepared occluders and the
//! buffers the volume passes draw) and the two volume passes, real and virtual.
//!
//! # How it works
//! [`Volumes`] builds both kinds of volume for the frame's sun, real parts limited to those that
//! can matter ([`crate::render::reach`]); [`RealVolumes`] and [`VirtualVolumes`] draw them into
//! the depth prepass's render pass, z-fail counted and resolved to their stencil flags
//! ([`crate::render::shadow_volume`], [`crate::render::stencil`]). All three are left out when the
//! stored stencil serves the frame (it holds their result) and when they are switched off; the
//! real pass also when no real part can shadow the objects or the surfaces their shadows fall
//! on.

use super::context::FrameContext;
use crate::gpu::Gpu;
use crate::render::RenderError;
use crate::render::frame::{PassReport, VolumeStats, pass};
use crate::render::occluder::Occluder;
use crate::render::plan::{Pass, Plan};
use crate::render::shadow_volume::ShadowVolumePass;
use crate::render::stencil::StencilResolve;
use crate::render::reach::relevant_components;
use crate::render::volume::{HVertex, Parts, build};
use crate::render::volume_compute::{ComputeVolumes, GpuOccluder};
use glam::Vec3;

/// Which builder makes the virtual occluders' volumes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Builder {
    /// rayon on the CPU, uploaded as a vertex buffer.
    #[default]
    Cpu,
    /// A compute pass writing the vertex buffer and an indirect draw.
    Compute,
}

/// A vertex buffer that grows to fit.
struct GrowBuffer {
    buffer: Option<wgpu::Buffer>,
    label: &'static str,
}

impl GrowBuffer {
    fn upload(&mut self, gpu: &Gpu, vertices: &[HVertex]) {
        let bytes: &[u8] = bytemuck::cast_slice(vertices);
        if bytes.is_empty() {
            return;
        }
        let size = bytes.len() as u64;
        if self.buffer.as_ref().is_none_or(|b| b.size() < size) {
            self.buffer = Some(gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(self.label),
                size: size.next_power_of_two(),
                usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }));
        }
        if let Some(b) = &self.buffer {
            gpu.queue.write_buffer(b, 0, bytes);
        }
    }
}

/// What one build did.
#[derive(Clone, Copy, Debug, Default)]
pub struct BuildStats {
    /// Virtual volume triangles (`None` for the compute builder).
    pub virtual_triangles: Option<usize>,
    /// Real volume triangles.
    pub real_triangles: usize,
    /// Real proxy parts with a volume.
    pub real_parts: usize,
    /// CPU time, ms.
    pub build_ms: f64,
    /// Upload time, ms.
    pub upload_ms: f64,
}

/// The occluders and their current volumes.
pub struct Volumes {
    /// Virtual objects, one occluder each.
    pub virtual_occ: Vec<Occluder>,
    /// The real proxy.
    pub proxy_occ: Occluder,
    builder: Builder,
    compute: Option<(ComputeVolumes, Vec<GpuOccluder>)>,
    virtual_buf: GrowBuffer,
    virtual_vertices: u32,
    real_buf: GrowBuffer,
    real_vertices: u32,
    scratch: Vec<HVertex>,
    /// Sun direction of the current volumes.
    pub built_for: Option<Vec3>,
}

impl Volumes {
    /// Prepares the occluders (and the compute buffers when asked for).
    pub fn new(gpu: &Gpu, virtual_occ: Vec<Occluder>, proxy_occ: Occluder, builder: Builder) -> Result<Self, RenderError> {
        let compute = match builder {
            Builder::Cpu => None,
            Builder::Compute => {
                let c = ComputeVolumes::new(&gpu.device)?;
                let bufs = virtual_occ.iter().map(|o| c.upload(&gpu.device, o)).collect::<Result<Vec<_>, _>>()?;
                Some((c, bufs))
            }
        };
        Ok(Self {
            virtual_occ,
            proxy_occ,
            builder,
            compute,
            virtual_buf: GrowBuffer { buffer: None, label: "virtual volumes" },
            virtual_vertices: 0,
            real_buf: GrowBuffer { buffer: None, label: "real volumes" },
            real_vertices: 0,
            scratch: Vec::new(),
            built_for: None,
        })
    }

    /// Replaces the occluder of virtual object `index` (it moved); the next frame builds the
    /// volumes again.
    pub fn set_virtual(&mut self, gpu: &Gpu, index: usize, occ: Occluder) -> Result<(), RenderError> {
        if let Some((c, bufs)) = &mut self.compute {
            bufs[index] = c.upload(&gpu.device, &occ)?;
        }
        self.virtual_occ[index] = occ;
        self.built_for = None;
        Ok(())
    }

    /// The builder in use.
    pub fn builder(&self) -> Builder {
        self.builder
    }

    /// Builds both kinds of volume for `sun`; the compute dispatches go into `encoder`. Real
    /// parts are limited to those that can matter to `virtual_bounds`.
    pub fn build(&mut self, gpu: &Gpu, encoder: &mut wgpu::CommandEncoder, sun: Vec3, virtual_bounds: &[(Vec3, Vec3)], cap_offset_m: f32) -> BuildStats {
        let mut stats = BuildStats::default();
        let t = std::time::Instant::now();
        let relevant = relevant_components(&self.proxy_occ, virtual_bounds, sun);
        self.scratch.clear();
        stats.real_triangles = build(&self.proxy_occ, sun, cap_offset_m, Parts::Only(&relevant), &mut self.scratch);
        stats.real_parts = relevant.len();
        let real = std::mem::take(&mut self.scratch);
        let mut virt = Vec::new();
        match &self.compute {
            Some((c, bufs)) => {
                for b in bufs {
                    c.record(&gpu.queue, encoder, b, sun, cap_offset_m);
                }
            }
            None => {
                let mut n = 0;
                for o in &self.virtual_occ {
                    n += build(o, sun, cap_offset_m, Parts::All, &mut virt);
                }
                stats.virtual_triangles = Some(n);
            }
        }
        stats.build_ms = t.elapsed().as_secs_f64() * 1e3;
        let t = std::time::Instant::now();
        self.real_buf.upload(gpu, &real);
        self.real_vertices = real.len() as u32;
        if self.compute.is_none() {
            self.virtual_buf.upload(gpu, &virt);
            self.virtual_vertices = virt.len() as u32;
        }
        stats.upload_ms = t.elapsed().as_secs_f64() * 1e3;
        self.scratch = real;
        self.built_for = Some(sun);
        stats
    }

    /// True when there are real volumes to draw.
    pub fn has_real(&self) -> bool {
        self.real_vertices > 0
    }

    /// Draws the real volumes (pipeline already set).
    pub fn draw_real(&self, pass: &mut wgpu::RenderPass<'_>) {
        if let (Some(b), true) = (&self.real_buf.buffer, self.real_vertices > 0) {
            pass.set_vertex_buffer(0, b.slice(..self.real_vertices as u64 * 16));
            pass.draw(0..self.real_vertices, 0..1);
        }
    }

    /// Draws the virtual volumes (pipeline already set).
    pub fn draw_virtual(&self, pass: &mut wgpu::RenderPass<'_>) {
        match &self.compute {
            Some((_, bufs)) => {
                for b in bufs {
                    pass.set_vertex_buffer(0, b.vertices.slice(..));
                    pass.draw_indirect(&b.draw_args, 0);
                }
            }
            None => {
                if let (Some(b), true) = (&self.virtual_buf.buffer, self.virtual_vertices > 0) {
                    pass.set_vertex_buffer(0, b.slice(..self.virtual_vertices as u64 * 16));
                    pass.draw(0..self.virtual_vertices, 0..1);
                }
            }
        }
    }

    /// The compute output buffers (tests read them back).
    pub fn compute_buffers(&self) -> Option<&[GpuOccluder]> {
        self.compute.as_ref().map(|(_, b)| b.as_slice())
    }

    /// The report's volume numbers before a build: the builder, and whether the stored
    /// volumes' results are reused.
    pub fn stats(&self, reused: bool) -> VolumeStats {
        VolumeStats { compute: self.builder == Builder::Compute, reused, ..Default::default() }
    }

    /// Builds the volumes for the frame's sun (the plan said so) and reports the numbers.
    pub fn record(&mut self, gpu: &Gpu, encoder: &mut wgpu::CommandEncoder, ctx: &FrameContext, virtual_bounds: &[(Vec3, Vec3)], cap_offset_m: f32, report: &mut PassReport) {
        let b = self.build(gpu, encoder, ctx.sun_dir, virtual_bounds, cap_offset_m);
        report.timings.volume_build_ms = b.build_ms;
        report.timings.upload_ms += b.upload_ms;
        report.volumes.virtual_triangles = b.virtual_triangles;
        report.volumes.real_triangles = b.real_triangles;
        report.volumes.real_parts = b.real_parts;
    }
}

impl Pass<FrameContext> for Volumes {
    const NAME: &'static str = pass::VOLUME_BUILD;

    fn plan(&self, ctx: &FrameContext) -> Plan {
        match &ctx.reuse {
            Some(why) => Plan::skip(why.clone()),
            None if !ctx.switches.virtual_volumes && !ctx.switches.real_volumes => Plan::skip(ctx.off.clone()),
            None => Plan::Run,
        }
    }
}

/// The plan of a volume pass switched `on` or off: the stored stencil's reason when it is
/// reused (the switch's when the pass is off), the switch's when it is off.
fn volume_plan(ctx: &FrameContext, on: bool) -> Option<Plan> {
    match (&ctx.reuse, on) {
        (Some(why), true) => Some(Plan::skip(why.clone())),
        (_, false) => Some(Plan::skip(ctx.off.clone())),
        (None, true) => None,
    }
}

/// Pass 2a as a unit: the real occluders' volumes, counted down on z-fail and resolved to the
/// real-shadow flag.
pub struct RealVolumes<'a> {
    /// The built volumes.
    pub volumes: &'a Volumes,
    /// The volume pipelines.
    pub pipelines: &'a ShadowVolumePass,
    /// The resolve pipelines.
    pub resolve: &'a StencilResolve,
}

impl RealVolumes<'_> {
    /// Records the volumes and their resolve into the depth prepass's render pass.
    pub fn record(&self, pass: &mut wgpu::RenderPass<'_>) {
        pass.set_pipeline(&self.pipelines.real);
        self.volumes.draw_real(pass);
        self.resolve.record_real(pass);
    }
}

impl Pass<FrameContext> for RealVolumes<'_> {
    const NAME: &'static str = pass::REAL_VOLUMES;

    fn plan(&self, ctx: &FrameContext) -> Plan {
        volume_plan(ctx, ctx.switches.real_volumes).unwrap_or_else(|| {
            if self.volumes.has_real() {
                Plan::Run
            } else {
                Plan::skip("no part of the real proxy can shadow the virtual objects or the surfaces their shadows fall on")
            }
        })
    }
}

/// Pass 2b as a unit: the virtual occluders' volumes, counted up on z-fail and resolved to the
/// virtual-shadow flag.
pub struct VirtualVolumes<'a> {
    /// The built volumes.
    pub volumes: &'a Volumes,
    /// The volume pipelines.
    pub pipelines: &'a ShadowVolumePass,
    /// The resolve pipelines.
    pub resolve: &'a StencilResolve,
}

impl VirtualVolumes<'_> {
    /// Records the volumes and their resolve into the depth prepass's render pass.
    pub fn record(&self, pass: &mut wgpu::RenderPass<'_>) {
        pass.set_pipeline(&self.pipelines.virtual_);
        self.volumes.draw_virtual(pass);
        self.resolve.record_virtual(pass);
    }
}

impl Pass<FrameContext> for VirtualVolumes<'_> {
    const NAME: &'static str = pass::VIRTUAL_VOLUMES;

    fn plan(&self, ctx: &FrameContext) -> Plan {
        volume_plan(ctx, ctx.switches.virtual_volumes).unwrap_or(Plan::Run)
    }
}
