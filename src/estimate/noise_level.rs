//! The read noise measured on the frame itself, for camera files that do not know it
//! (`response.read_noise = "auto"`, or absent at dusk and night: [`ReadNoise`]).
//!
//! [`super::noise`] needs the sensor's read noise `σ_r` (Jensen §3.1's fit with the noise model
//! of issue 16 §3). Here it is the intercept of the frame's noise level function, fitted as in
//! Foi et al. 2008 ("Practical Poissonian-Gaussian noise modeling and fitting for single-image raw
//! data", §4–5: local estimates on smooth parts of a wavelet detail, binned by level, and a fit of
//! `σ²(μ)`), with Immerkær's 1996 fast noise variance operator as the detail.
//!
//! # How it works
//! - **High-pass.** Per channel, the linear frame (radiance, [`Linearizer::radiance`]) is
//!   filtered by the Laplacian-difference mask `[1 −2 1; −2 4 −2; 1 −2 1]` (Immerkær 1996). It
//!   removes every signal of the form `f(x) + g(y)` (constants, ramps, horizontal and vertical
//!   edges), and its output's standard deviation is `6σ` for white noise of standard deviation
//!   `σ` (`√(1+4+1+4+16+4+1+4+1)`), so `h = mask∗x / 6` has the pixels' variance.
//! - **Blocks.** The frame is cut into 8×8 blocks; a block with a clipped or invalid pixel in it
//!   or in its 1-pixel margin is skipped. Each block gives its mean `m`, its variance
//!   `v = mean(h²)` and a robust one `s² = (1.4826·median|h|)²`. Edges and texture put large
//!   values into a few `h`: a block with `v > 3·s²` is left out (for noise alone `v/s²` has mean
//!   1 and a spread of ≈ 0.3 at 64 pixels).
//! - **Bins.** The blocks are sorted by `m` and cut into bins of equal count (at least 24
//!   blocks, at most 32 bins). In each bin, blocks whose `v` is more than 3 robust spreads above
//!   the bin's median are left out (texture that passed the block test); the bin's variance is
//!   the mean of the rest, with the standard error of that mean from their spread. For LDR
//!   frames the code's quantisation adds `Δ²/12` (Sheppard's correction; `Δ` the radiance step
//!   of one code at the block's level, [`Linearizer::code_step`]), which is taken off.
//! - **The clip at zero.** A camera clips `μ + n` at zero, which shrinks the variance of the
//!   darkest bins. A bin is clipped when its mean is under 3 of its standard deviations (0.13%
//!   of its pixels clipped) or when more than 0.2% of its pixels are exactly 0. The blocks above
//!   the brightest clipped bin are binned again (so that a frame mostly at zero keeps its bins
//!   for the rest), and clipped bins of that second pass are left out too.
//! - **Fit.** `σ²(μ) = σ_r² + g·μ + c·μ²` by weighted least squares (weights 1/se²) with all
//!   three terms ≥ 0: Foi's Poissonian–Gaussian model (`g·μ`, shot noise) with a relative term
//!   (`c·μ²`: fixed-pattern gain noise, and the relative part of [`super::noise`]'s model). The
//!   fit takes the best of the eight non-negative subsets of the terms. `σ_r = √σ_r²`, and its
//!   standard error by the delta method from the full (three-term) fit's covariance, scaled by
//!   the reduced χ² when that is above 1.
//!
//! The channels' blocks are pooled: the estimator's model has one `σ_r` for the three channels.

use crate::io::frames::{Frame, Linearizer, PixelState};
#[cfg(doc)]
use crate::io::frames::ReadNoise;

/// Side of the square blocks, pixels.
const BLOCK: usize = 8;
/// The mask's gain on white noise: `√(Σ w²) = 6`.
const MASK_GAIN: f64 = 6.0;
/// MAD to standard deviation for Gaussian data: `1/Φ⁻¹(¾)`.
const MAD_TO_SIGMA: f64 = 1.482_602_218_505_602;
/// A block whose variance is above this multiple of its robust one holds an edge or texture.
const EDGE_RATIO: f64 = 3.0;
/// Within a bin, blocks more than this many robust spreads above the median variance are left out.
const OUTLIER_SPREADS: f64 = 3.0;
/// Fewest blocks per bin.
const BLOCKS_PER_BIN: usize = 24;
/// Most bins.
const MAX_BINS: usize = 32;
/// Fewest bins for a fit (three terms).
const MIN_BINS: usize = 3;
/// A bin whose mean is under this many standard deviations is shrunk by the clip at zero.
const CLIP_MARGIN: f64 = 3.0;
/// A bin with more than this fraction of its pixels exactly 0 is shrunk by the clip at zero.
const MAX_ZERO_FRACTION: f64 = 0.002;

