//! Per-surface outlier flags carried from the bright frames to the dim ones (issue 16 §4,
//! "`k_i` within 5%").
//!
//! Jensen §3.1 draws 500 random pixels on every frame and fits each frame on its own; the robust
//! fit (LMedS start and Tukey's biweight, `super::solve`, `super::noise`) rejects a row whose
//! residual is beyond `c = 4.685` of its noise. §3.1 also assumes that every diffuse surface the
//! camera sees is modelled and that nothing alters its reflectance ("no precipitation"). Real
//! footage breaks both: a wet patch (albedo −40%), a person, a parked car. On a bright frame
//! their rows are far outside the noise and get zero weight; on a dark one (dusk, night: the read
//! noise a third of the lamp-lit paving's radiance) the same −40% is 1.3 σ per pixel, inside the
//! biweight, and a few dozen such rows pull the lamp's `k` down by 3–5%
//! (`docs/measurements.md`, "Why the dusk lamp's `k` came out low").
//!
//! **What is new here**: a memory per pool entry across frames. After each fitted frame the
//! fitted model `μ = a·Pa_s + h·P_b + b·Pd + Σ k_j·g_j` (every column the frame's fit used, at its
//! fitted value) is evaluated on *every* valid pool entry (≈ 4000 dot products, 0.3–10 ms a frame
//! in the debug build; the frame's 500 rows are a fresh random draw each frame, so an entry is
//! rarely drawn twice) and compared with the entry's pixel, in luminance:
//! - **level per surface**: per surface group (proxy node, sunlit or not) the model is scaled by
//!   the median of `y/μ` over the group's entries (groups of at least [`MIN_GROUP`] entries above
//!   the read noise; else 1). A whole surface off the model (a wall that sees more of the
//!   twilight's horizon than the sky's shape says, an albedo calibrated a few percent off) is the
//!   model's error, for the fit to carry; what is flagged is the part of a surface that departs
//!   from the rest of it: a wet patch, a person, a car. Let `l` be the scaled prediction.
//! - **noise** of the relative departure `d = (y − l)/l`: variance `v = s² + (σ_r/l)²`, `σ_r` the
//!   frame's read noise (`super::noise`; taken at its full value for the luminance, as if the
//!   channels' noise were correlated, which overstates it when they are not), `s` the relative
//!   scale at which the median of `(y − l)²/((s·l)² + σ_r²)` over the evaluated entries is that of
//!   χ²₁ (`super::noise`'s robust scale with `σ_r` known). Only entries with `l > c·σ_r`
//!   (`c = 4.685`, Tukey's constant) are used: there the clip at zero is negligible.
//! - **evidence**: each entry keeps the inverse-variance mean `D` of its departures and its
//!   variance `V` over its last [`MEMORY`] observations (older ones fade by `(M−1)/M` per
//!   observation: consecutive frames of real footage share their texture and their model error,
//!   so their evidence is not independent, and a departure must stay beyond `c/√M` of one frame's
//!   noise to be flagged however long the sequence). The entry is **flagged** when it has at
//!   least [`MIN_OBSERVATIONS`] and `|D| > c·√V`: the mean departure is beyond the biweight's band
//!   at its own noise (for Gaussian noise a consistent entry is flagged with probability 3·10⁻⁶).
//!   One frame is never enough (a passer-by, a noise excursion).
//! - **forgetting**: an observation whose departure from `D` is beyond `c·√(v + V)` means the
//!   surface changed (a parked car drove off, a person stepped in): the entry's evidence starts
//!   afresh from it, so a flagged surface seen consistent on a frame bright enough to tell is
//!   released at once. On frames whose noise hides the departure (the night: a −40% patch at
//!   1.3 σ_r) an observation adds little weight and cannot reset it, so what the bright frames
//!   learned carries into the dark ones.
//!
//! A surface that the moving sun puts into the proxy's shadow is modelled (its `b` drops), so it
//! stays consistent; only what the model cannot explain is flagged. Entries near a shadow
//! boundary are not evaluated (they are not in the pool's valid lists).
//!
//! On later frames flagged entries are not drawn ([`SurfaceFlags::exclusion`]), with a cap:
//! at most [`MAX_EXCLUDED_FRACTION`] of the frame's valid entries, the ones with the largest
//! departure in noise units first. The flag is meant for isolated surfaces the proxy does not
//! know; when much more of the view disagrees with the model, the model is wrong as a whole (a
//! sky shape, a calibration) and hiding that part would only make the fit agree with itself.
//!
//! Frames that update the flags: a fit with status `ok`, `no_direct_sun` or `night` and no
//! fallback, and one whose sun is up but lights no sample (`sun_not_separable` with `Pd` held or
//! unobservable: on `scenes/dusk` the two brightest frames, the courtyard in the shadow of its
//! buildings), whose fit models the shadowed entries only, so only they are evaluated; clipped and
//! invalid pixels are not evaluated. The flags are estimator state like the
//! smoother and the twilight band's prior: a resumed run or a chunk replays its warm-up frames
//! through the estimator and so learns them the same way (exactly so with the whole history as
//! warm-up, the default). `[estimator] surface_flags = false` turns this off (the draws are then
//! those of the plain estimator, bit for bit).
//!
//! # What it does on `scenes/dusk`
//! Five estimator seeds (`docs/measurements.md`, "Per-surface outlier flags carried from the
//! bright frames to the night"): 160–190 of 4096 entries flagged on frames 0–1; on seed 0, 160 of
//! its 161 are the person and the wet patch, with 88% of the wet patch's entries
//! (`tests/suite/estimate_dusk_rows.rs`); the lamp's `k` on frames 3–4 from a mean of 0.920, 0.921 to
//! 0.968, 0.993; `Pa`'s mean error on frames 2–5 from 1.6, 2.5, 4.5, 13.9% to 0.4, 1.1, 4.1, 8.6%;
//! the night composite (frame 4, MSAA 4) from 10.4% to 8.5% on the mean. A rule of two
//! consecutive single-frame strikes flagged only a third as many (the pixels' own scatter about
//! the model is 9% on these frames, so one frame's band is ±42%) and left frames 3–4 at 0.94–0.96.

