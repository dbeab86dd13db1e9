//! Lights of one map without the pipeline (no temporal filter, no lists): what one frame gives,
//! for the benches, tests and sweeps, and the irradiance of a set of lights.

use super::peaks;
use super::polar::PolarMap;
use super::sampling::pattern::Pattern;
use super::sampling::{self, PolarDistribution, SamplerKind};
use super::Light;
use glam::Vec3;

/// Unfiltered lights of one map: `n` samples of `kind`, each with power `P/n` (what one frame
/// gives before the temporal filter). Empty for a black map.
pub fn lights_of_map(map: &PolarMap, kind: SamplerKind, pattern: Pattern, n: usize) -> Vec<Light> {
    // The cuts build their own summed-area tables: no CDFs needed.
    match kind {
        SamplerKind::MedianCut => return sampling::median_cut::median_cut_lights(map, n),
        SamplerKind::CoherentCut => return sampling::coherent_cut::coherent_cut_lights(map, n),
        _ => {}
    }
    let dist = PolarDistribution::new(map);
    lights_of_distribution(&dist, map, kind, pattern, n)
}

/// [`lights_of_map`] with the distribution already built.
pub fn lights_of_distribution(dist: &PolarDistribution, map: &PolarMap, kind: SamplerKind, pattern: Pattern, n: usize) -> Vec<Light> {
    if dist.is_empty() || n == 0 {
        return Vec::new();
    }
    if kind == SamplerKind::MedianCut {
        return sampling::median_cut::median_cut_lights(map, n);
    }
    if kind == SamplerKind::CoherentCut {
        return sampling::coherent_cut::coherent_cut_lights(map, n);
    }
    let p = (dist.integral() / n as f64) as f32;
    (0..n)
        .filter_map(|k| {
            let r = dist.sample(kind, sampling::pattern::sample(pattern, k))?;
            Some(Light { index: k as u32, dir: r.dir, rgb: dist.light_rgb(map, &r).map(|c| c * p), radius: 0.0 })
        })
        .collect()
}

/// Unfiltered lights of one map with its peaks as lights of their own ([`peaks`]): at most
/// `n − 1` peak lights from `tracker` (indices tracked from its previous map), then
/// `n − peak lights` lights of `kind` on the remainder.
pub fn lights_with_peaks(tracker: &mut peaks::PeakTracker, map: &PolarMap, kind: SamplerKind, pattern: Pattern, n: usize) -> Vec<Light> {
    if n == 0 {
        return Vec::new();
    }
    tracker.split(map, n - 1);
    let mut l = lights_of_map(tracker.remainder(), kind, pattern, n - tracker.peaks().len());
    l.extend_from_slice(tracker.peaks());
    l
}

/// Irradiance (RGB) of a set of lights on a surface with unit normal `n`: `Σ rgb·max(n·l, 0)`.
pub fn irradiance(lights: &[Light], n: Vec3) -> [f64; 3] {
    let mut e = [0.0f64; 3];
    for l in lights {
        let c = n.dot(l.dir);
        if c > 0.0 {
            for k in 0..3 {
                e[k] += (l.rgb[k] * c) as f64;
            }
        }
    }
    e
}
