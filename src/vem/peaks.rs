//! Concentrated peaks (the sun, a bare lamp) as lights of their own (issue 14; opt-in,
//! `VemConfig::peaks`, `--peaks`).
//!
//! Equal-power samples (Havran §3.3: every light carries `P/N`) spend most of `N` on a sun that
//! holds most of the power, and when a cloud crosses it those lights all move at once. Here a
//! peak gets one light at its measured power and the rest of the map is sampled as before.
//!
//! # How it works
//! Per frame ([`PeakTracker::split`]):
//! 1. **Threshold.** Texels whose luminance exceeds [`PEAK_FACTOR`] × the map's median luminance
//!    (the mean if the median is 0) are candidates.
//! 2. **Regions.** Candidates are grouped into 4-connected regions (wrapping in `φ`). A region
//!    is a peak if it is compact (at most [`MAX_PEAK_TEXELS`] texels) and its excess power
//!    `Σ (L − B)·ΔΩ` (luminance) is at least [`MIN_PEAK_SHARE`] of the map's, where `B` is the
//!    mean radiance of the texels bordering the region (the sky around it). At most
//!    [`MAX_PEAKS`] peaks, the strongest.
//! 3. **Light.** One light at the region's excess-energy centroid with `rgb = Σ (L − B)·ΔΩ` per
//!    channel (its irradiance on a surface facing it, like every [`Light`]); in the remainder
//!    map the region's texels are set to `B`, so peaks + remainder keep the map's power (up to
//!    a channel whose excess would be negative, clamped at 0).
//! 4. **Tracking.** A peak within [`TRACK_RAD`] of one of the previous frame's keeps its index;
//!    a new one gets the next index from [`PEAK_INDEX_BASE`] on (apart from the samples'
//!    indices), so a peak's light keeps its identity while it exists.
//!
//! In the [`crate::vem::Decomposer`] the peak lights are appended to the filtered samples of
//! the remainder without the temporal filter: a peak's light follows its frame at once, while
//! the remainder comes with the FIR's delay (Havran §3.3: 4 frames at 21 Hz).

use crate::vem::Light;
use crate::vem::polar::{PolarMap, luminance};
use crate::vem::sampling::is_valid;
use glam::DVec3;

/// Candidates exceed this multiple of the median luminance.
pub const PEAK_FACTOR: f32 = 50.0;
/// Smallest share of the map's power (luminance) a peak holds.
pub const MIN_PEAK_SHARE: f64 = 0.01;
/// Largest region, texels, still called compact.
pub const MAX_PEAK_TEXELS: usize = 256;
/// Most peaks per frame.
pub const MAX_PEAKS: usize = 4;
/// A peak within this angle of a previous one is the same peak (5°).
pub const TRACK_RAD: f32 = 5.0 * std::f32::consts::PI / 180.0;
/// Indices of peak lights start here.
pub const PEAK_INDEX_BASE: u32 = 1 << 30;

/// Finds peaks frame after frame and keeps their indices (see the module docs).
#[derive(Clone, Debug)]
pub struct PeakTracker {
    next: u32,
    peaks: Vec<Light>,
    remainder: PolarMap,
    lum: Vec<f32>,
    label: Vec<u32>,
    stack: Vec<usize>,
}

impl Default for PeakTracker {
    fn default() -> Self {
        Self { next: 0, peaks: Vec::new(), remainder: PolarMap::new(0, 0), lum: Vec::new(), label: Vec::new(), stack: Vec::new() }
    }
}

/// A candidate region: its texels, excess power and centroid.
struct Candidate {
    texels: Vec<usize>,
    background: [f32; 3],
    excess: [f64; 3],
    centroid: DVec3,
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

    /// The map without its peaks (after [`PeakTracker::split`]).
    pub fn remainder(&self) -> &PolarMap {
        &self.remainder
    }

    /// Finds at most `max_peaks` peaks of `map`, their lights (indices tracked from the previous
    /// call) and the remainder map.
    pub fn split(&mut self, map: &PolarMap, max_peaks: usize) {
        self.remainder.clone_from(map);
        let mut found = self.candidates(map);
        found.sort_by(|a, b| luminance(b.excess.map(|v| v as f32)).total_cmp(&luminance(a.excess.map(|v| v as f32))));
        found.truncate(max_peaks.min(MAX_PEAKS));
        let previous = std::mem::take(&mut self.peaks);
        let mut used = vec![false; previous.len()];
        for c in &found {
            for &t in &c.texels {
                self.remainder.data[t] = c.background;
            }
            let dir = c.centroid.normalize().as_vec3();
            let near = previous.iter().enumerate().filter(|(k, p)| !used[*k] && p.dir.dot(dir) >= TRACK_RAD.cos()).max_by(|a, b| a.1.dir.dot(dir).total_cmp(&b.1.dir.dot(dir)));
            let index = match near {
                Some((k, p)) => {
                    used[k] = true;
                    p.index
                }
                None => {
                    self.next = self.next.wrapping_add(1);
                    PEAK_INDEX_BASE + (self.next - 1) % PEAK_INDEX_BASE
                }
            };
            self.peaks.push(Light { index, dir, rgb: c.excess.map(|v| v.max(0.0) as f32) });
        }
    }

