//! Temporally coherent median cut (issue 14, `--sampler coherent-cut`): Debevec's median cut
//! (*A median cut algorithm for light probe sampling*, SIGGRAPH 2005 poster; the baseline of
//! Havran §2) rebuilt so that a light keeps its index and moves continuously from frame to frame,
//! and so that the temporal FIR of Havran §3.3 (`../shared/papers/havran-2005-video-environment-maps.txt`)
//! can follow each light.
//!
//! # How it works
//! - **Energy.** Texel `(i, j)` carries `e_ij = Y_ij · ΔΩ_j` (luminance × its exact solid angle
//!   `Δφ·(cos θ_j − cos θ_j+1)`: the cos-latitude weighting). Summed-area tables hold `e`, the
//!   RGB energy `L·ΔΩ` and the direction-weighted energy `e·d_ij` (`d_ij` the texel's centre
//!   direction). The map is taken as constant over each texel, so the energy of any rectangle
//!   with *fractional* corners is the bilinear interpolation of the tables at its corners
//!   (exact for a piecewise-constant map), and a region's energy is a continuous function of
//!   its bounds.
//! - **A fixed tree.** For `N` lights the tree is the complete binary tree in heap order: inner
//!   nodes `1 … N−1`, leaves `N … 2N−1` (node `v`'s children are `2v`, `2v+1`). It depends on `N`
//!   only, never on the map, so no priority queue reorders anything from frame to frame.
//! - **Equal-energy cuts.** Node `v` with `n_v` leaves below it is cut, across one axis, at the
//!   continuous position where the energy on the low side is `E_v · n_2v / n_v` (bisection over
//!   the texel boundaries, then linear inside the texel, where the energy is linear). Every leaf
//!   therefore holds `P/N` of the map's power `P` exactly, as the FIR's equal sharing assumes
//!   ([`crate::vem::fir`]), and a small change of the map moves every cut a little. A black node
//!   is cut at the same fraction of its extent.
//! - **Axis with hysteresis.** A node is cut across its longer *angular* extent: its width
//!   along its widest row, `Δx·2π/W·sin θ₁` (`θ₁` its edge nearest the horizon), against its
//!   height `Δy·π/2H`. (Measured at the centre row, as median cut does, the error on the
//!   sun-dominated sequence of `heliar bench vem --what sun` was 1.5× higher at N = 64.) Once
//!   chosen, a node keeps its axis until the other extent is [`AXIS_HYSTERESIS`] times longer. The axes are the state kept from frame
//!   to frame ([`CoherentCut`]); node numbers are stable, so it survives a change of `N`.
//! - **Lights.** One light per leaf at the leaf's energy centroid (the normalised
//!   energy-weighted mean of the texel directions; the leaf's centre if it is black), carrying
//!   the leaf's power `Σ L·ΔΩ` per channel: each light's `rgb` is its irradiance on a surface
//!   facing it and the lights sum to the map's power.
//! - **Stable indices.** Leaf `v` has light index `(v / 2^z − 1) / 2`, with `2^z` the largest
//!   power of two dividing `v`. Going from `N` to `N + 1` lights splits leaf `N` into `2N`
//!   (which keeps its index) and `2N + 1` (the new index `N`); the other leaves keep node and
//!   index, so a change of the light count (or a peak appearing, [`crate::vem::peaks`]) moves
//!   the lights only by the shift of their ancestors' energy fractions.
//!
//! # Limits
//! - **Not progressive.** Adding a light moves the others (the energy fractions of its
//!   ancestors change, e.g. `150:150` → `151:150` at the root). A balanced tree cannot both keep
//!   every leaf at `P/N` and leave the lights in place when `N` changes; users who need lights
//!   that never move when `N` grows keep `--sampler havran`.
//! - A leaf inside one texel has that texel's centre as its centroid: a source a texel wide gets
//!   all of its share of the leaves at one direction; the [`crate::vem::Decomposer`] gives such
//!   a source lights of its own by default ([`crate::vem::peaks`]; `--no-peaks` turns that off).

use crate::vem::Light;
use crate::vem::polar::{PolarMap, dir_from_polar, luminance};
use crate::vem::sampling::is_valid;
use glam::DVec3;
use std::f64::consts::{FRAC_PI_2, TAU};

