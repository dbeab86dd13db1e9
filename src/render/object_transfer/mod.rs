//! Per-pixel ambient light transfer of the virtual objects: what the probe grid and the
//! ambient-occlusion factor approximate, computed exactly (up to Monte Carlo noise) for each
//! canvas pixel, once per camera and sun direction.
//!
//! The irradiance volume (Jensen §3.3–3.4) gives smooth ambient light between probes 1 m apart.
//! Next to a virtual object that is not enough: the object hides sky and bounce light from its
//! own parts (a sphere darkens the top of its pedestal from the sky, not from the ground), it
//! reflects light onto itself, it shadows the ground beside it that lights its lower parts, and
//! its glossy lobes see a different part of the surroundings than its normal does. With a static
//! calibrated camera and static objects (heliar's setting: placements come from the manifest, as
//! the ambient occlusion of [`super::occlusion`] already assumes), the outgoing ambient radiance
//! of each pixel is a fixed linear function of the sky and sun intensities, so it can be traced
//! once and scaled per frame.
//!
//! # How it works
//! For every canvas pixel whose centre ray first meets a virtual object, at that point `x` with
//! shading normal `n` and view direction `v`:
//!
//! `L_amb(x, v) = R_a·Pa + R_d·Pd` (per channel), where `R_a` is the radiance per unit `Pa`
//! arriving through any number of bounces from the uniform sky of the crate's radiometry
//! (radiance `Pa/π` over the upper hemisphere) and `R_d` the radiance per unit `Pd` of sun light
//! that reached `x` after at least one bounce. The direct sun at `x` itself is not included: the
//! shading pass adds it with the stencil shadow volumes' visibility.
//!
//! Both are path-traced against the real proxy and the virtual objects together:
//! - at virtual surfaces the glTF metallic–roughness BRDF ([`crate::geometry::brdf`]) is sampled
//!   (lobe mixture), so the specular ambient of glossy materials comes from the directions its
//!   lobe really sees;
//! - at real surfaces the proxy's Lambertian albedo, the same model as the estimator's `c` and
//!   `b` ([`crate::geometry::ambient`]) and the receivers' `c_v`, `b_v`;
//! - the sun is sampled by next-event estimation at every vertex after the first, with shadow
//!   rays against both, so the object's shadow on the ground next to it and its own shadows
//!   reach the bounce light;
//! - the first direction is stratified (`√N × √N` jittered strata), paths end after
//!   `max_bounces` surface hits.
//!
//! `R_a` does not depend on the sun and `R_d` changes slowly with it: both are traced on the first
//! frame; when the sun has moved more than the compositor's `bounce_rebuild_deg`, `R_d` is
//! re-traced for the new sun a bounded slice of lattice pixels per frame while the previous
//! values serve, and swapped in when complete (`retrace`). `R_a` is never re-traced for a sun
//! move: its estimate takes the same random numbers whatever the sun, so it would come out the
//! same.
//!
//! The real surfaces' albedo comes from the proxy's materials, as for the estimator's `c`, `b`
//! and the receivers: a proxy whose materials are far from the real surfaces' colours gets a
//! wrong bounce (the irradiance volume, which takes its albedo from the HDR map by inverse
//! rendering, does not share that weakness; `transfer_paths = 0` falls back to it). Both assume
//! the uniform sky of the crate's radiometry. Moving objects or a moving camera would need a
//! trace per frame: the manifest's placements and the calibrated camera are static.
//!
//! With `[[lights]]`, the lamps' light after one or more bounces is a third part,
//! `Σ k_i·R_i`, traced along the same paths (`walk`) once for all frames
//! ([`lamps`], issue 16 §3).
//!
//! Pixels are traced on a lattice, every `stride`-th canvas pixel in each direction: 1 (all of
//! them) while the object pixels times the paths fit [`TRANSFER_PATH_BUDGET`], coarser for
//! objects that fill much of a large frame. The shading pass reconstructs each fragment's value
//! from the 3×3 lattice entries around its pixel: a weighted mean of those whose surface point
//! lies within a few footprints of the fragment's and whose normal agrees with its normal
//! (Gaussian in the distance, so the pixel's own entry dominates). This bridges the lattice,
//! takes silhouettes and creases (where the pixel centre shows another face than a multisample)
//! from the right surface, and averages the Monte Carlo noise of neighbouring entries on the same
//! face. Where no entry matches, the probe grid times ambient occlusion stands in.

use crate::gpu::canvas::Canvas;
use crate::geometry::Mesh;
use crate::geometry::ambient::{Escape, TransportQuality};
use crate::lighting::FrameSky;
use crate::sky::radiance::SkyModel;
use crate::geometry::brdf::GltfSurface;
use crate::geometry::raycast::{Hit, RayScene};
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use std::f32::consts::FRAC_1_PI;
use std::sync::Arc;

