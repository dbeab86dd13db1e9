//! Visibility products kept between frames (issue 15 §4, "objects that did not move reuse their
//! last result"; cyberworlds §V-A.3 and §V-B, `../shared/papers/cyberworlds-captured-lighting-cuts.txt`).
//!
//! # How it works
//! A vertex's light is `Σ_k l_k v_k f(ω_k)` over the nodes of its product cut
//! `v = SVC × Π VCF_other × proxy` (Eqs. 3–4), a real receiver's `Σ_k w_k v_k / Σ_k w_k` over
//! `Π VCF` (`super::lighting::sky_visibility`). The product depends on the poses only: the
//! vertex's object's, and those of the objects whose field reaches the point (an object beyond
//! its outermost sphere is left out exactly, `super::vcf::VisibilityCutField::beyond_reach`);
//! the lighting `l_k`, `w_k` and the eye (the reflected direction in `f`) enter only the sum. So
//! when the lighting changes but an object did not move (every frame of the captured-VEM mode, a
//! frame of the outdoor mode whose sun or sky changed), the product is the same and a frame is
//! the dot of the kept product with the new clustered lighting, without looking up the fields
//! (eight neighbouring cuts each, interpolated) nor walking them.
//! - **What is kept** ([`VertexProduct`], [`ReceiverProduct`]): the product's non-zero nodes as
//!   the walk emits them, left to right: a `u16` heap id (`S ≤ 2^15`, so ids `< 2^16`) and an
//!   `f32` value, 6 bytes a node; per vertex the surface product (`SVC × Π VCF`, the lighting's
//!   ground texels) and, with a proxy field, the sky product (`× proxy`). Zero nodes add nothing
//!   to the sums and are left out.
//! - **Exact.** [`super::frame::FrameCuts::vertex_ambient`] itself records the product and then
//!   sums it (`FrameCuts::ambient_from_product`), and the receivers do the same, so a kept
//!   product summed again performs the very floating-point operations, in the same order, of a
//!   fresh evaluation: the result is equal **bit for bit** (not merely within summation order).
//! - **Invalidation** ([`ProductCache`] for the vertices, through `super::reuse`;
//!   [`ReceiverProducts`] for the receivers): exactly when an operand changes, as `super::reuse`
//!   decides for values: a vertex's product is kept while its object did not move and no moved
//!   object reaches it at its old or its new pose; a receiver's while no moved object reaches it
//!   at either pose. The eye is not an operand (the reflected direction is applied in the sum).
//! - **Memory** ([`ProductBudget`]): a vertex costs 6 bytes per product node plus about 56 bytes
//!   (its two boxed slices and their headers); a receiver the same plus its key (24 bytes) in a
//!   hash map. Past the budget (default [`DEFAULT_BUDGET_BYTES`]) an object's products or further
//!   receivers' are not kept, and the report says so with the bytes needed.

use std::cell::RefCell;
use std::collections::HashMap;

use super::local_sun::LocalSun;
use super::receiver_light::ReceiverLight;
use super::rotate::Pose;
use glam::Vec3;
use std::sync::Arc;

/// The products' memory budget by default: 256 MiB (about a million vertices at the courtyard's
/// mean product size; `docs/measurements.md`, "Visibility products kept between frames").
pub const DEFAULT_BUDGET_BYTES: usize = 256 << 20;

/// A memory budget for the kept products, in bytes (module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ProductBudget(pub usize);

impl Default for ProductBudget {
    fn default() -> Self {
        Self(DEFAULT_BUDGET_BYTES)
    }
}

/// Bytes of the boxed slices' pointers and lengths, and the allocator's headers, per kept
/// product (module docs): two `Box<[_]>` (32 bytes), an `Option<Box<_>>` (8) and two heap
/// headers (16).
const PER_PRODUCT_BYTES: usize = 56;

thread_local! {
    /// Per thread, the buffers a product is walked into before it is copied out at its size.
    static SCRATCH: RefCell<(Vec<u16>, Vec<f32>)> = const { RefCell::new((Vec::new(), Vec::new())) };
}

