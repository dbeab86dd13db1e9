//! Importance sampling of the polar map (Havran §3.1): the per-frame distribution and its two
//! inversions.
//!
//! # How it works
//! - **PDF.** Texel `(i, j)` has mass `Y_ij · sin θ_j` (luminance × sin θ, Havran §3.1; the
//!   exact texel solid angle `Δφ·(cos θ_j − cos θ_j+1)` is `sin θ_j` times a constant, so the
//!   two agree exactly). [`PolarDistribution::rebuild`] makes, once per frame, the cumulative
//!   masses of the rings (rows) and the conditional CDF over `φ` of every ring (`f64` sums, so
//!   values from 1e-4 to 1e6 in one map keep their share). Rings without light borrow the
//!   conditional of the nearest ring with light (only [`havran`]'s interpolation reads them).
//! - [`havran`]: the continuous inverse transform of Havran, Dmitriev & Seidel 2003 (the paper's
//!   [HDS03]): concentric square → disc, the radial marginal CDF, conditional CDFs over the disc
//!   angle interpolated linearly between neighbouring rings, and the area-preserving disc →
//!   hemisphere map. Bijective and continuous wherever the map is positive.
//! - [`standard`]: the standard marginal/conditional inversion (pbrt's `Distribution2D`, the
//!   paper's [PH04]) over the `(φ, θ)` parameter square: the baseline.
//! - [`median_cut`]: Debevec's median cut (a second baseline, `--sampler median-cut`): `N`
//!   regions of equal energy from a summed-area table, one light of the region's power each.
//! - [`coherent_cut`]: the temporally coherent median cut (`--sampler coherent-cut`): a fixed
//!   heap-shaped kd-tree with continuous equal-energy cuts, one light per leaf, stable indices.
//! - Both expose the triad `sample_*`, `*_pdf`, `invert_*`; [`PolarDistribution::sample`],
//!   [`PolarDistribution::pdf`], [`PolarDistribution::invert`] and
//!   [`PolarDistribution::integral`] dispatch on [`SamplerKind`].
//!
//! A light built from a sample carries power `P/N` in luminance (all lights equal, Havran §3.3)
//! and the colour of the light where it landed ([`PolarDistribution::light_rgb`]), so that the
//! sum over lights is an unbiased estimate of every RGB channel.

/// The summed `rgb` of `lights` (the map's power they carry), for the samplers' tests.
#[cfg(test)]
pub(crate) fn lights_power(lights: &[crate::vem::Light]) -> [f64; 3] {
    let mut p = [0.0; 3];
    for x in lights {
        for (c, v) in p.iter_mut().zip(x.rgb) {
            *c += v as f64;
        }
    }
    p
}

pub mod coherent_cut;
pub mod havran;
pub mod median_cut;
pub mod pattern;
pub mod standard;
pub mod tempered;

use super::polar::{PolarMap, luminance};
use glam::{Vec2, Vec3};

/// Which inverse transform turns unit-square samples into directions.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SamplerKind {
    /// Havran's continuous transform with the conditional CDFs of neighbouring rings blended over
    /// a band of at most half the lighter ring's mass on each side of their boundary (the
    /// default before the coherent cut; see [`havran`] for why). Progressive: adding lights moves
    /// none.
    Havran,
    /// Havran's transform with the conditional CDFs interpolated linearly between ring centres,
    /// as the paper describes it.
    HavranCentres,
    /// The standard marginal/conditional inversion (pbrt).
    Standard,
    /// Debevec's median cut ([`median_cut`]): not an inverse transform but a set of `N` lights
    /// of unequal power. [`PolarDistribution::sample`] and [`PolarDistribution::invert`] give
    /// `None` and [`PolarDistribution::pdf`] 0 for it; [`crate::vem::lights_of_map`] and the
    /// [`crate::vem::Decomposer`] build its lights with [`median_cut::median_cut_lights`].
    MedianCut,
    /// The temporally coherent median cut ([`coherent_cut`]): a fixed equal-energy kd-tree with
    /// continuous cuts, one light of power `P/N` per leaf at its energy centroid, the leaf's
    /// index as the light's identity (so the temporal filter follows it). Not an inverse
    /// transform: [`PolarDistribution::sample`] and [`PolarDistribution::invert`] give `None`
    /// and [`PolarDistribution::pdf`] 0 for it. The default, with peaks as lights of their own
    /// ([`crate::vem::peaks`]): it beats median cut at equal `N` (`heliar bench vem --what sun`)
    /// and follows its lights in time; it is not progressive.
    #[default]
    CoherentCut,
}

