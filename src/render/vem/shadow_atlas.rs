//! The shadow-map atlas (`shaders/vem/shadow_atlas.wgsl`; Havran §4.3: shadows for the clustered
//! lights): one square depth texture holding up to [`DEFAULT_SLOTS`] orthographic maps of
//! [`DEFAULT_TILE`]² texels, addressed from the light list (each light's `shadow` slot).
//!
//! # How it works
//! - **Slots.** The shadow maps belong to the clustered lights (the decomposer's clusters when
//!   it clusters, else `H` clustered here into at most `slots` lights with Havran's radius
//!   `ε = c_f·asin √(2/Q)`); every light of `H` and `L` reads the map of the cluster direction
//!   nearest to it ([`assign_slots`]).
//! - **Fit.** Each map is orthographic along its light, its footprint fitted to the casters' (the
//!   virtual objects') bounds seen from the light, its depth range to their extent along the
//!   light ([`fit_view`]). Receivers need not be inside: a point outside the footprint has no
//!   caster between it and the light (lit), and a point beyond the far side compares against
//!   depth 1, so any caster in front of it shadows it. The whole tile resolution goes to the
//!   objects.
//! - **Lookup** (in `shaders/vem/shading.wgsl`): one texel, read through a nearest-texel
//!   comparison sampler (GL cannot `textureLoad` a depth texture), with a normal offset of
//!   [`NORMAL_OFFSET_TEXELS`] texels and a depth bias of [`DEPTH_BIAS_TEXELS`] texels against
//!   self-shadowing acne.
//! - **As a unit.** [`ShadowAtlasPass`] runs when the frame has shadow maps to draw (shadows on,
//!   objects, lights with power: [`VemFrame::no_shadows`]) and records one viewport per map.
//! - **Perspective maps.** The outdoor compositor's lamps (issue 16 §2, Granier §4: one shadow
//!   map per filter position) use the same atlas, pipeline and lookup with perspective views
//!   from a point ([`fit_spot_view`]), and draw more than one mesh into it
//!   ([`ShadowAtlasPass::with_strides`], [`ShadowAtlasPass::record_geometry`]): the objects and
//!   the real proxy, so both cast lamp shadows. Their bias grows with the distance to the light
//!   (a texel's footprint does), so it is stored per metre and `bias.w` is 1.

use super::frame::VemFrame;
use super::pass;
use crate::gpu::mesh::VirtualBuffers;
use crate::gpu::shaders;
use crate::render::RenderError;
use crate::render::plan::{Pass, Plan};
use crate::vem::cluster::{DEFAULT_CF, cluster_lights, cluster_radius};
use crate::vem::regions::GpuLight;
use glam::{Mat4, Vec3, Vec4};

/// Default number of shadow maps (the 72).
pub const DEFAULT_SLOTS: usize = 72;
/// Default tile size, texels.
pub const DEFAULT_TILE: u32 = 256;
/// Normal offset of the lookup, in texels of the map (a surface tilted by up to ~60° to the
/// light then clears its own depth texel).
pub const NORMAL_OFFSET_TEXELS: f32 = 1.5;
/// Depth bias of the lookup, in texels of the map's footprint converted to depth units.
pub const DEPTH_BIAS_TEXELS: f32 = 1.0;
/// Depth format of the atlas.
pub const ATLAS_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;
/// Near plane of a perspective map, metres from the light: casters closer than this (a
/// luminaire's own housing in the proxy) cast no shadow.
pub const SPOT_NEAR_M: f32 = 0.02;
/// Widest half-angle of a perspective map (its tangent, ~80°): a light inside or beside the
/// receivers' box keeps a usable map and loses the rest of the box.
pub const SPOT_MAX_TAN_HALF: f32 = 5.67;