/// A node keeps its cut axis until its other angular dimension is this many times longer.
pub const AXIS_HYSTERESIS: f64 = 1.5;

/// No axis chosen yet, cut across `x` (`φ`), cut across `y` (`θ`).
const AXIS_NONE: u8 = 0;
const AXIS_X: u8 = 1;
const AXIS_Y: u8 = 2;

/// A rectangle `[x0, x1) × [y0, y1)` in continuous polar-map coordinates.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Rect {
    x0: f64,
    y0: f64,
    x1: f64,
    y1: f64,
}

/// The light index of heap leaf `v` (see the module docs).
#[inline]
pub fn leaf_index(v: usize) -> u32 {
    (((v >> v.trailing_zeros()) - 1) / 2) as u32
}

/// The coherent median cut and its state from frame to frame (buffers and each node's axis).
#[derive(Clone, Debug, Default)]
pub struct CoherentCut {
    width: usize,
    height: usize,
    /// `(W + 1) × (H + 1)` prefix sums of the luminance energy, row-major.
    sat_y: Vec<f64>,
    /// The same of `[R, G, B, e·d.x, e·d.y, e·d.z]`.
    sat6: Vec<[f64; 6]>,
    /// Per column, `(sin φ, −cos φ)` at the texel centre.
    cols: Vec<(f64, f64)>,
    /// Per row, `(sin θ, cos θ, ΔΩ)` at the texel centre.
    rows: Vec<(f64, f64, f64)>,
    /// Per heap node, its axis (kept from frame to frame).
    axis: Vec<u8>,
    /// Per heap node, the leaves below it, for `counts_n` lights.
    counts: Vec<u32>,
    counts_n: usize,
    rects: Vec<Rect>,
    invalid: usize,
    /// A row of the map with patches applied ([`CoherentCut::rebuild_patched`]).
    row: Vec<[f32; 3]>,
}

impl CoherentCut {
    /// A cut without history.
    pub fn new() -> Self {
        Self::default()
    }

    /// Texels of the last map that were not finite and non-negative (taken as black).
    pub fn invalid_texels(&self) -> usize {
        self.invalid
    }

    /// The last map's luminance power `Σ Y·ΔΩ`.
    pub fn total(&self) -> f64 {
        self.sat_y.last().copied().unwrap_or(0.0)
    }

    /// The last map's power `Σ L·ΔΩ` per channel.
    pub fn total_rgb(&self) -> [f64; 3] {
        self.sat6.last().map_or([0.0; 3], |s| [s[0], s[1], s[2]])
    }

    /// Builds the tables of `map` (see the module docs); a new map size forgets the axes.
    pub fn rebuild(&mut self, map: &PolarMap) {
        self.rebuild_patched(map, &[]);
    }

