//! The robust NNLS of [`super::solve`] for any number of known-shape columns: `Pa`, `Pd` and one
//! scale `k_i` per lamp (issue 16 §3; the model of Jensen §3.1 with the lamps' irradiance as more
//! terms, `y = a·Pa + b·Pd + Σ g_i·k_i`, `g_i = ρ/π·E_i·V_i`).
//!
//! # How it works
//! The same four steps as the two-column solver, generalised:
//! 1. **Weights:** each row divided by its noise level: `|y| + floor` for the start, the previous
//!    IRLS step's prediction `μ̂ + floor` in each step (the floor alone at `μ̂ ≤ 0`; the observed
//!    value biases noisy fits low, [`super::solve`] step 1).
//! 2. **Start (LMedS):** the plain NNLS fit and [`LMEDS_TRIALS_MULTI`] exact fits through `p`
//!    rows, one drawn among the rows where each column is non-zero (so a lamp's column gets a row
//!    it lights), scored by the median squared residual.
//! 3. **Refine:** Tukey IRLS at the LMedS scale ([`super::solve::irls_weight`]); each weighted solve is an NNLS on the normal
//!    equations by Lawson and Hanson's active sets, so every parameter stays `≥ 0`.
//! 4. **Report:** standard errors from `σ²·(AᵀWA)⁻¹`; the condition number `√(λ_max/λ_min)` of the
//!    weighted design with unit-norm columns (for two columns this is the solver's
//!    `√((1+|r|)/(1−|r|))`); and per column the same measure between the column and its best
//!    fit by the others (`r_j² = 1 − 1/VIF_j`, `VIF_j` the diagonal of the normalised inverse), which
//!    says which parameter cannot be told apart from the rest.

use super::solve::{COND_CAP, ChannelFit, IRLS_MAX_ITERS, IRLS_TOL, LMEDS_SCORE_ROWS, Level, MAD_TO_SIGMA, SIGMA_FLOOR, irls_weights, median_in_place, tukey};
use rand::Rng;

/// Minimal-fit trials of the LMedS start. With three columns and 30% outliers a triple is clean
/// with probability 0.34: 32 trials all fail with probability 0.66³² ≈ 2·10⁻⁶.
const LMEDS_TRIALS_MULTI: usize = 32;
/// A minimal fit whose smallest pivot is below this fraction of its largest is skipped.
const MIN_PIVOT_REL: f64 = 1e-6;

/// The fit of one channel with `p` columns.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MultiFit {
    /// Parameters, ≥ 0, in column order.
    pub x: Vec<f64>,
    /// Their standard errors (infinite when the design is singular).
    pub se: Vec<f64>,
    /// Weighted residual RMS, in the units of `y`.
    pub residual_rms: f64,
    /// Rows with non-zero final weight.
    pub inliers: usize,
    /// Condition number of the weighted, column-normalised design (≤ [`COND_CAP`]).
    pub condition: f64,
    /// Per column, the condition number against the best fit of it by the other columns.
    pub column_condition: Vec<f64>,
    /// The parameters' covariance, `p×p` row-major (infinite when the design is singular; zero
    /// for a fit without rows of light).
    pub covariance: Vec<f64>,
}

impl MultiFit {
    /// The fit of `Pa` (column 0) and, when `two`, `Pd` (column 1) as a [`ChannelFit`], whose
    /// condition number is `condition` (capped at [`COND_CAP`]; 1 for a one-column fit).
    pub(super) fn channel(&self, two: bool, condition: f64) -> ChannelFit {
        ChannelFit {
            pa: self.x[0],
            pd: if two { self.x[1] } else { 0.0 },
            pa_se: self.se[0],
            pd_se: if two { self.se[1] } else { f64::INFINITY },
            residual_rms: self.residual_rms,
            inliers: self.inliers,
            condition: if two { condition.min(COND_CAP) } else { 1.0 },
        }
    }
}

