//! Robust non-negative least squares for the lighting model, per colour channel.
//!
//! Each usable pixel sample gives one row `y = a·Pa + b·Pd` with `a = ρ·c/π` and
//! `b = ρ·(s·max(n·l,0) + b_bounce)/π` (Jensen §4.2, the same equation as the relighting). People,
//! cars, wet patches and highlights make outliers, so the fit is robust:
//!
//! 1. **Weights.** Each row is divided by its own noise level, so the fit minimises relative
//!    residuals. Camera noise grows with the signal, so this is the right weighting; it also makes
//!    the arithmetic independent of the overall scale (1e-4 … 1e5) and keeps dark shadowed samples
//!    from being swamped by bright sunlit ones when the sun-to-sky ratio is extreme. The level is
//!    the row's expected value plus a floor, [`LDR_NOISE_FLOOR_REL`] or [`HDR_NOISE_FLOOR_REL`] of
//!    the median: the observed `|y| + floor` for the start (step 2), then in each IRLS step the
//!    previous step's prediction `μ̂ + floor`, `μ̂ = a·Pa + b·Pd` (the floor alone at `μ̂ ≤ 0`).
//!    (Jensen §3.1 fits the two parameters to 500 sampled pixels and leaves the weighting open.)
//!    Dividing by the observed value instead gives rows whose noise happens to be negative more
//!    weight and pulls the fit low: by
//!    `E[u]/E[u²] − 1` with `u = 1/(1 + n)` for relative noise `n`, about `−2·var(n)` (−8.2% at 20%
//!    uniform noise, the unit test; −1.2 points of red `Pa` on the winter frames, whose red has 5%
//!    noise and an all-sunlit view that amplifies it, `docs/measurements.md`). With the prediction
//!    the IRLS's fixed point solves `Σ w·A·(y − A·x)/d(A·x)² = 0`, whose terms have zero mean at
//!    the truth for any zero-mean noise (a quasi-likelihood with variance ∝ μ²).
//! 2. **Start (LMedS).** Minimal fits through pairs of rows (one sunlit, one shadowed when both
//!    exist, so the pair is well conditioned), plus the plain least-squares fit, are scored by the
//!    median squared residual; the best one wins (Rousseeuw's least median of squares, breakdown
//!    ≈ 50%).
//! 3. **Refine (MM).** Iteratively reweighted least squares with Tukey's biweight (c = 4.685, 95%
//!    Gaussian efficiency) at the LMedS scale, on the relative residuals `(y − μ̂)/d` at the levels
//!    of step 1 ([`irls_weight`], shared with [`super::solve_multi`]). Every weighted solve is a
//!    2-variable NNLS solved exactly by its active sets, so `Pa, Pd ≥ 0` always. The convergence
//!    test is on the parameters' relative change. The iteration is a fixed-point map that
//!    converges linearly, at a rate of 0.1–0.55 per step on the bundled frames (a median of 15
//!    steps to the tolerance); every third step is extrapolated by Aitken's Δ² per parameter
//!    ([`aitken`]) when the last two changes shrink geometrically, and the plain steps that follow
//!    decide convergence, so the answer is the same fixed point to the tolerance in a median of 10
//!    steps (docs/measurements.md, "The estimator's IRLS steps").
//! 4. **Report.** On the rows divided by their levels at the fit: standard errors from
//!    `σ²·(AᵀWA)⁻¹`, the weighted residual RMS, the inlier count (non-zero biweight) and the
//!    condition number of the weighted design with unit-norm columns,
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

