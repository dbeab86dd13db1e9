//! Where the estimator may sample: the pixel map, the sample pool and the per-sun-direction state.
//!
//! # How it works
//! 1. **Pixel map** (once per camera pose). Every pixel's ray is cast against the proxy. A pixel
//!    is a *candidate* when it sees a marked diffuse surface and no *edge* lies within
//!    `edge_margin_px` (Chebyshev distance). An edge pixel has a 4-neighbour that sees nothing,
//!    another node, a normal more than [`CREASE_DEG`] away, or a point off its plane by more than
//!    [`OFF_PLANE_REL`] of the viewing distance (a silhouette in front of the same surface). The
//!    first hit along each ray already excludes surfaces hidden behind other proxy geometry.
//! 2. **Pool** (once per camera pose). Up to `pool_size` candidates are drawn uniformly at random
//!    (seeded) and given their albedo `ρ`, normal `n` and weighted-ambient factor `c`
//!    ([`crate::geometry::ambient`]). Each frame draws its N samples from this pool, so the
//!    expensive per-point integrals are paid once, not per frame.
//! 3. **Sun state** (when the sun has moved more than `sun_rebuild_deg`). For each pool entry:
//!    sun visibility `s` (a shadow ray), `max(n·l, 0)`, the optional sun-bounce factor, and a
//!    shadow-boundary test: the entry is left out when any of the 16 pixels on the square rings at
//!    Chebyshev radius `edge_margin_px` and half of it differs from it in sun visibility. The
//!    bounce follows the sun in slices across frames ([`super::rebuild`]), so a sun move never
//!    stalls a frame.

use super::EstimatorConfig;
use super::rebuild::{DirectTerms, Inputs, SlowTerms, assemble};
use crate::geometry::ambient::{TransportQuality, transport};
use crate::geometry::raycast::RayScene;
use crate::camera::View;
use glam::Vec3;
use rand::{SeedableRng, rngs::SmallRng, seq::index};
use rayon::prelude::*;
use std::f32::consts::PI;

/// Normals further apart than this (degrees) across neighbouring pixels make a crease edge.
pub const CREASE_DEG: f32 = 10.0;
/// Off-plane distance, relative to the viewing distance, that makes a depth edge.
pub const OFF_PLANE_REL: f32 = 0.01;
/// Pixels whose ray sees nothing.
pub(super) const NO_HIT: u32 = u32::MAX;
/// `max(n·l, 0)` below which a sunlit sample does not count as lit for the LMedS pairing.
pub const LIT_COS_MIN: f32 = 0.05;

/// First hits of every pixel and the candidate mask.
#[derive(Clone, Debug)]
pub struct PixelMap {
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// Triangle seen by each pixel, `u32::MAX` for none.
    pub tri: Vec<u32>,
    /// Hit point of each pixel.
    pub point: Vec<Vec3>,
    /// Facing normal of each pixel.
    pub normal: Vec<Vec3>,
    /// Candidate pixels (marked diffuse, away from edges).
    pub candidate: Vec<bool>,
    /// Pixels that see a marked diffuse surface at all.
    pub diffuse_pixels: usize,
}

impl PixelMap {
    /// Casts every pixel's ray (camera or equirect) and builds the candidate mask.
    pub fn build(view: View, scene: &RayScene, edge_margin_px: u32) -> Self {
        let (w, h) = view.size();
        let rows: Vec<Vec<(u32, Vec3, Vec3)>> = (0..h)
            .into_par_iter()
            .map(|y| {
                (0..w)
                    .map(|x| {
                        let hit = view
                            .ray(x, y)
                            .and_then(|(o, d)| scene.intersect(o.as_vec3(), d.as_vec3(), f32::MAX));
                        match hit {
                            Some(hit) => (hit.tri, hit.point, hit.normal),
                            None => (NO_HIT, Vec3::ZERO, Vec3::ZERO),
                        }
                    })
                    .collect()
            })
            .collect();
        let n = (w * h) as usize;
        let (mut tri, mut point, mut normal) = (Vec::with_capacity(n), Vec::with_capacity(n), Vec::with_capacity(n));
        for (t, p, nn) in rows.into_iter().flatten() {
            tri.push(t);
            point.push(p);
            normal.push(nn);
        }
        let eye = view.eye().as_vec3();
        let mesh = scene.mesh();
        let node = |i: usize| if tri[i] == NO_HIT { u32::MAX } else { mesh.tri_node[tri[i] as usize] };
        let cos_crease = CREASE_DEG.to_radians().cos();
        let continuous = |i: usize, j: usize| -> bool {
            if tri[i] == NO_HIT || tri[j] == NO_HIT || node(i) != node(j) {
                return false;
            }
            if normal[i].dot(normal[j]) < cos_crease {
                return false;
            }
            let dist = (point[i] - eye).length();
            normal[i].dot(point[j] - point[i]).abs() <= OFF_PLANE_REL * dist
        };
        let mut edge = vec![false; n];
        for y in 0..h as usize {
            for x in 0..w as usize {
                let i = y * w as usize + x;
                if x + 1 < w as usize && !continuous(i, i + 1) {
                    edge[i] = true;
                    edge[i + 1] = true;
                }
                if y + 1 < h as usize && !continuous(i, i + w as usize) {
                    edge[i] = true;
                    edge[i + w as usize] = true;
                }
            }
        }
        let near_edge = dilate(&edge, w as usize, h as usize, edge_margin_px as usize);
        let diffuse: Vec<bool> = (0..n).map(|i| tri[i] != NO_HIT && scene.is_diffuse(tri[i])).collect();
        let diffuse_pixels = diffuse.iter().filter(|&&d| d).count();
        // Pixels within the margin of the image border are left out too: their window is cut.
        let m = edge_margin_px as usize;
        let candidate = (0..n)
            .map(|i| {
                let (x, y) = (i % w as usize, i / w as usize);
                diffuse[i] && !near_edge[i] && x >= m && y >= m && x + m < w as usize && y + m < h as usize
            })
            .collect();
        Self { width: w, height: h, tri, point, normal, candidate, diffuse_pixels }
    }

