//! The compositor: one frame of footage in, the same frame with the virtual objects out.
//!
//! # How it works
//! (Jensen §3.2 steps 1–4, §3.3 and §5, made robust; the passes are documented in their own
//! modules.) On the undistorted canvas ([`crate::gpu::canvas`]), with MSAA when the adapter has it:
//!
//! 1. depth prepass: real proxy, then virtual objects (which set the virtual-surface stencil
//!    bit);
//! 2. shadow volumes of the real parts that can matter, z-fail counted, resolved to a flag; then
//!    those of the virtual objects, the same way (skipped without sun);
//! 3. the shadow masks: virtual shadow on real surfaces outside real shadow, and which
//!    virtual-surface samples are in some shadow;
//! 4. the virtual objects shaded in one geometry pass: sun term times the pixel's unshadowed
//!    fraction of virtual-surface samples, ambient from the per-pixel transfer
//!    ([`super::object_transfer`], traced on the CPU on the first frame; its sun part re-traced
//!    when the sun has moved past `bounce_rebuild_deg`, a slice of `trace_paths_per_frame` paths
//!    per frame while the previous one serves), or SH ambient from the probe grid times the
//!    objects' own ambient occlusion where the transfer has no entry (or is off); after the
//!    objects moved by translation, the per-vertex ambient of the visibility cuts instead
//!    (`motion`, issue 15 §2), except for the unmoved objects no moved one reaches, which keep
//!    the transfer (`kept`, issue 15 §5).
//!
//! Then, in the footage's pixel grid, the composite warps the canvas layers through the lens
//! model and darkens the footage: under the virtual shadow with the proxy's normal and `c`, and,
//! with the (default) differential model, also where the objects take sky and bounce light from
//! real surfaces next to them; there the virtual shadow removes the share of a pixel's sunlit
//! real samples that it covers, counted on the GPU's own samples.
//!
//! Work a frame does not need is left out, and the report says why: no virtual objects (the
//! footage passes through), no sun (`Pd ≈ 0` or the sun below the horizon: no volumes, no sun
//! term), no real part whose shadow can reach the objects or their shadows (no real volumes),
//! a sun that has not moved more than `reuse_sun_deg` with static objects (the volumes, the
//! stencil and the mask of the earlier frame are kept; only shading and composite run), and a
//! sun that has not moved more than `bounce_rebuild_deg` (the objects' transfer is kept). A sun
//! that has moved further never stalls a frame: the sun-dependent values (the receivers' `b`
//! and `s`, the objects' `R_d`) are re-traced within `trace_paths_per_frame` paths per frame;
//! the sky-only ones (`c`, `R_a`) keep their values (they share those paths, whose random numbers
//! do not depend on the sun, so they would come out the same) (issue 13 part 4).
//!
//! # Passes as units
//! Every pass is a unit ([`crate::render::plan`]): it plans from the frame's facts
//! ([`FrameContext`], with the frame-level [`Gate`]) and records its own commands, and what it
//! keeps between frames lives with it: the stored stencil and whether it serves a frame
//! ([`StencilCache`]), the traced transfer and whether it must be traced again
//! (`transfer.rs`), the volumes ([`Volumes`]). `encode` is the list, read top to bottom:
//!
//! | step | unit | kind |
//! |---|---|---|
//! | canvas region | [`StencilCache`] (kept with the stencil) | CPU |
//! | `volume_build` | [`Volumes`] | CPU (or compute) and upload |
//! | receivers' `c`, `b` | `receiver_update.rs` (not in the report) | CPU and upload |
//! | `object_transfer` | `transfer.rs` | CPU and upload |
//! | `lamp_bounce` (with `[[lights]]` only) | `lamp_bounce.rs` ([`crate::render::object_transfer::lamps`]) | CPU (once) and upload |
//! | footage, lighting uniform | | upload |
//! | `depth_prepass`, `real_volumes`, `virtual_volumes` | [`DepthPrepass`](crate::render::depth_prepass::DepthPrepass), [`RealVolumes`], [`VirtualVolumes`] | one render pass |
//! | `shadow_mask` | [`ShadowMask`](crate::render::shadow_mask::ShadowMask) | render pass |
//! | `lamp_shadows`, `lamp_term`, `lamp_ground` (with `[[lights]]` only) | [`LampPass`](crate::render::lamps::LampPass) (`lamps.rs`); `lamp_ground` is a term of the composite's shader ([`crate::render::lamps::ground`]) | atlas render passes; upload |
//! | `virtual_shading`, `sun_term` | [`VirtualShading`](crate::render::virtual_shading::VirtualShading), `SunTerm` (a term of its shader and the composite's); the lamp term drawn after it in its render pass | render pass |
//! | `composite` | [`Composite`](crate::render::composite::Composite) | render pass(es) |
//!
//! The plans of the GPU passes and the render passes they share are in `units.rs`; `setup.rs`
//! builds everything, `config.rs` holds the settings and plain values.
mod config;
mod context;
mod cut_cache;
mod encode;
mod ground_bounce;
mod kept;
mod lamp_bounce;
mod lamps;
mod motion;
mod receiver_update;
mod replay;
mod resources;
mod setup;
mod stencil_cache;
mod transfer;
mod units;
mod volumes;