/// The weighted normal-equation sums of the rows, row `i` (`a_i`, `b_i`, `y_i`) weighted by
/// `w(i, a_i, b_i, y_i)`.
fn sums(a: &[f64], b: &[f64], y: &[f64], w: impl Fn(usize, f64, f64, f64) -> f64) -> Sums {
    let mut s = Sums { saa: 0.0, sab: 0.0, sbb: 0.0, say: 0.0, sby: 0.0, sw: 0.0 };
    for (i, ((&ai, &bi), &yi)) in a.iter().zip(b).zip(y).enumerate() {
        let wi = w(i, ai, bi, yi);
        s.saa += wi * ai * ai;
        s.sab += wi * ai * bi;
        s.sbb += wi * bi * bi;
        s.say += wi * ai * yi;
        s.sby += wi * bi * yi;
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

/// How an IRLS step sets each row's noise level (module docs, step 3).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Level {
    /// The observed value, `|y| + floor`: the LMedS start's, and the IRLS's when a prediction
    /// explains nothing. Biased low on noisy rows (module docs).
    Observed,
    /// The previous step's prediction, `μ̂ + floor` (the floor alone at `μ̂ ≤ 0`).
    Predicted,
}

/// Row `y`'s IRLS weight and noise level `d` (module docs, step 3), shared by this solver and
/// [`super::solve_multi`]: `d` by `level`, from the observation `y` or the previous step's
/// prediction `mu`; the weight is Tukey's biweight of the relative residual `(y − μ)/d` at `sigma`
/// divided by `d²` (the raw row weighted by it is the row divided by `d` weighted by the biweight).
///
/// One division per row (by `d`; `1/(c·σ)` is the same for every row and hoisted out of the
/// loops) and no branch but selects: half the time of the three divisions and the branch it
/// replaced. A non-finite residual weighs zero.
#[inline]
pub(super) fn irls_weight(y: f64, mu: f64, floor: f64, sigma: f64, level: Level) -> (f64, f64) {
    let d = match level {
        Level::Observed => y.abs() + floor,
        Level::Predicted => mu.max(0.0) + floor,
    };
    let inv_d = 1.0 / d;
    let u = (y - mu) * inv_d * (1.0 / (TUKEY_C * sigma));
    let t = (1.0 - u * u).max(0.0);
    (t * t * (inv_d * inv_d), d)
}

/// Aitken's Δ² extrapolation of a linearly converging sequence `x0, x1, x2` (module docs, step
/// 3): its limit `x2 + Δ2·r/(1 − r)` with `r = Δ2/Δ1`, when the changes shrink with the same sign
/// or alternate (`0 < |r| ≤ 0.9`, so the jump is at most nine times the last change); otherwise `x2`. Never
/// negative (the parameters' bound).
fn aitken(x0: f64, x1: f64, x2: f64) -> f64 {
    let (d1, d2) = (x1 - x0, x2 - x1);
    let r = d2 / d1;
    if r != 0.0 && r.abs() <= 0.9 { (x2 + d2 * r / (1.0 - r)).max(0.0) } else { x2 }
}

/// [`irls_weight`] of every row into `w` and `d`. If every weight vanishes under predicted levels (a
/// start that predicts nothing), the observed levels are taken instead.
pub(super) fn irls_weights(y: &[f64], mu: &[f64], floor: f64, sigma: f64, level: Level, d: &mut Vec<f64>, w: &mut Vec<f64>) {
    let fill = |level: Level, d: &mut Vec<f64>, w: &mut Vec<f64>| {
        (d.clear(), w.clear());
        for (&yi, &mi) in y.iter().zip(mu) {
            let (wi, di) = irls_weight(yi, mi, floor, sigma, level);
            (d.push(di), w.push(wi));
        }
    };
    fill(level, d, w);
    if level == Level::Predicted && w.iter().all(|&v| v == 0.0) {
        fill(Level::Observed, d, w);
    }
}

/// Robust fit of `y = a·Pa + b·Pd` with `Pa, Pd ≥ 0`. `lit[i]` marks rows whose direct term is
/// substantial; they pair with unlit rows in the LMedS start. `two_params = false` fits `Pa`
/// alone (the `b` column is ignored). `noise_floor_rel` is the weighting floor relative to the
/// median row (see the module docs). Returns `None` with fewer than 3 rows.
pub fn robust_fit(rows: &ChannelRows, lit: &[bool], two_params: bool, noise_floor_rel: f64, rng: &mut impl Rng) -> Option<ChannelFit> {
    robust_fit_with(rows, lit, two_params, noise_floor_rel, Level::Predicted, rng)
}

/// [`robust_fit`] with the IRLS's noise levels set by `level`.
fn robust_fit_with(rows: &ChannelRows, lit: &[bool], two_params: bool, noise_floor_rel: f64, level: Level, rng: &mut impl Rng) -> Option<ChannelFit> {
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
        let s = sums(&rows.a, &rows.b, &rows.y, |_, _, _, _| 1.0);
        return Some(ChannelFit {
            condition: if two_params { condition(s.saa, s.sab, s.sbb) } else { 1.0 },
            pd_se: if two_params { 0.0 } else { f64::INFINITY },
            inliers: n,
            ..Default::default()
        });
    }
    let floor = noise_floor_rel * scale;
    let zeros;
    let b: &[f64] = if two_params {
        &rows.b
    } else {
        zeros = vec![0.0; n];
        &zeros
    };
    // 2. LMedS start on the rows divided by their observed levels, and the robust scale of the
    // relative residuals from its median squared residual.
    let observed: Vec<f64> = rows.y.iter().map(|v| v.abs() + floor).collect();
    let p = if two_params { 2.0 } else { 1.0 };
    let (start, med) = Scaled::new(&rows.a, b, &rows.y, observed, p).lmeds_start(lit, two_params, rng);
    let small_sample = 1.0 + 5.0 / (n as f64 - p).max(1.0);
    let sigma = (MAD_TO_SIGMA * small_sample * med.sqrt()).max(SIGMA_FLOOR);
    // 3. IRLS with Tukey's biweight at that scale, each row divided by its level (one pass a step;
    // under predicted levels a step whose weights all vanish takes the observed ones, as
    // `irls_weights`).
    let (a, y) = (&rows.a[..], &rows.y[..]);
    let step = |(pa, pd): (f64, f64), level: Level| {
        sums(a, b, y, |_, ai, bi, yi| irls_weight(yi, ai * pa + bi * pd, floor, sigma, level).0)
    };
    let (mut pa, mut pd) = start;
    // The two iterates before the current one, for the extrapolation.
    let mut before = [(pa, pd); 2];
    for it in 0..IRLS_MAX_ITERS {
        let mut st = step((pa, pd), level);
        if st.sw == 0.0 && level == Level::Predicted {
            st = step((pa, pd), Level::Observed);
        }
        let (npa, npd) = nnls2(st.saa, st.sab, st.sbb, st.say, st.sby);
        let change = (npa - pa).abs() + (npd - pd).abs();
        before = [before[1], (pa, pd)];
        pa = npa;
        pd = npd;
        if change <= IRLS_TOL * (pa + pd).max(1e-300) {
            break;
        }
        if it % 3 == 2 {
            let ([x0, x1], x2) = (before, (pa, pd));
            (pa, pd) = (aitken(x0.0, x1.0, x2.0), aitken(x0.1, x1.1, x2.1));
        }
    }
    // 4. Report, on the rows divided by their levels at the fit.
    let mu: Vec<f64> = (0..n).map(|i| a[i] * pa + b[i] * pd).collect();
    let (mut d, mut w) = (Vec::with_capacity(n), Vec::with_capacity(n));
    irls_weights(y, &mu, floor, sigma, level, &mut d, &mut w);
    Some(Scaled::new(&rows.a, b, &rows.y, d, p).report(pa, pd, sigma, two_params))
}