use super::noise::relative_scale;
use super::report::{Fallback, FrameEstimate, LampStatus, Status};
use super::sky_band::SkyBandStatus;
use super::solve::TUKEY_C;
use super::{Estimator, luma};
use crate::io::frames::{Frame, Linearizer, PixelState};
use serde::Serialize;

/// Observations an entry needs before it can be flagged (module docs).
pub const MIN_OBSERVATIONS: u8 = 2;
/// The evidence of at most this many observations is kept (module docs).
pub const MEMORY: u8 = 4;
/// At most this fraction of a frame's valid entries is left out of the draw (module docs).
pub const MAX_EXCLUDED_FRACTION: f64 = 0.1;
/// Entries a surface group needs for its own level (module docs): the median of `n` ratios has a
/// standard error of `1.25·σ/√n`, a third of their spread at 16.
pub const MIN_GROUP: usize = 16;

/// One pool entry's observation on a fitted frame: its pixel and the fitted model's prediction,
/// luminance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Observation {
    /// Pool entry.
    pub entry: u32,
    /// Observed radiance.
    pub y: f64,
    /// Fitted model's radiance.
    pub mu: f64,
    /// The entry's surface group (proxy node and sun visibility): the model's level is taken per
    /// group (module docs).
    pub group: u32,
}

/// The flags' state per pool entry: the inverse-variance sums of its relative departures.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SurfaceFlags {
    /// Observations in the sums (at most [`MEMORY`]).
    n: Vec<u8>,
    /// `Σ 1/v` over the observations.
    sw: Vec<f64>,
    /// `Σ d/v` over the observations.
    swd: Vec<f64>,
}

