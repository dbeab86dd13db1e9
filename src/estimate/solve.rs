//! Robust non-negative least squares for the lighting model, per colour channel.
//!
//! Each usable pixel sample gives one row `y = a·Pa + b·Pd` with `a = ρ·c/π` and
//! `b = ρ·(s·max(n·l,0) + b_bounce)/π` (Jensen §4.2, the same equation as the relighting). People,
//! cars, wet patches and highlights make outliers, so the fit is robust:
//!
//! 1. **Weights.** Each row is divided by its own noise level `|y| + floor`, so the fit
//!    minimises relative residuals. Camera noise grows with the signal, so this is the right
//!    weighting; it also makes the arithmetic independent of the overall scale (1e-4 … 1e5) and
//!    keeps dark shadowed samples from being swamped by bright sunlit ones when the sun-to-sky ratio
//!    is extreme. The floor is [`LDR_NOISE_FLOOR_REL`] or [`HDR_NOISE_FLOOR_REL`] of the median.
//! 2. **Start (LMedS).** Minimal fits through pairs of rows (one sunlit, one shadowed when both
//!    exist, so the pair is well conditioned), plus the plain least-squares fit, are scored by the
//!    median squared residual; the best one wins (Rousseeuw's least median of squares, breakdown
//!    ≈ 50%).
//! 3. **Refine (MM).** Iteratively reweighted least squares with Tukey's biweight (c = 4.685, 95%
//!    Gaussian efficiency) at the LMedS scale. Every weighted solve is a 2-variable NNLS solved
//!    exactly by its active sets, so `Pa, Pd ≥ 0` always.
//! 4. **Report.** Standard errors from `σ²·(AᵀWA)⁻¹`, the weighted residual RMS, the inlier count
//!    (non-zero biweight) and the condition number of the weighted design with unit-norm columns,
//!    `κ = √((1+|r|)/(1−|r|))` where `r` is the cosine between the `a` and `b` columns. `κ` grows
//!    without bound when the sunlit and ambient columns are proportional (all samples sunlit on one
//!    plane), which is exactly when `Pd` and `Pa` cannot be separated.

use rand::Rng;

/// Tukey biweight tuning constant (95% efficiency under Gaussian noise).
pub(super) const TUKEY_C: f64 = 4.685;
/// Consistency factor of the median absolute deviation for Gaussian noise.
pub(super) const MAD_TO_SIGMA: f64 = 1.4826;
/// Minimal-fit trials of the LMedS start. With 30% outliers a pair is clean with probability
/// 0.49, so 16 trials all fail with probability 0.51¹⁶ ≈ 2·10⁻⁵ (and the plain fit is a 17th).
const LMEDS_TRIALS: usize = 16;
/// Rows (an even stride through all rows) on which LMedS candidates are scored. The median of 101
/// squared residuals ranks candidates as well as that of all rows, at a fraction of the cost.
pub(super) const LMEDS_SCORE_ROWS: usize = 101;
/// IRLS iterations at most.
pub(super) const IRLS_MAX_ITERS: usize = 30;
/// Relative parameter change at which IRLS stops.
pub(super) const IRLS_TOL: f64 = 1e-9;
/// Scale floor relative to the median row value, so noise-free data does not divide by zero.
pub(super) const SIGMA_FLOOR: f64 = 1e-9;
/// Noise floor for 8-bit-like LDR input, relative to the median row value: rows are weighted as
/// if their noise were `|y| + floor`, relative (shot-like) noise with a floor for the quantisation
/// and read noise that dominate near-black codes.
pub const LDR_NOISE_FLOOR_REL: f64 = 0.05;
/// Noise floor for HDR (floating-point) input: merged or rendered HDR keeps its noise relative
/// over the whole range, so the floor only guards against division by zero.
pub const HDR_NOISE_FLOOR_REL: f64 = 1e-12;
/// Condition numbers are reported up to this value (larger means singular).
pub const COND_CAP: f64 = 1e12;

/// Rows of one colour channel.
#[derive(Clone, Debug, Default)]
pub struct ChannelRows {
    /// Ambient coefficients `ρ·c/π`.
    pub a: Vec<f64>,
    /// Direct coefficients `ρ·(s·cos + b)/π`.
    pub b: Vec<f64>,
    /// Observed linear radiance.
    pub y: Vec<f64>,
}