/// Runs `fill` on this thread's scratch buffers (emptied first) and returns them copied into
/// slices of their exact size (one allocation each, none while walking), with `fill`'s result.
pub(super) fn walk_into<R, E>(fill: impl FnOnce(&mut Vec<u16>, &mut Vec<f32>) -> Result<R, E>) -> Result<(Box<[u16]>, Box<[f32]>, R), E> {
    SCRATCH.with(|cell| {
        let mut guard = cell.borrow_mut();
        let (ids, values) = &mut *guard;
        ids.clear();
        values.clear();
        let r = fill(ids, values)?;
        Ok((Box::from(&ids[..]), Box::from(&values[..]), r))
    })
}

/// A vertex's product cuts (module docs): non-zero nodes in the walk's order.
#[derive(Clone, Debug, PartialEq)]
pub struct VertexProduct {
    ids: Box<[u16]>,
    values: Box<[f32]>,
    /// Where the sky product starts (`None`: no proxy field, the sky uses the surface product).
    sky_at: Option<u32>,
    /// The proxy field's lookup was clamped to its box.
    pub outside: bool,
}

impl VertexProduct {
    /// The surface nodes `ids[..sky_at]`, then the sky's (`None`: the same as the surface's).
    pub(super) fn new(ids: Box<[u16]>, values: Box<[f32]>, sky_at: Option<usize>, outside: bool) -> Self {
        Self { ids, values, sky_at: sky_at.map(|s| s as u32), outside }
    }

    /// `SVC × Π VCF`: heap ids and values.
    pub fn surface(&self) -> (&[u16], &[f32]) {
        let end = self.sky_at.map_or(self.ids.len(), |s| s as usize);
        (&self.ids[..end], &self.values[..end])
    }

    /// `SVC × Π VCF × proxy`: heap ids and values.
    pub fn sky(&self) -> (&[u16], &[f32]) {
        match self.sky_at {
            Some(s) => (&self.ids[s as usize..], &self.values[s as usize..]),
            None => self.surface(),
        }
    }

    /// Bytes it takes kept (module docs).
    pub fn bytes(&self) -> usize {
        PER_PRODUCT_BYTES + self.ids.len() * (2 + 4)
    }
}

/// What a frame did with one object's kept products (for the report).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ProductUse {
    /// Vertices whose product was kept from the last frame (and summed under this frame's light).
    pub reused: usize,
    /// Vertices whose product was walked afresh.
    pub walked: usize,
    /// Why the products of this object are not kept for the next frame (the budget), if so.
    pub not_kept: Option<String>,
}

/// Every object's per-vertex products at the last frame's poses (module docs).
#[derive(Clone, Debug, Default)]
pub struct ProductCache {
    pub(super) budget: ProductBudget,
    pub(super) poses: Vec<Pose>,
    /// Per object, per vertex (`None`: not kept).
    pub(super) objects: Vec<Option<Vec<Option<Box<VertexProduct>>>>>,
}

impl ProductCache {
    /// An empty cache with a memory budget.
    pub fn with_budget(budget: ProductBudget) -> Self {
        Self { budget, ..Self::default() }
    }

    /// Forgets every kept product.
    pub fn clear(&mut self) {
        self.poses.clear();
        self.objects.clear();
    }

    /// Bytes kept now.
    pub fn bytes(&self) -> usize {
        self.objects.iter().flatten().flatten().flatten().map(|p| p.bytes()).sum()
    }
}

/// A real receiver's product of the objects' fields (module docs), in the frame of object
/// `frame` (`None`: the world's, no object turned, or no object reaches it).
#[derive(Clone, Debug, PartialEq)]
pub struct ReceiverProduct {
    pub(super) frame: Option<usize>,
    /// Some object's field entered the product (else the receiver keeps all its light).
    pub(super) occluded: bool,
    pub(super) ids: Box<[u16]>,
    pub(super) values: Box<[f32]>,
}

impl ReceiverProduct {
    /// Bytes it takes kept, with its key (module docs).
    pub fn bytes(&self) -> usize {
        PER_PRODUCT_BYTES + 24 + self.ids.len() * (2 + 4)
    }
}

/// A receiver's key: its point's and normal's bits.
pub(super) type ReceiverKey = [u32; 6];

pub(super) fn receiver_key(x: Vec3, n: Vec3) -> ReceiverKey {
    let (x, n) = (x.to_array().map(f32::to_bits), n.to_array().map(f32::to_bits));
    [x[0], x[1], x[2], n[0], n[1], n[2]]
}

fn key_point(k: &ReceiverKey) -> Vec3 {
    Vec3::new(f32::from_bits(k[0]), f32::from_bits(k[1]), f32::from_bits(k[2]))
}