pub use config::{CompositorConfig, HALF_PRECISION, PassSwitches, REUSE_SUN_DEG, RenderedFrame, SceneParts, TRACE_PATHS_PER_FRAME};
pub use context::{FrameContext, Gate};
pub use cut_cache::{CutReceiverCounts, LightLeft, ReceiverField};
pub use motion::{ReceiverVisibility, VertexAmbient};
pub use resources::Resources;
pub use stencil_cache::StencilCache;
pub use volumes::{BuildStats, Builder, RealVolumes, VirtualVolumes, Volumes};

use super::RenderError;
use super::composite::Composite;
use super::depth_prepass::DepthPrepass;
use super::frame::{Darkening, PassReport, VideoFrame, pass};
use super::object_transfer::ObjectTransfer;
use super::probes::GpuProbes;
use super::receivers::Receivers;
use super::shadow_mask::ShadowMask;
use super::shadow_volume::ShadowVolumePass;
use super::stencil::StencilResolve;
use super::virtual_shading::VirtualShading;
use crate::geometry::raycast::RayScene;
use crate::gpu::canvas::Canvas;
use crate::gpu::mesh::{ProxyBuffers, VirtualBuffers};
use crate::gpu::readback::read_texture;
use crate::gpu::{Gpu, f32_from_f16};
use crate::io::image::LinearImage;
use crate::irradiance::ProbeGrid;
use crate::lighting::Lighting;
use glam::Vec3;
use receiver_update::ReceiverPixels;
use std::collections::HashMap;
use std::sync::Arc;
use transfer::TransferPass;

/// The GPU compositor of one scene and camera.
pub struct Compositor {
    gpu: Arc<Gpu>,
    config: CompositorConfig,
    canvas: Canvas,
    proxy_ray: Arc<RayScene>,
    receivers: Receivers,
    volumes: Volumes,
    virtual_bounds: Vec<(Vec3, Vec3)>,
    res: Resources,
    camera_bg: wgpu::BindGroup,
    lighting_buf: wgpu::Buffer,
    camera_buf: wgpu::Buffer,
    probes: GpuProbes,
    shading_bg: wgpu::BindGroup,
    proxy: ProxyBuffers,
    virt: VirtualBuffers,
    prepass: DepthPrepass,
    shadow: ShadowVolumePass,
    resolve: StencilResolve,
    shading: VirtualShading,
    mask: ShadowMask,
    composite_layout: wgpu::BindGroupLayout,
    composite_bg: wgpu::BindGroup,
    /// The lamps' data group's layout (lamp term and composite, `render::lamps::ground`).
    lamp_layout: wgpu::BindGroupLayout,
    /// The composite's lamp group without lamps (zero spots).
    no_lamps_bg: wgpu::BindGroup,
    composites: HashMap<wgpu::TextureFormat, Composite>,
    /// The stored depth, stencil and mask, and their canvas region.
    stencil: StencilCache,
    switches: PassSwitches,
    switched_off_reason: String,
    warnings: Vec<String>,
    frames: u64,
    /// The proxy and the virtual objects in one BVH (for `c_v`, `b_v` and the transfer).
    with_ray: Option<Arc<RayScene>>,
    /// The objects' per-pixel ambient transfer.
    transfer: TransferPass,
    /// The proxy pixels whose `c`, `b` (`c_v`, `b_v`) are kept up to date.
    receiver_pixels: ReceiverPixels,
    /// The stencil rebuild replayed frames owe (a resumed run; see `replay`).
    owed_stencil: Option<replay::OwedStencil>,
    /// Layout of the material bind groups (for re-uploading moved objects).
    mat_layout: wgpu::BindGroupLayout,
    /// The objects' per-vertex ambient from the visibility cuts (shading group 0, binding 11).
    cut_ambient: wgpu::Buffer,
    /// Per object, the mesh vertex of each of its vertices in the vertex buffer.
    vertex_sources: Vec<Vec<u32>>,
    /// The receivers' sky visibility from the visibility cuts, while they serve (see `motion`).
    cuts: Option<Arc<dyn ReceiverField>>,
    /// Their values per pixel, kept between frames (`cut_cache`).
    cut_cache: cut_cache::CutCache,
    /// The objects that keep their traced transfer while others move under the cuts (`kept`).
    kept: kept::KeptTrace,
    /// The lamp stage (`None`: the scene has no lamps).
    lamps: Option<super::lamps::LampPass>,
    /// The lamps' bounce on the objects (`None`: no lamps, or its option off).
    lamp_bounce: Option<lamp_bounce::LampBouncePass>,
    /// The lamps' bounce at the real receivers (`None`: no lamps, or its option off).
    ground_bounce: Option<ground_bounce::GroundBounceUnit>,
}

