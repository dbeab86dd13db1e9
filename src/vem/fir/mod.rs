//! Temporal filtering of the lights (Havran §3.3): a linear-phase FIR low-pass on every light's
//! direction (in 3D, then renormalised) and on the frame's total power.
//!
//! # Three ways to run it ([`Temporal`], issue 14 part 4)
//! - **Zero phase** ([`CentredFilter`], recorded input: `heliar vem` on files, with or without
//!   `--scene`): the symmetric taps centred on frame `t`, so frame `t`'s lights describe frame
//!   `t`; the output for `t` waits until frame `t + m` is in, and the first and last `m` frames
//!   use shortened symmetric windows.
//! - **Causal** ([`LightFilter`] with the design's taps): the paper's, output for frame `t`
//!   describes frame `t − m`.
//! - **Minimum phase** ([`LightFilter`] with [`FirDesign::minimum_phase`], live input): the same
//!   amplitude response with the least delay a causal filter of that length has
//!   ([`min_phase`]; ≈ 1 frame at 21 Hz instead of 4).
//!
//! # How it works
//! - **The paper's filter.** At 21 Hz capture the paper uses a 9-tap equiripple filter (order 8)
//!   with `w₁ = w₉ = 0.06216`, `w₂ = w₈ = 0.01296`, `w₃ = w₇ = −0.13816`, `w₄ = w₆ = 0.28315`,
//!   `w₅ = 0.65223` ([`PAPER_TAPS_21HZ`]). Those sum to 1.09245 (the passband ripple at DC);
//!   they are divided by their sum, which is how the paper keeps the energy ("normalizing the
//!   filter weighting coefficients"). The filter is symmetric, so its **delay is 4 frames**
//!   (`(taps − 1)/2`, 0.19 s at 21 Hz): the output for frame `t` describes frame `t − 4`.
//! - **Other capture rates.** [`FirDesign::for_rate`] designs an equiripple (Parks–McClellan /
//!   Remez exchange) low-pass with the band edges, in hertz, that reproduce the paper's response
//!   at 21 Hz: pass band to [`DESIGN_PASS_HZ`], stop band from [`DESIGN_STOP_HZ`]. (The paper
//!   quotes 7 and 9 Hz; an order-8 equiripple design with those edges has a different response
//!   from its printed taps, while 5.9/8.05 Hz reproduce them to within 0.002 per tap.) The order
//!   scales with the rate, `8·rate/21` rounded to even, so the delay stays about 0.19 s and the
//!   flicker band above ~8 Hz stays suppressed. Below 17 Hz capture (where 8.05 Hz is not below
//!   Nyquist) the edges scale with the rate instead, i.e. the paper's filter in frames. At 21 Hz
//!   the design matches the paper's normalised response within [`PAPER_RESPONSE_TOLERANCE`]
//!   (tested), and [`FirDesign::for_rate`] returns the paper's own taps.
//! - **Start-up.** A light's history is filled with its first sample, so the output is defined
//!   from its first frame (a light added later starts the same way; one absent for a frame
//!   restarts).
//! - **Degenerate windows.** If the filtered vector is shorter than [`MIN_FILTERED_NORM`] (samples
//!   in the window nearly cancel, e.g. antipodal jumps), the light keeps its last good direction.
//!   No NaN can come out.
//! - **Power.** The total power is filtered the same way and clamped at 0 (the negative taps can
//!   undershoot after a sudden rise from darkness). Each light carries `P_filtered / N` in
//!   luminance, times its filtered colour (renormalised to unit luminance).

mod centred;
mod design;
pub mod min_phase;

pub use centred::CentredFilter;

pub use design::{
    DESIGN_PASS_HZ, DESIGN_STOP_HZ, FirDesign, MAX_ORDER, PAPER_RATE_HZ, PAPER_RESPONSE_TOLERANCE, PAPER_TAPS_21HZ, TemporalError, amplitude,
    remez_lowpass,
};
use super::Light;
use super::polar::luminance;
use glam::Vec3;

