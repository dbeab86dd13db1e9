//! The objects' per-vertex ambient kept between frames (issue 15 §4, "objects that did not move
//! reuse their last result"; cyberworlds §V-B: an object's field matters only within its
//! outermost sphere, `../shared/papers/cyberworlds-captured-lighting-cuts.txt`).
//!
//! # How it works
//! [`FrameCuts::object_ambient_reusing`] computes what [`FrameCuts::object_ambient_bounced`]
//! does (first pass, Eq. 3, then the light the objects reflect onto themselves and each other,
//! `super::bounce`), bit for bit for every object whose ambient is used, and leaves out work
//! whose result is not used or cannot have changed:
//! - **Unused objects.** The caller says which objects' ambient is not shown (an object that
//!   keeps its traced per-pixel transfer, `render::compositor`'s `kept`). Such an object's own
//!   bounce (the light onto it) is not computed; its first pass only where it is the *source* of
//!   light onto a used object, i.e. when its field reaches a vertex of one (its radiance enters
//!   only there, `super::bounce`); otherwise nothing of it is evaluated. Its rows are then its
//!   first pass, or zero (not served), which the compositor does not show.
//! - **Reuse.** A vertex's first pass depends on its object's pose, the lighting, the eye, the
//!   sun (in its radiance) and the fields of the other objects that reach it: an object beyond its
//!   outermost sphere is left out exactly (`super::frame`'s occluders,
//!   [`super::vcf::VisibilityCutField::beyond_reach`]). So while the lighting (the same
//!   [`UnitLighting`] allocation), the eye and the sun are the same and the vertex's object did not
//!   move, a vertex that no moved object reaches at its old or its new pose keeps its last value
//!   bit for bit. An object all of whose vertices keep theirs keeps its radiance too, and the
//!   light it reflects clustered in another object's frame while that object's rotation is the
//!   same.
//!
//! - **Products** (`super::products`). Where the value cannot be kept because the lighting or the
//!   eye changed (every frame of the captured-VEM mode, a frame whose sun planes moved), a vertex
//!   whose object did not move and that no object moved since reaches keeps its *product cut*
//!   and sums it with the new lighting, bit for bit the fresh value; the others walk theirs
//!   again. [`AmbientCache::product_uses`] says per object how many did which, and why a product
//!   was not kept (its budget).
//!
//! [`ObjectUse`] says per object what was done, for the pass report.

use super::bounce::{Bounce, ObjectRadiance, add_rows};
use super::frame::{FrameCuts, ObjectAmbient, Occluders, UnitLighting, VertexAmbient};
use super::lighting::ClusteredLighting;
use super::products::{ProductBudget, ProductCache, ProductUse, VertexProduct, same_pose};
use super::rotate::{LeafRemap, Pose, relative};
use super::CutsError;
use glam::{Mat3, Vec3};
use rayon::prelude::*;
use std::sync::Arc;

/// What the frame did with one object's per-vertex ambient.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ObjectUse {
    /// Its ambient is shown: `evaluated` vertices' first pass computed, `reused` kept, and the
    /// light onto it added.
    Shown { evaluated: usize, reused: usize },
    /// Not shown, but the light it reflects onto a shown object needs its first pass:
    /// `evaluated` computed, `reused` kept; no light onto it computed.
    SourceOnly { evaluated: usize, reused: usize },
    /// Not shown and its field reaches no shown object's vertex: nothing evaluated.
    Skipped,
}

/// How a vertex's first pass was had this frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum How {
    /// Its last value kept.
    Value,
    /// Its last product kept, summed under this frame's lighting (`super::products`).
    Product,
    /// Its product walked afresh.
    Walked,
}

/// One vertex of [`FrameCuts::first_pass`].
struct Row {
    value: (VertexAmbient, bool),
    fields: Option<Occluders>,
    product: Option<Box<VertexProduct>>,
    how: How,
}