/// Mirrors `ShadowView` in `shaders/common/vem_lights.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ShadowView {
    /// World → clip of the map, column-major.
    pub light_from_world: [[f32; 4]; 4],
    /// Orthographic (`w = 0`): depth bias (clip z units), normal offset (metres), unused.
    /// Perspective (`w = 1`): the offsets toward the light and along the normal per metre of
    /// distance to the light, unused.
    pub bias: [f32; 4],
    /// Perspective maps of a source with an area ([`ShadowView::with_emitter`]): the emitter's
    /// radius (m; 0 for a point, a hard shadow), one texel's angular size on the axis
    /// (`2·tan(half-angle)/tile`), the far plane (m), unused. Zero for orthographic maps.
    pub penumbra: [f32; 4],
}

impl ShadowView {
    /// The same map for a light whose emitting area has radius `radius_m` (a perspective map
    /// from [`fit_spot_view`]): its lookup (`spot_soft_visibility` in
    /// `shaders/common/lamp_spots.wgsl`) averages over the penumbra that size casts (PCSS:
    /// a blocker search, then a filter of width `radius·(d_r − d_b)/(d_r·d_b)` in angle).
    /// Orthographic maps and non-positive radii keep one texel, a hard shadow.
    pub fn with_emitter(mut self, radius_m: f32) -> Self {
        if self.bias[3] > 0.0 && radius_m.is_finite() && radius_m > 0.0 {
            self.penumbra[0] = radius_m;
        }
        self
    }
}

/// Tiles per side of an atlas holding `slots` maps (the square atlas of the issue).
pub fn tiles_per_side(slots: usize) -> u32 {
    (slots.max(1) as f64).sqrt().ceil() as u32
}

/// The orthographic map along `to_light` (unit) fitted to the box `lo..hi`, for `tile`² texels.
pub fn fit_view(to_light: Vec3, lo: Vec3, hi: Vec3, tile: u32) -> ShadowView {
    let f = -to_light.normalize_or(Vec3::NEG_Y);
    let up = if f.y.abs() < 0.99 { Vec3::Y } else { Vec3::X };
    let u = up.cross(f).normalize();
    let w = f.cross(u);
    let (mut mn, mut mx) = (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN));
    for k in 0..8 {
        let p = Vec3::new(if k & 1 == 0 { lo.x } else { hi.x }, if k & 2 == 0 { lo.y } else { hi.y }, if k & 4 == 0 { lo.z } else { hi.z });
        let q = Vec3::new(p.dot(u), p.dot(w), p.dot(f));
        mn = mn.min(q);
        mx = mx.max(q);
    }
    // One texel of margin around the footprint, and a little depth margin so that the casters are
    // never clipped.
    let side = (mx.x - mn.x).max(mx.y - mn.y).max(1e-4);
    let texel = side / tile.max(1) as f32;
    let (ex, ey) = (0.5 * (mx.x - mn.x) + texel, 0.5 * (mx.y - mn.y) + texel);
    let (cx, cy) = (0.5 * (mx.x + mn.x), 0.5 * (mx.y + mn.y));
    let margin = 0.01 * (mx.z - mn.z) + texel;
    let (d0, d1) = (mn.z - margin, mx.z + margin);
    let dr = (d1 - d0).max(1e-6);
    let rows = [
        Vec4::new(u.x / ex, u.y / ex, u.z / ex, -cx / ex),
        Vec4::new(w.x / ey, w.y / ey, w.z / ey, -cy / ey),
        Vec4::new(f.x / dr, f.y / dr, f.z / dr, -d0 / dr),
        Vec4::new(0.0, 0.0, 0.0, 1.0),
    ];
    let m = Mat4::from_cols(rows[0], rows[1], rows[2], rows[3]).transpose();
    let texel_m = 2.0 * ex.max(ey) / tile.max(1) as f32;
    ShadowView { light_from_world: m.to_cols_array_2d(), bias: [DEPTH_BIAS_TEXELS * texel_m / dr, NORMAL_OFFSET_TEXELS * texel_m, 0.0, 0.0], penumbra: [0.0; 4] }
}