    /// The compact regions above the threshold holding enough power.
    fn candidates(&mut self, map: &PolarMap) -> Vec<Candidate> {
        let (w, h) = (map.width as usize, map.height as usize);
        self.lum.clear();
        self.lum.extend(map.data.iter().map(|p| if is_valid(p) { luminance(*p) } else { 0.0 }));
        let mut sorted = self.lum.clone();
        if sorted.is_empty() {
            return Vec::new();
        }
        let mid = sorted.len() / 2;
        let median = *sorted.select_nth_unstable_by(mid, f32::total_cmp).1;
        let level = if median > 0.0 { median } else { self.lum.iter().sum::<f32>() / self.lum.len() as f32 };
        let total: f64 = (0..h).map(|j| map.row_solid_angle(j as u32) as f64 * self.lum[j * w..(j + 1) * w].iter().map(|&y| y as f64).sum::<f64>()).sum();
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
            let texels = self.flood(start, w, h, t);
            if texels.len() > MAX_PEAK_TEXELS {
                continue;
            }
            let c = self.measure(map, texels, t);
            if luminance(c.excess.map(|v| v as f32)) as f64 >= MIN_PEAK_SHARE * total && c.centroid.length() > 0.0 {
                out.push(c);
            }
        }
        out
    }

    /// The 4-connected region of candidates containing `start` (labels it).
    fn flood(&mut self, start: usize, w: usize, h: usize, t: f32) -> Vec<usize> {
        let mut texels = Vec::new();
        self.stack.clear();
        self.stack.push(start);
        self.label[start] = 1;
        while let Some(k) = self.stack.pop() {
            texels.push(k);
            for n in neighbours(k, w, h).into_iter().flatten() {
                if self.label[n] == 0 && self.lum[n] > t {
                    self.label[n] = 1;
                    self.stack.push(n);
                }
            }
        }
        texels
    }

    /// Background, excess power and centroid of a region.
    fn measure(&self, map: &PolarMap, texels: Vec<usize>, t: f32) -> Candidate {
        let (w, h) = (map.width as usize, map.height as usize);
        let (mut b, mut nb) = ([0.0f64; 3], 0usize);
        for &k in &texels {
            for n in neighbours(k, w, h).into_iter().flatten() {
                let p = map.data[n];
                if self.lum[n] <= t && is_valid(&p) {
                    for c in 0..3 {
                        b[c] += p[c] as f64;
                    }
                    nb += 1;
                }
            }
        }
        let background = b.map(|v| (v / nb.max(1) as f64) as f32);
        let (mut excess, mut centroid) = ([0.0f64; 3], DVec3::ZERO);
        for &k in &texels {
            let (i, j) = ((k % w) as u32, (k / w) as u32);
            let dw = map.row_solid_angle(j) as f64;
            let p = map.data[k];
            let e: [f64; 3] = std::array::from_fn(|c| (p[c] - background[c]) as f64 * dw);
            for c in 0..3 {
                excess[c] += e[c];
            }
            let y = (0.2126 * e[0] + 0.7152 * e[1] + 0.0722 * e[2]).max(0.0);
            centroid += map.texel_dir(i, j).as_dvec3() * y;
        }
        Candidate { texels, background, excess, centroid }
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
mod tests {
    use super::*;

    fn sky_with_sun(i: u32, j: u32, e: f32) -> PolarMap {
        let mut m = PolarMap::from_fn(360, 90, |d| [0.5 + 0.3 * d.y, 0.6 + 0.3 * d.y, 0.9]);
        let sr = m.row_solid_angle(j);
        let k = (j * 360 + i) as usize;
        m.data[k] = m.data[k].map(|v| v + e / sr);
        m
    }

    #[test]
    fn a_sun_becomes_one_light_with_its_power_and_the_rest_is_kept() {
        let map = sky_with_sun(100, 30, 10.0);
        let mut t = PeakTracker::new();
        t.split(&map, 4);
        assert_eq!(t.peaks().len(), 1);
        let p = t.peaks()[0];
        assert!(p.dir.dot(map.texel_dir(100, 30)) > 1.0 - 1e-6);
        assert!((p.rgb[1] - 10.0).abs() < 1e-3 * 10.0, "{:?}", p.rgb);
        let (a, b) = (map.total_power(), t.remainder().total_power());
        for c in 0..3 {
            assert!((a[c] - b[c] - p.rgb[c] as f64).abs() < 1e-4 * a[c]);
        }
    }

    #[test]
    fn a_moving_sun_keeps_its_index_and_a_smooth_sky_has_no_peak() {
        let mut t = PeakTracker::new();
        t.split(&sky_with_sun(100, 30, 10.0), 4);
        let first = t.peaks()[0].index;
        assert!(first >= PEAK_INDEX_BASE);
        t.split(&sky_with_sun(101, 30, 9.0), 4);
        assert_eq!(t.peaks()[0].index, first);
        t.split(&sky_with_sun(101, 30, 0.0), 4);
        assert!(t.peaks().is_empty());
        t.split(&sky_with_sun(200, 60, 10.0), 4);
        assert_ne!(t.peaks()[0].index, first);
        t.split(&sky_with_sun(200, 60, 10.0), 0);
        assert!(t.peaks().is_empty());
    }
}
