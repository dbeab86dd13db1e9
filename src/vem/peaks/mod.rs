//! Concentrated peaks (the sun, a bare lamp) as lights of their own (issue 14; on by default with
//! the coherent cut, `VemConfig::peaks`, `--no-peaks` to turn it off).
//!
//! Equal-power samples (Havran §3.3, `../shared/papers/havran-2005-video-environment-maps.txt`:
//! every light carries `P/N`) spend most of `N` on a sun that holds most of the power, and when a
//! cloud crosses it, or a lamp flickers, those lights all move at once. Here a peak gets lights at
//! its measured power and the rest of the map is sampled as before.
//!
//! # How it works
//! Per frame ([`PeakTracker::split`]):
//! 1. **Threshold.** Texels whose luminance exceeds [`PEAK_FACTOR`] × the map's median luminance
//!    (the mean if the median is 0; the median of every [`MEDIAN_STRIDE`]-th texel) are
//!    candidates.
//! 2. **Regions.** Candidates are grouped into 4-connected regions (wrapping in `φ`). A region
//!    is a peak if it is compact (at most [`MAX_PEAK_SR`] steradians) and its excess power
//!    `Σ (L − B)·ΔΩ` (luminance) is at least [`MIN_PEAK_SHARE`] of the map's (half that for a
//!    peak tracked from the previous frame, so that a peak near the limit does not flicker in
//!    and out). The excess is taken over the region **and the ring of texels around it** (its
//!    halo: texels a source covers only in part, which a flickering lamp would otherwise leave
//!    flickering in the remainder), and `B` is the mean radiance of the texels around that ring
//!    (the sky around the source). At most [`MAX_PEAKS`] peaks, the strongest.
//! 3. **Lights.** A peak of solid angle `Ω` gets `k = ⌈Ω / PEAK_LIGHT_SR⌉` lights (at most
//!    [`MAX_PEAK_LIGHTS`]; a sun gets one): its excess energy cut into `k` groups of equal
//!    luminance ([`extended`]), one light per group at its excess-energy centroid with
//!    `rgb = Σ (L − B)·ΔΩ` per channel (its irradiance on a surface facing it, like every
//!    [`Light`]) and `radius` the angular radius of the group. In the remainder map the peak's
//!    texels are set to `B`, so peaks + remainder keep the map's power (up to a channel whose
//!    excess would be negative, clamped at 0).
//! 4. **Tracking.** A peak within [`TRACK_RAD`] of one of the previous frame's keeps its identity
//!    `p` and its light count (unless the count it would get now is twice or half of it); a new
//!    one gets the next identity. Light `s` of peak `p` has index
//!    `PEAK_INDEX_BASE + p·MAX_PEAK_LIGHTS + s`, apart from the samples' indices, so a peak's
//!    lights keep their identity while it exists.
//!
//! In the [`crate::vem::Decomposer`] the peak lights are appended to the filtered samples of
//! the remainder. Their directions are this frame's (a peak is measured, not sampled); their
//! total power is filtered in time (Havran §3.3: the flicker of a lamp on a dimmer or on AC is
//! what the filter is for), and each peak light keeps its share of it. On files (zero phase) the
//! filter is the median over the FIR's centred window: it removes a lamp's flicker but keeps a
//! step, such as a cloud reaching the sun, in its frame (the FIR would spread it over 9 frames).
//! With the paper's causal filter the FIR filters the peaks' power with its delay, as the rest;
//! live, with the minimum-phase filter (low delay first), the peaks' power is not filtered: a
//! cloud's step would lag (3.8% mean error against 0.19% on the sun sequence at 180 × 45,
//! N = 128), and a lamp's flicker passes.
//! With a glossy set
//! (Havran §4.2) the peak lights belong to both `L` and `H` at their own power; the samples of
//! the remainder make up the rest of each set.

mod extended;

use crate::vem::Light;
use crate::vem::polar::{PolarMap, luminance};
use crate::vem::sampling::is_valid;
use extended::PeakTexel;
use glam::{DVec3, Vec3};

