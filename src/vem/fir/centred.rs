//! The zero-phase (centred, non-causal) form of the temporal filter, for recorded input (issue
//! 14, part 4): frame `t`'s lights are the symmetric FIR of the design applied to frames
//! `t − m … t + m` (`m = (taps − 1)/2`), so they describe frame `t` itself instead of frame
//! `t − m` as the causal filter's do (Havran §3.3 runs it causally, for live capture).
//!
//! # How it works
//! - **Buffering.** [`CentredFilter::push`] keeps the raw samples of the last `2m + 1` frames;
//!   frame `t` can be given out ([`CentredFilter::emit`]) once frame `t + m` has been pushed, or
//!   at any time with fewer future frames (at the end of a recording).
//! - **Ends.** Where fewer than `m` frames exist on one side of `t` (the first and last `m`
//!   frames of a recording), the window is shortened symmetrically to the half-width `r` both
//!   sides have, and its taps (the design's centre `2r + 1`) are renormalised to sum 1: still
//!   zero phase, and a constant input stays exactly constant. A light that does not exist in
//!   every frame of the window (added later, or gone) is filtered over the symmetric window
//!   within its own run of frames the same way.
//! - **Dark frames** repeat every light's previous raw sample with power 0, as in the causal
//!   filter, so directions hold while the filtered power goes down.
//! - **Degenerate windows** (a filtered vector shorter than [`super::MIN_FILTERED_NORM`]) keep
//!   the light's last good direction, or its own raw direction the first time.

use super::{FilterStep, FirDesign, finish_light};
use crate::vem::Light;
use glam::Vec3;
use std::collections::VecDeque;

/// Renormalised half windows whose taps sum below this are not used (a narrower one is): a guard
/// for designs with large negative side lobes (the paper's shortest sums are 0.94 … 1.22).
const MIN_TAP_SUM: f64 = 0.25;

/// One pushed frame: total power (luminance) and raw lights `(direction, colour per unit
/// luminance)` by light index.
#[derive(Clone, Debug, Default)]
struct RawFrame {
    power: f64,
    lights: Vec<(Vec3, [f32; 3])>,
}

/// Zero-phase temporal filter state.
#[derive(Clone, Debug)]
pub struct CentredFilter {
    /// Per half-width `r = 0 … m`, the centre `2r + 1` taps renormalised (`None`: sum too small).
    windows: Vec<Option<Vec<f32>>>,
    /// Frames `first … first + frames.len() − 1`.
    frames: VecDeque<RawFrame>,
    first: u64,
    /// The next frame to give out.
    next: u64,
    last_good: Vec<Option<Vec3>>,
}

impl CentredFilter {
    /// An empty filter for a symmetric design (the taps are used centred whatever their order).
    pub fn new(design: &FirDesign) -> Self {
        let m = design.taps.len() / 2;
        let windows = (0..=m)
            .map(|r| {
                let w = &design.taps[m - r..=m + r];
                let s: f64 = w.iter().sum();
                (s > MIN_TAP_SUM).then(|| w.iter().map(|x| (x / s) as f32).collect())
            })
            .collect();
        Self { windows, frames: VecDeque::new(), first: 0, next: 0, last_good: Vec::new() }
    }

    /// Half-width `m` of the full window: the number of frames pushed after frame `t` before `t`
    /// is given out with the full window.
    pub fn half_width(&self) -> usize {
        self.windows.len() - 1
    }

    /// Frames pushed so far.
    fn pushed(&self) -> u64 {
        self.first + self.frames.len() as u64
    }

    /// Pushes the next frame's power and raw lights.
    pub fn push(&mut self, power: f64, raw: &[(Vec3, [f32; 3])]) {
        self.frames.push_back(RawFrame { power, lights: raw.to_vec() });
    }

    /// Pushes a frame without light: power 0, every light repeating its previous raw sample.
    pub fn push_dark(&mut self) {
        let lights = self.frames.back().map(|f| f.lights.clone()).unwrap_or_default();
        self.frames.push_back(RawFrame { power: 0.0, lights });
    }

    /// Whether the next frame has its full window (`m` frames after it pushed).
    pub fn ready(&self) -> bool {
        self.pushed() > self.next + self.half_width() as u64
    }

    /// Whether a pushed frame has not been given out yet.
    pub fn pending(&self) -> bool {
        self.next < self.pushed()
    }

