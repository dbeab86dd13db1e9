//! Read noise and values clipped at zero in the fit (issue 16 §3, the dark frames of dusk and
//! night).
//!
//! A camera's linear value is `max(μ + n, 0)`: `μ` the model's radiance (Jensen §3.1,
//! `y = a·Pa + b·Pd + Σ g_i·k_i`), `n` the sensor's noise, whose standard deviation has an
//! absolute floor, the read noise `σ_r`, beside a part that grows with the signal (shot noise,
//! and the model's relative errors: albedo, geometry); the black level clips the sum at zero.
//! The relative weights of [`super::solve`] and [`super::solve_multi`] (each row divided by
//! `|y| + floor`) model only the second part. On a frame whose surfaces are a fraction of `σ_r`
//! they trust the darkest rows most, and those rows' mean is lifted by the clip: at `μ = 9·10⁻⁵`
//! and `σ_r = 5·10⁻⁴` the clipped mean is `2.5·10⁻⁴` (the dusk scene's walls at 19:50,
//! `docs/measurements.md`).
//!
//! # How it works
//! With `σ_r > 0` (the camera file's `response.read_noise`, in radiance through the exposure:
//! [`crate::io::frames::Linearizer::read_noise`], or measured on the frame: [`super::noise_level`]), [`robust_fit_noise`] replaces steps 1 and 3
//! of the robust least squares (Jensen §3.1; the LMedS start and the Tukey IRLS of
//! [`super::solve_multi`]):
//! - **Noise model.** Row `i`'s standard deviation is `σ_i = √((s·(max(y_i, 0) + floor))² + σ_r²)`:
//!   the relative part on the observed level, as in the relative weights, so rows far above the
//!   read noise keep those weights (up to a common factor), and the read noise's floor under it.
//!   The relative scale `s` is unknown: it is the value at which the median of `(r_i/σ_i)²` is the
//!   median of χ²₁ (0.4549), a robust scale with `σ_r` known; `s = 0` when the read noise alone
//!   explains more than half of the rows. (With the predicted level `μ_i` in place of `y_i`, the
//!   dusk scene's `k` moved by −0.06 to +0.03 per frame and by −0.01 on average over five seeds;
//!   the observed level was kept for the property above.)
//! - **Clipped at zero** (a Gaussian censored at zero, as in a Tobit model):
//!   `E[max(μ + n, 0)] = μ·Φ(μ/σ) + σ·φ(μ/σ)` for `n ~ N(0, σ²)` ([`clipped_mean`], with
//!   `σ = σ_r`). Each IRLS step fits the de-biased observations `y'_i = y_i − (E_i − μ_i)` at the
//!   previous step's `μ`, so its fixed point solves `Σ w_i·A_i·(y_i − E[max(A_i·x + n, 0)])/σ_i² = 0`,
//!   a moment equation whose expectation vanishes at the true `x`. For fixed weights the step is a
//!   contraction by at most `max(1 − Φ(μ/σ)) = ½` (all `μ ≥ 0` under the NNLS).
//! - **Robust weights.** Tukey's biweight assumes symmetric noise; the clipped noise of a row
//!   near zero is skewed (residuals from `−0.4σ` to `+3σ` at `μ = 0`), and the biweight would
//!   down-weight its positive side and bias `μ` low. A row's weight is therefore blended from the
//!   biweight toward a 0/1 cut at the same width (`c = 4.685` scales), by the row's clip
//!   probability `λ = 2·(1 − Φ(μ/σ_r))` (1 at `μ = 0`, 0.003 at `μ = 3σ_r`).
//! - **Start.** The LMedS start of [`super::solve_multi`] on rows divided by `|y| + floor + σ_r`.
//! - **Report** as [`super::solve_multi`] on the scaled rows: standard errors from
//!   `σ²·(AᵀWA)⁻¹`, which takes the clipped mean's slope `Φ(μ/σ) ∈ [½, 1]` as 1; for rows at
//!   `μ ≈ 0` this and the clipped variance `(½ − 1/2π)·σ²` roughly cancel (a factor ≈ 1.2).
//!
//! With `σ_r = 0` (no `read_noise` in the camera file and the sun up, or `read_noise = 0`), nothing
//! here runs and the fits are those of [`super::solve`] and [`super::solve_multi`], bit for bit.
//! Under `read_noise = "auto"`, or with none given and the sun at or below the horizon, `σ_r` is
//! measured on the frame ([`super::noise_level`]).