    /// Number of candidate pixels.
    pub fn candidates(&self) -> usize {
        self.candidate.iter().filter(|&&c| c).count()
    }
}

/// Square-window binary dilation (separable running max) with radius `r`.
fn dilate(mask: &[bool], w: usize, h: usize, r: usize) -> Vec<bool> {
    if r == 0 {
        return mask.to_vec();
    }
    let mut tmp = vec![false; mask.len()];
    for y in 0..h {
        let row = &mask[y * w..(y + 1) * w];
        // prefix counts for O(1) window queries
        let mut pre = vec![0u32; w + 1];
        for x in 0..w {
            pre[x + 1] = pre[x] + row[x] as u32;
        }
        for x in 0..w {
            let (a, b) = (x.saturating_sub(r), (x + r + 1).min(w));
            tmp[y * w + x] = pre[b] > pre[a];
        }
    }
    let mut out = vec![false; mask.len()];
    for x in 0..w {
        let mut pre = vec![0u32; h + 1];
        for y in 0..h {
            pre[y + 1] = pre[y] + tmp[y * w + x] as u32;
        }
        for y in 0..h {
            let (a, b) = (y.saturating_sub(r), (y + r + 1).min(h));
            out[y * w + x] = pre[b] > pre[a];
        }
    }
    out
}

/// The sample pool: candidates with their sun-independent model inputs.
#[derive(Clone, Debug, Default)]
pub struct Pool {
    /// Pixel index (row-major) of each entry.
    pub pixel: Vec<u32>,
    /// Surface point.
    pub point: Vec<Vec3>,
    /// Facing normal.
    pub normal: Vec<Vec3>,
    /// Linear albedo.
    pub albedo: Vec<Vec3>,
    /// Weighted-ambient factor `c`.
    pub c: Vec<Vec3>,
    /// Ambient coefficient `ρ·c/π` per channel.
    pub a: Vec<[f32; 3]>,
    /// Proxy node seen by the entry.
    pub node: Vec<u32>,
}

impl Pool {
    /// Draws up to `size` candidates and integrates their `c`.
    pub fn build(map: &PixelMap, scene: &RayScene, size: usize, quality: TransportQuality, seed: u64) -> Self {
        let cands: Vec<u32> = (0..map.candidate.len() as u32).filter(|&i| map.candidate[i as usize]).collect();
        let mut rng = SmallRng::seed_from_u64(seed ^ 0x5eed_0001);
        let picked: Vec<u32> = if cands.len() <= size {
            cands
        } else {
            let mut v: Vec<u32> = index::sample(&mut rng, cands.len(), size).into_iter().map(|k| cands[k]).collect();
            v.sort_unstable();
            v
        };
        let entries: Vec<(Vec3, Vec3, Vec3, Vec3)> = picked
            .par_iter()
            .map(|&px| {
                let i = px as usize;
                let (p, n) = (map.point[i], map.normal[i]);
                let tri = map.tri[i];
                let albedo = scene.mesh().albedo(tri, scene.barycentric(tri, p));
                let t = transport(scene, p, n, None, quality, seed.wrapping_add(px as u64));
                (p, n, albedo, t.c)
            })
            .collect();
        let node = picked.iter().map(|&px| scene.mesh().tri_node[map.tri[px as usize] as usize]).collect();
        let mut pool = Pool { pixel: picked, node, ..Default::default() };
        for (p, n, albedo, c) in entries {
            pool.point.push(p);
            pool.normal.push(n);
            pool.albedo.push(albedo);
            pool.c.push(c);
            let a = albedo * c / PI;
            pool.a.push([a.x, a.y, a.z]);
        }
        pool
    }