/// The perspective map from the point `eye` (a lamp, or one filter position of a light field)
/// fitted to the receivers' box `lo..hi`, for `tile`² texels: centred on the box, wide enough to
/// hold its corners (at most [`SPOT_MAX_TAN_HALF`]), depth from [`SPOT_NEAR_M`] to the farthest
/// corner. Every caster between the light and a receiver in the box is then inside it.
pub fn fit_spot_view(eye: Vec3, lo: Vec3, hi: Vec3, tile: u32) -> ShadowView {
    let axis = (0.5 * (lo + hi) - eye).normalize_or(Vec3::NEG_Y);
    let up = if axis.y.abs() < 0.99 { Vec3::Y } else { Vec3::X };
    let view = glam::camera::rh::view::look_at_mat4(eye, eye + axis, up);
    let (mut tan_half, mut far) = (0.0f32, SPOT_NEAR_M);
    for k in 0..8 {
        let p = Vec3::new(if k & 1 == 0 { lo.x } else { hi.x }, if k & 2 == 0 { lo.y } else { hi.y }, if k & 4 == 0 { lo.z } else { hi.z });
        let q = view.transform_point3(p);
        far = far.max(q.length());
        let depth = -q.z;
        tan_half = if depth > 1e-6 { tan_half.max(q.x.abs() / depth).max(q.y.abs() / depth) } else { SPOT_MAX_TAN_HALF };
    }
    // One texel of margin on each side, and a little depth margin past the farthest corner.
    let tile = tile.max(1) as f32;
    let tan_half = (tan_half * (1.0 + 2.0 / tile)).clamp(1e-4, SPOT_MAX_TAN_HALF);
    let far = (far * 1.01 + 0.01).max(2.0 * SPOT_NEAR_M);
    let proj = glam::camera::rh::proj::directx::perspective(2.0 * tan_half.atan(), 1.0, SPOT_NEAR_M, far);
    let texel_per_m = 2.0 * tan_half / tile;
    ShadowView {
        light_from_world: (proj * view).to_cols_array_2d(),
        bias: [DEPTH_BIAS_TEXELS * texel_per_m, NORMAL_OFFSET_TEXELS * texel_per_m, 0.0, 1.0],
        penumbra: [0.0, texel_per_m, far, 0.0],
    }
}

/// The directions of the shadow maps: `clusters` when given, else `lights` clustered into at
/// most `slots` (Havran §4.3). At most `slots` directions.
pub fn shadow_directions(lights: &[GpuLight], clusters: &[Vec3], slots: usize) -> Vec<Vec3> {
    if !clusters.is_empty() {
        return clusters.iter().take(slots).copied().collect();
    }
    let lights: Vec<crate::vem::Light> =
        lights.iter().map(|l| crate::vem::Light { index: l.index, dir: Vec3::from_array(l.dir), rgb: l.rgb, radius: 0.0 }).collect();
    let mut out = Vec::new();
    cluster_lights(&lights, slots, cluster_radius(slots, DEFAULT_CF), &mut out);
    out.iter().map(|c| c.dir).collect()
}

/// Sets every light's `shadow` slot to the nearest of `dirs` (`u32::MAX` without maps).
pub fn assign_slots(lights: &mut [GpuLight], dirs: &[Vec3]) {
    for l in lights {
        let d = Vec3::from_array(l.dir);
        l.shadow = dirs
            .iter()
            .enumerate()
            .max_by(|a, b| d.dot(*a.1).total_cmp(&d.dot(*b.1)))
            .map_or(u32::MAX, |(i, _)| i as u32);
    }
}

/// The atlas pass: pipeline and layout.
pub struct ShadowAtlasPass {
    /// Depth-only pipeline (both faces, so open meshes cast too).
    pub pipeline: wgpu::RenderPipeline,
    /// Group 0: the views (storage, vertex stage).
    pub layout: wgpu::BindGroupLayout,
    /// The same pipeline for further vertex strides ([`Self::with_strides`]).
    pub others: Vec<wgpu::RenderPipeline>,
}

