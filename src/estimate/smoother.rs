//! Temporal behaviour of the estimate: smoothing across frames and the change detector that tells
//! later stages when to relight.
//!
//! # Smoothing
//! Each of the six intensities (`Pd`, `Pa` × RGB) is smoothed by a scalar Kalman filter with a
//! random-walk model: between frames `Δt` apart the true value may drift with standard deviation
//! `q·(Pd + Pa)·√Δt` (`q` = `smoothing_rate_per_sqrt_s`, relative to the channel's current total
//! light, so that a parameter near zero can still recover quickly), and each
//! frame's measurement has the variance of its standard error. A precise estimate (small standard
//! error) is trusted almost fully; a noisy one is averaged over more frames. A frame whose
//! parameter was not observed (e.g. `Pd` when every sample is in shadow) only predicts, so the held
//! value carries on with growing uncertainty. With `q = 0` the filter is a running inverse-variance
//! mean; with `q → ∞` it passes measurements through.
//!
//! **Clocks that do not move.** `Δt` is the time since the previous frame. When that is zero or
//! negative (frames stamped with the same time, a clock that steps back), the real interval is
//! unknown but not zero: the filter uses the last positive interval it saw, or
//! [`FALLBACK_INTERVAL_S`] before it has seen one. A `Δt` of 0 would stop the filter from
//! following the light at all (issue 13: a passing cloud was smoothed away). The run's clock
//! check names such frames in a warning.
//!
//! **How fast a cloud is followed.** At 30 fps a frame's drift allowance (`q·(Pd + Pa)·√Δt`, about
//! 6% of the light at the default `q` = 0.1) is several times the standard error of an N = 500
//! estimate, so the gain is close to 1 and a cloud that covers the sun within 0.5 s is followed
//! within a frame: `tests/suite/cloud_lag.rs` measures a half-way lag of 0.02 frames with 1% pixel
//! noise and 0.13 frames with 10%, settled within 5% of the step on the frame of full cover, and
//! holds it to at most 1 frame of lag and 2 frames of settling.
//!
//! **Lamps.** Each lamp's scale `k` (RGB, [`LampSmoother`]) is smoothed the same way, with a
//! drift of `q·k̄·√Δt` (`k̄` the larger of its largest channel and its prior scale, so a `k`
//! fitted near zero can recover) at its own rate `q`, `lamp_smoothing_rate_per_sqrt_s` (default
//! [`crate::scene::settings::LAMP_SMOOTHING_RATE`], far slower than the daylight's). A lamp's
//! scale is a property of the luminaire and its exposure, so it is a good candidate for
//! averaging; what breaks that is the lamp switching, so a frame where it is off resets the
//! filter and the first fit after it starts afresh, and a fit beyond Tukey's band of the
//! prediction in any channel (a warm-up, a dimming step) restarts it from that fit. Frames that
//! do not fit it (unreached, held for separability, a dark frame) only predict. The renderer
//! takes the smoothed `k` (`run::outdoor::lamp_scales`).
//!
//! # Change detection
//! [`ChangeDetector`] compares the smoothed lighting with the lighting that the last relight used.
//! It reports a change when, in any channel, `Pd` or `Pa` moved by more than `relight_threshold`
//! of that channel's total `Pd + Pa`, or when the sun direction moved by more than
//! `relight_sun_deg`. Stages downstream (relight, probe update, shadow volumes) run only then.

use glam::Vec3;

/// Kalman smoother of the six intensities.
#[derive(Clone, Debug, Default)]
pub struct Smoother {
    x: Option<[f64; 6]>,
    var: [f64; 6],
    clock: FrameInterval,
}

/// The interval between a smoother's frames: a clock that stands still or runs back is taken to
/// have advanced by the last positive interval (or [`FALLBACK_INTERVAL_S`]), never by zero.
#[derive(Clone, Debug, Default)]
struct FrameInterval {
    last_time_s: f64,
    /// The last positive frame interval, s.
    last_interval_s: Option<f64>,
}

impl FrameInterval {
    /// Moves to `time_s` and returns the interval to predict over: 0 when the filter has not
    /// `started` (its first observation initialises it).
    fn advance(&mut self, time_s: f64, started: bool) -> f64 {
        let raw = time_s - self.last_time_s;
        self.last_time_s = time_s;
        if !started {
            0.0
        } else if raw > 0.0 {
            self.last_interval_s = Some(raw);
            raw
        } else {
            self.last_interval_s.unwrap_or(FALLBACK_INTERVAL_S)
        }
    }
}

