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
//! **The receiver's own light** (`super::receiver_light`, the frame loop's outdoor path): the
//! weights are then the receiver's light by direction as it sees it (sky, or the proxy surface a
//! ray from it meets), for `c` and for `b` apart ([`LightLeft`]), and the light the nearest object
//! reflects onto it is added over what the product hides. A receiver closer to an object than
//! its field's innermost sphere takes that object's occlusion traced against its mesh instead of
//! the clamped field ([`near_cut`]).
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
use super::local_sun::LocalFrame;
use super::products::{LightKey, ReceiverKey, ReceiverProduct, ReceiverProductUse, ReceiverProducts, receiver_key, walk_into};
pub use super::receiver_light::LightLeft;
use super::receiver_light::{ObjectsSeen, ReceiverLight};
use super::tree::{DirectionTree, node_index};
use super::vcf::FieldRegion;
use crate::geometry::raycast::RayScene;
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
    /// What the objects show a receiver (`super::receiver_light`): their reflected light is
    /// added where they hide the receiver's own light.
    seen: Option<Arc<ObjectsSeen>>,
    /// Per object, its mesh in its cuts' frame, to trace the receivers closer to it than its
    /// field's innermost sphere ([`near_cut`]).
    near: Option<Vec<Option<Arc<RayScene>>>>,
}

/// A receiver normal's key in the weights cache: its exact bits (a proxy's receivers take
/// their triangles' face normals, so there are few), so that a receiver's weights never depend
/// on which other receivers are asked for.
type NormalKey = [u32; 3];

fn normal_key(n: Vec3) -> NormalKey {
    n.to_array().map(f32::to_bits)
}

/// One receiver's evaluation: what it keeps, its product if walked afresh, its light by
/// direction if traced afresh.
type Row = (LightLeft, Option<(ReceiverKey, ReceiverProduct)>, Option<(LightKey, ReceiverLight)>);