/// How the temporal filter runs (issue 14, part 4).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Temporal {
    /// The design's symmetric taps centred on the frame ([`CentredFilter`]; recorded input):
    /// frame `t`'s lights describe frame `t`, given out once frame `t + m` is in.
    ZeroPhase,
    /// The design's taps run causally, as in the paper ([`LightFilter`]): frame `t`'s lights
    /// describe frame `t − m` (`m = 4` at 21 Hz).
    #[default]
    Causal,
    /// The minimum-phase version of the design run causally (live input,
    /// [`min_phase`]): the same amplitude response with the least delay.
    MinimumPhase,
}

/// A filtered direction shorter than this is degenerate: the light holds its last good direction.
pub const MIN_FILTERED_NORM: f32 = 0.25;

/// Per-light and total-power FIR state.
#[derive(Clone, Debug)]
pub struct LightFilter {
    taps: Vec<f32>,
    head: usize,
    frame: u64,
    /// Per light slot, `taps.len()` past directions (ring buffer shared by all slots).
    dirs: Vec<Vec3>,
    /// Per light slot, past colours (unit luminance).
    rgb: Vec<[f32; 3]>,
    last_good: Vec<Vec3>,
    /// The frame number each slot last received a sample in (`u64::MAX`: never).
    seen: Vec<u64>,
    power: Vec<f64>,
    power_seen: bool,
    /// How many lights had the filter output present (lights that exist in this frame).
    active: usize,
}

/// What one filter step did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FilterStep {
    /// Filtered total power (luminance), ≥ 0.
    pub power: f64,
    /// Lights whose window was degenerate and held their last good direction.
    pub held: usize,
}

impl LightFilter {
    /// An empty filter with the given design.
    pub fn new(design: &FirDesign) -> Self {
        let taps: Vec<f32> = design.taps.iter().map(|&w| w as f32).collect();
        Self { taps, head: 0, frame: 0, dirs: vec![], rgb: vec![], last_good: vec![], seen: vec![], power: vec![], power_seen: false, active: 0 }
    }

    /// Number of taps.
    pub fn len(&self) -> usize {
        self.taps.len()
    }

    /// Whether the filter has no taps (never: designs have at least 3).
    pub fn is_empty(&self) -> bool {
        self.taps.is_empty()
    }

    /// Filters one frame: the total power `power` (luminance) and the raw lights
    /// `(direction, colour per unit luminance)`, indexed by light index. Writes the filtered
    /// lights to `out` (cleared first), each with power `P_filtered/N` times its colour.
    pub fn step(&mut self, power: f64, raw: &[(Vec3, [f32; 3])], out: &mut Vec<Light>) -> FilterStep {
        let len = self.taps.len();
        self.head = (self.head + 1) % len;
        let n = raw.len();
        if self.seen.len() < n {
            self.dirs.resize(n * len, Vec3::Y);
            self.rgb.resize(n * len, [1.0; 3]);
            self.last_good.resize(n, Vec3::Y);
            self.seen.resize(n, u64::MAX);
        }
        // Power.
        if !self.power_seen {
            self.power = vec![power; len];
            self.power_seen = true;
        }
        self.power[self.head] = power;
        let p = self.power.iter().zip(self.ring_taps()).map(|(v, w)| v * w as f64).sum::<f64>().max(0.0);
        // Directions and colours.
        for (k, &(d, c)) in raw.iter().enumerate() {
            let hist = k * len..(k + 1) * len;
            let continuing = self.frame > 0 && self.seen[k] == self.frame - 1;
            if !continuing {
                // New or returning light: fill its window with this sample.
                self.dirs[hist.clone()].fill(d);
                self.rgb[hist].fill(c);
                self.last_good[k] = d;
            } else {
                self.dirs[k * len + self.head] = d;
                self.rgb[k * len + self.head] = c;
            }
            self.seen[k] = self.frame;
        }
        self.active = n;
        let held = self.emit(p, out);
        self.frame += 1;
        FilterStep { power: p, held }
    }