/// A mesh drawn into every map of the atlas: vertices (position first) of the stride of
/// pipeline `pipeline` (0: [`ShadowAtlasPass::pipeline`], `i`: `others[i − 1]`), indices and
/// the index ranges to draw.
pub struct AtlasGeometry<'a> {
    /// Which pipeline (stride).
    pub pipeline: usize,
    /// Vertex buffer.
    pub vertices: &'a wgpu::Buffer,
    /// Index buffer (`u32`).
    pub indices: &'a wgpu::Buffer,
    /// Index ranges.
    pub ranges: Vec<std::ops::Range<u32>>,
}

impl AtlasGeometry<'_> {
    /// The virtual objects, with pipeline 0.
    pub fn objects(objects: &VirtualBuffers) -> AtlasGeometry<'_> {
        AtlasGeometry { pipeline: 0, vertices: &objects.vertices, indices: &objects.indices, ranges: objects.draws.iter().map(|d| d.indices.clone()).collect() }
    }
}

impl ShadowAtlasPass {
    /// Builds the pipelines for vertices of `strides` bytes (position first; at least one).
    pub fn with_strides(device: &wgpu::Device, strides: &[u64]) -> Result<Self, RenderError> {
        let mut pass = Self::new(device, strides.first().copied().unwrap_or(12))?;
        for &stride in strides.iter().skip(1) {
            pass.others.push(Self::pipeline(device, &pass.layout, stride)?);
        }
        Ok(pass)
    }

    /// Builds the pipeline for vertices of `stride` bytes (position first).
    pub fn new(device: &wgpu::Device, stride: u64) -> Result<Self, RenderError> {
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("vem shadow views"),
            entries: &[wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::VERTEX,
                ty: wgpu::BindingType::Buffer { ty: wgpu::BufferBindingType::Storage { read_only: true }, has_dynamic_offset: false, min_binding_size: None },
                count: None,
            }],
        });
        let pipeline = Self::pipeline(device, &layout, stride)?;
        Ok(Self { pipeline, layout, others: Vec::new() })
    }

    fn pipeline(device: &wgpu::Device, layout: &wgpu::BindGroupLayout, stride: u64) -> Result<wgpu::RenderPipeline, RenderError> {
        let module = shaders::module(device, "vem/shadow_atlas.wgsl")?;
        let pl = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor { label: Some("vem shadow atlas"), bind_group_layouts: &[Some(layout)], immediate_size: 0 });
        let attrs = [wgpu::VertexAttribute { format: wgpu::VertexFormat::Float32x3, offset: 0, shader_location: 0 }];
        Ok(device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("vem shadow atlas"),
            layout: Some(&pl),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("vs_main"),
                compilation_options: Default::default(),
                buffers: &[Some(wgpu::VertexBufferLayout { array_stride: stride, step_mode: wgpu::VertexStepMode::Vertex, attributes: &attrs })],
            },
            primitive: wgpu::PrimitiveState::default(),
            depth_stencil: Some(wgpu::DepthStencilState {
                format: ATLAS_FORMAT,
                depth_write_enabled: Some(true),
                depth_compare: Some(wgpu::CompareFunction::Less),
                stencil: Default::default(),
                bias: Default::default(),
            }),
            multisample: wgpu::MultisampleState::default(),
            fragment: None,
            multiview_mask: None,
            cache: None,
        }))
    }
}