impl ChannelRows {
    /// Appends a row.
    #[inline]
    pub fn push(&mut self, a: f64, b: f64, y: f64) {
        self.a.push(a);
        self.b.push(b);
        self.y.push(y);
    }

    /// Number of rows.
    pub fn len(&self) -> usize {
        self.y.len()
    }

    /// True with no rows.
    pub fn is_empty(&self) -> bool {
        self.y.is_empty()
    }

    /// Removes all rows (keeps the allocation).
    pub fn clear(&mut self) {
        self.a.clear();
        self.b.clear();
        self.y.clear();
    }
}

/// The result of a robust fit of one channel.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ChannelFit {
    /// Ambient parameter (`Pa`), ≥ 0.
    pub pa: f64,
    /// Direct parameter (`Pd`), ≥ 0 (0 for a one-parameter fit).
    pub pd: f64,
    /// Standard error of `pa`.
    pub pa_se: f64,
    /// Standard error of `pd` (infinite when unobservable).
    pub pd_se: f64,
    /// Weighted residual RMS, in the units of `y`.
    pub residual_rms: f64,
    /// Rows with non-zero final weight.
    pub inliers: usize,
    /// Condition number of the weighted, column-normalised design (≤ [`COND_CAP`]).
    pub condition: f64,
}

pub(super) fn median_in_place(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    let mid = v.len() / 2;
    let (_, m, _) = v.select_nth_unstable_by(mid, |x, y| x.total_cmp(y));
    *m
}

/// Weighted 2-variable NNLS from the normal-equation sums; returns `(pa, pd)`.
fn nnls2(saa: f64, sab: f64, sbb: f64, say: f64, sby: f64) -> (f64, f64) {
    let det = saa * sbb - sab * sab;
    if det > 1e-14 * saa * sbb && det > 0.0 {
        let pa = (sbb * say - sab * sby) / det;
        let pd = (saa * sby - sab * say) / det;
        if pa >= 0.0 && pd >= 0.0 {
            return (pa, pd);
        }
    }
    // Active sets with one variable at zero: pick the one with the smaller weighted SSE, which is
    // the one with the larger (projection)² / norm² gain.
    let only_a = if saa > 0.0 { (say / saa).max(0.0) } else { 0.0 };
    let only_b = if sbb > 0.0 { (sby / sbb).max(0.0) } else { 0.0 };
    let gain_a = only_a * say; // SSE reduction = say²/saa
    let gain_b = only_b * sby;
    if gain_a >= gain_b { (only_a, 0.0) } else { (0.0, only_b) }
}

struct Sums {
    saa: f64,
    sab: f64,
    sbb: f64,
    say: f64,
    sby: f64,
    sw: f64,
}

fn sums(a: &[f64], b: &[f64], y: &[f64], w: &[f64]) -> Sums {
    let mut s = Sums { saa: 0.0, sab: 0.0, sbb: 0.0, say: 0.0, sby: 0.0, sw: 0.0 };
    for i in 0..y.len() {
        let wi = w[i];
        s.saa += wi * a[i] * a[i];
        s.sab += wi * a[i] * b[i];
        s.sbb += wi * b[i] * b[i];
        s.say += wi * a[i] * y[i];
        s.sby += wi * b[i] * y[i];
        s.sw += wi;
    }
    s
}

pub(super) fn tukey(r: f64, sigma: f64) -> f64 {
    let u = r / (TUKEY_C * sigma);
    if u.abs() >= 1.0 { 0.0 } else { (1.0 - u * u).powi(2) }
}

/// Condition number of the weighted design with unit-norm columns.
fn condition(saa: f64, sab: f64, sbb: f64) -> f64 {
    if !(saa > 0.0 && sbb > 0.0) {
        return COND_CAP;
    }
    let r = (sab / (saa * sbb).sqrt()).abs().min(1.0);
    if r >= 1.0 {
        return COND_CAP;
    }
    ((1.0 + r) / (1.0 - r)).sqrt().min(COND_CAP)
}