    /// Gives out the next frame (with the widest symmetric window the frames pushed allow):
    /// its number, the filtered power and lights (written to `out`, cleared first, each with
    /// `P_filtered / N` times its colour). `None` when no frame is pending.
    pub fn emit(&mut self, out: &mut Vec<Light>) -> Option<(u64, FilterStep)> {
        out.clear();
        if !self.pending() {
            return None;
        }
        let t = self.next;
        let c = (t - self.first) as usize;
        let after = (self.pushed() - 1 - t) as usize;
        let r_max = self.half_width().min(c).min(after);
        let r = self.usable(r_max);
        let w = self.windows[r].as_deref().unwrap_or(&[1.0]);
        let p = (0..w.len()).map(|j| self.frames[c + j - r].power * w[j] as f64).sum::<f64>().max(0.0);
        let n = self.frames[c].lights.len();
        if self.last_good.len() < n {
            self.last_good.resize(n, None);
        }
        let per_light = if n > 0 { (p / n as f64) as f32 } else { 0.0 };
        let mut held = 0;
        for k in 0..n {
            // The light's own symmetric run around t.
            let mut rk = 0;
            while rk < r_max && self.frames[c - rk - 1].lights.len() > k && self.frames[c + rk + 1].lights.len() > k {
                rk += 1;
            }
            let rk = self.usable(rk);
            let wk = self.windows[rk].as_deref().unwrap_or(&[1.0]);
            let (mut v, mut col) = (Vec3::ZERO, [0.0f32; 3]);
            for (j, &wj) in wk.iter().enumerate() {
                let (d, cl) = self.frames[c + j - rk].lights[k];
                v += d * wj;
                for ch in 0..3 {
                    col[ch] += cl[ch] * wj;
                }
            }
            let (raw_dir, raw_col) = self.frames[c].lights[k];
            let fallback = self.last_good[k].unwrap_or(raw_dir);
            let (light, was_held) = finish_light(k as u32, v, col, fallback, raw_col, per_light);
            held += usize::from(was_held);
            self.last_good[k] = Some(light.dir);
            out.push(light);
        }
        self.next += 1;
        // Keep the m frames before the next one.
        while self.first + (self.half_width() as u64) < self.next && !self.frames.is_empty() {
            self.frames.pop_front();
            self.first += 1;
        }
        Some((t, FilterStep { power: p, held }))
    }

    /// The widest half-width `≤ r` whose renormalised taps are usable.
    fn usable(&self, r: usize) -> usize {
        (0..=r).rev().find(|&q| self.windows[q].is_some()).unwrap_or(0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::vem::polar::luminance;

    #[test]
    fn constant_input_is_unchanged_at_the_ends_and_inside() {
        // Closed form: every shortened window sums to 1, so a constant sequence comes out as it
        // went in, from the first frame to the last (f32 taps: to 1e-5).
        let mut f = CentredFilter::new(&FirDesign::paper());
        let raw = [(Vec3::new(0.3, 0.8, -0.2).normalize(), [1.2f32, 1.0, 0.7]), (Vec3::Y, [1.0; 3])];
        let mut out = Vec::new();
        let mut got = Vec::new();
        for _ in 0..12 {
            f.push(6.0, &raw);
            while f.ready() {
                got.push((f.emit(&mut out).unwrap(), out.clone()));
            }
        }
        while let Some(s) = f.emit(&mut out) {
            got.push((s, out.clone()));
        }
        assert_eq!(got.len(), 12);
        for (t, ((frame, step), lights)) in got.iter().enumerate() {
            assert_eq!(*frame, t as u64);
            assert!((step.power - 6.0).abs() < 1e-5, "frame {t}: {}", step.power);
            for (l, r) in lights.iter().zip(&raw) {
                assert!((l.dir - r.0).length() < 1e-6);
                let y = luminance(r.1);
                for ch in 0..3 {
                    assert!((l.rgb[ch] - r.1[ch] / y * 3.0).abs() < 1e-4, "frame {t}: {:?}", l.rgb);
                }
            }
        }
    }

    #[test]
    fn a_ramp_is_described_without_delay() {
        // A linear ramp in power passes a symmetric window unchanged (zero phase: no lag), where
        // the causal filter reports the value m frames earlier.
        let mut f = CentredFilter::new(&FirDesign::paper());
        let mut out = Vec::new();
        for t in 0..20 {
            f.push(10.0 + t as f64, &[(Vec3::Y, [1.0; 3])]);
            if f.ready() {
                let (frame, step) = f.emit(&mut out).unwrap();
                assert_eq!(frame + 4, t);
                assert!((step.power - (10.0 + frame as f64)).abs() < 1e-4, "frame {frame}: {}", step.power);
            }
        }
    }
}