impl SamplerKind {
    /// The name used in tables and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            SamplerKind::Havran => "havran",
            SamplerKind::HavranCentres => "havran_centres",
            SamplerKind::Standard => "standard",
            SamplerKind::MedianCut => "median_cut",
            SamplerKind::CoherentCut => "coherent_cut",
        }
    }
}

/// Where a sample landed: its direction, polar-map coordinates, and which rings' conditional CDFs
/// produced it (for the light's colour).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SampleRecord {
    /// Unit world direction.
    pub dir: Vec3,
    /// Continuous polar-map column coordinate.
    pub x: f32,
    /// Continuous polar-map row coordinate.
    pub y: f32,
    /// Ring (row) of the sample.
    pub ring: u32,
    /// Column of the sample.
    pub col: u32,
    /// The neighbouring ring whose conditional was blended in, and its weight `t ∈ [0, 1)`.
    pub blend: Option<(u32, f32)>,
}

/// The per-frame sampling distribution over a polar map.
#[derive(Clone, Debug, Default)]
pub struct PolarDistribution {
    width: u32,
    height: u32,
    /// Ring masses, normalised to sum 1 (all 0 for a black map).
    ring_mass: Vec<f64>,
    /// Cumulative ring masses, `height + 1` values from 0 to 1.
    marginal: Vec<f64>,
    /// `s = 1 − cos θ` at the ring boundaries (`height + 1` values).
    ring_s: Vec<f64>,
    /// Per ring, `width + 1` cumulative conditional values from 0 to 1.
    conditional: Vec<f32>,
    /// Per ring, the ring whose texels define its conditional (itself when it has light).
    cond_source: Vec<u32>,
    /// Per ring, the luminance sum of its texels (of `cond_source`).
    ring_sum: Vec<f32>,
    /// `Σ Y·ΔΩ` over the map.
    total: f64,
    /// `Σ L·ΔΩ` per channel.
    total_rgb: [f64; 3],
}

impl PolarDistribution {
    /// The distribution of `map` (see [`PolarDistribution::rebuild`]).
    pub fn new(map: &PolarMap) -> Self {
        let mut d = Self::default();
        d.rebuild(map);
        d
    }

    /// Rebuilds the CDFs for a new frame, reusing the buffers, and returns how many texels were
    /// not finite and non-negative in every channel: those count as black (they are not
    /// changed in `map`, and no light reads them).
    pub fn rebuild(&mut self, map: &PolarMap) -> usize {
        let (w, h) = (map.width as usize, map.height as usize);
        self.width = map.width;
        self.height = map.height;
        self.ring_mass.clear();
        self.ring_mass.resize(h, 0.0);
        self.marginal.clear();
        self.marginal.resize(h + 1, 0.0);
        self.conditional.resize(h * (w + 1), 0.0);
        self.cond_source.clear();
        self.cond_source.extend(0..h as u32);
        self.ring_sum.clear();
        self.ring_sum.resize(h, 0.0);
        self.ring_s.clear();
        let dtheta = std::f64::consts::FRAC_PI_2 / h as f64;
        self.ring_s.extend((0..=h).map(|j| 1.0 - (j as f64 * dtheta).cos()));
        self.total_rgb = [0.0; 3];
        let mut total = 0.0f64;
        let mut invalid = 0usize;
        for j in 0..h {
            let dw = map.row_solid_angle(j as u32) as f64;
            let row = &map.data[j * w..(j + 1) * w];
            let cdf = &mut self.conditional[j * (w + 1)..(j + 1) * (w + 1)];
            cdf[0] = 0.0;
            let (rgb, bad) = row_luminance_and_rgb(row, cdf);
            invalid += bad;
            prefix_sum(&mut cdf[1..]);
            let sum = cdf[w];
            if sum > 0.0 && sum.is_finite() {
                let inv = 1.0 / sum;
                cdf.iter_mut().for_each(|c| *c *= inv);
                cdf[w] = 1.0;
                self.ring_sum[j] = sum;
                self.ring_mass[j] = sum as f64 * dw;
                total += sum as f64 * dw;
                for c in 0..3 {
                    self.total_rgb[c] += rgb[c] * dw;
                }
            } else {
                cdf.fill(0.0);
            }
        }
        self.total = total;
        if total > 0.0 {
            self.finish_marginal(w, h);
        }
        invalid
    }