/// Robust fit of `y = a·Pa + b·Pd` with `Pa, Pd ≥ 0`. `lit[i]` marks rows whose direct term is
/// substantial; they pair with unlit rows in the LMedS start. `two_params = false` fits `Pa`
/// alone (the `b` column is ignored). `noise_floor_rel` is the weighting floor relative to the
/// median row (see the module docs). Returns `None` with fewer than 3 rows.
pub fn robust_fit(rows: &ChannelRows, lit: &[bool], two_params: bool, noise_floor_rel: f64, rng: &mut impl Rng) -> Option<ChannelFit> {
    let n = rows.len();
    if n < 3 {
        return None;
    }
    // 1. Scale.
    let mut tmp: Vec<f64> = rows.y.iter().map(|v| v.abs()).collect();
    let mut scale = median_in_place(&mut tmp);
    if !(scale > 0.0 && scale.is_finite()) {
        scale = rows.y.iter().map(|v| v.abs()).fold(0.0, f64::max);
    }
    if !(scale > 0.0 && scale.is_finite()) {
        // All-zero observations: the only consistent non-negative answer is zero light.
        let s = sums(&rows.a, &rows.b, &rows.y, &vec![1.0; n]);
        return Some(ChannelFit {
            condition: if two_params { condition(s.saa, s.sab, s.sbb) } else { 1.0 },
            pd_se: if two_params { 0.0 } else { f64::INFINITY },
            inliers: n,
            ..Default::default()
        });
    }
    // Each row is divided by its noise level d = |y| + floor, so residuals are relative.
    let floor = noise_floor_rel * scale;
    let d: Vec<f64> = rows.y.iter().map(|v| v.abs() + floor).collect();
    let y: Vec<f64> = (0..n).map(|i| rows.y[i] / d[i]).collect();
    let a: Vec<f64> = (0..n).map(|i| rows.a[i] / d[i]).collect();
    let b: Vec<f64> = if two_params { (0..n).map(|i| rows.b[i] / d[i]).collect() } else { vec![0.0; n] };
    let scaled = Scaled { a: &a, b: &b, y: &y, d: &d, p: if two_params { 2.0 } else { 1.0 } };
    // 2. LMedS start, and the robust scale from its median squared residual.
    let (start, med) = scaled.lmeds_start(lit, two_params, rng);
    let small_sample = 1.0 + 5.0 / (n as f64 - scaled.p).max(1.0);
    let sigma = (MAD_TO_SIGMA * small_sample * med.sqrt()).max(SIGMA_FLOOR);
    // 3. IRLS with Tukey's biweight at that scale.
    let (pa, pd) = scaled.irls(start, sigma);
    // 4. Report.
    Some(scaled.report(pa, pd, sigma, two_params))
}

/// The rows of one fit divided by their noise levels `d` (`p` parameters).
struct Scaled<'a> {
    a: &'a [f64],
    b: &'a [f64],
    y: &'a [f64],
    d: &'a [f64],
    p: f64,
}

