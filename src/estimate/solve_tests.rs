//! Tests of [`super`]: closed forms, outliers, scale, conditioning and the IRLS levels.

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
fn predicted_levels_remove_the_low_bias_of_observed_levels() {
    // Rows y = (a·Pa + b·Pd)·(1 + n), n uniform on ±h with h = 0.2·√3: zero mean, 20% relative
    // standard deviation, independent of the columns. Divided by their observed levels, the
    // normal equations are Σ v_i·u_i·(1 − u_i·v_i·x) = 0 with u = 1/(1 + n) and v_i = A_i/(A_i·X);
    // x = q·X solves them in expectation with q = E[u]/E[u²] = ((1 − h²)/(2h))·ln((1 + h)/(1 − h))
    // = 0.9180 for every column: 8.2% low. Tukey's weights, symmetric in the relative residual
    // 1 − q·u, trim both tails of u and move q to 0.919–0.924 at the relative scales 0.2–0.4
    // (the same expectation with the weights, by quadrature). Divided by the predicted levels,
    // the fixed point solves Σ w·A·(y − A·x)/(A·x)² = 0, whose terms at x = X are w(n)·n/(A·X):
    // symmetric weights on zero-mean noise, no bias.
    let h = 0.2 * 3f64.sqrt();
    let q = (1.0 - h * h) / (2.0 * h) * ((1.0 + h) / (1.0 - h)).ln();
    assert!((q - 0.9180).abs() < 1e-4, "{q}");
    let (pa, pd, trials) = (0.7, 3.1, 100);
    let mut mean = [[0.0; 2]; 4]; // [observed, predicted] × [two-column solver, multi solver]
    for t in 0..trials {
        let (mut rows, lit) = synth(1600, pa, pd, 0.0, 100 + t);
        let mut rng = SmallRng::seed_from_u64(1000 + t);
        rows.y.iter_mut().for_each(|y| *y *= 1.0 + rng.random_range(-h..h));
        let cols = vec![rows.a.clone(), rows.b.clone()];
        for (k, level) in [Level::Observed, Level::Predicted].into_iter().enumerate() {
            let f = robust_fit_with(&rows, &lit, true, HDR_NOISE_FLOOR_REL, level, &mut rng).unwrap();
            let m = crate::estimate::solve_multi::robust_fit_multi_with(&cols, &rows.y, HDR_NOISE_FLOOR_REL, level, &mut rng).unwrap();
            assert!(f.pa_se.is_finite() && f.pd_se.is_finite() && f.condition < 10.0, "{f:?}");
            for (j, v) in [f.pa / pa, f.pd / pd, m.x[0] / pa, m.x[1] / pd].into_iter().enumerate() {
                mean[j][k] += v / trials as f64;
            }
        }
    }
    for (j, [observed, predicted]) in mean.into_iter().enumerate() {
        eprintln!("column {j}: mean fit / truth {observed:.4} (observed levels), {predicted:.4} (predicted)");
        // 100 trials of 1 600 rows at 20% noise: the means' standard errors are ≈ 0.1%
        // (measured: predicted 0.9995–0.9998; observed 0.9219–0.9229, inside the biweight's
        // bracket above; with 400 rows a trial the finite-sample terms added up to +0.4 points)
        assert!((predicted - 1.0).abs() < 0.005, "column {j}: predicted levels {predicted:.4}");
        assert!(observed > q - 0.002 && observed < q + 0.008, "column {j}: observed levels {observed:.4} against {q:.4}");
    }
}

#[test]
fn a_prediction_at_or_below_zero_takes_the_floor() {
    let (y, floor, sigma) = ([1.0, 2.0, 0.5], 0.01, 0.1);
    let (mut d, mut w) = (Vec::new(), Vec::new());
    irls_weights(&y, &[1.0, -3.0, 0.0], floor, sigma, Level::Predicted, &mut d, &mut w);
    assert_eq!(d, vec![1.01, 0.01, 0.01]);
    // the first row's relative residual (1 − 1)/1.01 = 0: weight 1/d²; the others far out
    assert!((w[0] - 1.0 / (1.01 * 1.01)).abs() < 1e-12 && w[1] == 0.0 && w[2] == 0.0, "{w:?}");
    // a prediction of nothing anywhere: the observed levels |y| + floor
    irls_weights(&y, &[0.0; 3], floor, sigma, Level::Predicted, &mut d, &mut w);
    assert_eq!(d, vec![1.01, 2.01, 0.51]);
}

#[test]
fn one_parameter_fit() {
    let (rows, _) = synth(100, 0.9, 0.0, 0.0, 5);
    let f = robust_fit(&rows, &[false; 100], false, HDR_NOISE_FLOOR_REL, &mut SmallRng::seed_from_u64(0)).unwrap();
    assert!((f.pa - 0.9).abs() < 1e-9 && f.pd == 0.0 && f.pd_se.is_infinite());
}

#[test]
fn aitken_gives_the_limit_of_a_geometric_sequence() {
    // x_k = L + C·r^k: Δ² extrapolation is exact for every |r| < 1 it accepts
    for (l, c, r) in [(2.5, 0.3, 0.55), (1.0, -0.2, 0.85), (0.7, 0.1, -0.6), (3.0, 1e-4, 0.1)] {
        let x = |k: i32| l + c * f64::powi(r, k);
        let e = aitken(x(4), x(5), x(6));
        assert!((e - l).abs() < 1e-12 * l, "r {r}: {e} against {l}");
    }
    // changes that do not shrink fast enough, or vanish: the last iterate as it is
    assert_eq!(aitken(1.0, 1.5, 1.97), 1.97); // r = 0.94
    assert_eq!(aitken(1.0, 1.0, 1.0), 1.0); // converged: r = 0/0
    assert_eq!(aitken(1.0, 1.0, 1.2), 1.2); // r = ∞
    // never below the bound Pa, Pd ≥ 0
    assert_eq!(aitken(0.3, 0.1, 0.02), 0.0);
}

#[test]
fn the_weight_with_one_division_equals_tukeys_over_the_level_squared() {
    // the form before the hoisting, Tukey's biweight of (y − μ)/d divided by d², to rounding
    let mut rng = SmallRng::seed_from_u64(3);
    let (floor, sigma) = (1e-3, 0.05);
    for _ in 0..10_000 {
        let y: f64 = rng.random_range(-0.1..2.0);
        let mu: f64 = y * rng.random_range(0.7..1.3) + rng.random_range(-0.01..0.01);
        for level in [Level::Observed, Level::Predicted] {
            let (w, d) = irls_weight(y, mu, floor, sigma, level);
            let reference = tukey((y - mu) / d, sigma) / (d * d);
            // to rounding of the weight's largest value 1/d² (near |u| = 1 the weight is the
            // difference 1 − u², whose relative rounding grows as it vanishes)
            assert!((w - reference).abs() <= 1e-12 / (d * d), "{y} {mu}: {w} against {reference}");
        }
    }
}
