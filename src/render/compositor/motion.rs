//! Virtual objects that moved since the last frame (issue 15 §1): what the compositor keeps of
//! them is brought to their new place before the frame is encoded.
//!
//! # How it works
//! For each moved object its shadow-volume occluder is rebuilt; the objects' vertex buffer,
//! their bounds, the combined proxy-and-objects BVH and the objects' own per-pixel ambient
//! occlusion follow them; the receivers forget `c_v` and `b_v` (recomputed where the next frame
//! needs them) and the stored stencil is dropped. The per-pixel transfer traced for the objects'
//! old places is stale: it is dropped and the shading falls back to the probe grid times the
//! objects' ambient occlusion (reported as the `object_transfer` pass's reason) until the
//! visibility cuts are evaluated per frame (`crate::cuts`, not yet wired). Objects that did not
//! move keep their occluders and are reported as skipped with that reason.

use super::setup::{MIN_NEAR_RADIUS_M, NEAR_RADIUS_HALF_DIAGONALS, object_occlusion};
use super::{Compositor, ReceiverPixels};
use crate::geometry::Mesh;
use crate::gpu::mesh::VirtualBuffers;
use crate::render::RenderError;
use crate::render::object_transfer::TransferScene;
use crate::render::occluder::Occluder;

/// Why the transfer is off after a move.
const TRANSFER_DROPPED: &str =
    "an object moved: the traced transfer belongs to the old places; ambient from the probe grid times ambient occlusion";

impl Compositor {
    /// Moves the virtual objects to `objects` (every object, in set-up order, in world
    /// coordinates, with its name); `moved[k]` says which changed. See the module docs.
    pub fn move_objects(&mut self, proxy: &Mesh, objects: &[(String, &Mesh)], moved: &[bool]) -> Result<(), RenderError> {
        if !moved.iter().any(|m| *m) {
            return Ok(());
        }
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
        let scene = TransferScene::new(proxy, &meshes);
        self.with_ray = Some(scene.world.clone());
        self.res.occlusion.write(&self.gpu.queue, &object_occlusion(&self.canvas, Some(&scene), &self.config));
        self.transfer.drop_traced(TRANSFER_DROPPED);
        self.receivers.forget_objects();
        self.receiver_pixels = ReceiverPixels::new(near_radius_m);
        self.invalidate();
        Ok(())
    }
}
