//! Global Reinhard tone mapping with temporally smoothed parameters (Havran §5.1, after Reinhard,
//! Stark, Shirley & Ferwerda 2002), as a CPU function; the GPU pass applies the same parameters.
//!
//! # How it works
//! - Per frame, from the displayed HDR luminances: the log-average ("world") luminance
//!   `L̄ = exp(mean ln(δ + L))` and the key `a`, estimated automatically from where `L̄` sits
//!   between the robust minimum and maximum, in log₂ units (Reinhard 2002, "Parameter estimation
//!   for photographic tone reproduction", eq. 4): `a = 0.18 · 4^((2·log₂L̄ − log₂L_min −
//!   log₂L_max)/(log₂L_max − log₂L_min))`, clamped to `[0.045, 0.72]`. The white point is the
//!   robust maximum.
//! - **Temporal smoothing** (Havran's extension, against brightness flicker): `ln L̄`, `a` and
//!   `ln L_white` each follow the per-frame values with an exponential filter of time constant
//!   [`SMOOTHING_TAU_S`] (`x += (1 − e^(−Δt/τ))·(x_new − x)`). The first frame sets them.
//! - Display value: `L = a·L_w/L̄`, `L_d = L·(1 + L/L_white²)/(1 + L)` with `L_white` in the same
//!   scaled units; colours keep their ratios.

/// Time constant of the parameter smoothing, seconds.
pub const SMOOTHING_TAU_S: f64 = 0.5;
/// `δ` in the log average, avoiding `ln 0` for black pixels.
pub const LOG_DELTA: f64 = 1e-6;
/// Fraction of pixels ignored at each end for the robust minimum and maximum.
pub const ROBUST_FRACTION: f64 = 0.01;

/// One frame's tone-mapping parameters.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct ToneParams {
    /// Log-average luminance `L̄`.
    pub log_average: f64,
    /// Key `a`.
    pub key: f64,
    /// White point in scene luminance (maps to display 1).
    pub white: f64,
}

impl ToneParams {
    /// Display luminance in `[0, 1]` of scene luminance `l`.
    pub fn display(&self, l: f64) -> f64 {
        let scale = self.key / self.log_average.max(LOG_DELTA);
        let x = (l * scale).max(0.0);
        let w = (self.white * scale).max(1e-12);
        (x * (1.0 + x / (w * w)) / (1.0 + x)).min(1.0)
    }

    /// Tone-maps a linear RGB value (ratios kept).
    pub fn apply(&self, rgb: [f32; 3]) -> [f32; 3] {
        let l = super::polar::luminance(rgb) as f64;
        if !(l > 0.0) {
            return [0.0; 3];
        }
        let s = (self.display(l) / l) as f32;
        rgb.map(|c| (c * s).max(0.0))
    }
}

/// The per-frame estimate (no smoothing) of `luminances`; `None` without any finite value.
pub fn frame_params(luminances: &[f32]) -> Option<ToneParams> {
    let mut v: Vec<f64> = luminances.iter().map(|&l| l as f64).filter(|l| l.is_finite() && *l >= 0.0).collect();
    if v.is_empty() {
        return None;
    }
    let log_avg = (v.iter().map(|l| (LOG_DELTA + l).ln()).sum::<f64>() / v.len() as f64).exp();
    v.sort_by(|a, b| a.total_cmp(b));
    let k = ((ROBUST_FRACTION * v.len() as f64) as usize).min(v.len() - 1);
    let lo = v[k].max(LOG_DELTA);
    let hi = v[v.len() - 1 - k].max(lo);
    let (l2min, l2max, l2avg) = (lo.log2(), hi.log2(), log_avg.max(LOG_DELTA).log2());
    let key = if l2max - l2min > 1e-6 { 0.18 * 4f64.powf((2.0 * l2avg - l2min - l2max) / (l2max - l2min)) } else { 0.18 };
    Some(ToneParams { log_average: log_avg, key: key.clamp(0.045, 0.72), white: hi.max(log_avg) })
}

/// Temporally smoothed Reinhard parameters.
#[derive(Clone, Debug, Default)]
pub struct ToneMapper {
    state: Option<(f64, f64, f64)>,
}

impl ToneMapper {
    /// A tone mapper with no history.
    pub fn new() -> Self {
        Self::default()
    }

    /// Updates with a frame's luminances, `dt_s` seconds after the previous frame, and returns the
    /// smoothed parameters (the previous ones when the frame has no usable pixel).
    pub fn update(&mut self, luminances: &[f32], dt_s: f64) -> Option<ToneParams> {
        if let Some(p) = frame_params(luminances) {
            let new = (p.log_average.ln(), p.key, p.white.ln());
            self.state = Some(match self.state {
                None => new,
                Some(old) => {
                    let g = 1.0 - (-dt_s.max(0.0) / SMOOTHING_TAU_S).exp();
                    (old.0 + g * (new.0 - old.0), old.1 + g * (new.1 - old.1), old.2 + g * (new.2 - old.2))
                }
            });
        }
        self.state.map(|(la, k, w)| ToneParams { log_average: la.exp(), key: k, white: w.exp() })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uniform_image_closed_forms() {
        let p = frame_params(&[2.0; 100]).unwrap();
        assert!((p.log_average - 2.0).abs() < 1e-5);
        assert_eq!(p.key, 0.18);
        // Scaled: L = 0.18·L_w/2, white 0.18 (maps to 1); L_w = 1 gives
        // 0.09·(1 + 0.09/0.18²)/1.09.
        assert!((p.display(2.0) - 1.0).abs() < 1e-6);
        assert!((p.display(1.0) - 0.09 * (1.0 + 0.09 / (0.18 * 0.18)) / 1.09).abs() < 1e-6);
        assert!(frame_params(&[f32::NAN]).is_none());
        assert!(p.apply([0.0; 3]) == [0.0; 3]);
    }

    #[test]
    fn key_grows_for_bright_scenes_and_display_is_monotone() {
        // Mostly bright with a few dark pixels: L̄ near the top of the range, key above 0.18.
        let mut l = vec![100.0f32; 980];
        l.extend([0.01f32; 20]);
        assert!(frame_params(&l).unwrap().key > 0.18);
        let p = frame_params(&[0.1, 1.0, 10.0, 100.0]).unwrap();
        let mut last = -1.0;
        for i in 0..100 {
            let d = p.display(i as f64);
            assert!(d >= last && d <= 1.0);
            last = d;
        }
    }

    #[test]
    fn smoothing_suppresses_flicker() {
        // Brightness flickering ±30% every frame at 21 Hz: the smoothed log average moves much
        // less than the per-frame one.
        let mut tm = ToneMapper::new();
        let mut out = Vec::new();
        for t in 0..200 {
            let s = if t % 2 == 0 { 1.3f32 } else { 0.7 };
            out.push(tm.update(&[s, 2.0 * s, 0.5 * s, 4.0 * s], 1.0 / 21.0).unwrap().log_average);
        }
        let tail = &out[100..];
        let (mn, mx) = tail.iter().fold((f64::MAX, f64::MIN), |a, &x| (a.0.min(x), a.1.max(x)));
        assert!((mx / mn - 1.0) < 0.06, "smoothed swing {}", mx / mn - 1.0);
    }
}