/// Candidates exceed this multiple of the median luminance.
pub const PEAK_FACTOR: f32 = 50.0;
/// The median is taken over every this-many-th texel (a level, not an exact statistic).
pub const MEDIAN_STRIDE: usize = 7;
/// Smallest share of the map's power (luminance) a new peak holds (a tracked one: half).
pub const MIN_PEAK_SHARE: f64 = 0.01;
/// Largest solid angle, sr, of a region still called compact: a cap of about 10° radius.
pub const MAX_PEAK_SR: f64 = 0.1;
/// Solid angle, sr, one light of an extended peak stands for at most: a cap of 2° radius.
pub const PEAK_LIGHT_SR: f64 = 0.003_83;
/// Most lights of one peak.
pub const MAX_PEAK_LIGHTS: usize = 16;
/// Most peaks per frame.
pub const MAX_PEAKS: usize = 4;
/// A peak within this angle of a previous one is the same peak (5°).
pub const TRACK_RAD: f32 = 5.0 * std::f32::consts::PI / 180.0;
/// Indices of peak lights start here.
pub const PEAK_INDEX_BASE: u32 = 1 << 30;

/// A peak of the previous frame: its identity, centroid and light count.
#[derive(Clone, Copy, Debug)]
struct Tracked {
    id: u32,
    dir: Vec3,
    lights: usize,
}

/// Finds peaks frame after frame and keeps their indices (see the module docs).
#[derive(Clone, Debug)]
pub struct PeakTracker {
    next: u32,
    tracked: Vec<Tracked>,
    peaks: Vec<Light>,
    remainder: PolarMap,
    lum: Vec<f32>,
    sample: Vec<f32>,
    /// Per texel: 0 unvisited, [`CORE`], [`RING`] or [`OUTER`] (reset after each region).
    label: Vec<u8>,
    stack: Vec<usize>,
    outer: Vec<usize>,
    lights: Vec<extended::PeakLight>,
    /// The remainder as changes of the map: (texel, background), by texel.
    patches: Vec<(usize, [f32; 3])>,
}

const CORE: u8 = 1;
const RING: u8 = 2;
const OUTER: u8 = 3;

impl Default for PeakTracker {
    fn default() -> Self {
        Self {
            next: 0,
            tracked: Vec::new(),
            peaks: Vec::new(),
            remainder: PolarMap::new(0, 0),
            lum: Vec::new(),
            sample: Vec::new(),
            label: Vec::new(),
            stack: Vec::new(),
            outer: Vec::new(),
            lights: Vec::new(),
            patches: Vec::new(),
        }
    }
}

/// A candidate region: its texels (core and ring) with their excess, the background, the
/// excess luminance and share of the map's power, the centroid and the core's solid angle.
struct Candidate {
    texels: Vec<PeakTexel>,
    background: [f32; 3],
    y: f64,
    share: f64,
    dir: Vec3,
    core_sr: f64,
}

/// Luminance of an RGB triple in `f64`.
fn luminance64(e: [f64; 3]) -> f64 {
    0.2126 * e[0] + 0.7152 * e[1] + 0.0722 * e[2]
}

impl PeakTracker {
    /// A tracker without history.
    pub fn new() -> Self {
        Self::default()
    }

    /// This frame's peak lights (after [`PeakTracker::split`]).
    pub fn peaks(&self) -> &[Light] {
        &self.peaks
    }

    /// The map without its peaks (after [`PeakTracker::split`]; not built by
    /// [`PeakTracker::find`]).
    pub fn remainder(&self) -> &PolarMap {
        &self.remainder
    }

    /// The remainder as changes of the map given to [`PeakTracker::find`] or
    /// [`PeakTracker::split`]: `(texel, new value)`, in texel order.
    pub fn patches(&self) -> &[(usize, [f32; 3])] {
        &self.patches
    }