/// What one frame's update did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FlagUpdate {
    /// Entries evaluated.
    pub observed: usize,
    /// Entries whose departure on this frame alone is beyond `c` of its noise.
    pub strikes: usize,
    /// Entries released on this frame.
    pub released: usize,
    /// The relative noise scale `s` of the frame.
    pub relative_scale: f64,
}

/// The flags in a frame's report (`surface_flags` in the JSON line).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct SurfaceFlagsReport {
    /// Flagged entries (before the cap) when the frame was drawn.
    pub flagged: usize,
    /// Entries left out of the frame's draw (flagged, within the cap).
    pub excluded: usize,
    /// The cap on `excluded`.
    pub cap: usize,
    /// Entries evaluated after the fit (0: the frame did not update the flags).
    pub observed: usize,
    /// Entries whose departure on this frame alone is beyond `c` of its noise.
    pub strikes: usize,
    /// Entries released on this frame.
    pub released: usize,
    /// Flagged entries after this frame's update.
    pub flagged_after: usize,
    /// The relative noise scale `s` of the update.
    pub relative_scale: f64,
    /// Time of the update (model evaluated on every valid entry), ms.
    pub update_ms: f64,
}

impl SurfaceFlags {
    /// No flags, for a pool of `len` entries.
    pub fn new(len: usize) -> Self {
        Self { n: vec![0; len], sw: vec![0.0; len], swd: vec![0.0; len] }
    }

    /// Entry `e`'s mean departure `D` and its variance `V` (`None` before its first observation).
    fn evidence(&self, e: usize) -> Option<(f64, f64)> {
        let (&n, &sw) = (self.n.get(e)?, self.sw.get(e)?);
        (n > 0 && sw > 0.0).then(|| (self.swd[e] / sw, 1.0 / sw))
    }

    /// `|D|/√V` of entry `e`: its departure in standard errors.
    fn z(&self, e: usize) -> f64 {
        self.evidence(e).map_or(0.0, |(d, v)| d.abs() / v.sqrt())
    }

    /// Whether entry `e` is flagged: at least [`MIN_OBSERVATIONS`], and `|D| > c·√V`.
    pub fn is_flagged(&self, e: usize) -> bool {
        self.n.get(e).is_some_and(|&n| n >= MIN_OBSERVATIONS) && self.z(e) > TUKEY_C
    }

    /// Number of flagged entries.
    pub fn flagged(&self) -> usize {
        (0..self.n.len()).filter(|&e| self.is_flagged(e)).count()
    }

    /// Updates the flags with one fitted frame's observations (module docs); `read_noise` is the
    /// frame's `σ_r` (0: relative noise only).
    pub fn observe(&mut self, obs: &[Observation], read_noise: f64) -> FlagUpdate {
        let usable: Vec<&Observation> = obs.iter().filter(|o| o.y.is_finite() && o.mu.is_finite() && (o.mu > 0.0 || read_noise > 0.0)).collect();
        if usable.is_empty() {
            return FlagUpdate::default();
        }
        let scale = group_levels(&usable, read_noise);
        let level: Vec<f64> = usable.iter().map(|o| o.mu.max(0.0) * scale(o.group)).collect();
        let r: Vec<f64> = usable.iter().zip(&level).map(|(o, l)| o.y - l).collect();
        let s = relative_scale(&r, &level, read_noise, &mut Vec::with_capacity(r.len()));
        let mut up = FlagUpdate { observed: usable.len(), relative_scale: s, ..Default::default() };
        for ((o, r), &l) in usable.iter().zip(&r).zip(&level) {
            let e = o.entry as usize;
            // Only levels beyond Tukey's band of the read noise: there the clip at zero is
            // negligible (`Φ(−c)` = 1.4·10⁻⁶) and the relative departure has a variance.
            if e >= self.n.len() || !(l > TUKEY_C * read_noise && l > 0.0) {
                continue;
            }
            let (d, v) = (r / l, s * s + (read_noise / l).powi(2));
            if !(v > 0.0) {
                continue;
            }
            let was = self.is_flagged(e);
            up.strikes += (d.abs() > TUKEY_C * v.sqrt()) as usize;
            if let Some((mean, var)) = self.evidence(e)
                && (d - mean).abs() > TUKEY_C * (v + var).sqrt()
            {
                // The surface changed (a car drove off, a person stepped in): start afresh.
                (self.n[e], self.sw[e], self.swd[e]) = (0, 0.0, 0.0);
            }
            if self.n[e] >= MEMORY {
                let keep = f64::from(MEMORY - 1) / f64::from(MEMORY);
                (self.n[e], self.sw[e], self.swd[e]) = (MEMORY - 1, self.sw[e] * keep, self.swd[e] * keep);
            }
            self.n[e] += 1;
            self.sw[e] += 1.0 / v;
            self.swd[e] += d / v;
            up.released += (was && !self.is_flagged(e)) as usize;
        }
        up
    }

