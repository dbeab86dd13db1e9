//! A real receiver's light by direction, as the receiver itself sees it, so that an object takes
//! from the receiver's `c` and `b` the light that really came from where it stands (issue 15 §3,
//! the contact region at the wall; *not in the paper*: cyberworlds §V-A.4,
//! `../shared/papers/cyberworlds-captured-lighting-cuts.txt`, weighs a receiver's visibility by
//! the distant environment map alone).
//!
//! # Why
//! [`super::receivers`] darkens a receiver by `V = Σ_k w_k v_k / Σ_k w_k`, the share of its sky
//! light the objects leave, with `w` the whole sky's light per unit `Pa` on its normal. At the
//! foot of a wall the wall already hides half of that sky: the receiver's `c` holds only the
//! half it sees (and the wall's own light), so an object that hides a tenth of the *whole* sky
//! from it takes a fifth of its `c`, not a tenth. The same receiver's sun bounce `b` comes from
//! the sunlit wall and paving beside it, not from the sky, and an object hides it only where it
//! stands between them.
//!
//! # How it works
//! At depth [`super::local_sun::LOCAL_DEPTH`] of the direction tree (`2^8` nodes, 0.05 sr each)
//! one ray per node above the receiver's tangent plane, from the receiver's point, against the
//! proxy ([`super::local_sun::LocalFrame::radiance`], the objects left out):
//! - **it escapes**: the node's weight per unit `Pa` is the sky's, `w_K = Σ_{j∈K} lum(l_j)·max(n·ω_j, 0)`
//!   (the weights `V` uses); nothing per unit `Pd`;
//! - **it hits the proxy** at `p`: `lum(L_a(p))·Ω_K·max(n·ω_K, 0)` per unit `Pa` and
//!   `lum(L_d(p))·Ω_K·max(n·ω_K, 0)` per unit `Pd`, with `L_a = ρ/π·c(p)`, `L_d = ρ/π·(s·cos + b(p))`
//!   the proxy's light as `super::local_sun` takes it for a vertex.
//!
//! A node deeper than `2^8` takes its ancestor's weight in the share of its leaves, a shallower
//! one the sum under it (prefix sums, as `super::local_sun::Deltas`). Then with the objects'
//! product `v` the receiver keeps `Σ_k A_k v_k / Σ A` of its `c` and `Σ_k B_k v_k / Σ B` of its
//! `b` ([`LightLeft`]); a receiver with no bounce light keeps of `b` what it keeps of `c`.
//!
//! **What the objects show instead.** Where an object hides the receiver's light it shows its
//! own surface, lit by the sky and the sun: the traced `c_v`, `b_v` carry it (the statue's sunlit
//! side lights the paving at its foot; at the courtyard's statue in the sun it gives back about
//! two thirds of the light the statue hides). The receiver adds `H·L_o` per unit `Pa` and per
//! unit `Pd`: `H = Σ_k Ω_k max(n·ω_k, 0)(1 − v_k)` the projected solid angle the product hides,
//! and `L_o` the nearest reaching object's outgoing radiance ([`ObjectsSeen`]: the per-vertex
//! radiance of `super::bounce`, merged into patches and averaged over those facing the receiver,
//! weighted by the projected solid angle each subtends there).
//!
//! In a turned object's frame (the product is there, `super::receivers`) the rays go along the
//! nodes' directions turned into the world, and the sky weights are those pushed into that frame.
//!
//! Measured (`tests/suite/object_cuts*.rs`, debug build): the contact region's relative RMSE
//! against the trace at the wall's foot 11.1% → 7.19% with the receiver's own light, → 2.95% with
//! the objects' light and the near field traced (`super::receivers::near_cut`); on open paving
//! 6.2% → 2.17%, turned 6.3% / 6.9% → 1.94% / 2.40%, two statues 6.3% → 1.82%.
//!
//! # Limits
//! A shadow edge within a node is taken at its centre ray. The proxy's `c` at a hit does not
//! know the objects; the objects' light on a receiver does not know which of their parts hide
//! each other, nor which object hides what where two reach it (the nearest one's light is
//! taken). The receivers' light by direction is kept per receiver while the proxy's light holds
//! (the sun's planes); the objects' light is taken fresh where a receiver is evaluated, and kept
//! with its value (`render::compositor`'s `cut_cache`) while no moved object reaches it.
//! The frame loop's outdoor path only: without the proxy's light by texel (the captured-VEM mode,
//! the compute pass) a receiver keeps `V` of both, the sky's share.