    /// Filters a frame without light (a black map): power 0, and every light that exists
    /// repeats its newest raw sample, so directions stay put while the power decays.
    pub fn step_dark(&mut self, out: &mut Vec<Light>) -> FilterStep {
        let len = self.taps.len();
        let prev = self.head;
        self.head = (self.head + 1) % len;
        if !self.power_seen {
            self.power = vec![0.0; len];
            self.power_seen = true;
        }
        self.power[self.head] = 0.0;
        let p = self.power.iter().zip(self.ring_taps()).map(|(v, w)| v * w as f64).sum::<f64>().max(0.0);
        for k in 0..self.active {
            self.dirs[k * len + self.head] = self.dirs[k * len + prev];
            self.rgb[k * len + self.head] = self.rgb[k * len + prev];
            self.seen[k] = self.frame;
        }
        let held = self.emit(p, out);
        self.frame += 1;
        FilterStep { power: p, held }
    }

    /// The taps in ring-buffer order (tap `i` applies to the sample `i` frames before the newest;
    /// the filter is symmetric, so the order only matters for clarity).
    fn ring_taps(&self) -> impl Iterator<Item = f32> + '_ {
        let len = self.taps.len();
        (0..len).map(move |slot| self.taps[(self.head + len - slot) % len])
    }

    fn emit(&mut self, p: f64, out: &mut Vec<Light>) -> usize {
        out.clear();
        let len = self.taps.len();
        let n = self.active;
        if n == 0 {
            return 0;
        }
        let per_light = (p / n as f64) as f32;
        let w: Vec<f32> = self.ring_taps().collect();
        let mut held = 0;
        for k in 0..n {
            let (mut v, mut c) = (Vec3::ZERO, [0.0f32; 3]);
            for slot in 0..len {
                v += self.dirs[k * len + slot] * w[slot];
                let r = self.rgb[k * len + slot];
                for ch in 0..3 {
                    c[ch] += r[ch] * w[slot];
                }
            }
            let (light, was_held) = finish_light(k as u32, v, c, self.last_good[k], self.rgb[k * len + self.head], per_light);
            held += usize::from(was_held);
            self.last_good[k] = light.dir;
            out.push(light);
        }
        held
    }
}

