//! Virtual objects that moved since the last frame (issue 15 §1 and §2): what the compositor
//! keeps of them is brought to their new place before the frame is encoded.
//!
//! # How it works
//! Two ways, chosen by the frame loop (`crate::run::motion`):
//! - **With the visibility cuts** ([`Compositor::move_objects_with_cuts`]; objects moved
//!   rigidly, translated and turned, since the cuts were computed, cyberworlds §V and
//!   `cuts::rotate`). Each moved object's shadow-volume occluder is
//!   rebuilt (the sun keeps its exact stencil shadow volumes) and the vertex buffer and bounds
//!   follow. The objects that moved, and those a moved object's cut field reaches, take their
//!   ambient from the per-vertex ambient of the cuts (`cuts::frame`, uploaded for
//!   `shaders/virtual_shading.wgsl`); an object that did not move and that no moved object
//!   reaches keeps its traced per-pixel transfer (its vertices are not served by the cuts,
//!   `w = 0`), and so do the receivers no moved object reaches (`kept`, issue 15 §5). The
//!   receivers a moved object reaches take `c_v`, `b_v` from their sky visibility with the
//!   objects present (`c·V`, `b·V`, set where the next frame needs them, `receiver_update`)
//!   instead of a re-trace; `V` is evaluated again only within a moved object's field reach at
//!   its old or new pose, the other receivers keep theirs (`cut_cache`). Nothing is traced against the moved objects: no BVH with them, no
//!   ambient occlusion, no transfer. With one object, or when every object moved or is reached,
//!   all take the cuts.
//! - **The re-trace** ([`Compositor::move_objects`]; an object scaled along its motion, or a scene
//!   without cuts):
//!   the objects' buffers, bounds, the combined proxy-and-objects BVH and the objects' own
//!   per-pixel ambient occlusion follow them; the receivers forget `c_v` and `b_v` (traced again
//!   where the next frame needs them). The shading falls back to the probe grid times the
//!   objects' ambient occlusion.
//!
//! Unless an object keeps it, the per-pixel transfer traced for the objects' old places is
//! stale: it is dropped (reported as the `object_transfer` pass's reason, which names the
//! objects that keep it or why each takes the cuts); the stored stencil is dropped.

use super::setup::{MIN_NEAR_RADIUS_M, NEAR_RADIUS_HALF_DIAGONALS, object_occlusion};
use super::Compositor;
use crate::geometry::Mesh;
use crate::geometry::raycast::RayScene;
use crate::gpu::mesh::VirtualBuffers;
use crate::render::RenderError;
use crate::render::object_transfer::TransferScene;
use crate::render::occluder::Occluder;
use glam::Vec3;
use std::sync::Arc;

/// One vertex's ambient from the visibility cuts: irradiance per unit `Pa` about the normal
/// (`w = 1`: served by the cuts) and about the reflected view direction, then the same per unit
/// `Pd`. Mirrors `cut_ambient` in `shaders/virtual_shading.wgsl` (and `cuts::frame::VertexAmbient`).
pub type VertexAmbient = [[f32; 4]; 4];

/// The receivers' sky visibility with the objects present, in `[0, 1]`, at `(point, normal)`
/// pairs (world frame); from the objects' visibility cut fields (`run::motion_cuts`; kept per
/// pixel between frames where no moved object reaches, `cut_cache`).
pub type ReceiverVisibility = Box<dyn super::ReceiverField>;

/// Why the transfer is off after a move (re-trace).
const TRANSFER_DROPPED: &str =
    "an object moved: the traced transfer belongs to the old places; ambient from the probe grid times ambient occlusion";
/// Why the transfer is off after a move (cuts).
const TRANSFER_BY_CUTS: &str = "an object moved: the traced transfer belongs to the old places; ambient from the visibility cuts per vertex";

impl Compositor {
    /// The camera centre, world frame (the eye the objects' radiance is seen from).
    pub fn eye_world(&self) -> Vec3 {
        let e = self.canvas.uniform().eye_world;
        Vec3::new(e[0], e[1], e[2])
    }

    /// The proxy's BVH.
    pub fn proxy_ray(&self) -> &Arc<RayScene> {
        &self.proxy_ray
    }

    /// Per object, left out of the traced transfer, ambient occlusion and `c_v`, `b_v` (a mover
    /// among static objects, `kept`; empty or all false: none): the visibility cuts must serve
    /// it from the first frame (`run::motion`).
    pub fn left_out(&self) -> &[bool] {
        self.kept.left_out()
    }

    /// True while the visibility cuts serve the objects' ambient and the receivers' `c_v`.
    pub fn cuts_serve(&self) -> bool {
        self.cuts.is_some()
    }