/// One object's first pass ([`FrameCuts::first_pass`]).
struct FirstPass {
    values: Vec<(VertexAmbient, bool)>,
    fields: Vec<Option<Occluders>>,
    products: Vec<Option<Box<VertexProduct>>>,
    reused: usize,
    products_reused: usize,
    walked: usize,
}

/// A clustered radiance pair (per unit `Pa`, per unit `Pd`).
type Clustered = (ClusteredLighting, ClusteredLighting);

/// What the last frame computed, and under what (module docs).
#[derive(Clone, Debug)]
struct Last {
    lighting: Arc<UnitLighting>,
    eye: [u32; 3],
    sun: Option<[u32; 3]>,
    poses: Vec<Pose>,
    /// Per object, per vertex: the first pass and whether its proxy lookup was clamped.
    first: Vec<Option<Vec<(VertexAmbient, bool)>>>,
    /// Per object, its outgoing radiance.
    radiance: Vec<Option<ObjectRadiance>>,
    /// `clustered[a][b]`: `b`'s radiance clustered in `a`'s frame, with `a`'s rotation then.
    clustered: Vec<Vec<Option<(Option<[u32; 9]>, Arc<Clustered>)>>>,
}

/// The per-vertex ambient kept between frames ([`FrameCuts::object_ambient_reusing`]).
#[derive(Clone, Debug, Default)]
pub struct AmbientCache {
    last: Option<Last>,
    /// The vertices' visibility products (`super::products`), kept across lighting changes.
    products: ProductCache,
    /// What the last frame did with each object's products.
    product_uses: Vec<ProductUse>,
}

impl AmbientCache {
    /// An empty cache whose visibility products take at most `budget`.
    pub fn with_budget(budget: ProductBudget) -> Self {
        Self { products: ProductCache::with_budget(budget), ..Self::default() }
    }

    /// Forgets everything kept (the next frame evaluates all it needs).
    pub fn clear(&mut self) {
        self.last = None;
        self.products.clear();
        self.product_uses.clear();
    }

    /// Per object, what the last frame did with its visibility products (`super::products`).
    pub fn product_uses(&self) -> &[ProductUse] {
        &self.product_uses
    }

    /// Bytes of the visibility products kept now.
    pub fn product_bytes(&self) -> usize {
        self.products.bytes()
    }
}

fn bits3(v: Vec3) -> [u32; 3] {
    v.to_array().map(f32::to_bits)
}

fn rotation_bits(r: Option<Mat3>) -> Option<[u32; 9]> {
    r.map(|r| r.to_cols_array().map(f32::to_bits))
}


impl FrameCuts {
    /// True when object `b`'s field at `pose` reaches the world point `x` (within its outermost
    /// sphere; beyond, it is left out exactly).
    fn field_reaches(&self, b: usize, pose: &Pose, x: Vec3) -> bool {
        !self.cuts.objects[b].vcf.beyond_reach(pose.local_point(x))
    }

    /// Vertex `v` of object `k` at `poses`, world frame.
    fn vertex_point(&self, poses: &[Pose], k: usize, v: usize) -> Vec3 {
        poses[k].point(self.cuts.objects[k].positions[v])
    }

    /// Vertices of object `k` (their count as the first pass takes it).
    fn vertex_count(&self, k: usize) -> usize {
        let obj = &self.cuts.objects[k];
        obj.positions.len().min(obj.svc.cuts.len())
    }