    /// [`PeakTracker::find`], then the remainder map ([`PeakTracker::remainder`]).
    pub fn split(&mut self, map: &PolarMap, max_lights: usize) {
        self.find(map, max_lights);
        self.remainder.clone_from(map);
        for &(k, v) in &self.patches {
            self.remainder.data[k] = v;
        }
    }

    /// Finds the peaks of `map` and gives them at most `max_lights` lights (indices tracked from
    /// the previous call); the remainder is left as [`PeakTracker::patches`] (no copy of the map).
    pub fn find(&mut self, map: &PolarMap, max_lights: usize) {
        self.patches.clear();
        self.peaks.clear();
        let previous = std::mem::take(&mut self.tracked);
        if max_lights == 0 {
            return;
        }
        let near = |dir: Vec3, used: &[bool]| {
            previous.iter().enumerate().filter(|(k, p)| !used[*k] && p.dir.dot(dir) >= TRACK_RAD.cos()).max_by(|a, b| a.1.dir.dot(dir).total_cmp(&b.1.dir.dot(dir))).map(|(k, _)| k)
        };
        let mut found = self.candidates(map);
        let none_used = vec![false; previous.len()];
        found.retain(|c| c.share >= MIN_PEAK_SHARE || near(c.dir, &none_used).is_some());
        found.sort_by(|a, b| b.y.total_cmp(&a.y));
        found.truncate(MAX_PEAKS);
        let mut used = vec![false; previous.len()];
        let mut budget = max_lights;
        for mut c in found {
            if budget == 0 {
                break;
            }
            let target = ((c.core_sr / PEAK_LIGHT_SR).ceil() as usize).clamp(1, MAX_PEAK_LIGHTS);
            let (id, k) = match near(c.dir, &used) {
                Some(k) => {
                    used[k] = true;
                    let p = previous[k];
                    (p.id, if target >= 2 * p.lights || 2 * target <= p.lights { target } else { p.lights })
                }
                None => {
                    let id = self.next;
                    self.next = (self.next + 1) % (PEAK_INDEX_BASE / MAX_PEAK_LIGHTS as u32);
                    (id, target)
                }
            };
            self.patches.extend(c.texels.iter().map(|t| (t.k, c.background)));
            self.lights.clear();
            extended::split(&mut c.texels, k.min(budget), c.dir.as_dvec3(), &mut self.lights);
            budget -= self.lights.len();
            let base = PEAK_INDEX_BASE + id * MAX_PEAK_LIGHTS as u32;
            self.peaks.extend(self.lights.iter().enumerate().map(|(s, &(dir, rgb, radius))| Light { index: base + s as u32, dir, rgb, radius }));
            self.tracked.push(Tracked { id, dir: c.dir, lights: self.lights.len() });
        }
        self.patches.sort_unstable_by_key(|p| p.0);
    }

    /// The compact regions above the threshold holding at least half of [`MIN_PEAK_SHARE`].
    fn candidates(&mut self, map: &PolarMap) -> Vec<Candidate> {
        let (w, h) = (map.width as usize, map.height as usize);
        // One pass: the luminance of every texel and the map's power Σ Y·ΔΩ.
        self.lum.clear();
        let mut total = 0.0f64;
        for j in 0..h {
            let start = self.lum.len();
            self.lum.extend(map.data[j * w..(j + 1) * w].iter().map(|p| if is_valid(p) { luminance(*p) } else { 0.0 }));
            total += map.row_solid_angle(j as u32) as f64 * self.lum[start..].iter().map(|&y| y as f64).sum::<f64>();
        }
        if self.lum.is_empty() {
            return Vec::new();
        }
        self.sample.clear();
        self.sample.extend(self.lum.iter().step_by(MEDIAN_STRIDE));
        let mid = self.sample.len() / 2;
        let median = *self.sample.select_nth_unstable_by(mid, f32::total_cmp).1;
        let level = if median > 0.0 { median } else { self.lum.iter().sum::<f32>() / self.lum.len() as f32 };
        if !(level > 0.0) || !(total > 0.0) {
            return Vec::new();
        }
        let t = PEAK_FACTOR * level;
        self.label.clear();
        self.label.resize(w * h, 0);
        let mut out = Vec::new();
        for start in 0..w * h {
            if self.label[start] != 0 || self.lum[start] <= t {
                continue;
            }
            let core = self.flood(start, w, h, t);
            let core_sr: f64 = core.iter().map(|&k| map.row_solid_angle((k / w) as u32) as f64).sum();
            if core_sr > MAX_PEAK_SR {
                continue;
            }
            let c = self.measure(map, core, core_sr, total);
            if c.share >= 0.5 * MIN_PEAK_SHARE && c.y > 0.0 {
                out.push(c);
            }
        }
        out
    }