    /// Builds the tables of `map` with the texels of `patches` (`(texel, value)`, in texel
    /// order) replaced: the remainder of [`crate::vem::peaks::PeakTracker::find`] without a
    /// copy of the map.
    pub fn rebuild_patched(&mut self, map: &PolarMap, patches: &[(usize, [f32; 3])]) {
        let (w, h) = (map.width as usize, map.height as usize);
        let mut patches = patches.iter().peekable();
        let mut row_buf = std::mem::take(&mut self.row);
        if (w, h) != (self.width, self.height) {
            self.set_geometry(map);
        }
        let stride = w + 1;
        self.sat_y.resize(stride * (h + 1), 0.0);
        self.sat6.resize(stride * (h + 1), [0.0; 6]);
        let mut invalid = 0;
        for j in 0..h {
            let (st, ct, dw) = self.rows[j];
            let (y_prev, y_cur) = self.sat_y.split_at_mut((j + 1) * stride);
            let (y_prev, y_cur) = (&y_prev[j * stride + 1..], &mut y_cur[1..stride]);
            let (s_prev, s_cur) = self.sat6.split_at_mut((j + 1) * stride);
            let (s_prev, s_cur) = (&s_prev[j * stride + 1..], &mut s_cur[1..stride]);
            let mut row = &map.data[j * w..(j + 1) * w];
            if patches.peek().is_some_and(|p| p.0 < (j + 1) * w) {
                row_buf.clear();
                row_buf.extend_from_slice(row);
                while let Some(&&(k, v)) = patches.peek().filter(|p| p.0 < (j + 1) * w) {
                    if k >= j * w {
                        row_buf[k - j * w] = v;
                    }
                    patches.next();
                }
                row = &row_buf;
            }
            // Running row sums (of radiance; ΔΩ and the row's sin θ, cos θ applied per entry).
            let mut acc = [0.0f64; 6];
            for ((((p, &(sp, mcp)), yp), yc), (sp6, sc6)) in row.iter().zip(&self.cols).zip(y_prev).zip(y_cur.iter_mut()).zip(s_prev.iter().zip(s_cur.iter_mut())) {
                if is_valid(p) {
                    let l = luminance(*p) as f64;
                    acc[0] += p[0] as f64;
                    acc[1] += p[1] as f64;
                    acc[2] += p[2] as f64;
                    acc[3] += l * sp;
                    acc[4] += l;
                    acc[5] += l * mcp;
                } else {
                    invalid += 1;
                }
                *yc = yp + acc[4] * dw;
                let (a, b) = (dw, st * dw);
                *sc6 = [sp6[0] + acc[0] * a, sp6[1] + acc[1] * a, sp6[2] + acc[2] * a, sp6[3] + acc[3] * b, sp6[4] + acc[4] * ct * dw, sp6[5] + acc[5] * b];
            }
        }
        self.invalid = invalid;
        self.row = row_buf;
    }

    fn set_geometry(&mut self, map: &PolarMap) {
        let (w, h) = (map.width as usize, map.height as usize);
        self.width = w;
        self.height = h;
        self.cols = (0..w)
            .map(|i| {
                let phi = ((i as f64 + 0.5) / w as f64 - 0.5) * TAU;
                (phi.sin(), -phi.cos())
            })
            .collect();
        self.rows = (0..h)
            .map(|j| {
                let theta = (j as f64 + 0.5) / h as f64 * FRAC_PI_2;
                (theta.sin(), theta.cos(), map.row_solid_angle(j as u32) as f64)
            })
            .collect();
        self.sat_y.clear();
        self.sat6.clear();
        self.sat_y.resize((w + 1) * (h + 1), 0.0);
        self.sat6.resize((w + 1) * (h + 1), [0.0; 6]);
        self.axis.clear();
    }

    /// The table indices and bilinear weights of the point `(x, y)`.
    #[inline]
    fn corners(&self, x: f64, y: f64) -> ([usize; 4], [f64; 4]) {
        let (w, h) = (self.width, self.height);
        let i = (x.max(0.0) as usize).min(w - 1);
        let j = (y.max(0.0) as usize).min(h - 1);
        let (fx, fy) = ((x - i as f64).clamp(0.0, 1.0), (y - j as f64).clamp(0.0, 1.0));
        let a = j * (w + 1) + i;
        let b = a + w + 1;
        ([a, a + 1, b, b + 1], [(1.0 - fx) * (1.0 - fy), fx * (1.0 - fy), (1.0 - fx) * fy, fx * fy])
    }

    /// The luminance prefix sum at `(x, y)`.
    #[inline]
    fn sy(&self, x: f64, y: f64) -> f64 {
        let (k, w) = self.corners(x, y);
        (0..4).map(|q| self.sat_y[k[q]] * w[q]).sum()
    }

    /// Luminance energy of `r`.
    #[inline]
    fn energy(&self, r: &Rect) -> f64 {
        self.sy(r.x1, r.y1) - self.sy(r.x0, r.y1) - self.sy(r.x1, r.y0) + self.sy(r.x0, r.y0)
    }

    /// `[R, G, B, e·d]` energies of `r`.
    fn energy6(&self, r: &Rect) -> [f64; 6] {
        let mut out = [0.0f64; 6];
        for (x, y, sign) in [(r.x1, r.y1, 1.0), (r.x0, r.y1, -1.0), (r.x1, r.y0, -1.0), (r.x0, r.y0, 1.0)] {
            let (k, w) = self.corners(x, y);
            for q in 0..4 {
                let s = self.sat6[k[q]];
                for c in 0..6 {
                    out[c] += sign * w[q] * s[c];
                }
            }
        }
        out
    }