    /// One needed object's first pass ([`Self::object_ambient_reusing`]): per vertex its ambient
    /// and whether it lies outside the proxy box, the fields met where it was walked, how many
    /// vertices reused their last value (where object `k` did not move and no moved object
    /// reaches the vertex at its old or new pose, under the same lighting and eye), and the
    /// products (`super::products`): kept from `old` and summed under this frame's lighting where
    /// their operands did not change since `old_poses`, walked afresh elsewhere.
    #[allow(clippy::type_complexity, clippy::too_many_arguments)]
    fn first_pass(&self, lighting: &Arc<UnitLighting>, poses: &[Pose], eye: Vec3, k: usize, moved: &[bool], last: Option<&Last>, old_poses: &[Pose], old: Option<Vec<Option<Box<VertexProduct>>>>) -> Result<FirstPass, CutsError> {
        let n = self.cuts.objects.len();
        let count = self.vertex_count(k);
        let stored = last.filter(|_| !moved[k]).and_then(|l| l.first[k].as_ref().filter(|f| f.len() == count).map(|f| (l, f)));
        let keep: Vec<bool> = match stored {
            Some((l, _)) => (0..count)
                .into_par_iter()
                .map(|v| {
                    let x = self.vertex_point(poses, k, v);
                    (0..n).all(|b| b == k || !moved[b] || !(self.field_reaches(b, &l.poses[b], x) || self.field_reaches(b, &poses[b], x)))
                })
                .collect(),
            None => vec![false; count],
        };
        // The products' operands: object k did not move since they were walked, and no object
        // that moved since reaches the vertex at either pose.
        let old = old.filter(|o| o.len() == count && old_poses.len() == n && same_pose(&old_poses[k], &poses[k]));
        let changed: Vec<usize> = match &old {
            Some(_) => (0..n).filter(|&b| b != k && !same_pose(&old_poses[b], &poses[b])).collect(),
            None => Vec::new(),
        };
        let mut old = old.unwrap_or_else(|| vec![None; count]);
        let frame = if keep.iter().all(|k| *k) { None } else { Some(self.object_frame(lighting, poses, k)?) };
        let rows: Vec<Row> = old
            .par_iter_mut()
            .enumerate()
            .map(|(v, kept)| {
                let kept = kept.take();
                match (&frame, stored) {
                    (_, Some((_, f))) if keep[v] => Ok(Row { value: f[v], fields: None, product: kept, how: How::Value }),
                    (Some(frame), _) => {
                        let x = self.vertex_point(poses, k, v);
                        let same = || changed.iter().all(|&b| !(self.field_reaches(b, &old_poses[b], x) || self.field_reaches(b, &poses[b], x)));
                        match kept {
                            Some(p) if same() => {
                                let a = self.ambient_from_product(frame, poses, k, v, eye, &p)?;
                                Ok(Row { value: (a, p.outside), fields: None, product: Some(p), how: How::Product })
                            }
                            _ => {
                                let (p, occ) = self.vertex_product(frame, poses, k, v)?;
                                let a = self.ambient_from_product(frame, poses, k, v, eye, &p)?;
                                Ok(Row { value: (a, p.outside), fields: Some(occ), product: Some(Box::new(p)), how: How::Walked })
                            }
                        }
                    }
                    _ => Err(CutsError::Operands("a vertex kept without a stored value".into())),
                }
            })
            .collect::<Result<_, CutsError>>()?;
        let count_of = |h: How| rows.iter().filter(|r| r.how == h).count();
        let (reused, products_reused, walked) = (count_of(How::Value), count_of(How::Product), count_of(How::Walked));
        let mut out = FirstPass { values: Vec::with_capacity(count), fields: Vec::with_capacity(count), products: Vec::with_capacity(count), reused, products_reused, walked };
        for r in rows {
            out.values.push(r.value);
            out.fields.push(r.fields);
            out.products.push(r.product);
        }
        Ok(out)
    }

    /// Adds to each shown object's rows the light it reflects onto itself
    /// (`crate::cuts::self_bounce`), from its radiance.
    fn add_self_bounce(&self, ambient: &mut ObjectAmbient, poses: &[Pose], eye: Vec3, bounce: &Bounce, shown: &[bool], radiance: &[Option<ObjectRadiance>]) -> Result<(), CutsError> {
        for a in (0..shown.len()).filter(|&a| shown[a]) {
            let Some(rad) = &radiance[a] else { continue };
            let rows = self.self_bounce_rows(poses, a, eye, bounce, rad)?;
            add_rows(&mut ambient.vertices[a], &rows);
        }
        Ok(())
    }

