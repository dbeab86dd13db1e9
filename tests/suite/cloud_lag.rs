//! Issue 13 part 3: a cloud that covers the sun within 0.5 s of 30 fps footage is followed by
//! the estimator's smoother within a documented number of frames.
//!
//! Synthetic frames of the test world (tests/common): the sun's radiance `Pd` steady for 1 s,
//! then falling linearly to 10% over 15 frames (0.5 s: a cloud edge crossing the sun), then held
//! for 1.5 s; `Pa` steady; frames stamped 1/30 s apart. The estimator runs with
//! its defaults (N = 500 samples, `smoothing_rate_per_sqrt_s` = 0.1), with 1% and with 10% pixel
//! noise. The lag is measured two
//! ways on the smoothed `Pd` (green channel):
//! - half-way lag: frames between the truth and the smoothed value crossing the middle of the
//!   step;
//! - settling: frames after the cloud has fully covered the sun until the smoothed value stays
//!   within 5% of the step of the covered value.
//!
//! Documented bounds (docs in `estimate::smoother`): half-way lag ≤ 1 frame, settling ≤ 2
//! frames. Measured: half-way lag 0.02 frames (1% noise) and 0.13 frames (10%), settled on the
//! frame of full cover in both (`cargo test --test suite cloud_lag:: -- --nocapture` prints them).

use crate::common::*;
use heliar::estimate::EstimatorConfig;
use heliar::io::frames::{Linearizer, Response};
use heliar::io::image::LinearImage;
use rand::{Rng, SeedableRng, rngs::SmallRng};

const PD: [f32; 3] = [3.0, 2.8, 2.5];
const PA: [f32; 3] = [0.6, 0.7, 0.9];
const FPS: f64 = 30.0;
/// Frames before the cloud, of its edge crossing the sun, and after.
const CLEAR: usize = 30;
const RAMP: usize = 15;
const COVERED: usize = 45;
/// `Pd` under the cloud, relative.
const UNDER: f32 = 0.1;
/// The documented lags (module docs).
const MAX_HALFWAY_LAG_FRAMES: f64 = 1.0;
const MAX_SETTLING_FRAMES: usize = 2;

/// `Pd` of frame `k`, relative to the clear sky.
fn pd_scale(k: usize) -> f32 {
    if k < CLEAR {
        1.0
    } else if k < CLEAR + RAMP {
        1.0 - (1.0 - UNDER) * ((k - CLEAR + 1) as f32 / RAMP as f32)
    } else {
        UNDER
    }
}

/// The frame `per_pd·pd + per_sky·PA` per channel, with relative uniform noise of standard
/// deviation `noise` per pixel.
fn compose(per_pd: &LinearImage, per_sky: &LinearImage, pd: [f32; 3], noise: f32, rng: &mut SmallRng) -> LinearImage {
    let data = per_pd
        .data
        .iter()
        .zip(&per_sky.data)
        .map(|(a, b)| {
            let n = 1.0 + noise * (rng.random::<f32>() * 2.0 - 1.0) * 1.732;
            std::array::from_fn(|c| (a[c] * pd[c] + b[c] * PA[c]) * n)
        })
        .collect();
    LinearImage { width: per_pd.width, height: per_pd.height, data }
}

/// The smoothed green `Pd` of every frame, with `noise` relative pixel noise.
fn smoothed_pd(w: &World, per_pd: &LinearImage, per_sky: &LinearImage, noise: f32) -> (Vec<f64>, Vec<f64>) {
    let start = afternoon();
    let lin = Linearizer::new(&Response::Linear, 1.0, 1.0, Some(f32::INFINITY));
    let mut est = estimator(w, EstimatorConfig::default());
    let mut rng = SmallRng::seed_from_u64(13);
    let (mut truth, mut smoothed) = (Vec::new(), Vec::new());
    for k in 0..CLEAR + RAMP + COVERED {
        let pd = PD.map(|x| x * pd_scale(k));
        let time = start + chrono::Duration::nanoseconds((k as f64 * 1e9 / FPS).round() as i64);
        let e = est.estimate(k, &time, &frame(compose(per_pd, per_sky, pd, noise, &mut rng)), &lin).unwrap();
        let sm = e.smoothed.expect("a smoothed estimate every frame");
        truth.push(pd[1] as f64);
        smoothed.push(sm.pd[1]);
    }
    (truth, smoothed)
}

/// The half-way lag (fractional frames) and the settling (frames after full cover) of a run.
fn lags(truth: &[f64], smoothed: &[f64]) -> (f64, usize) {
    let (high, low) = (PD[1] as f64, (PD[1] * UNDER) as f64);
    let mid = 0.5 * (high + low);
    // Fractional frame at which a series first falls through `mid` (linear between frames).
    let crossing = |v: &[f64]| -> f64 {
        let k = v.iter().position(|&x| x <= mid).expect("the series falls through the middle");
        assert!(k > 0);
        (k - 1) as f64 + (v[k - 1] - mid) / (v[k - 1] - v[k])
    };
    let covered_from = CLEAR + RAMP - 1;
    let tolerance = 0.05 * (high - low);
    let settled = (covered_from..smoothed.len()).find(|&k| smoothed[k..].iter().all(|x| (x - low).abs() <= tolerance)).expect("the smoothed value settles");
    (crossing(smoothed) - crossing(truth), settled - covered_from)
}

#[test]
fn a_cloud_over_the_sun_in_half_a_second_is_followed_within_the_documented_frames() {
    let l = sun_dir(&afternoon());
    let w = world(WorldSpec::default(), l);
    // Unit renders (the model image is linear in Pd and Pa): the sun's part and the sky's.
    let per_pd = render(&w, l, [1.0; 3], [0.0; 3], 0.0, 1);
    let per_sky = render(&w, l, [0.0; 3], [1.0; 3], 0.0, 1);
    // 1% pixel noise (HDR footage) and 10% (noisy LDR footage: larger standard errors, so the
    // smoother averages more and lags more).
    for noise in [0.01f32, 0.1] {
        let (truth, smoothed) = smoothed_pd(&w, &per_pd, &per_sky, noise);
        let (halfway_lag, settling) = lags(&truth, &smoothed);
        let high = PD[1] as f64;
        eprintln!(
            "noise {noise}: cloud over the sun in {RAMP} frames at {FPS} fps: half-way lag {halfway_lag:.2} frames, settled within 5% of the step {settling} frames after full cover; clear-sky Pd (green) smoothed {:.3} vs {high:.3}",
            smoothed[CLEAR - 1]
        );
        assert!((smoothed[CLEAR - 1] - high).abs() < 0.03 * high, "noise {noise}: the clear frames are estimated: {} vs {high}", smoothed[CLEAR - 1]);
        assert!(halfway_lag <= MAX_HALFWAY_LAG_FRAMES, "noise {noise}: half-way lag {halfway_lag:.2} frames > {MAX_HALFWAY_LAG_FRAMES}");
        assert!(settling <= MAX_SETTLING_FRAMES, "noise {noise}: settled {settling} frames after full cover > {MAX_SETTLING_FRAMES}");
    }
}