pub use crate::geometry::proxy_light::LightLeft;
use super::bounce::ObjectRadiance;
use super::lighting::ReceiverWeights;
use super::local_sun::{LOCAL_DEPTH, LocalFrame, depth_rows};
use super::products::ReceiverProduct;
use super::tree::DirectionTree;
use glam::{Mat3, Vec3};

/// Rec. 709 luminance.
fn lum(c: Vec3) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

/// One receiver's weights per node at depth `D` (module docs), as prefix sums over the `2^D`
/// nodes (heap order from the depth's first node).
#[derive(Clone, Debug, PartialEq)]
pub struct ReceiverLight {
    depth: u32,
    ambient: Box<[f32]>,
    bounce: Box<[f32]>,
    /// The projected solid angle `Ω_K·max(n·ω_K, 0)` (what an object standing there shows).
    cosine: Box<[f32]>,
}

impl ReceiverLight {
    /// Traces the receiver at `x` with unit normal `n` (world) against `local`'s proxy; `sky`
    /// holds the sky weights of `n` in the frame the product will be in, `rotation` turns that
    /// frame into the world (`None`: the world's own).
    pub fn trace(local: &LocalFrame, tree: &DirectionTree, sky: &ReceiverWeights, rotation: Option<Mat3>, x: Vec3, n: Vec3) -> Self {
        let depth = LOCAL_DEPTH.min(tree.levels());
        let count = 1usize << depth;
        let first = count - 1;
        let omega = 4.0 * std::f32::consts::PI / count as f32;
        let (mut ambient, mut bounce, mut cosine) = (vec![0.0f32; count + 1], vec![0.0f32; count + 1], vec![0.0f32; count + 1]);
        let origin = x + n * 2e-3;
        for j in 0..count {
            let k = first + j;
            let d = tree.node_dir(k);
            let w = rotation.map_or(d, |r| r * d).normalize_or(Vec3::Y);
            let cos = n.dot(w);
            let (a, b) = if cos <= 0.0 {
                // Below the tangent plane: the sky weights are zero there too, but for the
                // leaves of a node that straddles the plane.
                (sky.node(k), 0.0)
            } else {
                match local.radiance(origin, w) {
                    Some((la, ld)) => (lum(la) * omega * cos, lum(ld) * omega * cos),
                    None => (sky.node(k), 0.0),
                }
            };
            ambient[j + 1] = ambient[j] + a;
            bounce[j + 1] = bounce[j] + b;
            cosine[j + 1] = cosine[j] + omega * cos.max(0.0);
        }
        Self { depth, ambient: ambient.into(), bounce: bounce.into(), cosine: cosine.into() }
    }

    /// The rows of heap node `k` at depth `D`, and its share of them.
    fn rows(&self, k: usize) -> (usize, usize, f32) {
        depth_rows(self.depth, k)
    }

    /// Weights of heap node `k` per unit `Pa` and `Pd` (module docs).
    fn node(&self, k: usize) -> (f32, f32) {
        let (j0, j1, share) = self.rows(k);
        ((self.ambient[j1] - self.ambient[j0]) * share, (self.bounce[j1] - self.bounce[j0]) * share)
    }

    /// The projected solid angle the objects' product `p` hides from the receiver, sr (0 where
    /// no field entered it).
    pub fn hidden(&self, p: &ReceiverProduct) -> f32 {
        if !p.occluded {
            return 0.0;
        }
        let mut open = 0.0f64;
        for (&k, &v) in p.ids.iter().zip(p.values.iter()) {
            let (j0, j1, share) = self.rows(k as usize);
            open += ((self.cosine[j1] - self.cosine[j0]) * share * v) as f64;
        }
        (self.cosine[self.cosine.len() - 1] as f64 - open).max(0.0) as f32
    }

    /// The receiver's total weights per unit `Pa` and `Pd`.
    pub fn totals(&self) -> (f32, f32) {
        let last = self.ambient.len() - 1;
        (self.ambient[last], self.bounce[last])
    }