impl Compositor {
    /// Warnings from set-up (open or non-manifold occluders), one line each.
    pub fn warnings(&self) -> &[String] {
        &self.warnings
    }
    /// The canvas and lens warp.
    pub fn canvas(&self) -> &Canvas {
        &self.canvas
    }
    /// The per-pixel proxy data.
    pub fn receivers(&self) -> &Receivers {
        &self.receivers
    }
    /// The device.
    pub fn gpu(&self) -> &Arc<Gpu> {
        &self.gpu
    }
    /// The settings.
    pub fn config(&self) -> &CompositorConfig {
        &self.config
    }
    /// Changes the darkening model (takes effect on the next frame, which rebuilds its stencil
    /// so that the per-pixel data the new model needs is computed).
    pub fn set_darkening(&mut self, d: Darkening) {
        if self.config.darkening != d {
            self.config.darkening = d;
            self.invalidate();
        }
    }
    /// Switches passes on or off from the next frame on; the passes switched off are reported
    /// as skipped with `reason` (e.g. "turned off in the live view"). A change rebuilds the
    /// stencil on the next frame.
    pub fn set_switches(&mut self, switches: PassSwitches, reason: &str) {
        if self.switches != switches {
            self.switches = switches;
            self.invalidate();
        }
        self.switched_off_reason = reason.to_owned();
    }
    /// The pass switches.
    pub fn switches(&self) -> PassSwitches {
        self.switches
    }
    /// The shadow volumes.
    pub fn volumes(&self) -> &Volumes {
        &self.volumes
    }
    /// The virtual objects' per-pixel ambient transfer, when it is on.
    pub fn transfer(&self) -> Option<&ObjectTransfer> {
        self.transfer.transfer()
    }
    /// The bounding boxes of the virtual objects.
    pub fn virtual_bounds(&self) -> &[(Vec3, Vec3)] {
        &self.virtual_bounds
    }
    /// Forgets the stored stencil, so the next frame rebuilds everything.
    pub fn invalidate(&mut self) {
        self.stencil.invalidate();
        if let Some(l) = &mut self.lamps {
            l.invalidate();
        }
    }

    /// Replaces the probe grid (call when the lighting was relit).
    pub fn set_probes(&mut self, grid: &ProbeGrid) {
        if self.probes.fits(grid) {
            self.probes.write(&self.gpu.queue, grid);
        } else {
            self.probes = GpuProbes::new(&self.gpu.device, &self.gpu.queue, grid);
            self.shading_bg = Self::shading_bind_group(&self.gpu.device, &self.shading, &self.camera_buf, &self.lighting_buf, &self.probes, &self.res, &self.cut_ambient);
        }
    }

    /// Composites one frame offscreen and reads it back.
    pub fn render(&mut self, video: &VideoFrame, lighting: &Lighting) -> Result<(RenderedFrame, PassReport), RenderError> {
        let target = self.res.output.view.clone();
        let (encoder, mut report) = self.encode(video, lighting, &target, self.gpu.output_format, 1.0)?;
        let t = std::time::Instant::now();
        self.gpu.queue.submit([encoder.finish()]);
        self.gpu.wait()?;
        report.timings.gpu_ms += t.elapsed().as_secs_f64() * 1e3;
        let t = std::time::Instant::now();
        let bytes = read_texture(&self.gpu, &self.res.output.texture, self.gpu.output_texel_bytes())?;
        let data: Vec<[f32; 3]> = if self.gpu.output_texel_bytes() == 16 {
            bytemuck::cast_slice::<u8, [f32; 4]>(&bytes).iter().map(|p| [p[0], p[1], p[2]]).collect()
        } else {
            bytes.chunks_exact(8).map(|p| std::array::from_fn(|c| f32_from_f16(u16::from_le_bytes([p[2 * c], p[2 * c + 1]])))).collect()
        };
        let image = LinearImage { width: self.canvas.out_width, height: self.canvas.out_height, data };
        let masks = if self.config.debug_masks {
            let b = read_texture(&self.gpu, &self.res.output_masks.texture, 4)?;
            Some(bytemuck::cast_slice::<u8, [u8; 4]>(&b).to_vec())
        } else {
            None
        };
        report.timings.readback_ms = t.elapsed().as_secs_f64() * 1e3;
        report.ran.push(pass::READBACK);
        let precision = if self.gpu.output_texel_bytes() == 16 { 0.0 } else { HALF_PRECISION };
        Ok((RenderedFrame { image, masks, precision }, report))
    }

    /// Composites one frame into `view` (a window's surface texture of `format`), with the
    /// output scaled by `exposure`. Submits without waiting.
    pub fn render_to(&mut self, view: &wgpu::TextureView, format: wgpu::TextureFormat, exposure: f32, video: &VideoFrame, lighting: &Lighting) -> Result<PassReport, RenderError> {
        if !self.composites.contains_key(&format) {
            let c = Composite::new(&self.gpu.device, &self.composite_layout, &self.lamp_layout, format, None)?;
            self.composites.insert(format, c);
        }
        let (encoder, report) = self.encode(video, lighting, view, format, exposure)?;
        self.gpu.queue.submit([encoder.finish()]);
        Ok(report)
    }
}