/// What an evaluation walked or traced afresh, to keep.
#[derive(Default)]
struct Fresh {
    products: Vec<(ReceiverKey, ReceiverProduct)>,
    lights: Vec<(LightKey, ReceiverLight)>,
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
        Self { cuts, lighting, poses, products: None, seen: None, near: None }
    }

    /// The same, tracing the receivers closer to an object than its field's innermost sphere
    /// against `meshes` (per object, in its cuts' frame; `None`: its field serves) instead of
    /// looking its field up there ([`near_cut`]).
    pub fn with_near(mut self, meshes: Vec<Option<Arc<RayScene>>>) -> Self {
        self.near = Some(meshes);
        self
    }

    /// The same, adding the light the objects reflect onto the receivers they hide light from,
    /// where each receiver's light by direction is known (the frame loop's outdoor path,
    /// `super::receiver_light`).
    pub fn with_seen(mut self, seen: Arc<ObjectsSeen>) -> Self {
        self.seen = Some(seen);
        self
    }

    /// The same, keeping the receivers' products in `store` between frames (`super::products`);
    /// the values are the same bit for bit.
    pub fn with_products(mut self, store: Arc<Mutex<ReceiverProducts>>) -> Self {
        self.products = Some(store);
        self
    }

    /// The share of its light each `(point, normal)` (world frame) keeps with the objects present
    /// ([`LightLeft`], in `[0, 1]`); all of it where the lookup fails (a non-finite point: nothing
    /// to darken). In parallel.
    pub fn visibility(&self, surfaces: &[(Vec3, Vec3)]) -> Vec<LightLeft> {
        let all: Vec<usize> = (0..surfaces.len()).collect();
        self.visibility_of(surfaces, &all)
    }

    /// [`Self::visibility`] at `surfaces[i]` for each `i` of `which` only, in that order (an
    /// index out of range gives 1). A receiver's value depends on its own point and normal only:
    /// the weights are per exact normal, so asking for fewer receivers changes none of them.
    pub fn visibility_of(&self, surfaces: &[(Vec3, Vec3)], which: &[usize]) -> Vec<LightLeft> {
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
    pub fn visibility_reusing(&self, surfaces: &[(Vec3, Vec3)], which: &[usize], store: &mut ReceiverProducts) -> Vec<LightLeft> {
        store.advance(&self.poses, |b, pose, x| self.cuts.cuts.objects.get(b).is_some_and(|o| !o.vcf.beyond_reach(pose.local_point(x))));
        store.light_for(self.lighting.local.as_ref());
        let (values, fresh) = self.evaluate(surfaces, which, Some(store));
        let mut over = 0;
        let walked = fresh.products.len();
        for (key, p) in fresh.products {
            if !store.keep(key, p) {
                over += 1;
            }
        }
        let traced = fresh.lights.len();
        for (key, l) in fresh.lights {
            store.keep_light(key, l);
        }
        store.last = ReceiverProductUse { reused: which.len() - walked, walked, over_budget: over, lights_traced: traced };
        values
    }

    /// The receivers `which`, with the products (and the receivers' light by direction,
    /// `super::receiver_light`) of `kept` where it has them; returns the values and what was
    /// walked or traced afresh.
    fn evaluate(&self, surfaces: &[(Vec3, Vec3)], which: &[usize], kept: Option<&ReceiverProducts>) -> (Vec<LightLeft>, Fresh) {
        let mut normals: HashMap<NormalKey, Vec3> = HashMap::new();
        for (_, n) in which.iter().filter_map(|&i| surfaces.get(i)) {
            normals.entry(normal_key(*n)).or_insert(*n);
        }
        let (tree, sky) = (&*self.cuts.tree, &self.lighting.sky_pa);
        let list: Vec<(NormalKey, Vec3)> = normals.into_iter().collect();
        let weights: HashMap<NormalKey, ReceiverWeights> = list.into_par_iter().filter_map(|(k, n)| ReceiverWeights::new(tree, sky, n).ok().map(|w| (k, w))).collect();
        let turned = self.poses.iter().any(|p| p.rotation.is_some());
        let remaps = turned.then(|| self.remaps(&weights));
        // The receivers' own light by direction, where the relighter gives the proxy's light
        // (the frame loop's outdoor path): the proxy alone, no object's shadow.
        let local = self.lighting.local.as_ref().map(|sun| LocalFrame::new(sun.clone(), &[]));
        let rows: Vec<Row> = which
            .par_iter()
            .map(|&i| {
                let Some((x, n)) = surfaces.get(i) else { return (LightLeft::ALL, None, None) };
                let Some(w) = weights.get(&normal_key(*n)) else { return (LightLeft::ALL, None, None) };
                let key = receiver_key(*x, *n);
                let value = |product: &ReceiverProduct| -> (LightLeft, Option<(LightKey, ReceiverLight)>) {
                    let rotation = product.frame.and_then(|f| self.poses.get(f)).and_then(|p| p.rotation);
                    let weights = match (&remaps, product.frame) {
                        (Some(remaps), Some(f)) if rotation.is_some() => remaps.weights.get(&(normal_key(*n), f)).unwrap_or(w),
                        _ => w,
                    };
                    let Some(local) = local.as_ref().filter(|_| product.occluded) else {
                        return (LightLeft::both(sky_visibility_of(weights, product).clamp(0.0, 1.0)), None);
                    };
                    let light_key = (key, rotation.map(|r| r.to_cols_array().map(f32::to_bits)));
                    if let Some(l) = kept.and_then(|k| k.lights.get(&light_key)) {
                        return (self.with_reflected(l, product, *x, *n), None);
                    }
                    let l = ReceiverLight::trace(local, tree, weights, rotation, *x, *n);
                    (self.with_reflected(&l, product, *x, *n), Some((light_key, l)))
                };
                if let Some(p) = kept.and_then(|k| k.kept.get(&key)) {
                    let (v, l) = value(p);
                    return (v, None, l);
                }
                let fresh = match &remaps {
                    None => self.translated_product(*x, *n),
                    Some(remaps) => self.turned_product(remaps, *x, *n),
                };
                match fresh {
                    Ok(p) => {
                        let (v, l) = value(&p);
                        (v, Some((key, p)), l)
                    }
                    Err(_) => (LightLeft::ALL, None, None),
                }
            })
            .collect();
        let mut values = Vec::with_capacity(rows.len());
        let mut fresh = Fresh::default();
        for (v, p, l) in rows {
            values.push(v);
            fresh.products.extend(p);
            fresh.lights.extend(l);
        }
        (values, fresh)
    }

    /// What the receiver at `x` with light `l` keeps under product `p`, and what the nearest
    /// object that reaches it reflects onto it over the projected solid angle the product hides
    /// (with [`Self::with_seen`]).
    fn with_reflected(&self, l: &ReceiverLight, p: &ReceiverProduct, x: Vec3, n: Vec3) -> LightLeft {
        let mut left = l.left(p);
        let Some(seen) = &self.seen else { return left };
        let nearest = (0..self.poses.len())
            .filter(|&b| self.reaches(b, x))
            .filter_map(|b| seen.centre(b).map(|c| (b, c.distance_squared(x))))
            .min_by(|a, b| a.1.total_cmp(&b.1));
        if let Some((b, _)) = nearest {
            let hidden = l.hidden(p);
            let (pa, pd) = seen.seen_from(b, x, n);
            left.ambient_add = pa * hidden;
            left.bounce_add = pd * hidden;
        }
        left
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
        for (b, (obj, pose)) in self.cuts.cuts.objects.iter().zip(&self.poses).enumerate() {
            let t = pose.translation;
            let centre = obj.vcf.centre + t;
            if n != Vec3::ZERO && n.dot(centre - x) < -obj.vcf.radius_m {
                continue;
            }
            if obj.vcf.beyond_reach(x - t) {
                continue;
            }
            cuts.push(self.field_at(b, x - t, n)?);
        }
        self.product_of(None, &cuts)
    }

    /// Object `b`'s field at `local` (its cuts' frame) for a receiver of normal `n_local` there:
    /// looked up, or traced against its mesh closer than the innermost sphere ([`near_cut`]).
    fn field_at(&self, b: usize, local: Vec3, n_local: Vec3) -> Result<Cut, CutsError> {
        let obj = &self.cuts.cuts.objects[b];
        let (cut, region) = obj.vcf.lookup(local)?;
        match (region, self.near.as_ref().and_then(|m| m.get(b)).and_then(Option::as_ref)) {
            (FieldRegion::InsideInner, Some(mesh)) => near_cut(mesh, &self.cuts.tree, local, n_local),
            _ => Ok(cut),
        }
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
            let cut = self.field_at(b, local, pose.local_dir(n))?;
            let f = *frame.get_or_insert(b);
            cuts.push(match &remaps.pairs[f][b] {
                Some(r) => r.cut(cut.view())?,
                None => cut,
            });
        }
        self.product_of(frame, &cuts)
    }
}