    /// Rebuilds the moved objects' occluders and the objects' vertex buffer and bounds, and
    /// decides which objects keep the traced transfer (`kept`; `reach_m`: each moved object's
    /// cut-field reach under the cuts, `None` for a re-trace). Those that do not: the transfer
    /// is dropped with `reason` and the receivers forget `c_v`, `b_v`; otherwise only the
    /// receivers a moved object reaches do. The stencil is dropped. Returns the meshes.
    fn follow<'a>(&mut self, objects: &'a [(String, &'a Mesh)], moved: &[bool], reason: &str, reach_m: Option<&[f32]>) -> Result<Vec<&'a Mesh>, RenderError> {
        let meshes: Vec<&Mesh> = objects.iter().map(|(_, m)| *m).collect();
        for (k, (name, mesh)) in objects.iter().enumerate() {
            if moved.get(k).copied().unwrap_or(false) {
                self.volumes.set_virtual(&self.gpu, k, Occluder::new(mesh, name))?;
            }
        }
        let closed: Vec<Vec<bool>> = self.volumes.virtual_occ.iter().zip(&meshes).map(|(o, m)| o.closed_triangles(m.triangles.len())).collect();
        self.virt = VirtualBuffers::new(&self.gpu.device, &self.gpu.queue, &self.mat_layout, &meshes, &closed)?;
        self.virtual_bounds = meshes.iter().filter_map(|m| m.bounds()).collect();
        let near_radius_m = self.virtual_bounds.iter().map(|(lo, hi)| (*hi - *lo).length() / 2.0 * NEAR_RADIUS_HALF_DIAGONALS).fold(MIN_NEAR_RADIUS_M, f32::max);
        let names: Vec<&str> = objects.iter().map(|(n, _)| n.as_str()).collect();
        let traced = self.transfer.transfer().is_some();
        match reach_m {
            Some(reach) if self.kept.decide(&self.canvas, &names, &self.virtual_bounds, moved, reach_m, traced) => {
                let reached = self.reached_pixels(moved, reach);
                self.receivers.forget_objects_at(&reached);
                self.transfer.set_note(Some(self.kept.note()));
            }
            _ => {
                if reach_m.is_none() {
                    self.kept.decide(&self.canvas, &names, &self.virtual_bounds, moved, None, traced);
                }
                let all_moved = self.kept.displaced().iter().all(|d| *d);
                let why = if traced && !all_moved { format!("{reason} ({})", self.kept.note()) } else { reason.to_owned() };
                self.transfer.drop_traced(&why);
                self.receivers.forget_objects();
            }
        }
        self.receiver_pixels = self.receiver_pixels.rebuilt(near_radius_m);
        self.invalidate();
        Ok(meshes)
    }

    /// Moves the virtual objects to `objects` (every object, in set-up order, in world
    /// coordinates, with its name) and traces what depends on them again; `moved[k]` says which
    /// changed. See the module docs.
    pub fn move_objects(&mut self, proxy: &Mesh, objects: &[(String, &Mesh)], moved: &[bool]) -> Result<(), RenderError> {
        if !moved.iter().any(|m| *m) {
            return Ok(());
        }
        let meshes = self.follow(objects, moved, TRANSFER_DROPPED, None)?;
        if let Some(g) = self.ground_bounce.as_mut() {
            g.forget();
        }
        if self.cuts.take().is_some() {
            self.write_cut_ambient(&[]);
        }
        self.cut_cache.clear();
        let scene = TransferScene::new(proxy, &meshes);
        self.with_ray = Some(scene.world.clone());
        self.res.occlusion.write(&self.gpu.queue, &object_occlusion(&self.canvas, Some(&scene), &self.config));
        Ok(())
    }

    /// Moves the virtual objects (as [`Self::move_objects`]) with their ambient and the
    /// receivers' visibility from the visibility cuts: `ambient[k][v]` for vertex `v` of object
    /// `k`'s mesh. See the module docs.
    /// `reach_m[k]`: how far object `k`'s visibility cut field reaches from its box (its
    /// outermost sphere's radius), which decides the objects and receivers that keep their trace
    /// (`kept`).
    pub fn move_objects_with_cuts(&mut self, objects: &[(String, &Mesh)], moved: &[bool], ambient: &[Vec<VertexAmbient>], receivers: ReceiverVisibility, reach_m: &[f32]) -> Result<(), RenderError> {
        if moved.iter().any(|m| *m) {
            self.follow(objects, moved, TRANSFER_BY_CUTS, Some(reach_m))?;
            if let Some(g) = self.ground_bounce.as_mut() {
                g.moved_by_cuts();
            }
        }
        self.set_cuts(ambient, receivers);
        Ok(())
    }

    /// Replaces the per-vertex cut ambient and the receivers' visibility (the lighting changed
    /// while the cuts serve; the receivers' values follow at the next stencil rebuild).
    pub fn set_cuts(&mut self, ambient: &[Vec<VertexAmbient>], receivers: ReceiverVisibility) {
        self.write_cut_ambient(ambient);
        self.cuts = Some(Arc::from(receivers));
    }

    /// Uploads `ambient` in the vertex buffer's order (zero where missing, and for the objects
    /// that keep the traced transfer: not served).
    fn write_cut_ambient(&self, ambient: &[Vec<VertexAmbient>]) {
        let mut data: Vec<VertexAmbient> = Vec::with_capacity(self.vertex_sources.iter().map(Vec::len).sum::<usize>().max(1));
        for (k, sources) in self.vertex_sources.iter().enumerate() {
            let keeps = self.kept.keeps().get(k).copied().unwrap_or(false) && self.transfer.transfer().is_some();
            let obj = ambient.get(k).filter(|_| !keeps);
            data.extend(sources.iter().map(|&v| obj.and_then(|a| a.get(v as usize)).copied().unwrap_or([[0.0; 4]; 4])));
        }
        if data.is_empty() {
            data.push([[0.0; 4]; 4]);
        }
        self.gpu.queue.write_buffer(&self.cut_ambient, 0, bytemuck::cast_slice(&data));
    }
}