    /// Node `v`'s axis for rectangle `r`: the longer angular extent, with hysteresis.
    fn choose_axis(&mut self, v: usize, r: &Rect) -> u8 {
        // The widest row is the one nearest the horizon (sin θ grows toward π/2).
        let wide = (r.x1 - r.x0) * TAU / self.width as f64 * (r.y1 * FRAC_PI_2 / self.height as f64).sin();
        let tall = (r.y1 - r.y0) * FRAC_PI_2 / self.height as f64;
        let a = match self.axis[v] {
            AXIS_X if tall > AXIS_HYSTERESIS * wide => AXIS_Y,
            AXIS_Y if wide > AXIS_HYSTERESIS * tall => AXIS_X,
            AXIS_NONE if wide >= tall => AXIS_X,
            AXIS_NONE => AXIS_Y,
            a => a,
        };
        self.axis[v] = a;
        a
    }

    /// The row index and weight of coordinate `y` (or column and weight of `x` with `n = W`).
    #[inline]
    fn cell(v: f64, n: usize) -> (usize, f64) {
        let k = (v.max(0.0) as usize).min(n - 1);
        (k, (v - k as f64).clamp(0.0, 1.0))
    }

    /// The cut of `r` across `axis` with energy `target` below it (of `e`, the energy of `r`);
    /// `frac` of the extent when `r` is black.
    fn cut(&self, r: &Rect, axis: u8, target: f64, e: f64, frac: f64) -> f64 {
        let (lo, hi) = if axis == AXIS_X { (r.x0, r.x1) } else { (r.y0, r.y1) };
        if !(e > 0.0) {
            return lo + (hi - lo) * frac;
        }
        let stride = self.width + 1;
        let sat = &self.sat_y;
        // The other axis' two bounds as (cell, weight): the energy below an integer knot c is
        // S(c, b1) − S(c, b0) − (the same at lo), S linear in the other coordinate.
        let (other, n_other) = if axis == AXIS_X { ((r.y0, r.y1), self.height) } else { ((r.x0, r.x1), self.width) };
        let (b0, b1) = (Self::cell(other.0, n_other), Self::cell(other.1, n_other));
        let at_knot = |c: usize| {
            let s = |(k, f): (usize, f64)| {
                let (a, b) = if axis == AXIS_X { (sat[k * stride + c], sat[(k + 1) * stride + c]) } else { (sat[c * stride + k], sat[c * stride + k + 1]) };
                a + f * (b - a)
            };
            s(b1) - s(b0)
        };
        // Strip energy at a real coordinate: linear between its knots.
        let strip = |v: f64| {
            let (k, f) = Self::cell(v, if axis == AXIS_X { self.width } else { self.height });
            let (a, b) = (at_knot(k), at_knot(k + 1));
            a + f * (b - a)
        };
        let s_lo = strip(lo);
        let below = |c: f64| strip(c) - s_lo;
        // Knots: lo, the texel boundaries strictly inside, hi. First knot with below ≥ target.
        let (k0, k1) = (lo.floor() as i64 + 1, hi.ceil() as i64 - 1);
        let (mut a, mut b) = (k0, k1 + 1); // search [k0, k1]; k1 + 1 stands for hi
        while a < b {
            let m = a + (b - a) / 2;
            if at_knot(m as usize) - s_lo >= target { b = m } else { a = m + 1 }
        }
        let right = if a > k1 { hi } else { a as f64 };
        let left = if a <= k0 { lo } else { (a - 1) as f64 };
        let (fl, fr) = (below(left), below(right));
        let c = if fr > fl { left + (target - fl) / (fr - fl) * (right - left) } else { left };
        c.clamp(lo, hi)
    }

    /// Leaves below every heap node for `n` lights.
    fn ensure_counts(&mut self, n: usize) {
        if self.counts_n == n {
            return;
        }
        self.counts.clear();
        self.counts.resize(2 * n, 0);
        for v in (1..2 * n).rev() {
            self.counts[v] = if v >= n { 1 } else { self.counts[2 * v] + self.counts[2 * v + 1] };
        }
        self.counts_n = n;
    }