/// The Kalman update of one value `x` of variance `var` by a measurement `z` of standard error
/// `se` (variance floored at [`REL_VAR_FLOOR`]·z²); the value stays non-negative.
fn correct(x: &mut f64, var: &mut f64, z: f64, se: f64) {
    let r = (se * se).max(REL_VAR_FLOOR * z * z);
    let gain = if *var + r > 0.0 { *var / (*var + r) } else { 1.0 };
    *x += gain * (z - *x);
    *x = x.max(0.0);
    *var *= 1.0 - gain;
}

/// The frame interval assumed when the clock has not moved and no earlier interval is known, s
/// (a frame per second: slow enough that a still camera is not over-smoothed, fast enough for a
/// time-lapse to still average its noise).
pub const FALLBACK_INTERVAL_S: f64 = 1.0;

/// Variance floor relative to the squared value, so a zero standard error cannot freeze the filter.
const REL_VAR_FLOOR: f64 = 1e-8;

impl Smoother {
    /// Feeds one frame at `time_s` (seconds, any origin). `meas[k]` is `Some((value, std_err))` for
    /// observed parameters (order `Pd r,g,b, Pa r,g,b`). Returns the smoothed values, or `None`
    /// until something has been observed.
    pub fn update(&mut self, time_s: f64, rate_per_sqrt_s: f64, meas: [Option<(f64, f64)>; 6]) -> Option<[f64; 6]> {
        // The first observation initialises; no interval is used.
        let dt = self.clock.advance(time_s, self.x.is_some());
        let Some(x) = self.x.as_mut() else {
            // Initialise from the first observation of each parameter.
            if meas.iter().all(Option::is_none) {
                return None;
            }
            let mut x0 = [0.0; 6];
            let mut v0 = [f64::INFINITY; 6];
            for k in 0..6 {
                if let Some((v, se)) = meas[k] {
                    x0[k] = v;
                    v0[k] = (se * se).max(REL_VAR_FLOOR * v * v);
                }
            }
            self.x = Some(x0);
            self.var = v0;
            return self.x;
        };
        for k in 0..6 {
            // Predict. The drift scales with the channel's total light (Pd + Pa), so a value near
            // zero (the sun behind a cloud) can still grow back quickly.
            let total = x[k % 3].abs() + x[k % 3 + 3].abs();
            let q = rate_per_sqrt_s * total;
            self.var[k] += q * q * dt;
            // Update.
            if let Some((z, se)) = meas[k] {
                if !self.var[k].is_finite() {
                    x[k] = z;
                    self.var[k] = (se * se).max(REL_VAR_FLOOR * z * z);
                    continue;
                }
                correct(&mut x[k], &mut self.var[k], z, se);
            }
        }
        self.x
    }
}

/// Kalman smoother of one lamp's scale `k` (RGB; module docs).
#[derive(Clone, Debug, Default)]
pub struct LampSmoother {
    k: Option<[f64; 3]>,
    var: [f64; 3],
    /// The variance after the last frame's prediction, before its measurement (what the
    /// backward pass of [`super::hindsight`] divides by).
    pred_var: [f64; 3],
    /// How many times the filter has (re)started from a fit: a new run of frames that shares no
    /// information with the one before (a switch-on, a departure).
    starts: u64,
    clock: FrameInterval,
}

/// The filter's state after a frame, for the backward pass ([`super::hindsight`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LampFilterState {
    /// The filtered `k`.
    pub k: [f64; 3],
    /// Its variance.
    pub var: [f64; 3],
    /// The variance predicted for this frame before its measurement (equal to `var` on the frame
    /// that started the run).
    pub pred_var: [f64; 3],
    /// The run of frames it belongs to ([`LampSmoother`]'s count of starts).
    pub run: u64,
}