/// Solves the `p×p` system `m·x = v` (row-major) by Gaussian elimination with partial pivoting;
/// `None` when a pivot falls below `MIN_PIVOT_REL` of the largest.
fn solve_dense(m: &[f64], v: &[f64], p: usize) -> Option<Vec<f64>> {
    let mut a: Vec<f64> = m.to_vec();
    let mut b = v.to_vec();
    let scale = a.iter().fold(0.0f64, |s, x| s.max(x.abs()));
    if !(scale > 0.0 && scale.is_finite()) {
        return None;
    }
    for k in 0..p {
        let piv = (k..p).max_by(|&i, &j| a[i * p + k].abs().total_cmp(&a[j * p + k].abs()))?;
        if !(a[piv * p + k].abs() > MIN_PIVOT_REL * scale) {
            return None;
        }
        if piv != k {
            for c in 0..p {
                a.swap(k * p + c, piv * p + c);
            }
            b.swap(k, piv);
        }
        for i in k + 1..p {
            let f = a[i * p + k] / a[k * p + k];
            for c in k..p {
                a[i * p + c] -= f * a[k * p + c];
            }
            b[i] -= f * b[k];
        }
    }
    let mut x = vec![0.0; p];
    for k in (0..p).rev() {
        let s: f64 = (k + 1..p).map(|c| a[k * p + c] * x[c]).sum();
        x[k] = (b[k] - s) / a[k * p + k];
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
}

/// The inverse of a symmetric positive definite `p×p` matrix, column by column.
fn inverse(g: &[f64], p: usize) -> Option<Vec<f64>> {
    let mut inv = vec![0.0; p * p];
    for j in 0..p {
        let e: Vec<f64> = (0..p).map(|i| (i == j) as u8 as f64).collect();
        let col = solve_dense(g, &e, p)?;
        for i in 0..p {
            inv[i * p + j] = col[i];
        }
    }
    Some(inv)
}

/// Eigenvalues of a symmetric `p×p` matrix by cyclic Jacobi rotations.
fn eigenvalues(g: &[f64], p: usize) -> Vec<f64> {
    let mut a = g.to_vec();
    for _ in 0..60 {
        let off: f64 = (0..p).flat_map(|i| (0..p).filter(move |&j| j != i).map(move |j| (i, j))).map(|(i, j)| a[i * p + j].powi(2)).sum();
        if off < 1e-30 {
            break;
        }
        for i in 0..p {
            for j in i + 1..p {
                let aij = a[i * p + j];
                if aij.abs() < 1e-300 {
                    continue;
                }
                let theta = (a[j * p + j] - a[i * p + i]) / (2.0 * aij);
                let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
                let t = if theta == 0.0 { 1.0 } else { t };
                let (c, s) = (1.0 / (t * t + 1.0).sqrt(), t / (t * t + 1.0).sqrt());
                for k in 0..p {
                    let (aki, akj) = (a[k * p + i], a[k * p + j]);
                    a[k * p + i] = c * aki - s * akj;
                    a[k * p + j] = s * aki + c * akj;
                }
                for k in 0..p {
                    let (aik, ajk) = (a[i * p + k], a[j * p + k]);
                    a[i * p + k] = c * aik - s * ajk;
                    a[j * p + k] = s * aik + c * ajk;
                }
            }
        }
    }
    (0..p).map(|i| a[i * p + i]).collect()
}

/// NNLS on the normal equations `G x = h` (Lawson–Hanson active sets).
pub(super) fn nnls(g: &[f64], h: &[f64], p: usize) -> Vec<f64> {
    let mut x = vec![0.0; p];
    let mut passive = vec![false; p];
    let mut barred = vec![false; p];
    let tol = 1e-12 * h.iter().fold(0.0f64, |s, v| s.max(v.abs())).max(1e-300);
    for _ in 0..3 * p + 3 {
        let w: Vec<f64> = (0..p).map(|i| h[i] - (0..p).map(|j| g[i * p + j] * x[j]).sum::<f64>()).collect();
        let Some(j) = (0..p).filter(|&i| !passive[i] && !barred[i] && w[i] > tol).max_by(|&a, &b| w[a].total_cmp(&w[b])) else { break };
        passive[j] = true;
        for _ in 0..3 * p + 3 {
            let idx: Vec<usize> = (0..p).filter(|&i| passive[i]).collect();
            let q = idx.len();
            let sub: Vec<f64> = idx.iter().flat_map(|&r| idx.iter().map(move |&c| g[r * p + c])).collect();
            let rhs: Vec<f64> = idx.iter().map(|&r| h[r]).collect();
            let Some(zp) = solve_dense(&sub, &rhs, q) else {
                // The new column is (nearly) a combination of the passive ones: leave it out.
                passive[j] = false;
                barred[j] = true;
                break;
            };
            let mut z = vec![0.0; p];
            for (k, &i) in idx.iter().enumerate() {
                z[i] = zp[k];
            }
            if idx.iter().all(|&i| z[i] > 0.0) {
                x = z;
                break;
            }
            let alpha = idx.iter().filter(|&&i| z[i] <= 0.0).map(|&i| x[i] / (x[i] - z[i])).fold(1.0f64, f64::min);
            for i in 0..p {
                x[i] += alpha * (z[i] - x[i]);
                if passive[i] && x[i] <= 1e-15 * (1.0 + x[i].abs()) {
                    passive[i] = false;
                    x[i] = 0.0;
                }
            }
        }
    }
    x
}

/// Weighted normal equations `G = AᵀWA`, `h = AᵀWy` and `Σw`.
pub(super) fn normal(cols: &[Vec<f64>], y: &[f64], w: &[f64]) -> (Vec<f64>, Vec<f64>, f64) {
    let p = cols.len();
    let mut g = vec![0.0; p * p];
    let mut h = vec![0.0; p];
    for i in 0..y.len() {
        if w[i] == 0.0 {
            continue;
        }
        for r in 0..p {
            let wr = w[i] * cols[r][i];
            h[r] += wr * y[i];
            for c in 0..p {
                g[r * p + c] += wr * cols[c][i];
            }
        }
    }
    (g, h, w.iter().sum())
}

/// Condition number of `g` with unit-norm columns, and each column's against the others: `r_j`
/// is the norm of column `j`'s projection on the span of the others (Gram–Schmidt in the
/// normalised Gram metric, dependent columns skipped), `κ_j = √((1+r_j)/(1−r_j))`.
fn conditions(g: &[f64], p: usize) -> (f64, Vec<f64>) {
    let d: Vec<f64> = (0..p).map(|i| g[i * p + i]).collect();
    if d.iter().any(|&v| !(v > 0.0)) {
        return (COND_CAP, vec![COND_CAP; p]);
    }
    let gn: Vec<f64> = (0..p * p).map(|k| g[k] / (d[k / p] * d[k % p]).sqrt()).collect();
    let ev = eigenvalues(&gn, p);
    let (lo, hi) = ev.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), &v| (lo.min(v), hi.max(v)));
    let cond = if lo > 0.0 { (hi / lo).sqrt().min(COND_CAP) } else { COND_CAP };
    let dot = |u: &[f64], v: &[f64]| -> f64 { (0..p).map(|i| (0..p).map(|j| u[i] * gn[i * p + j] * v[j]).sum::<f64>()).sum() };
    let unit = |i: usize| -> Vec<f64> { (0..p).map(|k| (k == i) as u8 as f64).collect() };
    let per = (0..p)
        .map(|j| {
            let mut basis: Vec<Vec<f64>> = Vec::new();
            for i in (0..p).filter(|&i| i != j) {
                let mut v = unit(i);
                for q in &basis {
                    let c = dot(&v, q);
                    v.iter_mut().zip(q).for_each(|(v, q)| *v -= c * q);
                }
                let norm2 = dot(&v, &v);
                if norm2 > 1e-12 {
                    basis.push(v.iter().map(|x| x / norm2.sqrt()).collect());
                }
            }
            let ej = unit(j);
            let r = basis.iter().map(|q| dot(&ej, q).powi(2)).sum::<f64>().sqrt();
            if r >= 1.0 { COND_CAP } else { ((1.0 + r) / (1.0 - r)).sqrt().min(COND_CAP) }
        })
        .collect();
    (cond, per)
}