use super::solve::{ChannelFit, ChannelRows, IRLS_MAX_ITERS, IRLS_TOL, MAD_TO_SIGMA, SIGMA_FLOOR, TUKEY_C, median_in_place, robust_fit, tukey};
use super::solve_multi::{MultiFit, lmeds_start, nnls, normal, report, robust_fit_multi};
use rand::Rng;

/// Median of the χ² distribution with one degree of freedom: `(Φ⁻¹(¾))²`.
const CHI2_1_MEDIAN: f64 = 0.454_936_423_119_572_7;
/// Bisection steps of the relative scale `s` (each halves its bracket).
const SCALE_BISECTIONS: usize = 48;
/// Beyond this many standard deviations above zero the clip is ignored (`Φ(−8) ≈ 6·10⁻¹⁶`).
const CLIP_IGNORED_ABOVE: f64 = 8.0;

/// The complementary error function (Numerical Recipes' `erfcc`, fractional error < 1.2·10⁻⁷).
fn erfc(x: f64) -> f64 {
    let z = x.abs();
    let t = 1.0 / (1.0 + 0.5 * z);
    let poly = -1.265_512_23
        + t * (1.000_023_68
            + t * (0.374_091_96 + t * (0.096_784_18 + t * (-0.186_288_06 + t * (0.278_868_07 + t * (-1.135_203_98 + t * (1.488_515_87 + t * (-0.822_152_23 + t * 0.170_872_77))))))));
    let ans = t * (-z * z + poly).exp();
    if x >= 0.0 { ans } else { 2.0 - ans }
}

/// The standard normal distribution function `Φ`.
pub fn norm_cdf(x: f64) -> f64 {
    0.5 * erfc(-x / std::f64::consts::SQRT_2)
}

/// The standard normal density `φ`.
fn norm_pdf(x: f64) -> f64 {
    (-0.5 * x * x).exp() / (2.0 * std::f64::consts::PI).sqrt()
}

/// `E[max(μ + n, 0)]` for `n ~ N(0, σ²)`: `μ·Φ(μ/σ) + σ·φ(μ/σ)` (module docs).
pub fn clipped_mean(mu: f64, sigma: f64) -> f64 {
    if !(sigma > 0.0) || mu > CLIP_IGNORED_ABOVE * sigma {
        return mu.max(0.0);
    }
    let u = mu / sigma;
    mu * norm_cdf(u) + sigma * norm_pdf(u)
}

/// The relative scale `s ≥ 0` at which the median of `r²/((s·level)² + σ_r²)` is that of χ²₁.
pub(super) fn relative_scale(r: &[f64], level: &[f64], read_noise: f64, tmp: &mut Vec<f64>) -> f64 {
    let mut median_at = |s: f64| {
        tmp.clear();
        tmp.extend(r.iter().zip(level).map(|(r, l)| r * r / ((s * l).powi(2) + read_noise * read_noise)));
        median_in_place(tmp)
    };
    if median_at(0.0) <= CHI2_1_MEDIAN {
        return 0.0;
    }
    let mut hi = 1e-3;
    while median_at(hi) > CHI2_1_MEDIAN {
        if hi > 1e9 {
            // More than half of the rows have no level: the read noise cannot explain them.
            return hi;
        }
        hi *= 4.0;
    }
    let mut lo = 0.0;
    for _ in 0..SCALE_BISECTIONS {
        let mid = 0.5 * (lo + hi);
        if median_at(mid) > CHI2_1_MEDIAN { lo = mid } else { hi = mid }
    }
    hi
}