/// A receiver's light by direction's key: the receiver's, and the turned frame's rotation
/// (`None`: the world's) as bits.
pub(super) type LightKey = (ReceiverKey, Option<[u32; 9]>);

/// The receivers' products at the last call's poses, their light by direction
/// (`super::receiver_light`) under the last call's proxy light, and what the last call did.
#[derive(Clone, Debug, Default)]
pub struct ReceiverProducts {
    pub(super) budget: ProductBudget,
    pub(super) poses: Vec<Pose>,
    pub(super) kept: HashMap<ReceiverKey, ReceiverProduct>,
    pub(super) bytes: usize,
    /// The receivers' light by direction; it does not depend on the poses, only on the proxy's
    /// light (`light_of`).
    pub(super) lights: HashMap<LightKey, ReceiverLight>,
    pub(super) light_bytes: usize,
    light_of: Option<Arc<LocalSun>>,
    /// The last call's counts.
    pub last: ReceiverProductUse,
}

/// What a call did with the receivers' products.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ReceiverProductUse {
    /// Receivers whose product was kept (summed under this call's light).
    pub reused: usize,
    /// Receivers whose product was walked afresh.
    pub walked: usize,
    /// Receivers walked but not kept for lack of budget.
    pub over_budget: usize,
    /// Receivers whose light by direction was traced (`super::receiver_light`).
    pub lights_traced: usize,
}

impl ReceiverProducts {
    /// An empty store with a memory budget.
    pub fn with_budget(budget: ProductBudget) -> Self {
        Self { budget, ..Self::default() }
    }

    /// Bytes kept now.
    pub fn bytes(&self) -> usize {
        self.bytes
    }

    /// Moves the store to `poses`: drops every product that an object whose pose changed reaches
    /// at its old or its new pose (`reaches(b, pose, x)`), or all of them when the object count
    /// changed.
    pub(super) fn advance(&mut self, poses: &[Pose], reaches: impl Fn(usize, &Pose, Vec3) -> bool) {
        if self.poses.len() != poses.len() {
            self.kept.clear();
            self.bytes = 0;
        } else {
            let moved: Vec<usize> = (0..poses.len()).filter(|&b| !same_pose(&self.poses[b], &poses[b])).collect();
            if !moved.is_empty() {
                let old = std::mem::take(&mut self.poses);
                let mut dropped = 0;
                self.kept.retain(|k, p| {
                    let x = key_point(k);
                    let keep = !moved.iter().any(|&b| reaches(b, &old[b], x) || reaches(b, &poses[b], x));
                    if !keep {
                        dropped += p.bytes();
                    }
                    keep
                });
                self.bytes -= dropped;
            }
        }
        self.poses = poses.to_vec();
    }

    /// Forgets the receivers' light by direction unless it was traced under `local` (the same
    /// proxy light, by identity).
    pub(super) fn light_for(&mut self, local: Option<&Arc<LocalSun>>) {
        let same = match (&self.light_of, local) {
            (Some(a), Some(b)) => Arc::ptr_eq(a, b),
            (None, None) => true,
            _ => false,
        };
        if !same {
            self.lights.clear();
            self.light_bytes = 0;
            self.light_of = local.cloned();
        }
    }

    /// Keeps a receiver's light by direction unless the budget (shared with the products) is
    /// spent.
    pub(super) fn keep_light(&mut self, key: LightKey, light: ReceiverLight) {
        let b = light.bytes() + 64;
        if self.bytes + self.light_bytes + b > self.budget.0 {
            return;
        }
        self.light_bytes += b;
        if self.lights.insert(key, light).is_some() {
            self.light_bytes -= b;
        }
    }

    /// Keeps `product` for `key` unless the budget is spent; false when it was not kept.
    pub(super) fn keep(&mut self, key: ReceiverKey, product: ReceiverProduct) -> bool {
        let b = product.bytes();
        if self.bytes + self.light_bytes + b > self.budget.0 {
            return false;
        }
        self.bytes += b;
        if let Some(old) = self.kept.insert(key, product) {
            self.bytes -= old.bytes();
        }
        true
    }
}

/// The same pose, bit for bit.
pub(super) fn same_pose(a: &Pose, b: &Pose) -> bool {
    let bits = |p: &Pose| (p.rotation.map(|r| r.to_cols_array().map(f32::to_bits)), p.translation.to_array().map(f32::to_bits));
    bits(a) == bits(b)
}