    /// What the receiver keeps with the objects' product `p` (module docs): all of it where no
    /// object's field entered the product.
    pub fn left(&self, p: &ReceiverProduct) -> LightLeft {
        let (ta, tb) = self.totals();
        if !p.occluded || ta <= 0.0 {
            return LightLeft::ALL;
        }
        let (mut a, mut b) = (0.0f64, 0.0f64);
        for (&k, &v) in p.ids.iter().zip(p.values.iter()) {
            let (wa, wb) = self.node(k as usize);
            a += (wa * v) as f64;
            b += (wb * v) as f64;
        }
        let ambient = ((a / ta as f64) as f32).clamp(0.0, 1.0);
        let bounce = if tb > 0.0 { ((b / tb as f64) as f32).clamp(0.0, 1.0) } else { ambient };
        LightLeft { ambient, bounce, ..LightLeft::ALL }
    }

    /// Bytes it takes kept.
    pub fn bytes(&self) -> usize {
        64 + 4 * (self.ambient.len() + self.bounce.len() + self.cosine.len())
    }
}

/// Patches per bounding radius along each axis when an object's vertices are merged for
/// [`ObjectsSeen`] (cells of `r/6`: about a hundred patches over a statue's surface).
const PATCHES_PER_RADIUS: f32 = 6.0;

/// A patch of an object's surface: area, area-weighted centre and normal (not unit), and the
/// mean radiance per unit `Pa` and `Pd`.
#[derive(Clone, Copy, Debug)]
struct Patch {
    area: f32,
    point: Vec3,
    normal: Vec3,
    pa: Vec3,
    pd: Vec3,
}

/// What each object shows a receiver near it: its surface's outgoing radiance per unit `Pa` and
/// `Pd` (`super::bounce::ObjectRadiance`, the light the objects reflect onto each other) averaged
/// over the patches that face the receiver, weighted by the projected solid angle each subtends
/// there (`A·cos θ_p·cos θ_x / d²`; the object's own parts hiding each other are left out).
/// The vertices are merged into patches (cells of `r/6` and the dominant axis of the normal) once
/// per frame.
#[derive(Clone, Debug, Default)]
pub struct ObjectsSeen {
    /// Per object: its bounding sphere's centre (world) and its patches.
    objects: Vec<(Vec3, Vec<Patch>)>,
}

impl ObjectsSeen {
    /// Patches of each object from its vertices' world `positions`, its `radiance` (world frame),
    /// its bounding sphere's centre and radius.
    pub fn new(objects: &[(Vec3, f32, &[Vec3], &ObjectRadiance)]) -> Self {
        let objects = objects.iter().map(|(centre, radius, positions, r)| (*centre, patches(*centre, *radius, positions, r))).collect();
        Self { objects }
    }

    /// Object `b`'s radiance per unit `Pa` and `Pd` as the receiver at `x` with unit normal `n`
    /// sees it (zero when no patch faces it, or for an unknown object).
    pub fn seen_from(&self, b: usize, x: Vec3, n: Vec3) -> (Vec3, Vec3) {
        let Some((_, patches)) = self.objects.get(b) else { return (Vec3::ZERO, Vec3::ZERO) };
        let (mut pa, mut pd, mut w) = (Vec3::ZERO, Vec3::ZERO, 0.0f32);
        for p in patches {
            let to = p.point - x;
            let d2 = to.length_squared();
            if d2 <= 1e-12 {
                continue;
            }
            // `normal` is area-weighted: `−normal·to/|to|` is `A·cos θ_p`.
            let (facing, cos_x) = (-p.normal.dot(to), n.dot(to));
            if facing <= 0.0 || cos_x <= 0.0 {
                continue;
            }
            let weight = facing * cos_x / (d2 * d2);
            pa += p.pa * weight;
            pd += p.pd * weight;
            w += weight;
        }
        if w > 0.0 { (pa / w, pd / w) } else { (Vec3::ZERO, Vec3::ZERO) }
    }

    /// The centre of object `b` (world).
    pub fn centre(&self, b: usize) -> Option<Vec3> {
        self.objects.get(b).map(|o| o.0)
    }
}