    /// The `n` lights of the map last given to [`CoherentCut::rebuild`], written to `out`
    /// (cleared first) in index order: `out[k].index == k`. Empty for a black map or `n = 0`.
    pub fn lights_of_tables(&mut self, n: usize, out: &mut Vec<Light>) {
        out.clear();
        if n == 0 || !(self.total() > 0.0) {
            return;
        }
        self.ensure_counts(n);
        if self.axis.len() < 2 * n {
            self.axis.resize(2 * n, AXIS_NONE);
        }
        self.rects.resize(2 * n, Rect::default());
        self.rects[1] = Rect { x0: 0.0, y0: 0.0, x1: self.width as f64, y1: self.height as f64 };
        for v in 1..n {
            let r = self.rects[v];
            let (nl, nr) = (self.counts[2 * v] as f64, self.counts[2 * v + 1] as f64);
            let frac = nl / (nl + nr);
            let e = self.energy(&r);
            let axis = self.choose_axis(v, &r);
            let c = self.cut(&r, axis, e * frac, e, frac);
            let (a, b) = if axis == AXIS_X { (Rect { x1: c, ..r }, Rect { x0: c, ..r }) } else { (Rect { y1: c, ..r }, Rect { y0: c, ..r }) };
            self.rects[2 * v] = a;
            self.rects[2 * v + 1] = b;
        }
        let (w, h) = (self.width as u32, self.height as u32);
        out.resize(n, Light { index: 0, dir: glam::Vec3::Y, rgb: [0.0; 3], radius: 0.0 });
        for v in n..2 * n {
            let r = self.rects[v];
            let s = self.energy6(&r);
            let centre = || dir_from_polar((0.5 * (r.x0 + r.x1)) as f32, (0.5 * (r.y0 + r.y1)) as f32, w, h);
            let dir = DVec3::new(s[3], s[4], s[5]).try_normalize().map_or_else(centre, |d| d.as_vec3());
            let k = leaf_index(v);
            out[k as usize] = Light { index: k, dir, rgb: [s[0].max(0.0) as f32, s[1].max(0.0) as f32, s[2].max(0.0) as f32], radius: 0.0 };
        }
    }

    /// [`CoherentCut::rebuild`] then [`CoherentCut::lights_of_tables`].
    pub fn lights(&mut self, map: &PolarMap, n: usize, out: &mut Vec<Light>) {
        self.rebuild(map);
        self.lights_of_tables(n, out);
    }
}

