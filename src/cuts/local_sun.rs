//! The proxy's light as each vertex sees it, not as the map's capture point does (issue 15 §3,
//! the static case; *not in the paper*: cyberworlds §V, Eq. 3,
//! `../shared/papers/cyberworlds-captured-lighting-cuts.txt`, lights every vertex with the one
//! distant environment map, and Jensen's relit map, `../shared/papers/jensen-outdoor-ar-ibl.txt`
//! §4.2, is that map seen from its capture centre).
//!
//! # Why
//! The cuts light an object with the relit map's surface texels as *distant* light
//! (`super::frame`): along a direction `ω` a vertex gets the radiance of the proxy point the
//! capture centre sees along `ω`. Near a wall or the object's own foot the point the vertex
//! really sees along `ω` is another one: the paving at the pedestal's foot in the wall's sun
//! shadow (or in the statue's own), where the map shows sunlit paving metres away; the wall's
//! face above the horizon, where the map shows sky (the proxy field then closes the sky and
//! nothing takes its place). The traced per-pixel transfer (`crate::render::object_transfer`)
//! sees the true point.
//!
//! # How it works
//! - **Per vertex, per coarse direction.** At depth [`LOCAL_DEPTH`] of the direction tree
//!   (`2^8` nodes, 0.05 sr each), one ray per node from the vertex (its world point, the node's
//!   representative direction turned into the world) against the proxy. At the hit `p` (normal
//!   `n_p` facing the vertex, the proxy's albedo `ρ_p` as the traced transfer takes it) the
//!   radiance arriving from `p` is, per unit `Pd`, `ρ_p/π·(s(p)·max(n_p·l, 0) + b(p))` with
//!   `s(p)` a shadow ray to the sun against the proxy *and the objects at this frame's poses*,
//!   and per unit `Pa`, `ρ_p/π·c(p)`. The smooth factors `c` and `b` (sky visibility and the
//!   sun's bounce at the point) are the bake's and the relighter's at the texel that shows `p`
//!   from the capture centre (`crate::envmap::relight::Relighter::local_light`); where the
//!   capture centre does not see `p` that texel shows a point in front of it, whose `c` and `b`
//!   stand in.
//! - **Into the cut sums.** Node `K` of the map's lighting holds `l_K` (Eq. 3); the vertex's
//!   own holds `L(p)·Ω_K`. Their difference `δ_K` goes to the product's nodes: a node below `K`
//!   takes `δ_K` in the share of its leaves, a node above the sum of the `δ` under it; the
//!   cosine-folded product values `v_k` and the specular factor are those of the first pass
//!   (`super::frame::add_node`). A node whose ray misses the proxy keeps the map's value.
//! - **Only in the frame loop's outdoor path** (`crate::run::motion_cuts`, `UnitLighting::local`):
//!   the compute pass and the captured-VEM mode keep the map's light.
//!
//! # Limits
//! One ray per 0.05 sr node: a shadow edge within a node is taken at its centre. `c` at `p` does
//! not know the objects (the statue hides sky from the paving at its foot). Rays that miss the
//! proxy keep the map's light. The cost is about `2^8` rays and half as many shadow rays per
//! vertex evaluated.
//!
//! Measured (`tests/suite/object_cuts_static.rs`, docs/measurements.md, "The proxy's light per
//! vertex"): the unmoved statue against its traced transfer 7.35% → 2.22% (depth 7: 2.37%), at
//! the wall's foot 9.93% → 4.74%, with the bounce sources' sun shadow traced too
//! (`super::bounce`).

use super::frame::UnitLighting;
use super::lighting::{ClusteredLighting, MIN_BRDF_COS};
use super::rotate::Pose;
use super::tree::DirectionTree;
use crate::geometry::Mesh;
use crate::geometry::equirect::texel_index;
pub use crate::geometry::proxy_light::ProxyLight;
use crate::geometry::raycast::RayScene;
use glam::Vec3;
use std::f32::consts::FRAC_1_PI;
use std::sync::Arc;

/// Depth of the tree at which each vertex traces its directions.
pub const LOCAL_DEPTH: u32 = 8;

/// Whether the light per unit `Pa` is taken locally too (else the per unit `Pd` only).
const LOCAL_PA: bool = true;

/// Below `n·ω` under this a node lies wholly below the vertex's tangent plane (its cosine-folded
/// self-visibility is zero there): no ray.
const BELOW: f32 = -0.45;

/// The map's texels as light arriving at their points, the proxy, and the objects' meshes in
/// their cuts' frame (for their shadows on the proxy).
pub struct LocalSun {
    /// The relighter's texels.
    pub texels: ProxyLight,
    /// Per object, its mesh in the frame its cuts were computed in.
    pub objects: Vec<Arc<Mesh>>,
}

impl std::fmt::Debug for LocalSun {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LocalSun").field("sun", &self.texels.sun).field("objects", &self.objects.len()).finish()
    }
}

impl PartialEq for LocalSun {
    fn eq(&self, other: &Self) -> bool {
        std::ptr::eq(self, other)
    }
}

/// [`LocalSun`] for one frame's poses: the objects placed, for the shadow rays.
pub struct LocalFrame {
    sun: Arc<LocalSun>,
    shadows: Option<RayScene>,
}

impl LocalFrame {
    /// The objects placed at `poses` (cut frame → world).
    pub fn new(sun: Arc<LocalSun>, poses: &[Pose]) -> Self {
        let mut all: Option<Mesh> = None;
        for (mesh, pose) in sun.objects.iter().zip(poses) {
            let mut m = (**mesh).clone();
            for p in &mut m.positions {
                *p = pose.point(*p);
            }
            match &mut all {
                Some(a) => a.append(&m),
                None => all = Some(m),
            }
        }
        Self { shadows: all.filter(|m| !m.triangles.is_empty()).map(RayScene::new), sun }
    }