    /// Adds to each shown object's rows the light the other objects reflect onto it, their
    /// radiance clustered in its frame (reused from `last` with all of a source's vertices);
    /// returns those clusterings for the next frame.
    #[allow(clippy::too_many_arguments, clippy::type_complexity)]
    fn add_others_bounce(&self, ambient: &mut ObjectAmbient, poses: &[Pose], eye: Vec3, shown: &[bool], radiance: &[Option<ObjectRadiance>], last: Option<&Last>, all_reused: &[bool], fields: &[Vec<Option<Occluders>>]) -> Result<Vec<Vec<Option<(Option<[u32; 9]>, Arc<Clustered>)>>>, CutsError> {
        let n = shown.len();
        let mut clustered: Vec<Vec<Option<(Option<[u32; 9]>, Arc<Clustered>)>>> = vec![vec![None; n]; n];
        if n > 1 {
            let mut added: Vec<(usize, Vec<VertexAmbient>)> = Vec::new();
            for a in (0..n).filter(|&a| shown[a]) {
                let rot = poses[a].rotation;
                let key = rotation_bits(rot);
                let mut lights: Vec<Option<Clustered>> = vec![None; n];
                for b in (0..n).filter(|&b| b != a) {
                    let Some(rad) = &radiance[b] else { continue };
                    let old = last.and_then(|l| l.clustered[a][b].clone()).filter(|(k, _)| all_reused[b] && *k == key);
                    let c = match old {
                        Some((_, c)) => c,
                        None => Arc::new(rad.clustered(&self.tree, rot)),
                    };
                    lights[b] = Some((*c).clone());
                    clustered[a][b] = Some((key, c));
                }
                let remaps: Vec<Option<LeafRemap>> = poses.iter().map(|p| relative(p.rotation, rot).map(|q| LeafRemap::new(&self.tree, &self.index, q))).collect();
                let rows: Vec<VertexAmbient> = (0..self.vertex_count(a))
                    .into_par_iter()
                    .map(|v| match fields[a].get(v).and_then(Option::as_ref) {
                        Some(f) => self.vertex_bounce(poses, a, v, eye, &lights, f),
                        None => self.vertex_bounce(poses, a, v, eye, &lights, &self.vertex_fields(poses, a, v, &remaps)?),
                    })
                    .collect::<Result<_, _>>()?;
                added.push((a, rows));
            }
            for (a, rows) in added {
                add_rows(&mut ambient.vertices[a], &rows);
            }
        }
        Ok(clustered)
    }