    /// Normalises the ring masses into the marginal CDF; rings without light borrow the
    /// conditional of the nearest ring with light.
    fn finish_marginal(&mut self, w: usize, h: usize) {
        let total = self.total;
        let mut acc = 0.0;
        for j in 0..h {
            self.ring_mass[j] /= total;
            acc += self.ring_mass[j];
            self.marginal[j + 1] = acc;
        }
        self.marginal[h] = 1.0;
        for j in 0..h {
            if self.ring_mass[j] > 0.0 {
                continue;
            }
            let src = (1..h)
                .flat_map(|d| [j.checked_sub(d), (j + d < h).then_some(j + d)])
                .flatten()
                .find(|&k| self.ring_mass[k] > 0.0);
            if let Some(k) = src {
                self.cond_source[j] = k as u32;
                self.ring_sum[j] = self.ring_sum[k];
                let (a, b) = (k * (w + 1), j * (w + 1));
                self.conditional.copy_within(a..a + w + 1, b);
            }
        }
    }

    /// Polar map width.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Polar map height.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// `Σ Y·ΔΩ`, the luminance power of the map (0 for a black map).
    pub fn integral(&self) -> f64 {
        self.total
    }

    /// `Σ L·ΔΩ` per channel.
    pub fn integral_rgb(&self) -> [f64; 3] {
        self.total_rgb
    }

    /// Whether there is any light to sample.
    pub fn is_empty(&self) -> bool {
        !(self.total > 0.0)
    }

    /// Normalised mass of ring `j`.
    pub fn ring_mass(&self, j: u32) -> f64 {
        self.ring_mass[j as usize]
    }

    /// The cumulative conditional values of ring `j` (`width + 1` values).
    #[inline]
    pub(crate) fn cdf(&self, j: u32) -> &[f32] {
        let w = self.width as usize + 1;
        &self.conditional[j as usize * w..(j as usize + 1) * w]
    }

    /// Ring `j` and the fraction `τ ∈ [0, 1]` of its mass below `u`: the inverse of the
    /// piecewise-linear marginal CDF. `None` for a black map.
    #[inline]
    pub(crate) fn invert_marginal(&self, u: f64) -> Option<(u32, f64)> {
        if self.is_empty() {
            return None;
        }
        let h = self.height as usize;
        let u = u.clamp(0.0, 1.0);
        let mut j = self.marginal[1..=h].partition_point(|&m| m <= u).min(h - 1);
        while self.ring_mass[j] <= 0.0 && j > 0 {
            j -= 1; // only reachable for u = 1 after trailing black rings
        }
        let tau = ((u - self.marginal[j]) / self.ring_mass[j]).clamp(0.0, 1.0);
        Some((j as u32, tau))
    }

    /// The marginal CDF at fraction `τ` into ring `j`.
    #[inline]
    pub(crate) fn marginal_at(&self, j: u32, tau: f64) -> f64 {
        self.marginal[j as usize] + tau * self.ring_mass[j as usize]
    }

    /// `s = 1 − cos θ` at the lower boundary of ring `j` and the ring's width in `s`.
    #[inline]
    pub(crate) fn ring_s(&self, j: u32) -> (f64, f64) {
        let j = j as usize;
        (self.ring_s[j], self.ring_s[j + 1] - self.ring_s[j])
    }

    /// Samples a direction with the given transform; `None` for a black map.
    pub fn sample(&self, kind: SamplerKind, u: Vec2) -> Option<SampleRecord> {
        match kind {
            SamplerKind::Havran => self.sample_havran(u, havran::RingBlend::Lighter),
            SamplerKind::HavranCentres => self.sample_havran(u, havran::RingBlend::Centres),
            SamplerKind::Standard => self.sample_standard(u),
            SamplerKind::MedianCut | SamplerKind::CoherentCut => None,
        }
    }

    /// Density (per steradian) with which `kind` produces `dir`.
    pub fn pdf(&self, kind: SamplerKind, dir: Vec3) -> f32 {
        match kind {
            SamplerKind::Havran => self.havran_pdf(dir, havran::RingBlend::Lighter),
            SamplerKind::HavranCentres => self.havran_pdf(dir, havran::RingBlend::Centres),
            SamplerKind::Standard => self.standard_pdf(dir),
            SamplerKind::MedianCut | SamplerKind::CoherentCut => 0.0,
        }
    }

