//! The real receivers' sky visibility with the objects present, for one frame's poses (issue 15
//! §2, "moving objects' shadows on real ground"; cyberworlds §V-A.4,
//! `../shared/papers/cyberworlds-captured-lighting-cuts.txt`).
//!
//! # How it works
//! A receiver at `x` with normal `n` (world frame) keeps the share
//! `Σ_k w_k Π_b V_b / Σ_k w_k` of its sky light ([`super::lighting::sky_visibility`]), with the
//! weights `w` of its normal under the sky per unit `Pa` (cached per distinct normal: a proxy has
//! few) and the fields `V_b` of the objects whose bounding sphere is not wholly below its tangent
//! plane (§V-B), each looked up at `x` taken into the object's cut frame.
//! - **No object turned**: the fields are over world directions; the product runs as for the
//!   translated objects (`super::eval::CutScene::receiver_visibility`), unchanged.
//! - **Some turned** (`super::rotate`): the product runs in the frame of the first object that
//!   reaches the receiver. The weights are pushed forward into that frame (exact for the
//!   nearest-leaf remap, cached per normal and frame), so the commonest case, one turned object
//!   over the ground, remaps nothing per receiver; the fields of other objects turned differently
//!   are remapped into that frame.

use super::eval::CutScene;
use super::frame::{FrameCuts, UnitLighting};
use super::lighting::{ReceiverWeights, sky_visibility};
use super::rotate::{LeafRemap, Pose, relative};
use super::{Cut, CutsError};
use glam::Vec3;
use rayon::prelude::*;
use std::collections::HashMap;
use std::sync::Arc;

/// The real receivers' sky visibility with the objects at one frame's poses.
#[derive(Clone, Debug)]
pub struct ReceiverCuts {
    cuts: FrameCuts,
    lighting: Arc<UnitLighting>,
    poses: Vec<Pose>,
}

/// A receiver normal's key in the weights cache (a proxy has few distinct normals).
fn normal_key(n: Vec3) -> [i32; 3] {
    (n * 1000.0).round().as_ivec3().to_array()
}

/// The remaps a frame with turned objects needs (module docs).
struct Remaps {
    /// `pairs[f][b]`: object `b`'s field into object `f`'s frame (`None`: the same frame).
    pairs: Vec<Vec<Option<LeafRemap>>>,
    /// Per normal key and frame object `f`, the weights in `f`'s frame.
    weights: HashMap<([i32; 3], usize), ReceiverWeights>,
}

impl ReceiverCuts {
    /// The receivers of `cuts` under `lighting`'s sky with the objects at `poses`.
    pub fn new(cuts: FrameCuts, lighting: Arc<UnitLighting>, poses: Vec<Pose>) -> Self {
        Self { cuts, lighting, poses }
    }

    /// The share of sky light the objects leave at each `(point, normal)` (world frame), in
    /// `[0, 1]`; 1 where the lookup fails (a non-finite point: nothing to darken). In parallel.
    pub fn visibility(&self, surfaces: &[(Vec3, Vec3)]) -> Vec<f32> {
        let mut normals: HashMap<[i32; 3], Vec3> = HashMap::new();
        for (_, n) in surfaces {
            normals.entry(normal_key(*n)).or_insert(*n);
        }
        let (tree, sky) = (&*self.cuts.tree, &self.lighting.sky_pa);
        let list: Vec<([i32; 3], Vec3)> = normals.into_iter().collect();
        let weights: HashMap<[i32; 3], ReceiverWeights> = list.into_par_iter().filter_map(|(k, n)| ReceiverWeights::new(tree, sky, n).ok().map(|w| (k, w))).collect();
        if self.poses.iter().all(|p| p.rotation.is_none()) {
            let translations: Vec<Vec3> = self.poses.iter().map(|p| p.translation).collect();
            let scene = CutScene { tree, lighting: sky, objects: &self.cuts.cuts.objects, translations: &translations, proxy: None };
            return surfaces
                .par_iter()
                .map(|(x, n)| match weights.get(&normal_key(*n)) {
                    Some(w) => scene.receiver_visibility(w, *x, *n).map_or(1.0, |r| r.visibility.clamp(0.0, 1.0)),
                    None => 1.0,
                })
                .collect();
        }
        let remaps = self.remaps(&weights);
        surfaces
            .par_iter()
            .map(|(x, n)| match weights.get(&normal_key(*n)) {
                Some(w) => self.turned_visibility(&remaps, w, normal_key(*n), *x, *n).map_or(1.0, |v| v.clamp(0.0, 1.0)),
                None => 1.0,
            })
            .collect()
    }

    /// The pair remaps and the weights pushed into every turned object's frame.
    fn remaps(&self, world: &HashMap<[i32; 3], ReceiverWeights>) -> Remaps {
        let (tree, index) = (&*self.cuts.tree, &*self.cuts.index);
        let remap = |q: Option<glam::Mat3>| q.map(|q| LeafRemap::new(tree, index, q));
        let pairs = self.poses.iter().map(|f| self.poses.iter().map(|b| remap(relative(b.rotation, f.rotation))).collect()).collect();
        let mut weights = HashMap::new();
        for (f, pose) in self.poses.iter().enumerate() {
            // World weights into f's frame: ω_f = Rᵀ·ω_world.
            let Some(push) = remap(relative(pose.rotation, None)) else { continue };
            for (key, w) in world {
                if let Ok(pushed) = ReceiverWeights::from_leaf_weights(tree.levels(), &push.push_forward(w.leaves())) {
                    weights.insert((*key, f), pushed);
                }
            }
        }
        Remaps { pairs, weights }
    }

    /// One receiver's visibility with some object turned (module docs).
    fn turned_visibility(&self, remaps: &Remaps, world: &ReceiverWeights, key: [i32; 3], x: Vec3, n: Vec3) -> Result<f32, CutsError> {
        let mut frame: Option<usize> = None;
        let mut cuts: Vec<Cut> = Vec::new();
        for (b, obj) in self.cuts.cuts.objects.iter().enumerate() {
            let pose = &self.poses[b];
            if n != Vec3::ZERO && n.dot(pose.point(obj.vcf.centre) - x) < -obj.vcf.radius_m {
                continue;
            }
            let (cut, _region) = obj.vcf.lookup(pose.local_point(x))?;
            let f = *frame.get_or_insert(b);
            cuts.push(match &remaps.pairs[f][b] {
                Some(r) => r.cut(cut.view())?,
                None => cut,
            });
        }
        let Some(f) = frame else { return Ok(1.0) };
        let weights = match self.poses[f].rotation {
            Some(_) => remaps.weights.get(&(key, f)).unwrap_or(world),
            None => world,
        };
        let views: Vec<_> = cuts.iter().map(Cut::view).collect();
        sky_visibility(weights, &views)
    }
}