impl ShadowAtlasPass {
    /// Records the atlas (cleared to the far depth 1): the objects once per map, `maps` maps of
    /// `tile`² in rows of `tiles`, each map's view read from `views` by its slot (the instance).
    #[allow(clippy::too_many_arguments)] // the pass's inputs, each named; a struct would only rename them
    pub fn record(&self, device: &wgpu::Device, encoder: &mut wgpu::CommandEncoder, atlas: &wgpu::TextureView, views: &wgpu::Buffer, objects: &VirtualBuffers, maps: u32, tiles: u32, tile: u32) {
        self.record_geometry(device, encoder, atlas, views, &[AtlasGeometry::objects(objects)], maps, tiles, tile);
    }

    /// [`Self::record`] for any meshes: each of `geometry` once per map.
    #[allow(clippy::too_many_arguments)] // as `record`
    pub fn record_geometry(&self, device: &wgpu::Device, encoder: &mut wgpu::CommandEncoder, atlas: &wgpu::TextureView, views: &wgpu::Buffer, geometry: &[AtlasGeometry<'_>], maps: u32, tiles: u32, tile: u32) {
        let views_bg = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("vem shadow views"),
            layout: &self.layout,
            entries: &[wgpu::BindGroupEntry { binding: 0, resource: views.as_entire_binding() }],
        });
        let mut pa = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("vem shadow atlas"),
            color_attachments: &[],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: atlas,
                depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Clear(1.0), store: wgpu::StoreOp::Store }),
                stencil_ops: None,
            }),
            ..Default::default()
        });
        pa.set_bind_group(0, &views_bg, &[]);
        for g in geometry {
            let pipeline = match g.pipeline {
                0 => &self.pipeline,
                i => match self.others.get(i - 1) {
                    Some(p) => p,
                    None => continue,
                },
            };
            pa.set_pipeline(pipeline);
            pa.set_vertex_buffer(0, g.vertices.slice(..));
            pa.set_index_buffer(g.indices.slice(..), wgpu::IndexFormat::Uint32);
            for slot in 0..maps {
                let (x, y) = ((slot % tiles) * tile, (slot / tiles) * tile);
                pa.set_viewport(x as f32, y as f32, tile as f32, tile as f32, 0.0, 1.0);
                pa.set_scissor_rect(x, y, tile, tile);
                for r in &g.ranges {
                    pa.draw_indexed(r.clone(), 0, slot..slot + 1);
                }
            }
        }
    }
}

impl Pass<VemFrame> for ShadowAtlasPass {
    const NAME: &'static str = pass::SHADOW_ATLAS;

    fn plan(&self, frame: &VemFrame) -> Plan {
        match &frame.no_shadows {
            Some(why) => Plan::skip(why.clone()),
            None => Plan::Run,
        }
    }
}