/// The rows of one IRLS step: columns and de-biased observations divided by the rows' standard
/// deviations `d`, and Tukey's scale on them.
struct Step {
    cs: Vec<Vec<f64>>,
    ys: Vec<f64>,
    d: Vec<f64>,
    sigma: f64,
    /// Per row, the clip's share of the robust weight: `2·(1 − Φ(μ/σ_r))`.
    clip: Vec<f64>,
}

impl Step {
    /// The robust weight of row `i` at scaled residual `r` (module docs): Tukey's biweight, blended
    /// toward a 0/1 cut at the same width as the clip skews the row's noise.
    fn weight(&self, i: usize, r: f64) -> f64 {
        let hard = if r.abs() < TUKEY_C * self.sigma { 1.0 } else { 0.0 };
        self.clip[i] * hard + (1.0 - self.clip[i]) * tukey(r, self.sigma)
    }
}

/// The noise model at `x` (module docs): the clip's bias at `μ = A·x` taken off `y`, `s`, `σ_i`
/// and Tukey's scale.
fn step(cols: &[Vec<f64>], y: &[f64], x: &[f64], floor: f64, read_noise: f64, small_sample: f64) -> Step {
    let n = y.len();
    let mu: Vec<f64> = (0..n).map(|i| cols.iter().zip(x).map(|(c, x)| c[i] * x).sum::<f64>().max(0.0)).collect();
    let yc: Vec<f64> = (0..n).map(|i| y[i] - (clipped_mean(mu[i], read_noise) - mu[i])).collect();
    let r: Vec<f64> = (0..n).map(|i| yc[i] - mu[i]).collect();
    let level: Vec<f64> = y.iter().map(|v| v.max(0.0) + floor).collect();
    let mut tmp = Vec::with_capacity(n);
    let s = relative_scale(&r, &level, read_noise, &mut tmp);
    let d: Vec<f64> = level.iter().map(|l| ((s * l).powi(2) + read_noise * read_noise).sqrt()).collect();
    tmp.clear();
    tmp.extend((0..n).map(|i| (r[i] / d[i]).powi(2)));
    let sigma = (MAD_TO_SIGMA * small_sample * median_in_place(&mut tmp).sqrt()).max(SIGMA_FLOOR);
    let cs = cols.iter().map(|c| (0..n).map(|i| c[i] / d[i]).collect()).collect();
    let ys = (0..n).map(|i| yc[i] / d[i]).collect();
    let clip = mu.iter().map(|&m| 2.0 * (1.0 - norm_cdf(m / read_noise))).collect();
    Step { cs, ys, d, sigma, clip }
}

/// Robust fit of `y = Σ cols[j]·x_j`, `x ≥ 0`, with read noise `read_noise` (radiance, ≥ 0) and
/// values clipped at zero (module docs). With `read_noise = 0` it is [`robust_fit_multi`].
pub fn robust_fit_noise(cols: &[Vec<f64>], y: &[f64], noise_floor_rel: f64, read_noise: f64, rng: &mut impl Rng) -> Option<MultiFit> {
    if !(read_noise > 0.0 && read_noise.is_finite()) {
        return robust_fit_multi(cols, y, noise_floor_rel, rng);
    }
    let (n, p) = (y.len(), cols.len());
    if p == 0 || n < 3.max(p + 1) {
        return None;
    }
    let mut tmp: Vec<f64> = y.iter().map(|v| v.abs()).collect();
    let floor = noise_floor_rel * median_in_place(&mut tmp);
    let d0: Vec<f64> = y.iter().map(|v| v.abs() + floor + read_noise).collect();
    let cs0: Vec<Vec<f64>> = cols.iter().map(|c| (0..n).map(|i| c[i] / d0[i]).collect()).collect();
    let ys0: Vec<f64> = (0..n).map(|i| y[i] / d0[i]).collect();
    let (mut x, _) = lmeds_start(&cs0, &ys0, rng);
    let small_sample = 1.0 + 5.0 / (n as f64 - p as f64).max(1.0);
    for _ in 0..IRLS_MAX_ITERS {
        let st = step(cols, y, &x, floor, read_noise, small_sample);
        let res = |i: usize| st.ys[i] - (0..p).map(|j| st.cs[j][i] * x[j]).sum::<f64>();
        let w: Vec<f64> = (0..n).map(|i| st.weight(i, res(i))).collect();
        let (g, h, _) = normal(&st.cs, &st.ys, &w);
        let nx = nnls(&g, &h, p);
        let change: f64 = (0..p).map(|j| (nx[j] - x[j]).abs()).sum();
        x = nx;
        if change <= IRLS_TOL * x.iter().sum::<f64>().max(1e-300) {
            break;
        }
    }
    let st = step(cols, y, &x, floor, read_noise, small_sample);
    Some(report(&st.cs, &st.ys, &st.d, x, |i, r| st.weight(i, r)))
}