impl LampSmoother {
    /// Feeds one frame at `time_s`: `on` false (the lamp is off) resets the filter and returns
    /// `None`; `meas` is the frame's fitted `(k, k_se)`, `None` when it was not fitted; `prior`
    /// is the lamp's prior scale. Returns the smoothed `k`, `None` until a fit after the last
    /// switch-on.
    pub fn update(&mut self, time_s: f64, rate_per_sqrt_s: f64, on: bool, prior: f64, meas: Option<([f64; 3], [f64; 3])>) -> Option<[f64; 3]> {
        if !on {
            *self = Self { starts: self.starts, ..Self::default() };
            return None;
        }
        let dt = self.clock.advance(time_s, self.k.is_some());
        let Some(k) = self.k.as_mut() else {
            let (z, se) = meas?;
            return self.update_first(z, se);
        };
        let level = k.iter().fold(prior.abs(), |m, v| m.max(v.abs()));
        let q = rate_per_sqrt_s * level;
        for c in 0..3 {
            self.var[c] += q * q * dt;
        }
        self.pred_var = self.var;
        let Some((z, se)) = meas else { return self.k };
        // A frame beyond the robust band of the prediction in any channel: the luminaire changed
        // (warm-up, dimming), not the noise; start afresh from it.
        let departs = (0..3).any(|c| {
            let r = (se[c] * se[c]).max(REL_VAR_FLOOR * z[c] * z[c]);
            (z[c] - k[c]).abs() > super::solve::TUKEY_C * (self.var[c] + r).sqrt()
        });
        if departs {
            *self = Self { clock: self.clock.clone(), starts: self.starts, ..Self::default() };
            return self.update_first(z, se);
        }
        for c in 0..3 {
            correct(&mut k[c], &mut self.var[c], z[c], se[c]);
        }
        self.k
    }

    /// The first fit after a (re)start is taken as it is.
    fn update_first(&mut self, z: [f64; 3], se: [f64; 3]) -> Option<[f64; 3]> {
        self.k = Some(z);
        self.var = std::array::from_fn(|c| (se[c] * se[c]).max(REL_VAR_FLOOR * z[c] * z[c]));
        self.pred_var = self.var;
        self.starts += 1;
        self.k
    }

    /// The state after the last frame: `None` while the lamp is off or not fitted since it
    /// switched on.
    pub fn state(&self) -> Option<LampFilterState> {
        Some(LampFilterState { k: self.k?, var: self.var, pred_var: self.pred_var, run: self.starts })
    }
}

/// Why the detector asked for a relight (or did not).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ChangeReason {
    /// Nothing relit yet.
    FirstFrame,
    /// `Pd` moved past the threshold.
    DirectChanged,
    /// `Pa` moved past the threshold.
    AmbientChanged,
    /// The sun moved past its threshold.
    SunMoved,
    /// Within both thresholds: later stages may reuse their results.
    Unchanged,
}

/// Decides when the lighting changed enough to relight.
#[derive(Clone, Debug, Default)]
pub struct ChangeDetector {
    reference: Option<(Vec3, [f64; 6])>,
}