/// A perspective map's stored depth `z` (in `[0, 1]`, from [`SPOT_NEAR_M`] to `far`) as
/// metres along its axis: `z = f·(d − n) / (d·(f − n))`, so `d = n·f / (f − z·(f − n))`.
/// Written again in `shaders/common/lamp_spots.wgsl` (`spot_linear_depth`).
pub fn spot_linear_depth(z: f32, far: f32) -> f32 {
    SPOT_NEAR_M * far / (far - z * (far - SPOT_NEAR_M)).max(1e-6)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn apply(v: &ShadowView, p: Vec3) -> Vec3 {
        let q = Mat4::from_cols_array_2d(&v.light_from_world) * p.extend(1.0);
        q.truncate() / q.w
    }

    #[test]
    fn fitted_view_holds_the_box_and_orders_depth_from_the_light() {
        let (lo, hi) = (Vec3::new(-1.0, 0.0, -0.5), Vec3::new(0.5, 2.0, 1.0));
        for l in [Vec3::Y, Vec3::new(0.3, 0.8, -0.2).normalize(), Vec3::new(-0.9, 0.1, 0.4).normalize()] {
            let v = fit_view(l, lo, hi, 256);
            for k in 0..8 {
                let p = Vec3::new(if k & 1 == 0 { lo.x } else { hi.x }, if k & 2 == 0 { lo.y } else { hi.y }, if k & 4 == 0 { lo.z } else { hi.z });
                let q = apply(&v, p);
                assert!(q.x.abs() < 1.0 && q.y.abs() < 1.0 && q.z > 0.0 && q.z < 1.0, "{l} {p} -> {q}");
            }
            // Moving toward the light decreases depth; moving across it keeps it.
            let c = 0.5 * (lo + hi);
            assert!(apply(&v, c + 0.1 * l).z < apply(&v, c).z);
            let side = l.any_orthonormal_vector();
            assert!((apply(&v, c + 0.1 * side).z - apply(&v, c).z).abs() < 1e-5);
            assert!(v.bias[0] > 0.0 && v.bias[1] > 0.0);
        }
        assert_eq!(tiles_per_side(72), 9);
        assert_eq!(tiles_per_side(1), 1);
    }

    #[test]
    fn a_spot_view_holds_the_box_in_perspective_and_orders_depth_from_the_light() {
        let (lo, hi) = (Vec3::new(-0.5, 0.0, -0.5), Vec3::new(0.5, 1.2, 0.5));
        for eye in [Vec3::new(0.0, 4.0, 0.0), Vec3::new(3.0, 2.5, -1.0), Vec3::new(-2.0, 0.6, 0.2)] {
            let v = fit_spot_view(eye, lo, hi, 256);
            for k in 0..8 {
                let p = Vec3::new(if k & 1 == 0 { lo.x } else { hi.x }, if k & 2 == 0 { lo.y } else { hi.y }, if k & 4 == 0 { lo.z } else { hi.z });
                let q = apply(&v, p);
                assert!(q.x.abs() < 1.0 && q.y.abs() < 1.0 && q.z > 0.0 && q.z < 1.0, "{eye} {p} -> {q}");
            }
            // Along a ray from the light depth grows; points on one ray share x, y.
            let c = 0.5 * (lo + hi);
            let (near, far) = (apply(&v, eye + 0.5 * (c - eye)), apply(&v, c));
            assert!(near.z < far.z && (near.x - far.x).abs() < 1e-4 && (near.y - far.y).abs() < 1e-4);
            assert!(v.bias[0] > 0.0 && v.bias[1] > 0.0 && v.bias[3] == 1.0);
            // The penumbra's data: a point source until given an area; the stored depth back to
            // metres along the axis as `spot_linear_depth` (shaders/common/lamp_spots.wgsl) does.
            assert_eq!(v.penumbra[0], 0.0);
            assert_eq!(v.with_emitter(0.15).penumbra[0], 0.15);
            assert_eq!(fit_view(Vec3::Y, lo, hi, 256).with_emitter(0.15).penumbra, [0.0; 4]);
            let axis = (c - eye).normalize();
            for p in [c, lo, hi, eye + 0.3 * (hi - eye)] {
                let d = (p - eye).dot(axis);
                let z = apply(&v, p).z;
                let back = spot_linear_depth(z, v.penumbra[2]);
                assert!((back - d).abs() < 1e-3 * d.max(1.0), "{eye} {p}: {back} against {d}");
            }
            assert!((v.penumbra[1] - v.bias[0] / DEPTH_BIAS_TEXELS).abs() < 1e-9);
        }
    }

    #[test]
    fn slots_go_to_the_nearest_direction() {
        let mut lights = vec![
            GpuLight { dir: Vec3::new(0.1, 1.0, 0.0).normalize().to_array(), shadow: 0, rgb: [1.0; 3], index: 0 },
            GpuLight { dir: Vec3::new(1.0, 0.1, 0.0).normalize().to_array(), shadow: 0, rgb: [1.0; 3], index: 1 },
        ];
        assign_slots(&mut lights, &[Vec3::X, Vec3::Y]);
        assert_eq!((lights[0].shadow, lights[1].shadow), (1, 0));
        assign_slots(&mut lights, &[]);
        assert_eq!(lights[0].shadow, u32::MAX);
    }
}