/// The frame's noise level function and its read noise.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NoiseLevel {
    /// `σ_r`: the noise's standard deviation at zero level, scaled radiance.
    pub read_noise: f64,
    /// Standard error of `read_noise`.
    pub read_noise_se: f64,
    /// `g`: the variance's slope in the level (shot noise), radiance.
    pub gain: f64,
    /// `c`: the variance's relative part (`(c·μ)²`'s coefficient `c²` is `c` here), unitless.
    pub relative: f64,
    /// Blocks (of all channels) in the bins that were fitted.
    pub blocks: usize,
    /// Bins fitted.
    pub bins: usize,
}

/// One block's statistics.
#[derive(Clone, Copy, Debug)]
struct Block {
    mean: f64,
    var: f64,
    zeros: u32,
    /// The code's quantisation variance at the block's level (0 for HDR).
    quant_var: f64,
}

/// One bin's level, variance and its standard error.
#[derive(Clone, Copy, Debug)]
struct Bin {
    mean: f64,
    var: f64,
    se: f64,
    blocks: usize,
    zero_fraction: f64,
}

/// The noise level of `frame` through `lin` (module docs); `None` when fewer than three bins
/// of flat blocks above the clip are left.
pub fn measure(frame: &Frame, lin: &Linearizer) -> Option<NoiseLevel> {
    let (w, h) = (frame.width as usize, frame.height as usize);
    // One channel at a time: one plane of `f32` in memory (33 MB for a 4K frame).
    let mut plane = vec![f32::NAN; w * h];
    let mut blocks = Vec::new();
    for c in 0..3 {
        for (i, p) in plane.iter_mut().enumerate() {
            let (v, state) = lin.radiance(frame, i);
            *p = if state == PixelState::Ok { v[c] } else { f32::NAN };
        }
        blocks_of(&plane, w, h, |m| lin.code_step(frame, m as f32, c) as f64, &mut blocks);
    }
    fit_blocks(blocks)
}

/// The noise level of one linear plane (`NaN`: unusable pixel), for tests and tools.
pub fn measure_plane(plane: &[f32], width: usize, height: usize, code_step: impl Fn(f64) -> f64) -> Option<NoiseLevel> {
    let mut blocks = Vec::new();
    blocks_of(plane, width, height, code_step, &mut blocks);
    fit_blocks(blocks)
}

/// The flat blocks of a plane (module docs: "Blocks").
fn blocks_of(plane: &[f32], w: usize, h: usize, code_step: impl Fn(f64) -> f64, out: &mut Vec<Block>) {
    if w < BLOCK + 2 || h < BLOCK + 2 {
        return;
    }
    let mut hp = Vec::with_capacity(BLOCK * BLOCK);
    for by in 0..(h - 2) / BLOCK {
        'block: for bx in 0..(w - 2) / BLOCK {
            let (x0, y0) = (1 + bx * BLOCK, 1 + by * BLOCK);
            hp.clear();
            let (mut sum, mut zeros) = (0.0, 0u32);
            for y in y0..y0 + BLOCK {
                for x in x0..x0 + BLOCK {
                    let at = |dx: isize, dy: isize| plane[(y as isize + dy) as usize * w + (x as isize + dx) as usize] as f64;
                    let corners = at(-1, -1) + at(1, -1) + at(-1, 1) + at(1, 1);
                    let sides = at(0, -1) + at(0, 1) + at(-1, 0) + at(1, 0);
                    let v = (corners - 2.0 * sides + 4.0 * at(0, 0)) / MASK_GAIN;
                    if !v.is_finite() {
                        continue 'block;
                    }
                    hp.push(v);
                    sum += at(0, 0);
                    zeros += u32::from(at(0, 0) <= 0.0);
                }
            }
            let n = hp.len() as f64;
            let var = hp.iter().map(|v| v * v).sum::<f64>() / n;
            let mut abs: Vec<f64> = hp.iter().map(|v| v.abs()).collect();
            let mad = median(&mut abs);
            let robust_var = (MAD_TO_SIGMA * mad).powi(2);
            if var > EDGE_RATIO * robust_var && var > 0.0 {
                continue;
            }
            let mean = sum / n;
            let step = code_step(mean);
            out.push(Block { mean, var, zeros, quant_var: step * step / 12.0 });
        }
    }
}