    /// Light per unit `Pa` and per unit `Pd` arriving at `x` along world direction `w` from the
    /// proxy (module docs); `None` when the ray misses it.
    pub(super) fn radiance(&self, x: Vec3, w: Vec3) -> Option<(Vec3, Vec3)> {
        let t = &self.sun.texels;
        let hit = t.ray.intersect(x, w, f32::MAX)?;
        let rho = t.ray.albedo(&hit) * FRAC_1_PI;
        let (p, n, l) = (hit.point, hit.normal, t.sun);
        let cos = n.dot(l).max(0.0);
        let lit = cos > 0.0 && t.ray.sees_direction(p, n, l) && !self.shadows.as_ref().is_some_and(|s| s.occluded(p + n * 1e-3, l, f32::MAX));
        let i = texel_index((p - t.centre).normalize_or(w), t.width, t.height);
        let (c, b) = (t.pa.get(i).copied().unwrap_or(Vec3::ZERO), t.pd.get(i).copied().unwrap_or(Vec3::ZERO));
        Some((rho * c, rho * (Vec3::splat(if lit { cos } else { 0.0 }) + b)))
    }

    /// Per node at depth `D = min(LOCAL_DEPTH, levels)` (in heap order from its first node), the
    /// difference `δ_K` per unit `Pa` and per unit `Pd` between the light vertex `x` (world;
    /// normal `n` in its object's frame) sees along the node and the map's `l_K` (module docs),
    /// as prefix sums (`D`'s node count + 1 entries).
    pub fn deltas(&self, tree: &DirectionTree, lighting: &UnitLighting, pose: &Pose, x: Vec3, n: Vec3) -> Deltas {
        let depth = LOCAL_DEPTH.min(tree.levels());
        let count = 1usize << depth;
        let first = count - 1;
        let omega = 4.0 * std::f32::consts::PI / count as f32;
        let (mut pa, mut pd) = (vec![Vec3::ZERO; count + 1], vec![Vec3::ZERO; count + 1]);
        let origin = x + pose.dir(n) * 2e-3;
        for j in 0..count {
            let k = first + j;
            let d = tree.node_dir(k);
            let (mut a, mut b) = (Vec3::ZERO, Vec3::ZERO);
            if n.dot(d) >= BELOW
                && let Some((la, ld)) = self.radiance(origin, pose.dir(d).normalize_or(Vec3::Y))
            {
                let map = |l: &Option<ClusteredLighting>| l.as_ref().map_or(Vec3::ZERO, |l| l.node(k));
                if LOCAL_PA {
                    a = la * omega - map(&lighting.surface_pa);
                }
                b = ld * omega - map(&lighting.surface_pd);
            }
            pa[j + 1] = pa[j] + a;
            pd[j + 1] = pd[j] + b;
        }
        Deltas { depth, pa, pd }
    }
}

/// The rows `[j0, j1)` of a table over the `2^depth` nodes at `depth` (heap order from the
/// depth's first node) that heap node `k` covers, and its share of them: a node deeper than
/// `depth` takes `2^-up` of its ancestor's row, a shallower one the rows under it whole.
pub(super) fn depth_rows(depth: u32, k: usize) -> (usize, usize, f32) {
    let d = usize::BITS - 1 - (k + 1).leading_zeros();
    let first = (1usize << depth) - 1;
    if d >= depth {
        let up = d - depth;
        let j = ((k + 1) >> up) - 1 - first;
        (j, j + 1, 1.0 / (1u32 << up) as f32)
    } else {
        let down = depth - d;
        let j0 = ((k + 1) << down) - 1 - first;
        (j0, j0 + (1usize << down), 1.0)
    }
}

/// One vertex's `δ_K` as prefix sums ([`LocalFrame::deltas`]).
pub struct Deltas {
    depth: u32,
    pa: Vec<Vec3>,
    pd: Vec<Vec3>,
}

impl Deltas {
    /// `δ` of heap node `k` per unit `Pa` and `Pd`: a share of its ancestor's at depth `D`, or
    /// the sum of its descendants' there.
    fn node(&self, k: usize) -> (Vec3, Vec3) {
        let (j0, j1, share) = depth_rows(self.depth, k);
        ((self.pa[j1] - self.pa[j0]) * share, (self.pd[j1] - self.pd[j0]) * share)
    }

    /// The changes of `(E_n, E_r)` per unit `Pa` and per unit `Pd` over a product's nodes
    /// (`(heap ids, values)`, the surface part), with the reflected direction `r` (object frame).
    pub fn sums(&self, tree: &DirectionTree, (ids, values): (&[u16], &[f32]), n: Vec3, r: Vec3) -> [(Vec3, Vec3); 2] {
        let mut out = [(Vec3::ZERO, Vec3::ZERO); 2];
        for (&k, &v) in ids.iter().zip(values) {
            let k = k as usize;
            let (a, b) = self.node(k);
            if a == Vec3::ZERO && b == Vec3::ZERO {
                continue;
            }
            let dir = tree.node_dir(k);
            let spec = r.dot(dir).max(0.0) / n.dot(dir).max(MIN_BRDF_COS);
            out[0].0 += a * v;
            out[0].1 += a * v * spec;
            out[1].0 += b * v;
            out[1].1 += b * v * spec;
        }
        out
    }
}