/// Default paths per traced pixel; `heliar bench render --knob transfer-paths` gives the
/// error-against-time table.
pub const TRANSFER_PATHS: u32 = 512;
/// Largest number of paths one trace may take with an automatic stride: the stride grows
/// (every 2nd, 3rd, … canvas pixel in each direction) until the traced pixels times the paths
/// per pixel fit. 2²¹ paths take about 1.6 s on this machine's two cores (1.3 M paths/s on the
/// bundled courtyard, release build).
pub const TRANSFER_PATH_BUDGET: u64 = 1 << 21;
/// Largest automatic stride (beyond it the objects are too large on screen for a per-pixel
/// transfer to be worth its cost at any stride the lookup can bridge).
const MAX_AUTO_STRIDE: u32 = 8;
/// Default surface hits per path.
pub const TRANSFER_BOUNCES: u32 = 4;
/// A path's throughput below which it stops (its remaining contribution is negligible).
const MIN_THROUGHPUT: f32 = 1e-4;
/// Smallest `|n·v|` used to widen a pixel's footprint on an oblique surface.
const MIN_FOOTPRINT_COS: f32 = 0.2;

/// The surface a pixel's centre shows.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PixelSurface {
    /// Canvas pixel (row-major index).
    pub pixel: u32,
    /// World point.
    pub point: Vec3,
    /// Unit shading normal on the camera's side.
    pub normal: Vec3,
    /// Unit geometric normal on the camera's side.
    pub face_normal: Vec3,
    /// Unit direction toward the camera.
    pub view: Vec3,
    /// Triangle of the combined scene (proxy first, then the objects).
    pub tri: u32,
    /// Radius of the pixel's footprint on the surface, metres.
    pub footprint_m: f32,
}

/// `R_a` and `R_d` of one point (see the module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PointTransfer {
    /// Ambient radiance per unit `Pa` (RGB).
    pub sky: Vec3,
    /// Ambient radiance per unit `Pd` (RGB): sun light after one or more bounces.
    pub sun: Vec3,
}

/// The proxy and the virtual objects in one BVH, with what the transfer needs to tell them apart.
pub struct TransferScene {
    /// Proxy triangles first, then the objects'.
    pub world: Arc<RayScene>,
    /// Index of the first virtual triangle in `world`.
    pub first_object_tri: u32,
    /// The virtual objects alone (materials and shading normals, triangle `t` of `world` being
    /// triangle `t − first_object_tri` here).
    pub objects: Mesh,
}

impl TransferScene {
    /// The scene of `proxy` and `objects`.
    pub fn new(proxy: &Mesh, objects: &[&Mesh]) -> Self {
        let mut world = proxy.clone();
        let mut all = Mesh::default();
        for o in objects {
            world.append(o);
            all.append(o);
        }
        Self { first_object_tri: proxy.triangles.len() as u32, world: Arc::new(RayScene::new(world)), objects: all }
    }

    /// Whether triangle `tri` of the combined scene belongs to a virtual object.
    pub fn is_object(&self, tri: u32) -> bool {
        tri >= self.first_object_tri
    }

    /// The glTF surface of a virtual triangle at a hit.
    fn surface(&self, tri: u32, bary: Vec2) -> GltfSurface {
        let t = tri - self.first_object_tri;
        let m = &self.objects.materials[self.objects.tri_material[t as usize] as usize];
        GltfSurface::new(m, self.objects.albedo(t, bary))
    }

    /// Shading normal of a virtual triangle (interpolated vertex normals when the mesh has them,
    /// the face normal otherwise), on the side of `face_normal`.
    fn shading_normal(&self, tri: u32, bary: Vec2, face_normal: Vec3) -> Vec3 {
        let o = &self.objects;
        let t = (tri - self.first_object_tri) as usize;
        if o.normals.len() != o.positions.len() || o.normals.is_empty() {
            return face_normal;
        }
        let [a, b, c] = o.triangles[t];
        let n = o.normals[a as usize] * (1.0 - bary.x - bary.y) + o.normals[b as usize] * bary.x + o.normals[c as usize] * bary.y;
        let n = n.normalize_or(face_normal);
        if n.dot(face_normal) < 0.0 { -n } else { n }
    }
}

/// Traces `R_a` and `R_d` of one surface point (module docs) under `sky`. `sun` is the unit
/// direction toward the sun, or `None` for `R_a` alone. Deterministic for a given `seed`.
pub fn trace_point(scene: &TransferScene, s: &PixelSurface, sun: Option<Vec3>, sky: &impl Escape, quality: TransportQuality, seed: u64) -> PointTransfer {
    let mut visit = SkySun { world: &scene.world, env: sky, sun, sky: Vec3::ZERO, sun_sum: Vec3::ZERO };
    let k = walk::walk(scene, s, quality, seed ^ 0x7a3f_10c5_be11_0001, &mut visit);
    PointTransfer { sky: visit.sky / k as f32, sun: visit.sun_sum / k as f32 }
}