/// The rows of one fit divided by their noise levels `d` (`p` parameters).
struct Scaled {
    a: Vec<f64>,
    b: Vec<f64>,
    y: Vec<f64>,
    d: Vec<f64>,
    p: f64,
}

impl Scaled {
    /// Rows `a`, `b`, `y` divided by the levels `d`.
    fn new(a: &[f64], b: &[f64], y: &[f64], d: Vec<f64>, p: f64) -> Self {
        let div = |v: &[f64]| v.iter().zip(&d).map(|(v, d)| v / d).collect();
        Scaled { a: div(a), b: div(b), y: div(y), d, p }
    }

    /// The least-median-of-squares start (Rousseeuw): the plain fit and `LMEDS_TRIALS` exact fits
    /// through random pairs (a sunlit and a shadowed row when both exist), scored on at most
    /// `LMEDS_SCORE_ROWS` rows. Returns the best `(Pa, Pd)` and its median squared residual.
    fn lmeds_start(&self, lit: &[bool], two_params: bool, rng: &mut impl Rng) -> ((f64, f64), f64) {
        let (a, b, y) = (&self.a[..], &self.b[..], &self.y[..]);
        let n = y.len();
        let s = sums(a, b, y, |_, _, _, _| 1.0);
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

    /// The fit's standard errors (from the weighted normal equations), condition number,
    /// inliers and residual RMS in the rows' own units.
    fn report(&self, pa: f64, pd: f64, sigma: f64, two_params: bool) -> ChannelFit {
        let (a, b, y, d) = (&self.a[..], &self.b[..], &self.y[..], &self.d[..]);
        let n = y.len();
        let r: Vec<f64> = (0..n).map(|i| y[i] - a[i] * pa - b[i] * pd).collect();
        let w: Vec<f64> = r.iter().map(|&ri| tukey(ri, sigma)).collect();
        let s = sums(a, b, y, |i, _, _, _| w[i]);
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
#[path = "solve_tests.rs"]
mod tests;