impl ChangeDetector {
    /// Compares `lighting` (`Pd` rgb, `Pa` rgb) and `sun_dir` with the last relit state; on a change
    /// the new state becomes the reference.
    pub fn check(&mut self, sun_dir: Vec3, lighting: [f64; 6], threshold: f64, sun_deg: f64) -> ChangeReason {
        let reason = match &self.reference {
            None => ChangeReason::FirstFrame,
            Some((dir, old)) => {
                let angle = dir.dot(sun_dir).clamp(-1.0, 1.0).acos().to_degrees() as f64;
                let mut reason = ChangeReason::Unchanged;
                for c in 0..3 {
                    let total = (old[c] + old[c + 3]).max(lighting[c] + lighting[c + 3]).max(1e-300);
                    if (lighting[c] - old[c]).abs() > threshold * total {
                        reason = ChangeReason::DirectChanged;
                        break;
                    }
                    if (lighting[c + 3] - old[c + 3]).abs() > threshold * total {
                        reason = ChangeReason::AmbientChanged;
                    }
                }
                if reason == ChangeReason::Unchanged && angle > sun_deg {
                    reason = ChangeReason::SunMoved;
                }
                reason
            }
        };
        if reason != ChangeReason::Unchanged {
            self.reference = Some((sun_dir, lighting));
        }
        reason
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn smoother_averages_noise_and_follows_steps() {
        let mut s = Smoother::default();
        let mut out = [0.0; 6];
        // 50 frames at 10 fps of a constant 1.0 with ±2% alternating noise, se = 2%.
        for i in 0..50 {
            let z = 1.0 + if i % 2 == 0 { 0.02 } else { -0.02 };
            out = s.update(i as f64 * 0.1, 0.01, [Some((z, 0.02)); 6]).unwrap();
        }
        assert!((out[0] - 1.0).abs() < 0.01, "{out:?}");
        // A step to 0.2 (a cloud) with precise measurements is followed within a few frames.
        for i in 50..60 {
            out = s.update(i as f64 * 0.1, 0.01, [Some((0.2, 0.002)); 6]).unwrap();
        }
        assert!((out[0] - 0.2).abs() < 0.01, "{out:?}");
    }

    /// Issue 13: frames stamped with one time follow a change as frames one interval apart do
    /// (the last positive interval, else `FALLBACK_INTERVAL_S`), not as a frozen filter.
    #[test]
    fn a_clock_that_does_not_move_does_not_freeze_the_filter() {
        let run = |times: &dyn Fn(usize) -> f64| {
            let mut s = Smoother::default();
            let mut out = [0.0; 6];
            for i in 0..40 {
                out = s.update(times(i), 0.1, [Some((1.0, 0.05)); 6]).unwrap();
            }
            for i in 40..43 {
                out = s.update(times(i), 0.1, [Some((0.2, 0.05)); 6]).unwrap();
            }
            out[0]
        };
        let stamped_once = run(&|_| 5.0);
        let one_second = run(&|i| i as f64);
        let ten_then_stuck = run(&|i| if i < 2 { 10.0 * i as f64 } else { 10.0 });
        let ten_seconds = run(&|i| 10.0 * i as f64);
        assert_eq!(stamped_once, one_second, "no interval known: one second");
        assert_eq!(ten_then_stuck, ten_seconds, "the last interval carries on");
        assert!(stamped_once < 0.6, "the step is followed: {stamped_once}");
        // Time going back is not a negative interval either.
        let back = run(&|i| 100.0 - i as f64);
        assert_eq!(back, one_second);
    }

    #[test]
    fn a_value_near_zero_recovers_quickly() {
        // The sun behind a cloud (Pd ≈ 0) and back 10 s later: the filter follows at once.
        let mut s = Smoother::default();
        s.update(0.0, 0.1, [Some((0.03, 0.001)), Some((0.03, 0.001)), Some((0.03, 0.001)), Some((0.8, 0.01)), Some((0.8, 0.01)), Some((0.8, 0.01))]);
        let out = s.update(10.0, 0.1, [Some((0.9, 0.01)), Some((0.9, 0.01)), Some((0.9, 0.01)), Some((0.8, 0.01)), Some((0.8, 0.01)), Some((0.8, 0.01))]).unwrap();
        assert!((out[0] - 0.9).abs() < 0.02, "{out:?}");
    }

    #[test]
    fn unobserved_parameters_hold() {
        let mut s = Smoother::default();
        s.update(0.0, 0.5, [Some((3.0, 0.01)); 6]);
        let mut m = [Some((1.0, 0.01)); 6];
        m[0] = None;
        let out = s.update(1.0, 0.5, m).unwrap();
        assert_eq!(out[0], 3.0);
        assert!(out[3] < 1.1);
        assert!(out[1] < 1.1);
    }

    #[test]
    fn change_detector_thresholds() {
        let mut d = ChangeDetector::default();
        let l = [3.0, 3.0, 3.0, 1.0, 1.0, 1.0];
        assert_eq!(d.check(Vec3::Y, l, 0.02, 0.5), ChangeReason::FirstFrame);
        assert_eq!(d.check(Vec3::Y, [3.05, 3.0, 3.0, 1.0, 1.0, 1.0], 0.02, 0.5), ChangeReason::Unchanged);
        assert_eq!(d.check(Vec3::Y, [2.5, 3.0, 3.0, 1.0, 1.0, 1.0], 0.02, 0.5), ChangeReason::DirectChanged);
        let tilted = Vec3::new(0.0, 1.0, (1.0f32).to_radians().tan()).normalize();
        assert_eq!(d.check(tilted, [2.5, 3.0, 3.0, 1.0, 1.0, 1.0], 0.02, 0.5), ChangeReason::SunMoved);
    }

    #[test]
    fn lamp_scale_is_averaged_while_on_and_restarts_after_a_switch() {
        use rand::{Rng, SeedableRng, rngs::SmallRng};
        // 30 fps, a constant k = 0.8 measured with a standard error of 0.05, q = 0.1: the drift
        // allowance per frame is q·max(k, prior)·√Δt = 0.018, so the steady-state Kalman filter
        // has gain ≈ 0.30 and a posterior standard deviation ≈ 0.027, 0.55 of one frame's.
        let mut f = LampSmoother::default();
        let mut rng = SmallRng::seed_from_u64(4);
        let (truth, se) = (0.8, 0.05);
        let (mut raw_sq, mut smooth_sq, mut n) = (0.0, 0.0, 0);
        for i in 0..300 {
            let z = std::array::from_fn(|_| truth + se * 1.732 * (rng.random::<f64>() * 2.0 - 1.0));
            let k = f.update(i as f64 / 30.0, 0.1, true, 1.0, Some((z, [se; 3]))).unwrap();
            if i >= 50 {
                raw_sq += (z[1] - truth).powi(2);
                smooth_sq += (k[1] - truth).powi(2);
                n += 1;
            }
        }
        let (raw, smooth) = ((raw_sq / n as f64).sqrt(), (smooth_sq / n as f64).sqrt());
        assert!(smooth < 0.7 * raw, "smoothed rms {smooth} vs raw {raw}");
        // A frame without a fit holds the value.
        let held = f.update(10.0 + 1.0 / 30.0, 0.1, true, 1.0, None).unwrap();
        assert!((held[1] - truth).abs() < 2.0 * smooth + 1e-3);
        // Off: reset; nothing until the next fit, which is taken as it is (a new luminaire state).
        assert_eq!(f.update(11.0, 0.1, false, 1.0, Some(([0.8; 3], [se; 3]))), None);
        assert_eq!(f.update(11.1, 0.1, true, 1.0, None), None);
        assert_eq!(f.update(11.2, 0.1, true, 1.0, Some(([0.3, 0.4, 0.5], [se; 3]))), Some([0.3, 0.4, 0.5]));
        // A fit at zero can recover: the drift scales with the prior as well.
        let mut g = LampSmoother::default();
        g.update(0.0, 0.1, true, 1.0, Some(([0.0; 3], [1e-6; 3])));
        let k = g.update(600.0, 0.1, true, 1.0, Some(([1.0; 3], [0.05; 3]))).unwrap();
        assert!(k[0] > 0.9, "{k:?}");
    }

    #[test]
    fn a_steady_lamp_is_averaged_over_minutes_and_a_step_restarts_the_filter() {
        use crate::scene::settings::LAMP_SMOOTHING_RATE as RATE;
        // Frames ten minutes apart (the dusk scene's clock), k = 1 measured with se 0.03 in
        // alternating ±0.03 errors: the drift allowance over 600 s is 0.0005·√600 = 1.2% of k, so
        // the filter's variance settles at v = (−a + √(a² + 4ab))/2 (a = 0.0122², b = 0.03²):
        // σ ≈ 0.017 and a gain of 0.33, and the alternating errors leave ±0.006.
        let mut f = LampSmoother::default();
        let mut last = [0.0; 3];
        for i in 0..20 {
            let z = if i % 2 == 0 { 1.03 } else { 0.97 };
            last = f.update(600.0 * i as f64, RATE, true, 1.0, Some(([z; 3], [0.03; 3]))).unwrap();
        }
        // After a frame at 0.97 the estimate sits near 1, not on the frame.
        assert!((last[0] - 1.0).abs() < 0.008, "{last:?}");
        // Dimmed to half: 0.5 is 0.5/√(v + a + 0.03²) ≈ 14 σ from the prediction, beyond Tukey's
        // 4.685: taken at once rather than crept towards.
        let dimmed = f.update(600.0 * 20.0, RATE, true, 1.0, Some(([0.5; 3], [0.03; 3]))).unwrap();
        assert_eq!(dimmed, [0.5; 3]);
        // At 30 fps the allowance per frame is 0.0005·√(1/30) = 0.009% of k: a 1% error in one
        // frame moves the estimate by little once the filter has settled.
        let mut g = LampSmoother::default();
        for i in 0..300 {
            g.update(i as f64 / 30.0, RATE, true, 1.0, Some(([1.0; 3], [0.03; 3])));
        }
        let k = g.update(10.0, RATE, true, 1.0, Some(([1.01; 3], [0.03; 3]))).unwrap();
        assert!(k[0] > 1.0 && k[0] < 1.001, "{k:?}");
    }
}