/// The `n` coherent-cut lights of one map, without history (each node takes its longer axis).
pub fn coherent_cut_lights(map: &PolarMap, n: usize) -> Vec<Light> {
    let mut out = Vec::new();
    CoherentCut::new().lights(map, n, &mut out);
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::vem::sampling::lights_power as power;
    use glam::Vec3;

    fn angle(a: Vec3, b: Vec3) -> f64 {
        (a.dot(b).clamp(-1.0, 1.0) as f64).acos()
    }

    #[test]
    fn leaf_indices_are_a_bijection_and_a_new_light_takes_the_next_index() {
        for n in [1usize, 2, 3, 7, 64, 300, 1000] {
            let mut idx: Vec<u32> = (n..2 * n).map(leaf_index).collect();
            idx.sort_unstable();
            assert_eq!(idx, (0..n as u32).collect::<Vec<_>>(), "n={n}");
            // N → N + 1 splits leaf N into 2N (same index) and 2N + 1 (index N).
            assert_eq!(leaf_index(2 * n), leaf_index(n));
            assert_eq!(leaf_index(2 * n + 1), n as u32);
        }
    }

    #[test]
    fn a_uniform_map_gives_exactly_n_leaves_of_equal_power_summing_to_the_map() {
        // Closed form: every leaf holds P/N of the solid-angle-weighted power P = Σ L·ΔΩ (2π·L for a
        // constant L; the texel sum is exact up to f32 solid angles, 1e-5).
        let map = PolarMap::from_fn(360, 90, |_| [2.0, 1.0, 0.5]);
        let want = map.total_power();
        assert!((want[0] - 2.0 * std::f64::consts::TAU).abs() < 1e-4 * want[0]);
        for n in [1usize, 7, 64, 128, 300] {
            let l = coherent_cut_lights(&map, n);
            assert_eq!(l.len(), n);
            assert!(l.iter().enumerate().all(|(k, x)| x.index == k as u32));
            let got = power(&l);
            for c in 0..3 {
                assert!((got[c] - want[c]).abs() < 1e-6 * want[c], "n={n} channel {c}: {} vs {}", got[c], want[c]);
            }
            for x in &l {
                // Cuts are continuous, so the leaves are equal to f64 rounding (f32 output: 1e-5).
                assert!((x.rgb[0] as f64 - want[0] / n as f64).abs() < 1e-5 * want[0] / n as f64, "n={n}: {:?}", x.rgb);
                assert!(x.dir.y >= 0.0 && (x.dir.length() - 1.0).abs() < 1e-5);
            }
        }
    }

    #[test]
    fn a_single_bright_texel_holds_every_leaf_at_its_direction() {
        // All the energy is in one texel, so every equal-energy leaf lies inside it and its centroid
        // is the texel's direction; N = 1 is the one light at that texel.
        let mut map = PolarMap::new(360, 90);
        let (i, j) = (123u32, 40u32);
        map.data[(j * 360 + i) as usize] = [50.0, 40.0, 30.0];
        let dw = map.row_solid_angle(j) as f64;
        for n in [1usize, 7, 64] {
            let l = coherent_cut_lights(&map, n);
            assert_eq!(l.len(), n);
            for x in &l {
                assert!(angle(x.dir, map.texel_dir(i, j)) < 1e-3, "n={n}: {:?}", x.dir);
            }
            let p = power(&l);
            assert!((p[0] - 50.0 * dw).abs() < 1e-6 * 50.0 * dw, "n={n}: {p:?}");
        }
        assert!(coherent_cut_lights(&PolarMap::new(36, 9), 8).is_empty());
        assert!(coherent_cut_lights(&map, 0).is_empty());
    }

    #[test]
    fn patched_tables_are_the_tables_of_the_patched_map() {
        // The same f64 sums in the same order: bit for bit.
        let map = PolarMap::from_fn(72, 18, |d| [1.0 + d.x.max(0.0), 0.5 + d.y, 0.3]);
        let patches = [(5usize, [9.0f32, 8.0, 7.0]), (6, [0.0; 3]), (72 * 3 + 71, [2.0; 3]), (72 * 17, [f32::NAN; 3])];
        let mut copy = map.clone();
        for &(k, v) in &patches {
            copy.data[k] = v;
        }
        let (mut a, mut b) = (CoherentCut::new(), CoherentCut::new());
        a.rebuild_patched(&map, &patches);
        b.rebuild(&copy);
        assert_eq!(a.sat_y, b.sat_y);
        assert_eq!(a.sat6, b.sat6);
        assert_eq!(a.invalid_texels(), 1);
        a.rebuild_patched(&map, &[]);
        b.rebuild(&map);
        assert_eq!(a.sat6, b.sat6);
    }

    #[test]
    fn the_energy_of_a_fractional_rectangle_is_exact_for_a_piecewise_constant_map() {
        // Closed form: half of texel (5, 3) and all of texel (6, 3), each of its own value.
        let mut map = PolarMap::new(12, 6);
        map.data[3 * 12 + 5] = [1.0; 3];
        map.data[3 * 12 + 6] = [3.0; 3];
        let mut cut = CoherentCut::new();
        cut.rebuild(&map);
        let e = cut.energy(&Rect { x0: 5.5, y0: 3.0, x1: 7.0, y1: 4.0 });
        let dw = map.row_solid_angle(3) as f64;
        assert!((e - (0.5 + 3.0) * dw).abs() < 1e-9, "{e} vs {}", 3.5 * dw);
        let e = cut.energy(&Rect { x0: 5.0, y0: 3.25, x1: 6.0, y1: 3.75 });
        assert!((e - 0.5 * dw).abs() < 1e-9);
    }
}