/// An object's vertices merged into [`Patch`]es (see [`ObjectsSeen`]).
fn patches(centre: Vec3, radius: f32, positions: &[Vec3], r: &ObjectRadiance) -> Vec<Patch> {
    let cell = (radius / PATCHES_PER_RADIUS).max(1e-3);
    let mut cells: std::collections::HashMap<([i32; 3], u8), Patch> = std::collections::HashMap::new();
    for (y, p) in positions.iter().enumerate() {
        let (Some(n), Some(a), Some(pa), Some(pd)) = (r.normals.get(y), r.area_m2.get(y), r.pa.get(y), r.pd.get(y)) else { break };
        if !(*a > 0.0) || !p.is_finite() {
            continue;
        }
        let q = ((*p - centre) / cell).floor();
        let axis = n.abs().max_position() as u8 * 2 + u8::from(n[n.abs().max_position()] < 0.0);
        let e = cells.entry(([q.x as i32, q.y as i32, q.z as i32], axis)).or_insert(Patch { area: 0.0, point: Vec3::ZERO, normal: Vec3::ZERO, pa: Vec3::ZERO, pd: Vec3::ZERO });
        e.area += a;
        e.point += *p * *a;
        e.normal += *n * *a;
        e.pa += *pa * *a;
        e.pd += *pd * *a;
    }
    let mut out: Vec<Patch> = cells
        .into_values()
        .map(|e| Patch { area: e.area, point: e.point / e.area, normal: e.normal, pa: e.pa / e.area, pd: e.pd / e.area })
        .collect();
    // A fixed order, so that the sums do not depend on the hash map's.
    out.sort_by(|a, b| a.point.x.total_cmp(&b.point.x).then(a.point.y.total_cmp(&b.point.y)).then(a.point.z.total_cmp(&b.point.z)));
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cuts::frame::UnitLighting;
    use crate::cuts::local_sun::{LocalSun, ProxyLight};
    use crate::cuts::shapes;
    use crate::geometry::raycast::RayScene;
    use std::sync::Arc;

    /// A product that keeps the leaves `keep` says (value 1) and hides the others (left out:
    /// zero), leaf by leaf.
    fn product(tree: &DirectionTree, keep: impl Fn(Vec3) -> bool) -> ReceiverProduct {
        let first = tree.leaf_count() - 1;
        let ids: Vec<u16> = tree.leaf_dirs().iter().enumerate().filter(|(_, d)| keep(**d)).map(|(j, _)| (first + j) as u16).collect();
        let values = vec![1.0; ids.len()];
        ReceiverProduct { frame: None, occluded: true, ids: ids.into(), values: values.into() }
    }

    /// Ground at the foot of a tall sunlit wall (albedo 0.5, `c = 0.5` on it) under the uniform
    /// sky: the receiver sees sky on the open side (weight 1/2 of the unoccluded ground's 1)
    /// and the wall on the other (`ρ/π·c·π/2 = 0.125` per unit `Pa`, `ρ/π·cos·π/2 = 0.177` per
    /// unit `Pd` with the sun at 45°). An object hiding the open side leaves `0.125/0.625 = 0.2`
    /// of `c` and all of `b` (the sky's weights alone would say 1/2 of both); one hiding the
    /// wall leaves 0.8 of `c` and none of `b`. Within 3 points: one ray per 0.05 sr node.
    #[test]
    fn a_receiver_at_a_walls_foot_loses_the_light_of_the_side_an_object_hides() {
        let tree = DirectionTree::new(10).unwrap();
        let proxy = Arc::new(RayScene::new(shapes::wall(-200.0, 200.0, 400.0, -0.5)));
        let sun = Vec3::new(0.0, 1.0, 1.0).normalize();
        let (w, h) = (16, 8);
        let texels = ProxyLight { width: w, height: h, centre: Vec3::new(0.0, 1.0, 5.0), sun, pa: vec![Vec3::splat(0.5); (w * h) as usize], pd: vec![Vec3::ZERO; (w * h) as usize], ray: proxy };
        let local = LocalFrame::new(Arc::new(LocalSun { texels, objects: Vec::new() }), &[]);
        let sky = UnitLighting::uniform_sky(&tree).sky_pa;
        let weights = ReceiverWeights::new(&tree, &sky, Vec3::Y).unwrap();
        let light = ReceiverLight::trace(&local, &tree, &weights, None, Vec3::ZERO, Vec3::Y);
        let (ta, tb) = light.totals();
        let bounce = 0.5 * std::f32::consts::FRAC_1_SQRT_2 / 2.0;
        assert!((ta - 0.625).abs() < 0.03 && (tb - bounce).abs() < 0.03 * bounce / 0.177, "totals {ta} {tb}");
        let open_hidden = light.left(&product(&tree, |d| d.z < 0.0));
        assert!((open_hidden.ambient - 0.2).abs() < 0.03 && open_hidden.bounce > 0.97, "{open_hidden:?}");
        let wall_hidden = light.left(&product(&tree, |d| d.z >= 0.0));
        assert!((wall_hidden.ambient - 0.8).abs() < 0.03 && wall_hidden.bounce < 0.03, "{wall_hidden:?}");
        // Nothing in the way: all of it; the sky's weights alone give the same for both.
        let none = ReceiverProduct { frame: None, occluded: false, ids: Box::new([]), values: Box::new([]) };
        assert_eq!(light.left(&none), LightLeft::ALL);
        assert_eq!(light.hidden(&none), 0.0);
        // The projected solid angle hidden: half of the hemisphere's π either way.
        for hidden in [light.hidden(&product(&tree, |d| d.z < 0.0)), light.hidden(&product(&tree, |d| d.z >= 0.0))] {
            assert!((hidden - std::f32::consts::FRAC_PI_2).abs() < 0.05, "{hidden}");
        }
    }

    /// One patch of radiance `(a, d)` facing the receiver is what it sees, whatever its size;
    /// patches facing away, or behind the receiver's tangent plane, show nothing; two patches
    /// facing it mix by the projected solid angle each subtends (`A·cos θ_p·cos θ_x / d²`).
    #[test]
    fn objects_show_the_radiance_of_the_patches_facing_a_receiver() {
        let one = |n: Vec3, pa: f32| ObjectRadiance { normals: vec![n], area_m2: vec![0.01], pa: vec![Vec3::splat(pa)], pd: vec![Vec3::splat(2.0 * pa)], ..ObjectRadiance::default() };
        let facing = one(Vec3::NEG_X, 0.3);
        let seen = ObjectsSeen::new(&[(Vec3::new(1.0, 0.5, 0.0), 0.5, &[Vec3::new(1.0, 0.5, 0.0)], &facing)]);
        let (a, d) = seen.seen_from(0, Vec3::ZERO, Vec3::Y);
        assert!((a - Vec3::splat(0.3)).abs().max_element() < 1e-6 && (d - Vec3::splat(0.6)).abs().max_element() < 1e-6, "{a} {d}");
        // Facing away (+x, the receiver at −x of it), or below the receiver's plane.
        let away = one(Vec3::X, 0.3);
        let seen = ObjectsSeen::new(&[(Vec3::new(1.0, 0.5, 0.0), 0.5, &[Vec3::new(1.0, 0.5, 0.0)], &away)]);
        assert_eq!(seen.seen_from(0, Vec3::ZERO, Vec3::Y), (Vec3::ZERO, Vec3::ZERO));
        let seen = ObjectsSeen::new(&[(Vec3::new(1.0, -0.5, 0.0), 0.5, &[Vec3::new(1.0, -0.5, 0.0)], &facing)]);
        assert_eq!(seen.seen_from(0, Vec3::ZERO, Vec3::Y), (Vec3::ZERO, Vec3::ZERO));
        // Two patches, 1 m and 2 m off along x at the same height ratio: at (1, 1) and (2, 2)
        // they subtend A·cos θ_p·cos θ_x/d² = A·(1/√2)(1/√2)/2 and A·(1/√2)(1/√2)/8: weights 4 : 1.
        let two = ObjectRadiance {
            normals: vec![Vec3::new(-1.0, -1.0, 0.0).normalize(); 2],
            area_m2: vec![0.01; 2],
            pa: vec![Vec3::splat(1.0), Vec3::splat(0.0)],
            pd: vec![Vec3::ZERO; 2],
            ..ObjectRadiance::default()
        };
        let points = [Vec3::new(1.0, 1.0, 0.0), Vec3::new(2.0, 2.0, 0.0)];
        let seen = ObjectsSeen::new(&[(Vec3::new(1.5, 1.5, 0.0), 2.0, &points, &two)]);
        let (a, _) = seen.seen_from(0, Vec3::ZERO, Vec3::Y);
        assert!((a.x - 0.8).abs() < 1e-5, "{a}");
    }
}