/// Robust fit of `y = Σ cols[j]·x_j`, `x ≥ 0` (module docs). `None` with fewer rows than
/// `max(3, p + 1)` or no column.
pub fn robust_fit_multi(cols: &[Vec<f64>], y: &[f64], noise_floor_rel: f64, rng: &mut impl Rng) -> Option<MultiFit> {
    robust_fit_multi_with(cols, y, noise_floor_rel, Level::Predicted, rng)
}

/// [`robust_fit_multi`] with the IRLS's noise levels set by `level`.
pub(super) fn robust_fit_multi_with(cols: &[Vec<f64>], y: &[f64], noise_floor_rel: f64, level: Level, rng: &mut impl Rng) -> Option<MultiFit> {
    let (n, p) = (y.len(), cols.len());
    if p == 0 || n < 3.max(p + 1) {
        return None;
    }
    let mut tmp: Vec<f64> = y.iter().map(|v| v.abs()).collect();
    let mut scale = median_in_place(&mut tmp);
    if !(scale > 0.0 && scale.is_finite()) {
        scale = y.iter().map(|v| v.abs()).fold(0.0, f64::max);
    }
    if !(scale > 0.0 && scale.is_finite()) {
        let (g, _, _) = normal(cols, y, &vec![1.0; n]);
        let (condition, column_condition) = conditions(&g, p);
        return Some(MultiFit { x: vec![0.0; p], se: vec![0.0; p], residual_rms: 0.0, inliers: n, condition, column_condition, covariance: vec![0.0; p * p] });
    }
    let floor = noise_floor_rel * scale;
    let observed: Vec<f64> = y.iter().map(|v| v.abs() + floor).collect();
    let (cs, ys) = divided(cols, y, &observed);
    let (mut x, med) = lmeds_start(&cs, &ys, rng);
    let small_sample = 1.0 + 5.0 / (n as f64 - p as f64).max(1.0);
    let sigma = (MAD_TO_SIGMA * small_sample * med.sqrt()).max(SIGMA_FLOOR);
    // IRLS on the raw rows, each weighted by its biweight over its level squared.
    let (mut d, mut w) = (Vec::with_capacity(n), Vec::with_capacity(n));
    let predict = |x: &[f64]| -> Vec<f64> { (0..n).map(|i| (0..p).map(|j| cols[j][i] * x[j]).sum()).collect() };
    for _ in 0..IRLS_MAX_ITERS {
        irls_weights(y, &predict(&x), floor, sigma, level, &mut d, &mut w);
        let (g, h, _) = normal(cols, y, &w);
        let nx = nnls(&g, &h, p);
        let change: f64 = (0..p).map(|j| (nx[j] - x[j]).abs()).sum();
        x = nx;
        if change <= IRLS_TOL * x.iter().sum::<f64>().max(1e-300) {
            break;
        }
    }
    irls_weights(y, &predict(&x), floor, sigma, level, &mut d, &mut w);
    let (cs, ys) = divided(cols, y, &d);
    Some(report(&cs, &ys, &d, x, |_, r| tukey(r, sigma)))
}