/// The median of `v` (reorders it); 0 for an empty slice.
fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    let mid = v.len() / 2;
    let (_, m, _) = v.select_nth_unstable_by(mid, |a, b| a.total_cmp(b));
    *m
}

/// Bins of equal count by level, with their outliers left out (module docs: "Bins").
fn bins_of(mut blocks: Vec<Block>) -> Vec<Bin> {
    blocks.sort_by(|a, b| a.mean.total_cmp(&b.mean));
    let nbins = (blocks.len() / BLOCKS_PER_BIN).min(MAX_BINS);
    let mut bins = Vec::with_capacity(nbins);
    for b in 0..nbins {
        let part = &blocks[b * blocks.len() / nbins..(b + 1) * blocks.len() / nbins];
        let mut vars: Vec<f64> = part.iter().map(|k| k.var).collect();
        let med = median(&mut vars);
        let mut dev: Vec<f64> = part.iter().map(|k| (k.var - med).abs()).collect();
        let spread = MAD_TO_SIGMA * median(&mut dev);
        let kept: Vec<&Block> = part.iter().filter(|k| k.var <= med + OUTLIER_SPREADS * spread).collect();
        let n = kept.len() as f64;
        if kept.len() < 2 {
            continue;
        }
        let mean_var = kept.iter().map(|k| k.var).sum::<f64>() / n;
        let sd = (kept.iter().map(|k| (k.var - mean_var).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
        let quant = kept.iter().map(|k| k.quant_var).sum::<f64>() / n;
        let pixels = (part.len() * BLOCK * BLOCK) as f64;
        bins.push(Bin {
            mean: kept.iter().map(|k| k.mean).sum::<f64>() / n,
            var: mean_var - quant,
            se: sd / n.sqrt(),
            blocks: kept.len(),
            zero_fraction: part.iter().map(|k| k.zeros as f64).sum::<f64>() / pixels,
        });
    }
    bins
}

/// Bins above the clip, and the fit of `σ²(μ)` on them (module docs: "The clip", "Fit").
fn fit_blocks(blocks: Vec<Block>) -> Option<NoiseLevel> {
    let clipped = |b: &Bin| b.zero_fraction > MAX_ZERO_FRACTION || b.mean < CLIP_MARGIN * b.var.max(0.0).sqrt();
    // The darkest level above which no bin is clipped; the blocks above it are binned again, so
    // that a frame mostly at zero keeps all its bins for the part above the clip.
    let first = bins_of(blocks.clone());
    let floor = match first.iter().rposition(clipped) {
        Some(i) if i + 1 < first.len() => 0.5 * (first[i].mean + first[i + 1].mean),
        Some(_) => return None,
        None => f64::NEG_INFINITY,
    };
    let bins: Vec<Bin> = bins_of(blocks.into_iter().filter(|b| b.mean >= floor).collect()).into_iter().filter(|b| !clipped(b)).collect();
    if bins.len() < MIN_BINS {
        return None;
    }
    // Weights: the bins' standard errors, floored at a small fraction of the largest so that a
    // bin of exactly noiseless blocks (se 0) does not take all the weight.
    let se_max = bins.iter().map(|b| b.se).fold(0.0, f64::max);
    let var_max = bins.iter().map(|b| b.var.abs()).fold(0.0, f64::max);
    let se_floor = (1e-3 * se_max).max(1e-12 * var_max).max(f64::MIN_POSITIVE);
    let scale = bins.iter().map(|b| b.mean).fold(0.0, f64::max).max(f64::MIN_POSITIVE);
    let rows: Vec<([f64; 3], f64, f64)> = bins
        .iter()
        .map(|b| {
            let u = b.mean / scale;
            ([1.0, u, u * u], b.var, 1.0 / b.se.max(se_floor).powi(2))
        })
        .collect();
    let (coef, cov) = nnls3(&rows)?;
    let a = coef[0];
    let read_noise = a.max(0.0).sqrt();
    let se_a = cov[0].max(0.0).sqrt();
    // Delta method: d√a/da = 1/(2√a); at a ≈ 0 the standard error of √a is about √se_a.
    let read_noise_se = if read_noise > se_a.sqrt() { se_a / (2.0 * read_noise) } else { se_a.sqrt() };
    Some(NoiseLevel {
        read_noise,
        read_noise_se,
        gain: coef[1] / scale,
        relative: coef[2] / (scale * scale),
        blocks: bins.iter().map(|b| b.blocks).sum(),
        bins: bins.len(),
    })
}

/// Weighted least squares of `y ≈ x·β` (rows `(x, y, weight)`) with `β ≥ 0`: the best of the
/// eight subsets of free terms whose solution is non-negative. Returns `β` and the diagonal of
/// the full model's covariance (the subset's when the full one is singular), scaled by the
/// reduced χ² when that is above 1.
fn nnls3(rows: &[([f64; 3], f64, f64)]) -> Option<([f64; 3], [f64; 3])> {
    let mut best: Option<(f64, [f64; 3], [f64; 3])> = None;
    for mask in 1u8..8 {
        let free: Vec<usize> = (0..3).filter(|j| mask & (1 << j) != 0).collect();
        let Some((beta, diag)) = wls(rows, &free) else { continue };
        if beta.iter().any(|&b| b < 0.0) {
            continue;
        }
        let chi2: f64 = rows.iter().map(|(x, y, w)| w * (y - (0..3).map(|j| x[j] * beta[j]).sum::<f64>()).powi(2)).sum();
        if best.as_ref().is_none_or(|(c, _, _)| chi2 < *c) {
            best = Some((chi2, beta, diag));
        }
    }
    // The standard errors of the full model when it can be solved: a term held at 0 by the
    // constraint is still uncertain, and the subset's covariance would leave that out.
    let (chi2, beta, subset_diag) = best?;
    let diag = wls(rows, &[0, 1, 2]).map_or(subset_diag, |(_, d)| d);
    let birge = (chi2 / rows.len().saturating_sub(3).max(1) as f64).max(1.0);
    Some((beta, diag.map(|d| d * birge)))
}

/// Weighted least squares on the `free` terms (the others 0): `β` and the diagonal of
/// `(XᵀWX)⁻¹`; `None` when singular.
fn wls(rows: &[([f64; 3], f64, f64)], free: &[usize]) -> Option<([f64; 3], [f64; 3])> {
    let k = free.len();
    if rows.len() < k {
        return None;
    }
    let mut g = vec![vec![0.0; k + 1]; k];
    for (x, y, w) in rows {
        for (r, &jr) in free.iter().enumerate() {
            for (c, &jc) in free.iter().enumerate() {
                g[r][c] += w * x[jr] * x[jc];
            }
            g[r][k] += w * x[jr] * y;
        }
    }
    let inv = invert(&g.iter().map(|r| r[..k].to_vec()).collect::<Vec<_>>())?;
    let (mut beta, mut diag) = ([0.0; 3], [0.0; 3]);
    for (r, &jr) in free.iter().enumerate() {
        beta[jr] = (0..k).map(|c| inv[r][c] * g[c][k]).sum();
        diag[jr] = inv[r][r];
    }
    Some((beta, diag))
}

/// The inverse of a small symmetric matrix by Gauss–Jordan with partial pivoting; `None` when
/// singular (a pivot below `1e-14` of the largest diagonal).
fn invert(m: &[Vec<f64>]) -> Option<Vec<Vec<f64>>> {
    let n = m.len();
    let tiny = 1e-14 * m.iter().enumerate().map(|(i, r)| r[i].abs()).fold(0.0, f64::max);
    let mut a: Vec<Vec<f64>> = m.iter().enumerate().map(|(i, r)| r.iter().copied().chain((0..n).map(|j| f64::from(u8::from(i == j)))).collect()).collect();
    for col in 0..n {
        let piv = (col..n).max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))?;
        if !(a[piv][col].abs() > tiny) {
            return None;
        }
        a.swap(col, piv);
        let p = a[col][col];
        a[col].iter_mut().for_each(|v| *v /= p);
        for r in 0..n {
            if r != col {
                let f = a[r][col];
                let pivot_row = a[col].clone();
                a[r].iter_mut().zip(&pivot_row).for_each(|(v, pv)| *v -= f * pv);
            }
        }
    }
    Some(a.into_iter().map(|r| r[n..].to_vec()).collect())
}

#[cfg(test)]
#[path = "noise_level_tests.rs"]
mod tests;