    /// The entries left out of a draw from `valid` (the frame's valid entries): the flagged ones,
    /// at most [`MAX_EXCLUDED_FRACTION`] of `valid`, largest departure first. Returns the mask
    /// over the pool (`None` when nothing is left out), the flagged count among `valid` and the
    /// cap.
    pub fn exclusion(&self, valid: impl Iterator<Item = u32>) -> (Option<Vec<bool>>, usize, usize) {
        let mut n = 0usize;
        let mut flagged: Vec<u32> = Vec::new();
        for e in valid {
            n += 1;
            if self.is_flagged(e as usize) {
                flagged.push(e);
            }
        }
        let cap = (MAX_EXCLUDED_FRACTION * n as f64).floor() as usize;
        let count = flagged.len();
        if flagged.is_empty() || cap == 0 {
            return (None, count, cap);
        }
        if flagged.len() > cap {
            // Largest departure in noise units first; ties by entry, so the mask is deterministic.
            flagged.sort_by(|&a, &b| self.z(b as usize).total_cmp(&self.z(a as usize)).then(a.cmp(&b)));
            flagged.truncate(cap);
        }
        let mut mask = vec![false; self.n.len()];
        for e in flagged {
            mask[e as usize] = true;
        }
        (Some(mask), count, cap)
    }
}

/// Per surface group, the median of `y/μ` over its entries well above the read noise (`μ` beyond
/// Tukey's band of it, so that the read noise moves a ratio by less than `1/c`), when it has at
/// least [`MIN_GROUP`] of them; else 1.
fn group_levels(obs: &[&Observation], read_noise: f64) -> impl Fn(u32) -> f64 {
    let mut ratios: Vec<(u32, f64)> = obs.iter().filter(|o| o.mu > TUKEY_C * read_noise && o.mu > 0.0).map(|o| (o.group, o.y / o.mu)).collect();
    ratios.sort_by(|a, b| a.0.cmp(&b.0).then(a.1.total_cmp(&b.1)));
    let mut levels: Vec<(u32, f64)> = Vec::new();
    for chunk in ratios.chunk_by(|a, b| a.0 == b.0) {
        if chunk.len() >= MIN_GROUP {
            let m = chunk.len();
            let median = if m % 2 == 1 { chunk[m / 2].1 } else { 0.5 * (chunk[m / 2 - 1].1 + chunk[m / 2].1) };
            levels.push((chunk[0].0, median));
        }
    }
    move |g| levels.iter().find(|l| l.0 == g).map_or(1.0, |l| l.1)
}