/// The columns and observations divided row by row by the levels `d`.
fn divided(cols: &[Vec<f64>], y: &[f64], d: &[f64]) -> (Vec<Vec<f64>>, Vec<f64>) {
    let div = |v: &[f64]| v.iter().zip(d).map(|(v, d)| v / d).collect();
    (cols.iter().map(|c| div(c)).collect(), div(y))
}

/// Residual of scaled row `i` at `x`.
pub(super) fn resid(cs: &[Vec<f64>], ys: &[f64], x: &[f64], i: usize) -> f64 {
    ys[i] - (0..cs.len()).map(|j| cs[j][i] * x[j]).sum::<f64>()
}

/// The LMedS start on scaled rows (module docs, step 2): the best candidate and its median
/// squared residual.
pub(super) fn lmeds_start(cs: &[Vec<f64>], ys: &[f64], rng: &mut impl Rng) -> (Vec<f64>, f64) {
    let (n, p) = (ys.len(), cs.len());
    let (g, h, _) = normal(cs, ys, &vec![1.0; n]);
    let mut candidates = vec![nnls(&g, &h, p)];
    let support: Vec<Vec<usize>> = cs.iter().map(|c| (0..n).filter(|&i| c[i] > 0.0).collect()).collect();
    if support.iter().all(|s| !s.is_empty()) {
        for _ in 0..LMEDS_TRIALS_MULTI {
            let rows: Vec<usize> = support.iter().map(|s| s[rng.random_range(0..s.len())]).collect();
            let m: Vec<f64> = rows.iter().flat_map(|&i| cs.iter().map(move |c| c[i])).collect();
            let v: Vec<f64> = rows.iter().map(|&i| ys[i]).collect();
            if let Some(x) = solve_dense(&m, &v, p) {
                candidates.push(x.iter().map(|v| v.max(0.0)).collect());
            }
        }
    }
    let stride = n.div_ceil(LMEDS_SCORE_ROWS).max(1);
    let mut best = (f64::INFINITY, 0);
    let mut r = Vec::with_capacity(n);
    for (k, x) in candidates.iter().enumerate() {
        r.clear();
        r.extend((0..n).step_by(stride).map(|i| resid(cs, ys, x, i).powi(2)));
        let med = median_in_place(&mut r);
        if med < best.0 {
            best = (med, k);
        }
    }
    (candidates.swap_remove(best.1), best.0)
}