    /// Number of entries.
    pub fn len(&self) -> usize {
        self.pixel.len()
    }

    /// True when empty.
    pub fn is_empty(&self) -> bool {
        self.pixel.is_empty()
    }
}

/// Per-sun-direction model inputs of the pool.
///
/// The entries a frame may draw from are split by sun visibility: frames draw half of their
/// samples from each class (or all of the smaller class and the rest from the other), a
/// stratified draw that keeps both `Pd` and `Pa` well determined even when shadow covers a small
/// part of the view.
#[derive(Clone, Debug, PartialEq)]
pub struct SunState {
    /// Sun direction this state was built for.
    pub dir: Vec3,
    /// Whether the sun was above the horizon.
    pub above_horizon: bool,
    /// Direct coefficient `ρ·(s·max(n·l,0) + b)/π` per entry and channel.
    pub b: Vec<[f32; 3]>,
    /// Entry is sunlit (`s = 1`, `n·l` ≥ [`LIT_COS_MIN`]).
    pub lit: Vec<bool>,
    /// Sunlit entries away from shadow boundaries.
    pub valid_lit: Vec<u32>,
    /// Unlit entries away from shadow boundaries.
    pub valid_unlit: Vec<u32>,
    /// Entries left out as near a shadow boundary.
    pub near_shadow_boundary: usize,
    /// Wall time of the frame's work on the sun-dependent terms that produced it, ms.
    pub build_ms: f64,
}

impl SunState {
    /// Entries frames may draw from.
    pub fn available(&self) -> usize {
        self.valid_lit.len() + self.valid_unlit.len()
    }

    /// Draws `n` distinct entries, stratified by sun visibility (see the type docs).
    pub fn draw(&self, n: usize, rng: &mut impl rand::Rng, out: &mut Vec<u32>) {
        draw_from(&self.valid_lit, &self.valid_unlit, n, rng, out);
    }

    /// [`SunState::draw`] among the entries whose `excluded` mask is false (the surface flags,
    /// `super::surface_flags`); with `None` it is [`SunState::draw`], draw for draw.
    pub fn draw_excluding(&self, n: usize, rng: &mut impl rand::Rng, out: &mut Vec<u32>, excluded: Option<&[bool]>) {
        let Some(x) = excluded else { return self.draw(n, rng, out) };
        let keep = |v: &[u32]| -> Vec<u32> { v.iter().copied().filter(|&e| !x.get(e as usize).copied().unwrap_or(false)).collect() };
        draw_from(&keep(&self.valid_lit), &keep(&self.valid_unlit), n, rng, out);
    }

    /// The valid entries, sunlit first.
    pub fn valid(&self) -> impl Iterator<Item = u32> + '_ {
        self.valid_lit.iter().chain(&self.valid_unlit).copied()
    }
}

/// `n` distinct entries, half from `lit` and half from `unlit` when both have enough (all of the
/// smaller class and the rest from the other otherwise).
fn draw_from(lit: &[u32], unlit: &[u32], n: usize, rng: &mut impl rand::Rng, out: &mut Vec<u32>) {
    out.clear();
    let (nl, nu) = (lit.len(), unlit.len());
    let n = n.min(nl + nu);
    let take_lit = (n / 2).max(n.saturating_sub(nu)).min(nl);
    let take_unlit = n - take_lit;
    out.extend(index::sample(rng, nl, take_lit).into_iter().map(|k| lit[k]));
    out.extend(index::sample(rng, nu, take_unlit).into_iter().map(|k| unlit[k]));
}

impl SunState {
    /// Builds the state for sun direction `l` (unit, toward the sun) whole: the direct terms
    /// and the bounce of every entry for `l` (a frame's state comes from `super::rebuild`, which
    /// may serve an earlier sun's bounce while it re-traces; once it has, it equals this).
    pub fn build(map: &PixelMap, pool: &Pool, scene: &RayScene, l: Vec3, above_horizon: bool, cfg: &EstimatorConfig) -> Self {
        let t0 = std::time::Instant::now();
        let inp = Inputs { map, pool, scene, cfg, sky: None };
        let (direct, _, _) = DirectTerms::trace(&inp, l, above_horizon);
        let (slow, _) = SlowTerms::full(&inp, l, above_horizon);
        let mut st = assemble(pool, &direct, &slow.bounce);
        st.build_ms = t0.elapsed().as_secs_f64() * 1e3;
        st
    }
}

#[cfg(test)]
mod tests {
    use super::dilate;

    #[test]
    fn dilation_is_a_square_window() {
        let (w, h) = (9, 7);
        let mut m = vec![false; w * h];
        m[3 * w + 4] = true;
        let d = dilate(&m, w, h, 2);
        for y in 0..h {
            for x in 0..w {
                let inside = (x as i32 - 4).abs() <= 2 && (y as i32 - 3).abs() <= 2;
                assert_eq!(d[y * w + x], inside, "({x},{y})");
            }
        }
    }
}