impl Estimator {
    /// After the frame's fit: evaluates the fitted model on every valid pool entry, updates the
    /// flags (module docs) and puts the frame's flag report into `out`.
    pub(super) fn learn_flags(&mut self, out: &mut FrameEstimate, frame: &Frame, lin: &Linearizer) {
        let Some(mut report) = self.flag_report.take() else { return };
        // The model of the frame's fit: `Pd` as reported, or with the sun up but unseen, the `Pd`
        // of the fit of the shadowed rows (`flag_pd`), whose model holds for them only.
        let model = match (out.status, out.fallback) {
            (Status::Ok | Status::NoDirectSun | Status::Night, None) => out.pd.map(|pd| (pd, false)),
            (Status::SunNotSeparable, Some(Fallback::HeldPd | Fallback::PdUnobservable)) => self.flag_pd.map(|pd| (pd, true)),
            _ => None,
        };
        if let (Some((pd, shadowed_only)), Some(pa)) = (model, out.pa) {
            let t = std::time::Instant::now();
            let obs = self.flag_observations(out, pa, pd, shadowed_only, frame, lin);
            if let Some(flags) = self.flags.as_mut() {
                let up = flags.observe(&obs, self.read_noise);
                report.observed = up.observed;
                report.strikes = up.strikes;
                report.released = up.released;
                report.relative_scale = up.relative_scale;
            }
            report.update_ms = t.elapsed().as_secs_f64() * 1e3;
        }
        report.flagged_after = self.flags.as_ref().map_or(0, SurfaceFlags::flagged);
        out.surface_flags = Some(report);
    }

    /// Every valid pool entry's unclipped pixel (the shadowed ones only when `shadowed_only`)
    /// against the frame's fitted model: the sky's shape and band at their fitted scales
    /// (`super::sky_band`'s report), `Pd` and every lamp that is not off at its reported `k`
    /// (luminance).
    fn flag_observations(&self, out: &FrameEstimate, pa: [f64; 3], pd: [f64; 3], shadowed_only: bool, frame: &Frame, lin: &Linearizer) -> Vec<Observation> {
        let Some(sun) = self.sun.as_ref() else { return Vec::new() };
        let overcast = self.overcast();
        let (sky, band_scale) = match &out.sky_band {
            Some(b) if b.status != SkyBandStatus::Dropped => (b.shape_pa, b.scale),
            _ => (pa, [0.0; 3]),
        };
        let band = self.sun_sky.as_ref().and_then(|s| s.band.as_ref()).filter(|_| band_scale.iter().any(|&v| v != 0.0));
        let lamps: Vec<(usize, [f64; 3])> = out.lamps.iter().enumerate().filter(|(_, r)| r.status != LampStatus::Off).map(|(j, r)| (j, r.k)).collect();
        let lc = self.lamps.as_ref();
        let entries: Box<dyn Iterator<Item = u32>> = if shadowed_only { Box::new(sun.valid_unlit.iter().copied()) } else { Box::new(sun.valid()) };
        entries
            .filter_map(|e| {
                let eu = e as usize;
                let (v, state) = lin.radiance(frame, self.pool.pixel[eu] as usize);
                if state != PixelState::Ok {
                    return None;
                }
                let (a, b) = self.entry_columns(sun, eu, overcast);
                let h = band.map_or([0.0; 3], |h| h[eu]);
                let mu: [f64; 3] = std::array::from_fn(|c| {
                    let lamp: f64 = lc.map_or(0.0, |lc| lamps.iter().map(|&(j, k)| k[c] * lc.g(j, eu)[c]).sum());
                    f64::from(a[c]) * sky[c] + f64::from(h[c]) * band_scale[c] + f64::from(b[c]) * pd[c] + lamp
                });
                let group = self.pool.node[eu].wrapping_mul(2) + u32::from(sun.lit[eu]);
                Some(Observation { entry: e, y: luma(&v.map(f64::from)), mu: luma(&mu), group })
            })
            .collect()
    }
}

#[cfg(test)]
#[path = "surface_flags_tests.rs"]
mod tests;
