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
//!
//! **Reach.** An object is left out where the receiver lies beyond its field's outermost sphere
//! (`outer·r`, [`super::vcf::VisibilityCutField::beyond_reach`]; the field would clamp to that
//! sphere's cuts, which over-estimate the occlusion a little, `super::vcf`): its field is then
//! exactly 1 there, so a receiver's value depends only on the objects that reach it
//! ([`ReceiverCuts::reaches`]). The weights are cached per exact normal, so a receiver's value
//! does not depend on which other receivers are asked for either
//! ([`ReceiverCuts::visibility_of`]). Together these let the compositor evaluate, when an object
//! moves, only the receivers within its reach at its old or new pose and keep the others' last
//! values bit for bit (`render::compositor`'s `cut_cache`).

use super::frame::{FrameCuts, UnitLighting};
use super::lighting::ReceiverWeights;
use super::products::{ReceiverKey, ReceiverProduct, ReceiverProductUse, ReceiverProducts, receiver_key, walk_into};
use super::tree::node_index;
use super::walk::product_for_each;
use super::rotate::{LeafRemap, Pose, relative};
use super::{Cut, CutsError};
use glam::Vec3;
use rayon::prelude::*;
use std::collections::HashMap;
use std::sync::{Arc, Mutex};

/// The real receivers' sky visibility with the objects at one frame's poses.
#[derive(Clone, Debug)]
pub struct ReceiverCuts {
    cuts: FrameCuts,
    lighting: Arc<UnitLighting>,
    poses: Vec<Pose>,
    /// The receivers' products kept between frames (`super::products`), shared with the frame
    /// loop; `None`: every receiver asked for is walked.
    products: Option<Arc<Mutex<ReceiverProducts>>>,
}

/// A receiver normal's key in the weights cache: its exact bits (a proxy's receivers take
/// their triangles' face normals, so there are few), so that a receiver's weights never depend
/// on which other receivers are asked for.
type NormalKey = [u32; 3];

fn normal_key(n: Vec3) -> NormalKey {
    n.to_array().map(f32::to_bits)
}

/// The remaps a frame with turned objects needs (module docs).
struct Remaps {
    /// `pairs[f][b]`: object `b`'s field into object `f`'s frame (`None`: the same frame).
    pairs: Vec<Vec<Option<LeafRemap>>>,
    /// Per normal key and frame object `f`, the weights in `f`'s frame.
    weights: HashMap<(NormalKey, usize), ReceiverWeights>,
}

impl ReceiverCuts {
    /// The receivers of `cuts` under `lighting`'s sky with the objects at `poses`.
    pub fn new(cuts: FrameCuts, lighting: Arc<UnitLighting>, poses: Vec<Pose>) -> Self {
        Self { cuts, lighting, poses, products: None }
    }

    /// The same, keeping the receivers' products in `store` between frames (`super::products`);
    /// the values are the same bit for bit.
    pub fn with_products(mut self, store: Arc<Mutex<ReceiverProducts>>) -> Self {
        self.products = Some(store);
        self
    }

    /// The share of sky light the objects leave at each `(point, normal)` (world frame), in
    /// `[0, 1]`; 1 where the lookup fails (a non-finite point: nothing to darken). In parallel.
    pub fn visibility(&self, surfaces: &[(Vec3, Vec3)]) -> Vec<f32> {
        let all: Vec<usize> = (0..surfaces.len()).collect();
        self.visibility_of(surfaces, &all)
    }

    /// [`Self::visibility`] at `surfaces[i]` for each `i` of `which` only, in that order (an
    /// index out of range gives 1). A receiver's value depends on its own point and normal only:
    /// the weights are per exact normal, so asking for fewer receivers changes none of them.
    pub fn visibility_of(&self, surfaces: &[(Vec3, Vec3)], which: &[usize]) -> Vec<f32> {
        match &self.products {
            Some(store) => {
                let mut store = store.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
                self.visibility_reusing(surfaces, which, &mut store)
            }
            None => self.evaluate(surfaces, which, None).0,
        }
    }

    /// [`Self::visibility_of`], summing the products kept in `store` where no object that moved
    /// since reaches the receiver, walking (and keeping, within the budget) the others
    /// (`super::products`); equal bit for bit. `store.last` counts what was done.
    pub fn visibility_reusing(&self, surfaces: &[(Vec3, Vec3)], which: &[usize], store: &mut ReceiverProducts) -> Vec<f32> {
        store.advance(&self.poses, |b, pose, x| self.cuts.cuts.objects.get(b).is_some_and(|o| !o.vcf.beyond_reach(pose.local_point(x))));
        let (values, fresh) = self.evaluate(surfaces, which, Some(store));
        let mut over = 0;
        let walked = fresh.len();
        for (key, p) in fresh {
            if !store.keep(key, p) {
                over += 1;
            }
        }
        store.last = ReceiverProductUse { reused: which.len() - walked, walked, over_budget: over };
        values
    }