/// The sky at the escapes and the sun by next-event estimation at the vertices (`R_a`, `R_d`).
struct SkySun<'a, E> {
    world: &'a RayScene,
    env: &'a E,
    sun: Option<Vec3>,
    sky: Vec3,
    sun_sum: Vec3,
}

impl<E: Escape> walk::Vertices for SkySun<'_, E> {
    fn escape(&mut self, throughput: Vec3, dir: Vec3) {
        if let Some((pa, pd)) = self.env.escape(dir) {
            self.sky += throughput * FRAC_1_PI * pa;
            self.sun_sum += throughput * FRAC_1_PI * pd;
        }
    }

    fn object(&mut self, throughput: Vec3, hit: &Hit, surf: &GltfSurface, n: Vec3, v: Vec3) {
        if let Some(l) = self.sun
            && self.world.sees_direction(hit.point, hit.normal, l)
        {
            self.sun_sum += throughput * surf.eval_cos(n, v, l);
        }
    }

    fn proxy(&mut self, throughput: Vec3, hit: &Hit, rho: Vec3) {
        if let Some(l) = self.sun {
            let cos = hit.normal.dot(l);
            if cos > 0.0 && self.world.sees_direction(hit.point, hit.normal, l) {
                self.sun_sum += throughput * rho * FRAC_1_PI * cos;
            }
        }
    }
}

/// The surfaces the canvas pixels' centres show on the virtual objects (pixels whose centre ray
/// meets the proxy first, or nothing, are left out).
pub fn pixel_surfaces(canvas: &Canvas, scene: &TransferScene) -> Vec<PixelSurface> {
    let (w, h) = (canvas.intrinsics.width, canvas.intrinsics.height);
    let eye = canvas.pose.translation.as_vec3();
    (0..w * h)
        .into_par_iter()
        .filter_map(|i| {
            let d = canvas.pixel_dir(i);
            let hit = scene.world.intersect_front(eye, d)?;
            if !scene.is_object(hit.tri) {
                return None;
            }
            let view = -d;
            let normal = scene.shading_normal(hit.tri, hit.bary, hit.normal);
            let cos = hit.normal.dot(view).abs().max(MIN_FOOTPRINT_COS);
            let footprint_m = hit.t / canvas.intrinsics.fx.min(canvas.intrinsics.fy) as f32 / cos;
            Some(PixelSurface { pixel: i, point: hit.point, normal, face_normal: hit.normal, view, tri: hit.tri, footprint_m })
        })
        .collect()
}

/// The stride for `pixels` object pixels: `requested` when it is not 0, else the smallest whose
/// traced pixels (about `pixels / stride²`) times `paths` fit [`TRANSFER_PATH_BUDGET`].
pub fn stride_for(pixels: usize, paths: u32, requested: u32) -> u32 {
    if requested > 0 {
        return requested;
    }
    (1..=MAX_AUTO_STRIDE)
        .find(|s| (pixels as u64).div_ceil((s * s) as u64).saturating_mul(paths as u64) <= TRANSFER_PATH_BUDGET)
        .unwrap_or(MAX_AUTO_STRIDE)
}

/// The transfer of the object pixels of a canvas on a lattice of every `stride`-th pixel, in
/// texture layout for the shading pass.
pub struct ObjectTransfer {
    surfaces: Vec<PixelSurface>,
    /// Object pixels seen by the canvas (traced or not).
    object_pixels: usize,
    stride: u32,
    /// `R_a` per canvas pixel, `w = 1` where there is an entry.
    pub sky: Vec<[f32; 4]>,
    /// `R_d` per canvas pixel.
    pub sun: Vec<[f32; 4]>,
    /// Surface point per canvas pixel, `w` = footprint radius (metres).
    pub point: Vec<[f32; 4]>,
    /// Shading normal per canvas pixel.
    pub normal: Vec<[f32; 4]>,
    /// Sun direction `sun` belongs to; `None` before the first trace with a sun.
    traced_sun: Option<Vec3>,
    traced: bool,
    /// A trace replayed frames decided on but did not do (with its sun and sky), paid by
    /// `restore`.
    owed: Option<(Option<Vec3>, SkyModel)>,
    /// Lattice pixels re-traced per frame after a sun move (0: all at once); see `retrace`.
    slice: usize,
    /// The re-trace for a new sun in progress.
    job: Option<retrace::SunJob>,
    /// The sky the frame's paths see (`R_a` depends on the sun unless it is uniform): the
    /// scene's, or the variant the frame's estimate used ([`ObjectTransfer::set_frame_sky`]).
    sky_model: SkyModel,
    /// The sky the served `R_a`, `R_d` were traced under (differs from `sky_model` while a
    /// re-trace for a fitted turbidity is owed or in progress).
    traced_sky: SkyModel,
    /// The scene's sky.
    scene_sky: SkyModel,
    quality: TransportQuality,
    seed: u64,
}