/// One channel's `Pa` (and `Pd` when `two`): [`robust_fit`] without read noise, else
/// [`robust_fit_noise`] on the columns `a` (and `b`).
pub(super) fn fit_channel(rows: &ChannelRows, lit: &[bool], two: bool, noise_floor_rel: f64, read_noise: f64, rng: &mut impl Rng) -> Option<ChannelFit> {
    if !(read_noise > 0.0) {
        return robust_fit(rows, lit, two, noise_floor_rel, rng);
    }
    let cols = if two { vec![rows.a.clone(), rows.b.clone()] } else { vec![rows.a.clone()] };
    let f = robust_fit_noise(&cols, &rows.y, noise_floor_rel, read_noise, rng)?;
    Some(f.channel(two, f.condition))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::estimate::solve::HDR_NOISE_FLOOR_REL;
    use rand::{SeedableRng, rngs::SmallRng};

    /// A standard normal draw (Box–Muller).
    fn gauss(rng: &mut SmallRng) -> f64 {
        let u: f64 = rng.random_range(f64::EPSILON..1.0);
        let v: f64 = rng.random_range(0.0..1.0);
        (-2.0 * u.ln()).sqrt() * (2.0 * std::f64::consts::PI * v).cos()
    }

    #[test]
    fn the_clipped_mean_matches_its_integral() {
        // Φ at known points (tables): Φ(0) = ½, Φ(1.96) = 0.9750021, Φ(−1) = 0.1586553.
        assert!((norm_cdf(0.0) - 0.5).abs() < 2e-7);
        assert!((norm_cdf(1.96) - 0.975_002_1).abs() < 2e-7);
        assert!((norm_cdf(-1.0) - 0.158_655_3).abs() < 2e-7);
        // E[max(μ + σz, 0)] by the midpoint rule over z ∈ [−12, 12] (10⁵ steps: error ~10⁻¹⁰).
        let sigma = 5e-4;
        for u in [-2.0, -0.5, 0.0, 0.2, 1.0, 3.0, 9.0] {
            let mu = u * sigma;
            let (m, dz) = (100_000, 24.0 / 100_000.0);
            let integral: f64 = (0..m).map(|k| -12.0 + (k as f64 + 0.5) * dz).map(|z| (mu + sigma * z).max(0.0) * norm_pdf(z) * dz).sum();
            // erfc's fractional error 1.2·10⁻⁷ bounds the closed form's
            assert!((clipped_mean(mu, sigma) - integral).abs() < 1e-6 * sigma, "μ/σ = {u}: {} vs {integral}", clipped_mean(mu, sigma));
        }
        // the dusk walls (μ = 9·10⁻⁵, σ = 5·10⁻⁴): 9·10⁻⁵·Φ(0.18) + 5·10⁻⁴·φ(0.18) = 2.48·10⁻⁴
        assert!((clipped_mean(9e-5, 5e-4) - 2.477e-4).abs() < 1e-6, "{}", clipped_mean(9e-5, 5e-4));
    }

    /// A night frame in miniature: `n` rows lit by the sky (`a`) at a fifth of the read noise,
    /// 30% of them also by a lamp (`g`) at about 3σ, noise `N(0, σ²)` plus 1% relative, clipped
    /// at zero.
    fn night_rows(n: usize, x: [f64; 2], sigma: f64, seed: u64) -> (Vec<Vec<f64>>, Vec<f64>) {
        let mut rng = SmallRng::seed_from_u64(seed);
        let (mut a, mut g, mut y) = (Vec::new(), Vec::new(), Vec::new());
        for _ in 0..n {
            let rho: f64 = rng.random_range(0.2..0.6);
            let ai = rho * rng.random_range(0.5..1.0) / std::f64::consts::PI;
            let gi = if rng.random_bool(0.3) { rho * rng.random_range(0.5..2.0) } else { 0.0 };
            let mu = ai * x[0] + gi * x[1];
            a.push(ai);
            g.push(gi);
            y.push((mu + (sigma + 0.01 * mu) * gauss(&mut rng)).max(0.0));
        }
        (vec![a, g], y)
    }

    #[test]
    fn the_clip_correction_recovers_the_lamp_under_read_noise() {
        // Pa = 2·10⁻³ puts the sky rows at μ ≈ 0.16–0.76·10⁻⁴ … 3.8·10⁻⁴, mostly below σ;
        // k = 2·10⁻³ puts the lamp rows at 0.4–2.4·10⁻³ (1–5σ).
        let (truth, sigma) = ([2e-3, 2e-3], 5e-4);
        let (mut worst_k, mut worst_pa): (f64, f64) = (0.0, 0.0);
        let (mut best_plain, mut worst_plain_pa): (f64, f64) = (f64::INFINITY, 0.0);
        for seed in 0..6 {
            let (cols, y) = night_rows(500, truth, sigma, seed);
            let mut rng = SmallRng::seed_from_u64(7);
            let f = robust_fit_noise(&cols, &y, HDR_NOISE_FLOOR_REL, sigma, &mut rng).unwrap();
            let plain = robust_fit_multi(&cols, &y, HDR_NOISE_FLOOR_REL, &mut rng).unwrap();
            eprintln!("seed {seed}: x {:?} se {:?}; without the model {:?}", f.x, f.se, plain.x);
            worst_k = worst_k.max((f.x[1] / truth[1] - 1.0).abs());
            worst_pa = worst_pa.max((f.x[0] / truth[0] - 1.0).abs());
            best_plain = best_plain.min((plain.x[1] / truth[1] - 1.0).abs());
            worst_plain_pa = worst_plain_pa.max(plain.x[0] / truth[0]);
            // the reported standard error covers the error (3 standard errors)
            for j in 0..2 {
                assert!((f.x[j] - truth[j]).abs() < 3.0 * f.se[j], "seed {seed}: x{j} {} ± {}", f.x[j], f.se[j]);
            }
            assert!(f.condition < 10.0, "{f:?}");
        }
        // ~150 lamp rows at σ ≈ 0.2–1.2 of their signal: k's standard error is ≈ 3.3% (measured
        // worst of six seeds 4.9%); Pa, carried by rows at a fifth of σ, has ≈ 10% (worst 14%).
        // The bounds are about 2.5 standard errors.
        assert!(worst_k < 0.08, "corrected: worst |k − 1| {worst_k:.3}");
        assert!(worst_pa < 0.25, "corrected: worst |Pa − 1| {worst_pa:.3}");
        // Without the model, the relative weights and the clip give the sky's light to the lamp: Pa
        // 0 and k 11–23% high on every seed (measured, with the levels at the prediction; with the
        // levels at the observation k came out 28–100% low instead).
        assert!(worst_plain_pa < 0.5, "plain: largest Pa / truth {worst_plain_pa:.3}");
        assert!(best_plain > 0.08, "plain: best |k − 1| {best_plain:.3}");
    }

    #[test]
    fn without_read_noise_it_is_the_relative_fit() {
        let (cols, y) = night_rows(200, [1.0, 1.0], 0.0, 3);
        let f = robust_fit_noise(&cols, &y, HDR_NOISE_FLOOR_REL, 0.0, &mut SmallRng::seed_from_u64(1)).unwrap();
        let g = robust_fit_multi(&cols, &y, HDR_NOISE_FLOOR_REL, &mut SmallRng::seed_from_u64(1)).unwrap();
        assert_eq!(f, g);
    }
}