/// The fit's report (module docs, step 4) from scaled rows, their scales `d` and the robust
/// weight `weight(row, residual)`.
pub(super) fn report(cs: &[Vec<f64>], ys: &[f64], d: &[f64], x: Vec<f64>, weight: impl Fn(usize, f64) -> f64) -> MultiFit {
    let (n, p) = (ys.len(), cs.len());
    let res: Vec<f64> = (0..n).map(|i| resid(cs, ys, &x, i)).collect();
    let w: Vec<f64> = res.iter().enumerate().map(|(i, &ri)| weight(i, ri)).collect();
    let (g, _, sw) = normal(cs, ys, &w);
    let wss: f64 = (0..n).map(|i| w[i] * res[i] * res[i]).sum();
    let s2 = wss / (sw - p as f64).max(1.0);
    let (condition, column_condition) = conditions(&g, p);
    let covariance: Vec<f64> = match inverse(&g, p) {
        Some(inv) if condition < COND_CAP => inv.iter().map(|v| s2 * v).collect(),
        _ => vec![f64::INFINITY; p * p],
    };
    let se = (0..p).map(|j| covariance[j * p + j].max(0.0).sqrt()).collect();
    let wss_units: f64 = (0..n).map(|i| w[i] * (res[i] * d[i]).powi(2)).sum();
    MultiFit {
        x,
        se,
        residual_rms: if sw > 0.0 { (wss_units / sw).sqrt() } else { f64::INFINITY },
        inliers: w.iter().filter(|&&v| v > 0.0).count(),
        condition,
        column_condition,
        covariance,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::estimate::solve::{ChannelRows, HDR_NOISE_FLOOR_REL, robust_fit};
    use rand::{SeedableRng, rngs::SmallRng};

    /// Rows lit by the sky, the sun on 60% of them and a lamp falling off with distance.
    fn synth(n: usize, x: [f64; 3], noise: f64, seed: u64) -> (Vec<Vec<f64>>, Vec<f64>) {
        let mut rng = SmallRng::seed_from_u64(seed);
        let mut cols = vec![Vec::new(), Vec::new(), Vec::new()];
        let mut y = Vec::new();
        for _ in 0..n {
            let rho: f64 = rng.random_range(0.1..0.6);
            let a = rho * rng.random_range(0.5..1.0);
            let b = if rng.random_bool(0.6) { rho * rng.random_range(0.3..1.0) } else { 0.0 };
            let r: f64 = rng.random_range(1.0..8.0);
            let g = if rng.random_bool(0.8) { rho / (r * r) } else { 0.0 };
            cols[0].push(a);
            cols[1].push(b);
            cols[2].push(g);
            y.push((a * x[0] + b * x[1] + g * x[2]) * (1.0 + noise * rng.random_range(-1.0..1.0)));
        }
        (cols, y)
    }

    #[test]
    fn exact_and_noisy_data_are_recovered() {
        let truth = [0.7, 3.1, 12.0];
        let (cols, y) = synth(300, truth, 0.0, 1);
        let f = robust_fit_multi(&cols, &y, HDR_NOISE_FLOOR_REL, &mut SmallRng::seed_from_u64(0)).unwrap();
        for j in 0..3 {
            // exact rows: the NNLS solve is exact up to rounding
            assert!((f.x[j] / truth[j] - 1.0).abs() < 1e-9, "{f:?}");
        }
        assert!(f.condition > 1.0 && f.condition < 10.0 && f.column_condition.iter().all(|&c| c < 10.0), "{f:?}");
        let (cols, mut y) = synth(500, truth, 0.02, 2);
        // 20% gross outliers of both signs (people, highlights), at random rows
        let mut rng = SmallRng::seed_from_u64(9);
        for v in y.iter_mut() {
            if rng.random_bool(0.2) {
                *v *= if rng.random_bool(0.5) { rng.random_range(0.05..0.4) } else { rng.random_range(2.0..6.0) };
            }
        }
        let f = robust_fit_multi(&cols, &y, HDR_NOISE_FLOOR_REL, &mut SmallRng::seed_from_u64(0)).unwrap();
        for j in 0..3 {
            // 2% uniform noise over ~400 inliers: the errors are a few tenths of a percent
            assert!((f.x[j] / truth[j] - 1.0).abs() < 0.02, "{j}: {f:?}");
            assert!(f.se[j] > 0.0 && f.se[j] < 0.02 * truth[j], "{f:?}");
        }
        assert!(f.inliers < 430 && f.inliers > 370, "{f:?}");
    }

    #[test]
    fn two_columns_match_the_two_column_solver() {
        let (cols, y) = synth(200, [0.7, 3.1, 0.0], 0.0, 3);
        let f = robust_fit_multi(&cols[..2], &y, HDR_NOISE_FLOOR_REL, &mut SmallRng::seed_from_u64(0)).unwrap();
        let mut rows = ChannelRows::default();
        for i in 0..y.len() {
            rows.push(cols[0][i], cols[1][i], y[i]);
        }
        let lit: Vec<bool> = cols[1].iter().map(|&b| b > 0.0).collect();
        let f2 = robust_fit(&rows, &lit, true, HDR_NOISE_FLOOR_REL, &mut SmallRng::seed_from_u64(0)).unwrap();
        assert!((f.x[0] - f2.pa).abs() < 1e-9 && (f.x[1] - f2.pd).abs() < 1e-9);
        // the same condition number by its two definitions
        assert!((f.condition / f2.condition - 1.0).abs() < 1e-9, "{} vs {}", f.condition, f2.condition);
        assert!((f.column_condition[0] / f2.condition - 1.0).abs() < 1e-9);
    }

    #[test]
    fn proportional_columns_are_flagged_and_stay_non_negative() {
        let (mut cols, y) = synth(200, [0.7, 3.1, 12.0], 0.0, 4);
        // a fourth column proportional to the lamp's: the two cannot be told apart
        cols.push(cols[2].iter().map(|g| 2.0 * g).collect());
        let f = robust_fit_multi(&cols, &y, HDR_NOISE_FLOOR_REL, &mut SmallRng::seed_from_u64(0)).unwrap();
        assert!(f.condition > 1e6 && f.column_condition[2] > 1e6 && f.column_condition[3] > 1e6, "{f:?}");
        assert!(f.column_condition[0] < 10.0 && f.column_condition[1] < 10.0, "{f:?}");
        assert!(f.x.iter().all(|&v| v >= 0.0));
        // the light is still explained: x₂ + 2 x₃ = 12
        assert!((f.x[2] + 2.0 * f.x[3] - 12.0).abs() < 1e-6, "{f:?}");
        assert!(f.se[2].is_infinite());
    }

    #[test]
    fn nnls_clamps_at_zero() {
        // unconstrained solution (2, −1): the constrained optimum sets x₁ = 0
        let g = [2.0, 1.0, 1.0, 2.0];
        let h = [3.0, 0.0];
        let x = nnls(&g, &h, 2);
        assert!((x[0] - 1.5).abs() < 1e-12 && x[1] == 0.0, "{x:?}");
    }
}