/// A filtered light from its weighted sum of directions `v` and of colours `c`: the direction
/// renormalised (or `fallback_dir` when the sum is degenerate, reported by the flag), the colour
/// clamped at 0 and brought to unit luminance (or `fallback_colour` if it has none), times
/// `per_light`.
fn finish_light(index: u32, v: Vec3, c: [f32; 3], fallback_dir: Vec3, fallback_colour: [f32; 3], per_light: f32) -> (Light, bool) {
    let norm = v.length();
    let (dir, held) = if norm >= MIN_FILTERED_NORM && norm.is_finite() { (v / norm, false) } else { (fallback_dir, true) };
    let c = c.map(|x| x.max(0.0));
    let y = luminance(c);
    let c = if y > 0.0 && y.is_finite() { c.map(|x| x / y) } else { fallback_colour };
    (Light { index, dir, rgb: c.map(|x| x * per_light), radius: 0.0 }, held)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paper_filter_has_unit_gain_and_a_four_frame_delay() {
        let f = FirDesign::paper();
        assert_eq!(f.delay_frames(), 4);
        assert!((f.taps.iter().sum::<f64>() - 1.0).abs() < 1e-12);
        assert!((f.response(0.0) - 1.0).abs() < 1e-12);
        // Stop band from ~9 Hz: below 10% there.
        for hz in [9.0, 9.5, 10.0, 10.5] {
            assert!(f.response(hz).abs() < 0.1, "{hz} Hz: {}", f.response(hz));
        }
        assert_eq!(FirDesign::for_rate(21.0).unwrap(), f);
    }

    #[test]
    fn design_at_21_hz_reproduces_the_paper() {
        let (d, p) = (FirDesign::design(21.0).unwrap(), FirDesign::paper());
        assert_eq!(d.taps.len(), 9);
        let mut worst = 0.0f64;
        for i in 0..=1050 {
            let hz = i as f64 / 100.0;
            worst = worst.max((d.response(hz) - p.response(hz)).abs());
        }
        assert!(worst < PAPER_RESPONSE_TOLERANCE, "max response difference {worst}");
        for (a, b) in d.taps.iter().zip(&p.taps) {
            assert!((a - b).abs() < 0.002, "{:?} vs {:?}", d.taps, p.taps);
        }
    }

    #[test]
    fn designs_for_other_rates_keep_the_band_in_hertz() {
        for rate in [30.0, 60.0, 120.0] {
            let f = FirDesign::for_rate(rate).unwrap();
            let delay_s = f.delay_frames() as f64 / rate;
            assert!((delay_s - 4.0 / 21.0).abs() < 0.03, "{rate} Hz: delay {delay_s} s");
            assert!((f.response(0.0) - 1.0).abs() < 1e-9);
            assert!(f.response(3.0) > 0.85, "{rate} Hz: {}", f.response(3.0));
            for hz in [9.0, 12.0, rate / 2.0] {
                assert!(f.response(hz).abs() < 0.12, "{rate} Hz at {hz} Hz: {}", f.response(hz));
            }
        }
        // Slow capture: the paper's filter in frames.
        let f = FirDesign::for_rate(10.0).unwrap();
        assert_eq!(f.taps.len(), 9);
        assert!(f.response(5.0).abs() < 0.1);
        assert!(FirDesign::for_rate(0.0).is_err() && FirDesign::for_rate(f64::NAN).is_err());
    }

    #[test]
    fn degenerate_windows_hold_the_last_good_direction() {
        let mut f = LightFilter::new(&FirDesign::paper());
        let mut out = Vec::new();
        let d = Vec3::new(0.3, 0.8, -0.2).normalize();
        for t in 0..30 {
            let s = if t % 2 == 0 { d } else { -d };
            let st = f.step(1.0, &[(s, [1.0; 3]), (Vec3::Y, [1.0; 3])], &mut out);
            for l in &out {
                assert!(l.dir.is_finite() && (l.dir.length() - 1.0).abs() < 1e-5);
                assert!(l.rgb.iter().all(|c| c.is_finite()));
            }
            assert!((out[1].dir - Vec3::Y).length() < 1e-6);
            if t > 8 {
                assert_eq!(st.held, 1);
                assert!((out[0].dir - d).length() < 1e-5 || (out[0].dir + d).length() < 1e-5);
            }
        }
        // An exactly cancelling window: still no NaN.
        let mut f = LightFilter::new(&FirDesign { taps: vec![0.5, 0.0, 0.5], rate_hz: 21.0 });
        let st = f.step(1.0, &[(Vec3::X, [1.0; 3])], &mut out);
        assert_eq!((st.held, out[0].dir), (0, Vec3::X));
        // Window (−X, X, X) with taps (½, 0, ½): exactly zero.
        let st = f.step(1.0, &[(Vec3::NEG_X, [1.0; 3])], &mut out);
        assert_eq!(st.held, 1);
        assert_eq!(out[0].dir, Vec3::X);
        assert!(out[0].rgb.iter().all(|c| c.is_finite()));
    }

    #[test]
    fn constant_input_passes_unchanged_and_power_is_shared() {
        let mut f = LightFilter::new(&FirDesign::paper());
        let mut out = Vec::new();
        let raw = [(Vec3::Y, [1.0f32; 3]), (Vec3::X, [2.0, 1.0, 0.5])];
        for _ in 0..12 {
            let st = f.step(8.0, &raw, &mut out);
            assert!((st.power - 8.0).abs() < 1e-5); // f32 taps
        }
        assert_eq!(out.len(), 2);
        assert!((out[0].dir - Vec3::Y).length() < 1e-6 && (out[1].dir - Vec3::X).length() < 1e-6);
        let y: f32 = out.iter().map(|l| luminance(l.rgb)).sum();
        assert!((y - 8.0).abs() < 1e-4);
        // A step in power reaches the new level after the delay, with the filter's overshoot.
        for t in 0..9 {
            let st = f.step(0.0, &raw, &mut out);
            assert!(st.power >= 0.0);
            if t == 8 {
                assert!(st.power.abs() < 1e-9);
            }
        }
        // Dark frames hold directions and bring the power down.
        for _ in 0..9 {
            let st = f.step_dark(&mut out);
            assert_eq!(out.len(), 2);
            assert!(st.power.abs() < 1e-9);
        }
        assert!((out[1].dir - Vec3::X).length() < 1e-6);
    }
}