    /// The unit-square point that `kind` maps to `dir`; `None` where the map is black (there the
    /// transform is not onto) or below the horizon.
    pub fn invert(&self, kind: SamplerKind, dir: Vec3) -> Option<Vec2> {
        match kind {
            SamplerKind::Havran => self.invert_havran(dir, havran::RingBlend::Lighter),
            SamplerKind::HavranCentres => self.invert_havran(dir, havran::RingBlend::Centres),
            SamplerKind::Standard => self.invert_standard(dir),
            SamplerKind::MedianCut | SamplerKind::CoherentCut => None,
        }
    }

    /// RGB per unit luminance of a light placed by `rec` on `map` (the map this distribution was
    /// built from): the colour of its texel, or, where two rings' conditionals were blended, the
    /// mix of the two texels in proportion to their share of the sampling density.
    pub fn light_rgb(&self, map: &PolarMap, rec: &SampleRecord) -> [f32; 3] {
        let w = self.width;
        let texel = |ring: u32| {
            let p = map.data[(self.cond_source[ring as usize] * w + rec.col) as usize];
            if is_valid(&p) { p } else { [0.0; 3] }
        };
        let (a, sa) = (texel(rec.ring), self.ring_sum[rec.ring as usize]);
        let (num, den) = match rec.blend {
            None => (a, luminance(a)),
            Some((n, t)) => {
                let (b, sb) = (texel(n), self.ring_sum[n as usize]);
                let (wa, wb) = ((1.0 - t) / sa.max(f32::MIN_POSITIVE), t / sb.max(f32::MIN_POSITIVE));
                (std::array::from_fn(|c| wa * a[c] + wb * b[c]), wa * luminance(a) + wb * luminance(b))
            }
        };
        if den > 0.0 && den.is_finite() {
            num.map(|v| v / den)
        } else {
            [1.0; 3] // a texel of zero width in the CDF cannot be drawn; neutral colour if it is
        }
    }
}

/// Whether a texel is finite and non-negative in every channel.
#[inline]
pub fn is_valid(p: &[f32; 3]) -> bool {
    // Non-short-circuit `&`: no branches. NaN fails both comparisons.
    (p[0] >= 0.0) & (p[1] >= 0.0) & (p[2] >= 0.0) & (p[0] < f32::INFINITY) & (p[1] < f32::INFINITY) & (p[2] < f32::INFINITY)
}

/// In-place inclusive prefix sum, as four running sums over quarters of the slice (independent
/// dependency chains, so about four times the throughput of one) plus the quarters' offsets.
fn prefix_sum(x: &mut [f32]) {
    let b = x.len() / 4;
    if b == 0 {
        let mut a = 0.0;
        for v in x.iter_mut() {
            a += *v;
            *v = a;
        }
        return;
    }
    let (q0, rest) = x.split_at_mut(b);
    let (q1, rest) = rest.split_at_mut(b);
    let (q2, q3) = rest.split_at_mut(b);
    let (q3, tail) = q3.split_at_mut(b);
    let mut a = [0.0f32; 4];
    for (((v0, v1), v2), v3) in q0.iter_mut().zip(q1.iter_mut()).zip(q2.iter_mut()).zip(q3.iter_mut()) {
        a[0] += *v0;
        *v0 = a[0];
        a[1] += *v1;
        *v1 = a[1];
        a[2] += *v2;
        *v2 = a[2];
        a[3] += *v3;
        *v3 = a[3];
    }
    for v in tail.iter_mut() {
        a[3] += *v;
        *v = a[3];
    }
    // Offsets: each quarter gets the total of the quarters before it.
    let o1 = a[0];
    let o2 = o1 + a[1];
    let o3 = o2 + a[2];
    q1.iter_mut().for_each(|v| *v += o1);
    q2.iter_mut().for_each(|v| *v += o2);
    q3.iter_mut().chain(tail.iter_mut()).for_each(|v| *v += o3);
}