impl ObjectTransfer {
    /// Finds the object pixels of `canvas` and keeps those on the lattice of `stride` (0: the
    /// automatic stride of [`stride_for`]); nothing is traced yet.
    pub fn new(canvas: &Canvas, scene: &TransferScene, quality: TransportQuality, stride: u32, seed: u64) -> Self {
        let n = (canvas.intrinsics.width * canvas.intrinsics.height) as usize;
        let mut surfaces = pixel_surfaces(canvas, scene);
        let object_pixels = surfaces.len();
        let stride = stride_for(object_pixels, quality.paths, stride);
        let w = canvas.intrinsics.width;
        surfaces.retain(|s| (s.pixel % w).is_multiple_of(stride) && (s.pixel / w).is_multiple_of(stride));
        let mut point = vec![[0.0f32; 4]; n];
        let mut normal = vec![[0.0f32; 4]; n];
        for s in &surfaces {
            point[s.pixel as usize] = [s.point.x, s.point.y, s.point.z, s.footprint_m];
            normal[s.pixel as usize] = [s.normal.x, s.normal.y, s.normal.z, 0.0];
        }
        Self { surfaces, object_pixels, stride, sky: vec![[0.0; 4]; n], sun: vec![[0.0; 4]; n], point, normal, traced_sun: None, traced: false, owed: None, slice: 0, job: None, sky_model: SkyModel::uniform(), traced_sky: SkyModel::uniform(), scene_sky: SkyModel::uniform(), quality, seed }
    }

    /// Re-traces `R_d` after a sun move in slices of about `paths_per_frame` paths, one slice per
    /// frame, serving the previous values until the last slice is done (0: all in the frame
    /// that decides it, as on the first frame). See `retrace`.
    pub fn with_budget(mut self, paths_per_frame: u64) -> Self {
        self.slice = retrace::slice_pixels(paths_per_frame, self.quality.paths as u64);
        self
    }

    /// Traces under `sky` instead of Jensen's uniform sky; `R_a` is then re-traced with `R_d`
    /// when the sun moves (the sky's shape follows it).
    pub fn with_sky(mut self, sky: SkyModel) -> Self {
        self.scene_sky = sky.clone();
        self.traced_sky = sky.clone();
        self.sky_model = sky;
        self
    }

    /// True when [`Self::set_frame_sky`] with `sky` would change the sky the paths see (and
    /// there are pixels to trace): the next frame traces.
    pub fn sky_switch_pending(&self, sky: FrameSky) -> bool {
        !self.surfaces.is_empty() && self.scene_sky.for_frame(sky.parts()) != self.sky_model
    }

    /// Traces under the sky the frame's estimate used from now on. A switch between the uniform
    /// sky (an overcast frame) and the scene's shape drops the traced state and any re-trace in
    /// progress, so the next [`Self::ensure`] (or [`Self::replay`]) traces in full under the new
    /// sky; a change of the shape's turbidity alone ([`SkyModel::reshapes_to`]) is re-traced as
    /// a sun move is, a slice per frame while the served values stay (`retrace`). This depends
    /// on the frames' lighting only, so replayed frames decide alike.
    pub fn set_frame_sky(&mut self, sky: FrameSky) {
        let model = self.scene_sky.for_frame(sky.parts());
        if model != self.sky_model {
            if !self.sky_model.reshapes_to(&model) {
                self.traced = false;
                self.job = None;
            }
            self.sky_model = model;
        }
    }

    /// The sky the frame's paths see.
    pub fn sky_model(&self) -> &SkyModel {
        &self.sky_model
    }

    /// The sky the served values were traced under.
    pub fn traced_sky(&self) -> &SkyModel {
        &self.traced_sky
    }

    /// The traced pixels (the object pixels on the lattice).
    pub fn surfaces(&self) -> &[PixelSurface] {
        &self.surfaces
    }

    /// Object pixels of the canvas, traced or not.
    pub fn object_pixels(&self) -> usize {
        self.object_pixels
    }

    /// Lattice spacing of the traced pixels, canvas pixels.
    pub fn stride(&self) -> u32 {
        self.stride
    }

    /// The sun direction the stored `R_d` belongs to.
    pub fn traced_sun(&self) -> Option<Vec3> {
        self.traced_sun
    }
}

pub mod lamps;
mod retrace;
mod walk;

pub use lamps::{LampBounce, trace_lamp_point};
pub use retrace::TransferUpdate;

#[cfg(test)]
mod tests;