    /// The receivers `which`, with the products of `kept` where it has them; returns the values
    /// and the products walked afresh.
    #[allow(clippy::type_complexity)]
    fn evaluate(&self, surfaces: &[(Vec3, Vec3)], which: &[usize], kept: Option<&ReceiverProducts>) -> (Vec<f32>, Vec<(ReceiverKey, ReceiverProduct)>) {
        let mut normals: HashMap<NormalKey, Vec3> = HashMap::new();
        for (_, n) in which.iter().filter_map(|&i| surfaces.get(i)) {
            normals.entry(normal_key(*n)).or_insert(*n);
        }
        let (tree, sky) = (&*self.cuts.tree, &self.lighting.sky_pa);
        let list: Vec<(NormalKey, Vec3)> = normals.into_iter().collect();
        let weights: HashMap<NormalKey, ReceiverWeights> = list.into_par_iter().filter_map(|(k, n)| ReceiverWeights::new(tree, sky, n).ok().map(|w| (k, w))).collect();
        let turned = self.poses.iter().any(|p| p.rotation.is_some());
        let remaps = turned.then(|| self.remaps(&weights));
        let rows: Vec<(f32, Option<(ReceiverKey, ReceiverProduct)>)> = which
            .par_iter()
            .map(|&i| {
                let Some((x, n)) = surfaces.get(i) else { return (1.0, None) };
                let Some(w) = weights.get(&normal_key(*n)) else { return (1.0, None) };
                let key = receiver_key(*x, *n);
                let value = |product: &ReceiverProduct| {
                    let weights = match (&remaps, product.frame) {
                        (Some(remaps), Some(f)) if self.poses[f].rotation.is_some() => remaps.weights.get(&(normal_key(*n), f)).unwrap_or(w),
                        _ => w,
                    };
                    sky_visibility_of(weights, product).clamp(0.0, 1.0)
                };
                if let Some(p) = kept.and_then(|k| k.kept.get(&key)) {
                    return (value(p), None);
                }
                let fresh = match &remaps {
                    None => self.translated_product(*x, *n),
                    Some(remaps) => self.turned_product(remaps, *x, *n),
                };
                match fresh {
                    Ok(p) => (value(&p), Some((key, p))),
                    Err(_) => (1.0, None),
                }
            })
            .collect();
        let mut values = Vec::with_capacity(rows.len());
        let mut fresh = Vec::new();
        for (v, p) in rows {
            values.push(v);
            fresh.extend(p);
        }
        (values, fresh)
    }

    /// True when object `b`'s field enters the product at `x` (world frame): `x` lies within its
    /// outermost sphere at this frame's pose ([`super::vcf::VisibilityCutField::beyond_reach`]).
    /// Beyond it the object is left out, so its field there is exactly 1 (module docs).
    pub fn reaches(&self, b: usize, x: Vec3) -> bool {
        match (self.cuts.cuts.objects.get(b), self.poses.get(b)) {
            (Some(obj), Some(pose)) => !obj.vcf.beyond_reach(pose.local_point(x)),
            _ => false,
        }
    }

    /// Each object's pose (cut frame → world) this frame.
    pub fn poses(&self) -> &[Pose] {
        &self.poses
    }

    /// The lighting the receivers' weights come from.
    pub fn lighting(&self) -> &Arc<UnitLighting> {
        &self.lighting
    }

    /// One receiver's product with no object turned: the fields looked up at `x` less each
    /// translation, as `CutScene::receiver_visibility`, with the objects beyond reach left out.
    fn translated_product(&self, x: Vec3, n: Vec3) -> Result<ReceiverProduct, CutsError> {
        let mut cuts: Vec<Cut> = Vec::new();
        for (obj, pose) in self.cuts.cuts.objects.iter().zip(&self.poses) {
            let t = pose.translation;
            let centre = obj.vcf.centre + t;
            if n != Vec3::ZERO && n.dot(centre - x) < -obj.vcf.radius_m {
                continue;
            }
            if obj.vcf.beyond_reach(x - t) {
                continue;
            }
            let (cut, _region) = obj.vcf.lookup(x - t)?;
            cuts.push(cut);
        }
        self.product_of(None, &cuts)
    }

    /// The product of `cuts` in object `frame`'s frame, its non-zero nodes (`super::products`).
    fn product_of(&self, frame: Option<usize>, cuts: &[Cut]) -> Result<ReceiverProduct, CutsError> {
        let levels = self.cuts.tree.levels();
        let (ids, values, ()) = walk_into(|ids, values| {
            if !cuts.is_empty() {
                let views: Vec<_> = cuts.iter().map(Cut::view).collect();
                product_for_each(&views, |h, first, v| {
                    if v != 0.0 {
                        ids.push(node_index(levels, h, first) as u16);
                        values.push(v);
                    }
                })?;
            }
            Ok::<_, CutsError>(())
        })?;
        Ok(ReceiverProduct { frame, occluded: !cuts.is_empty(), ids, values })
    }