/// An object's occlusion at a receiver closer to it than its field's innermost sphere, traced:
/// one ray per node at depth [`super::local_sun::LOCAL_DEPTH`] against the object's `mesh` from
/// `p` (its cuts' frame), its leaves taking the ray's value, 1 below the receiver's tangent plane
/// (normal `n`), where nothing weighs. The field would clamp to the innermost sphere's cut there
/// (`super::vcf`), which sees the object from `1.2·r` and misses most of what it hides from the
/// ground at its foot (measured at the courtyard's wall: the statue 5 cm away kept 0.59 of the
/// paving's light by the field, 0.29 traced).
pub fn near_cut(mesh: &RayScene, tree: &DirectionTree, p: Vec3, n: Vec3) -> Result<Cut, CutsError> {
    let levels = tree.levels();
    let depth = super::local_sun::LOCAL_DEPTH.min(levels);
    let (first, per) = ((1usize << depth) - 1, 1usize << (levels - depth));
    let origin = p + n * 2e-3;
    let mut leaves = vec![1.0f32; tree.leaf_count()];
    for j in 0..1usize << depth {
        let d = tree.node_dir(first + j).normalize_or(Vec3::Y);
        if n.dot(d) > -0.2 && mesh.occluded(origin, d, f32::MAX) {
            leaves[j * per..(j + 1) * per].fill(0.0);
        }
    }
    Cut::from_leaves(levels, &leaves, 0.0)
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
    use crate::cuts::lighting::ClusteredLighting;
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

    /// At the foot of a wall-shaped object (2 m × 2 m, facing +z), from a receiver 1 cm in front
    /// of it with normal +y: the traced cut hides what the wall covers behind it and nothing in
    /// front. The share of the cosine-weighted hemisphere it covers is the form factor of the
    /// receiver to the rectangle, 0.497 (integrated by Monte Carlo, 4·10⁵ cosine-distributed
    /// directions): the traced cut leaves 0.503 within 0.02 (one ray per 0.05 sr node). The
    /// field, clamped to its innermost sphere 1.2 r away, hides much less.
    #[test]
    fn the_near_field_is_traced_where_the_field_would_clamp() {
        let tree = DirectionTree::new(10).unwrap();
        let wall = shapes::wall(-1.0, 1.0, 2.0, 0.0);
        let cut = near_cut(&RayScene::new(wall.clone()), &tree, Vec3::new(0.0, 0.0, 0.01), Vec3::Y).unwrap();
        let sky = ClusteredLighting::from_fn(&tree, |_| Vec3::ONE);
        let w = ReceiverWeights::new(&tree, &sky, Vec3::Y).unwrap();
        let seen = crate::cuts::lighting::sky_visibility(&w, &[cut.view()]).unwrap();
        assert!((seen - 0.503).abs() < 0.02, "{seen}");
        let leaves = |c: &Cut| -> Vec<f32> { (0..tree.leaf_count() as u32).map(|j| crate::cuts::bounce::leaf_value(c.view(), j)).collect() };
        let l = leaves(&cut);
        for (j, d) in tree.leaf_dirs().iter().enumerate() {
            // Well in front (+z), or well behind and low in the middle: open and hidden.
            if d.z > 0.2 && d.y > 0.0 {
                assert_eq!(l[j], 1.0, "{d}");
            }
            if d.z < -0.5 && d.y > 0.05 && d.y < 0.5 && d.x.abs() < 0.2 {
                assert_eq!(l[j], 0.0, "{d}");
            }
        }
        let vcf = VcfSampling { spheres: 4, rows: 8, cols: 8, ..VcfSampling::default() };
        let field = crate::cuts::vcf::VisibilityCutField::compute("wall", &wall, &tree, &vcf, &no_progress).unwrap();
        let (clamped, region) = field.lookup(Vec3::new(0.0, 0.0, 0.01)).unwrap();
        assert_eq!(region, FieldRegion::InsideInner);
        let by_field = crate::cuts::lighting::sky_visibility(&w, &[clamped.view()]).unwrap();
        assert!(by_field > seen + 0.15, "the field {by_field}, traced {seen}");
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
                    assert_eq!(all[i], LightLeft::ALL, "turned {turned}: receiver {i} at {x} is reached by no object");
                } else {
                    reached += 1;
                }
            }
            // 5 m either side of x = 0 and x = 8 (with the 0.6 m height): most of -12..16 m.
            assert!(reached > 20 && reached < 40, "turned {turned}: {reached} reached");
            assert!(all.iter().any(|v| v.ambient < 0.9), "turned {turned}: {all:?}");
            let some: Vec<usize> = (0..surfaces.len()).filter(|i| i % 3 == 1).collect();
            let part = rc.visibility_of(&surfaces, &some);
            for (k, &i) in some.iter().enumerate() {
                assert_eq!(part[k].ambient.to_bits(), all[i].ambient.to_bits(), "turned {turned}: receiver {i}");
            }
        }
    }
}