    /// The 4-connected region of candidates containing `start` (labels it [`CORE`]).
    fn flood(&mut self, start: usize, w: usize, h: usize, t: f32) -> Vec<usize> {
        let mut texels = Vec::new();
        self.stack.clear();
        self.stack.push(start);
        self.label[start] = CORE;
        while let Some(k) = self.stack.pop() {
            texels.push(k);
            for n in neighbours(k, w, h).into_iter().flatten() {
                if self.label[n] == 0 && self.lum[n] > t {
                    self.label[n] = CORE;
                    self.stack.push(n);
                }
            }
        }
        texels
    }

    /// Adds the ring around `core` (labelled [`RING`]), measures the background on the texels
    /// around the ring and the excess of core and ring.
    fn measure(&mut self, map: &PolarMap, core: Vec<usize>, core_sr: f64, total: f64) -> Candidate {
        let (w, h) = (map.width as usize, map.height as usize);
        let mut support = core;
        let n_core = support.len();
        for i in 0..n_core {
            for n in neighbours(support[i], w, h).into_iter().flatten() {
                if self.label[n] == 0 {
                    self.label[n] = RING;
                    support.push(n);
                }
            }
        }
        self.outer.clear();
        for i in n_core..support.len() {
            for n in neighbours(support[i], w, h).into_iter().flatten() {
                if self.label[n] == 0 {
                    self.label[n] = OUTER;
                    self.outer.push(n);
                }
            }
        }
        let (mut b, mut nb) = ([0.0f64; 3], 0usize);
        for &k in &self.outer {
            self.label[k] = 0;
            let p = map.data[k];
            if is_valid(&p) {
                for c in 0..3 {
                    b[c] += p[c] as f64;
                }
                nb += 1;
            }
        }
        let background = b.map(|v| (v / nb.max(1) as f64) as f32);
        let (mut excess, mut centroid) = ([0.0f64; 3], DVec3::ZERO);
        let texels: Vec<PeakTexel> = support
            .iter()
            .map(|&k| {
                let (i, j) = ((k % w) as u32, (k / w) as u32);
                let sr = map.row_solid_angle(j) as f64;
                let p = if is_valid(&map.data[k]) { map.data[k] } else { [0.0; 3] };
                let rgb: [f64; 3] = std::array::from_fn(|c| (p[c] - background[c]) as f64 * sr);
                let y = luminance64(rgb).max(0.0);
                let dir = map.texel_dir(i, j).as_dvec3();
                for c in 0..3 {
                    excess[c] += rgb[c];
                }
                centroid += dir * y;
                PeakTexel { dir, rgb, y, sr, k }
            })
            .collect();
        let y = luminance64(excess);
        let dir = centroid.try_normalize().unwrap_or(DVec3::Y).as_vec3();
        Candidate { texels, background, y, share: y / total, dir, core_sr }
    }
}

/// The 4 neighbours of texel `k` (columns wrap, rows do not).
fn neighbours(k: usize, w: usize, h: usize) -> [Option<usize>; 4] {
    let (i, j) = (k % w, k / w);
    [
        Some(j * w + (i + w - 1) % w),
        Some(j * w + (i + 1) % w),
        (j > 0).then(|| k - w),
        (j + 1 < h).then(|| k + w),
    ]
}

#[cfg(test)]
mod tests;