    /// The pair remaps and the weights pushed into every turned object's frame.
    fn remaps(&self, world: &HashMap<NormalKey, ReceiverWeights>) -> Remaps {
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

    /// One receiver's product with some object turned (module docs).
    fn turned_product(&self, remaps: &Remaps, x: Vec3, n: Vec3) -> Result<ReceiverProduct, CutsError> {
        let mut frame: Option<usize> = None;
        let mut cuts: Vec<Cut> = Vec::new();
        for (b, obj) in self.cuts.cuts.objects.iter().enumerate() {
            let pose = &self.poses[b];
            if n != Vec3::ZERO && n.dot(pose.point(obj.vcf.centre) - x) < -obj.vcf.radius_m {
                continue;
            }
            let local = pose.local_point(x);
            if obj.vcf.beyond_reach(local) {
                continue;
            }
            let (cut, _region) = obj.vcf.lookup(local)?;
            let f = *frame.get_or_insert(b);
            cuts.push(match &remaps.pairs[f][b] {
                Some(r) => r.cut(cut.view())?,
                None => cut,
            });
        }
        self.product_of(frame, &cuts)
    }
}

/// `Σ w_k v_k / Σ w` over a receiver's product (`super::lighting::sky_visibility`, the same
/// operations in the same order; the zero nodes left out add `+0`, which changes no sum of
/// non-negative terms): 1 when no object's field entered it or nothing weighs.
fn sky_visibility_of(weights: &ReceiverWeights, p: &ReceiverProduct) -> f32 {
    if !p.occluded || weights.total() <= 0.0 {
        return 1.0;
    }
    let mut seen = 0.0f64;
    for (&k, &v) in p.ids.iter().zip(p.values.iter()) {
        seen += (weights.node(k as usize) * v) as f64;
    }
    (seen / weights.total() as f64) as f32
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cuts::eval::ObjectCuts;
    use crate::cuts::file::PrecomputedCuts;
    use crate::cuts::svc::SvcSettings;
    use crate::cuts::vcf::VcfSampling;
    use crate::cuts::{DirectionTree, no_progress, shapes};
    use glam::Mat3;

    /// Two spheres of radius 0.5 m (object frame at the origin), the second turned by 30° about y
    /// when `turned`, and receivers on the ground along x, some within reach of an object and
    /// some beyond (the outermost sphere at 10 r = 5 m).
    fn scene(turned: bool) -> (ReceiverCuts, Vec<(Vec3, Vec3)>) {
        let levels = 8;
        let tree = DirectionTree::new(levels).unwrap();
        let vcf = VcfSampling { spheres: 4, rows: 8, cols: 8, ..VcfSampling::default() };
        let one = ObjectCuts::compute("sphere", &shapes::icosphere(Vec3::ZERO, 0.5, 1), &tree, &SvcSettings::default(), &vcf, &no_progress).unwrap();
        let frame = FrameCuts::new(PrecomputedCuts { inputs_hash: [0; 32], levels, objects: vec![one; 2], proxy: None }).unwrap();
        let light = Arc::new(UnitLighting::uniform_sky(&frame.tree));
        let second = if turned { Pose::from_parts(Mat3::from_rotation_y(0.5), Vec3::new(8.0, 0.6, 0.0)).unwrap() } else { Pose::translated(Vec3::new(8.0, 0.6, 0.0)) };
        let poses = vec![Pose::translated(Vec3::new(0.0, 0.6, 0.0)), second];
        let surfaces = (0..40).map(|i| (Vec3::new(-12.0 + i as f32 * 0.7, 0.0, 0.3), Vec3::Y)).collect();
        (frame.receivers_posed(light, poses), surfaces)
    }

    /// Beyond an object's reach its field is left out: a receiver that no object reaches keeps
    /// all of its sky, exactly; one under an object loses some. Asking for a subset gives each
    /// receiver the same value, bit for bit, as asking for all (the compositor's `cut_cache`
    /// relies on both); turned or not.
    #[test]
    fn beyond_reach_is_exactly_one_and_a_subset_changes_nothing() {
        for turned in [false, true] {
            let (rc, surfaces) = scene(turned);
            let all = rc.visibility(&surfaces);
            let mut reached = 0;
            for (i, (x, _)) in surfaces.iter().enumerate() {
                if !(rc.reaches(0, *x) || rc.reaches(1, *x)) {
                    assert_eq!(all[i], 1.0, "turned {turned}: receiver {i} at {x} is reached by no object");
                } else {
                    reached += 1;
                }
            }
            // 5 m either side of x = 0 and x = 8 (with the 0.6 m height): most of -12..16 m.
            assert!(reached > 20 && reached < 40, "turned {turned}: {reached} reached");
            assert!(all.iter().any(|v| *v < 0.9), "turned {turned}: {all:?}");
            let some: Vec<usize> = (0..surfaces.len()).filter(|i| i % 3 == 1).collect();
            let part = rc.visibility_of(&surfaces, &some);
            for (k, &i) in some.iter().enumerate() {
                assert_eq!(part[k].to_bits(), all[i].to_bits(), "turned {turned}: receiver {i}");
            }
        }
    }
}