/// The inverse of the piecewise-linear CDF `cdf` (`n + 1` knots from 0 to 1) at `v ∈ [0, 1)`:
/// the segment `k` with `cdf[k] ≤ v < cdf[k + 1]` and the fraction into it.
#[inline]
pub(crate) fn invert_cdf(knot: impl Fn(usize) -> f32, n: usize, v: f32) -> (u32, f32) {
    let v = v.clamp(0.0, 1.0 - f32::EPSILON);
    let (mut lo, mut hi) = (0usize, n);
    while hi - lo > 1 {
        let mid = (lo + hi) / 2;
        if knot(mid) <= v { lo = mid } else { hi = mid }
    }
    let (a, b) = (knot(lo), knot(lo + 1));
    let f = if b > a { ((v - a) / (b - a)).clamp(0.0, 1.0) } else { 0.5 };
    (lo as u32, f)
}

/// Writes the luminance of `row` into `cdf[1..]` and returns the row's RGB sums and how many
/// texels were invalid (those get luminance 0 and stay out of the sums). The sums and smallest
/// values run in twelve independent lanes (four texels × three channels), so both loops
/// vectorise; finite sums and no negative value mean every texel is valid, otherwise the slow
/// path checks each.
fn row_luminance_and_rgb(row: &[[f32; 3]], cdf: &mut [f32]) -> ([f64; 3], usize) {
    for (c, p) in cdf[1..].iter_mut().zip(row) {
        *c = luminance(*p);
    }
    let flat = row.as_flattened();
    let (mut sum, mut min) = ([0.0f32; 12], [0.0f32; 12]);
    let chunks = flat.chunks_exact(12);
    let rest = chunks.remainder();
    for ch in chunks {
        for k in 0..12 {
            sum[k] += ch[k];
            min[k] = if ch[k] < min[k] { ch[k] } else { min[k] };
        }
    }
    for (k, v) in rest.iter().enumerate() {
        sum[k] += v;
        min[k] = if *v < min[k] { *v } else { min[k] };
    }
    let mut rgb = [0.0f64; 3];
    for k in 0..12 {
        rgb[k % 3] += sum[k] as f64;
    }
    let mut invalid = 0;
    let row_ok = rgb.iter().all(|v| v.is_finite()) && min.iter().all(|&m| m >= 0.0);
    if !row_ok {
        rgb = [0.0; 3];
        for (c, p) in cdf[1..].iter_mut().zip(row) {
            if is_valid(p) {
                for k in 0..3 {
                    rgb[k] += p[k] as f64;
                }
            } else {
                *c = 0.0;
                invalid += 1;
            }
        }
    }
    (rgb, invalid)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn integral_and_masses() {
        let map = PolarMap::from_fn(36, 9, |d| [d.y + 0.1, 1.0, 2.0]);
        let dist = PolarDistribution::new(&map);
        let p = map.total_power();
        let y = 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2];
        assert!((dist.integral() - y).abs() < 1e-4 * y);
        let s: f64 = (0..9).map(|j| dist.ring_mass(j)).sum();
        assert!((s - 1.0).abs() < 1e-12);
        let black = PolarDistribution::new(&PolarMap::new(36, 9));
        assert!(black.is_empty() && black.integral() == 0.0);
        assert!(black.sample(SamplerKind::Havran, Vec2::splat(0.3)).is_none());
        assert!(black.sample(SamplerKind::Standard, Vec2::splat(0.3)).is_none());
    }

    #[test]
    fn blocked_prefix_sum_matches_the_sequential_one() {
        for n in [0usize, 1, 3, 4, 5, 90, 361] {
            let v: Vec<f32> = (0..n).map(|i| (i % 7) as f32 * 0.5).collect();
            let mut p = v.clone();
            prefix_sum(&mut p);
            let mut acc = 0.0;
            for (a, b) in v.iter().zip(&p) {
                acc += a;
                assert!((acc - b).abs() < 1e-4, "n={n}");
            }
        }
    }

    #[test]
    fn cdf_inversion_skips_empty_segments() {
        let c = [0.0f32, 0.25, 0.25, 1.0];
        assert_eq!(invert_cdf(|k| c[k], 3, 0.0), (0, 0.0));
        assert_eq!(invert_cdf(|k| c[k], 3, 0.125), (0, 0.5));
        let (k, f) = invert_cdf(|k| c[k], 3, 0.25);
        assert_eq!(k, 2);
        assert!(f.abs() < 1e-6);
        assert_eq!(invert_cdf(|k| c[k], 3, 1.0).0, 2);
    }
}