    /// [`Self::object_ambient_bounced`] for the objects at `poses`, keeping in `cache` what can
    /// serve the next frame; `unused[k]`: object `k`'s ambient is not shown (module docs). The
    /// rows of every object not `unused` equal [`Self::object_ambient_bounced`]'s bit for bit
    /// (given the same `bounce`); an unused object's rows are its first pass or zero.
    pub fn object_ambient_reusing(&self, lighting: &Arc<UnitLighting>, poses: &[Pose], eye: Vec3, bounce: &Bounce, unused: &[bool], cache: &mut AmbientCache) -> Result<(ObjectAmbient, Vec<ObjectUse>), CutsError> {
        self.check_poses(poses)?;
        let n = self.cuts.objects.len();
        let own = !bounce.own.is_empty();
        if bounce.surfaces.len() != n || (own && bounce.own.len() != n) {
            return Err(CutsError::Operands(format!("bounce: {n} objects, {} surfaces, {} self gathers", bounce.surfaces.len(), bounce.own.len())));
        }
        let shown: Vec<bool> = (0..n).map(|k| !unused.get(k).copied().unwrap_or(false)).collect();
        let (eye_bits, sun_bits) = (bits3(eye), bounce.sun.map(bits3));
        let last = cache.last.take().filter(|l| Arc::ptr_eq(&l.lighting, lighting) && l.eye == eye_bits && l.sun == sun_bits && l.poses.len() == n);
        let moved: Vec<bool> = (0..n).map(|b| last.as_ref().is_none_or(|l| !same_pose(&l.poses[b], &poses[b]))).collect();
        // An unused object is needed as a source when its field reaches a shown object's vertex.
        let needed: Vec<bool> = (0..n)
            .map(|k| shown[k] || (0..n).any(|a| a != k && shown[a] && (0..self.vertex_count(a)).into_par_iter().any(|v| self.field_reaches(k, &poses[k], self.vertex_point(poses, a, v)))))
            .collect();

        // First pass, per object and vertex: reused where its object did not move and no moved
        // object reaches it at its old or new pose.
        let mut ambient = ObjectAmbient::default();
        let mut first: Vec<Option<Vec<(VertexAmbient, bool)>>> = Vec::with_capacity(n);
        let mut fields: Vec<Vec<Option<Occluders>>> = Vec::with_capacity(n);
        let mut uses = Vec::with_capacity(n);
        let mut all_reused = vec![false; n];
        let old_poses = std::mem::take(&mut cache.products.poses);
        let mut old_products = std::mem::take(&mut cache.products.objects);
        old_products.resize(n, None);
        let (budget, mut spent) = (cache.products.budget.0, 0usize);
        let mut products = Vec::with_capacity(n);
        let mut product_uses = Vec::with_capacity(n);
        for (k, old) in old_products.into_iter().enumerate().take(n) {
            let count = self.vertex_count(k);
            if !needed[k] {
                ambient.vertices.push(vec![[[0.0; 4]; 4]; count]);
                first.push(None);
                fields.push(Vec::new());
                uses.push(ObjectUse::Skipped);
                products.push(None);
                product_uses.push(ProductUse::default());
                continue;
            }
            let pass = self.first_pass(lighting, poses, eye, k, &moved, last.as_ref(), &old_poses, old)?;
            let bytes: usize = pass.products.iter().flatten().map(|p| p.bytes()).sum();
            let not_kept = (spent + bytes > budget).then(|| format!("its products need {bytes} bytes and the budget of {budget} bytes has {} left: not kept for the next frame", budget - spent));
            if not_kept.is_none() {
                spent += bytes;
            }
            product_uses.push(ProductUse { reused: pass.products_reused, walked: pass.walked, not_kept: not_kept.clone() });
            products.push(not_kept.is_none().then_some(pass.products));
            let (vals, occ, reused) = (pass.values, pass.fields, pass.reused);
            all_reused[k] = reused == count;
            uses.push(match shown[k] {
                true => ObjectUse::Shown { evaluated: count - reused, reused },
                false => ObjectUse::SourceOnly { evaluated: count - reused, reused },
            });
            ambient.outside_proxy_box += vals.iter().filter(|r| r.1).count();
            ambient.vertices.push(vals.iter().map(|r| r.0).collect());
            first.push(Some(vals));
            fields.push(occ);
        }

        // Radiance of the needed objects (the sources), reused with all of an object's vertices.
        let radiating = n > 1 || own;
        let radiance: Vec<Option<ObjectRadiance>> = (0..n)
            .map(|b| {
                if !radiating || !needed[b] {
                    return Ok(None);
                }
                match last.as_ref().and_then(|l| l.radiance[b].as_ref()).filter(|_| all_reused[b]) {
                    Some(r) => Ok(Some(r.clone())),
                    None => self.object_radiance(&ambient, poses, b, bounce).map(Some),
                }
            })
            .collect::<Result<_, _>>()?;

        // The light onto the shown objects: their own (self-bounce), then the others'.
        if own {
            self.add_self_bounce(&mut ambient, poses, eye, bounce, &shown, &radiance)?;
        }
        let clustered = self.add_others_bounce(&mut ambient, poses, eye, &shown, &radiance, last.as_ref(), &all_reused, &fields)?;
        cache.products.poses = poses.to_vec();
        cache.products.objects = products;
        cache.product_uses = product_uses;
        cache.last = Some(Last { lighting: lighting.clone(), eye: eye_bits, sun: sun_bits, poses: poses.to_vec(), first, radiance, clustered });
        Ok((ambient, uses))
    }
}