impl Scaled<'_> {
    /// The least-median-of-squares start (Rousseeuw): the plain fit and `LMEDS_TRIALS` exact fits
    /// through random pairs (a sunlit and a shadowed row when both exist), scored on at most
    /// `LMEDS_SCORE_ROWS` rows. Returns the best `(Pa, Pd)` and its median squared residual.
    fn lmeds_start(&self, lit: &[bool], two_params: bool, rng: &mut impl Rng) -> ((f64, f64), f64) {
        let (a, b, y) = (self.a, self.b, self.y);
        let n = y.len();
        let ones = vec![1.0; n];
        let s = sums(a, b, y, &ones);
        let mut candidates = vec![nnls2(s.saa, s.sab, s.sbb, s.say, s.sby)];
        let lit_idx: Vec<usize> = (0..n).filter(|&i| lit.get(i).copied().unwrap_or(false)).collect();
        let dark_idx: Vec<usize> = (0..n).filter(|&i| !lit.get(i).copied().unwrap_or(false)).collect();
        for _ in 0..LMEDS_TRIALS {
            if two_params {
                let (i, j) = if !lit_idx.is_empty() && !dark_idx.is_empty() {
                    (lit_idx[rng.random_range(0..lit_idx.len())], dark_idx[rng.random_range(0..dark_idx.len())])
                } else {
                    (rng.random_range(0..n), rng.random_range(0..n))
                };
                let det = a[i] * b[j] - a[j] * b[i];
                let size = (a[i] * b[j]).abs() + (a[j] * b[i]).abs();
                if !(det.abs() > 1e-3 * size) {
                    continue;
                }
                let pa = (y[i] * b[j] - y[j] * b[i]) / det;
                let pd = (a[i] * y[j] - a[j] * y[i]) / det;
                candidates.push((pa.max(0.0), pd.max(0.0)));
            } else {
                let i = rng.random_range(0..n);
                if a[i] > 0.0 {
                    candidates.push(((y[i] / a[i]).max(0.0), 0.0));
                }
            }
        }
        let stride = n.div_ceil(LMEDS_SCORE_ROWS).max(1);
        let score_idx: Vec<usize> = (0..n).step_by(stride).collect();
        let mut r = Vec::with_capacity(n);
        let mut best = (f64::INFINITY, candidates[0]);
        for &(pa, pd) in &candidates {
            r.clear();
            r.extend(score_idx.iter().map(|&i| {
                let e = y[i] - a[i] * pa - b[i] * pd;
                e * e
            }));
            let med = median_in_place(&mut r);
            if med < best.0 {
                best = (med, (pa, pd));
            }
        }
        (best.1, best.0)
    }

    /// Iteratively reweighted non-negative least squares with Tukey's biweight at `sigma`.
    fn irls(&self, start: (f64, f64), sigma: f64) -> (f64, f64) {
        let (a, b, y) = (self.a, self.b, self.y);
        let (mut pa, mut pd) = start;
        for _ in 0..IRLS_MAX_ITERS {
            let mut st = Sums { saa: 0.0, sab: 0.0, sbb: 0.0, say: 0.0, sby: 0.0, sw: 0.0 };
            for i in 0..y.len() {
                let wi = tukey(y[i] - a[i] * pa - b[i] * pd, sigma);
                st.saa += wi * a[i] * a[i];
                st.sab += wi * a[i] * b[i];
                st.sbb += wi * b[i] * b[i];
                st.say += wi * a[i] * y[i];
                st.sby += wi * b[i] * y[i];
            }
            let (npa, npd) = nnls2(st.saa, st.sab, st.sbb, st.say, st.sby);
            let change = (npa - pa).abs() + (npd - pd).abs();
            pa = npa;
            pd = npd;
            if change <= IRLS_TOL * (pa + pd).max(1e-300) {
                break;
            }
        }
        (pa, pd)
    }

    /// The fit's standard errors (from the weighted normal equations), condition number,
    /// inliers and residual RMS in the rows' own units.
    fn report(&self, pa: f64, pd: f64, sigma: f64, two_params: bool) -> ChannelFit {
        let (a, b, y, d) = (self.a, self.b, self.y, self.d);
        let n = y.len();
        let r: Vec<f64> = (0..n).map(|i| y[i] - a[i] * pa - b[i] * pd).collect();
        let w: Vec<f64> = r.iter().map(|&ri| tukey(ri, sigma)).collect();
        let s = sums(a, b, y, &w);
        let inliers = w.iter().filter(|&&x| x > 0.0).count();
        let wss: f64 = (0..n).map(|i| w[i] * r[i] * r[i]).sum();
        let dof = (s.sw - self.p).max(1.0);
        let s2 = wss / dof;
        let (pa_se, pd_se, cond) = if two_params {
            let det = s.saa * s.sbb - s.sab * s.sab;
            let cond = condition(s.saa, s.sab, s.sbb);
            if det > 0.0 && cond < COND_CAP {
                ((s2 * s.sbb / det).sqrt(), (s2 * s.saa / det).sqrt(), cond)
            } else {
                (f64::INFINITY, f64::INFINITY, cond)
            }
        } else {
            let se = if s.saa > 0.0 { (s2 / s.saa).sqrt() } else { f64::INFINITY };
            (se, f64::INFINITY, 1.0)
        };
        let wss_units: f64 = (0..n).map(|i| w[i] * (r[i] * d[i]).powi(2)).sum();
        ChannelFit {
            pa,
            pd,
            pa_se,
            pd_se,
            residual_rms: if s.sw > 0.0 { (wss_units / s.sw).sqrt() } else { f64::INFINITY },
            inliers,
            condition: cond,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{SeedableRng, rngs::SmallRng};

    fn synth(n: usize, pa: f64, pd: f64, noise: f64, seed: u64) -> (ChannelRows, Vec<bool>) {
        let mut rng = SmallRng::seed_from_u64(seed);
        let mut rows = ChannelRows::default();
        let mut lit = Vec::new();
        for _ in 0..n {
            let rho: f64 = rng.random_range(0.1..0.6);
            let c: f64 = rng.random_range(0.5..1.0);
            let sun = rng.random_bool(0.6);
            let cos: f64 = rng.random_range(0.3..1.0);
            let a = rho * c / std::f64::consts::PI;
            let b = if sun { rho * cos / std::f64::consts::PI } else { 0.0 };
            let y = (a * pa + b * pd) * (1.0 + noise * rng.random_range(-1.0..1.0));
            rows.push(a, b, y);
            lit.push(sun);
        }
        (rows, lit)
    }

    #[test]
    fn exact_data_is_recovered_exactly() {
        let (rows, lit) = synth(200, 0.7, 3.1, 0.0, 1);
        let f = robust_fit(&rows, &lit, true, HDR_NOISE_FLOOR_REL, &mut SmallRng::seed_from_u64(0)).unwrap();
        assert!((f.pa - 0.7).abs() < 1e-9 && (f.pd - 3.1).abs() < 1e-9, "{f:?}");
        assert!(f.condition > 1.0 && f.condition < 10.0);
    }

    #[test]
    fn thirty_percent_outliers_are_rejected() {
        let (mut rows, lit) = synth(500, 0.7, 3.1, 0.01, 2);
        let mut rng = SmallRng::seed_from_u64(3);
        // 30% gross outliers of both signs (shadows of unmodelled people, highlights).
        for i in 0..150 {
            rows.y[i * 3] *= if rng.random_bool(0.5) { rng.random_range(0.05..0.4) } else { rng.random_range(2.0..6.0) };
        }
        let f = robust_fit(&rows, &lit, true, HDR_NOISE_FLOOR_REL, &mut rng).unwrap();
        assert!((f.pa / 0.7 - 1.0).abs() < 0.02, "{f:?}");
        assert!((f.pd / 3.1 - 1.0).abs() < 0.02, "{f:?}");
        assert!(f.inliers < 380 && f.inliers > 330, "{f:?}");
    }

    #[test]
    fn never_negative() {
        // Observations that a negative Pd would fit best: sunlit rows darker than shadowed ones.
        let mut rows = ChannelRows::default();
        let mut lit = Vec::new();
        for i in 0..100 {
            let sun = i % 2 == 0;
            rows.push(0.1, if sun { 0.1 } else { 0.0 }, if sun { 0.5 } else { 1.0 });
            lit.push(sun);
        }
        let f = robust_fit(&rows, &lit, true, HDR_NOISE_FLOOR_REL, &mut SmallRng::seed_from_u64(0)).unwrap();
        assert!(f.pa >= 0.0 && f.pd == 0.0, "{f:?}");
    }

    #[test]
    fn scale_invariance_over_nine_decades() {
        for scale in [1e-4, 1.0, 1e5] {
            let (rows, lit) = synth(300, 0.7 * scale, 3.1 * scale, 0.01, 4);
            let f = robust_fit(&rows, &lit, true, HDR_NOISE_FLOOR_REL, &mut SmallRng::seed_from_u64(0)).unwrap();
            assert!((f.pa / (0.7 * scale) - 1.0).abs() < 0.02, "{scale}: {f:?}");
            assert!((f.pd / (3.1 * scale) - 1.0).abs() < 0.01, "{scale}: {f:?}");
        }
    }

    #[test]
    fn collinear_columns_report_a_huge_condition_number() {
        let mut rows = ChannelRows::default();
        for i in 0..100 {
            let rho = 0.2 + 0.003 * i as f64;
            rows.push(rho * 0.9, rho * 0.7, rho * (0.9 * 0.5 + 0.7 * 3.0));
        }
        let f = robust_fit(&rows, &[true; 100], true, HDR_NOISE_FLOOR_REL, &mut SmallRng::seed_from_u64(0)).unwrap();
        assert!(f.condition > 1e6, "{f:?}");
    }

    #[test]
    fn one_parameter_fit() {
        let (rows, _) = synth(100, 0.9, 0.0, 0.0, 5);
        let f = robust_fit(&rows, &[false; 100], false, HDR_NOISE_FLOOR_REL, &mut SmallRng::seed_from_u64(0)).unwrap();
        assert!((f.pa - 0.9).abs() < 1e-9 && f.pd == 0.0 && f.pd_se.is_infinite());
    }
}
