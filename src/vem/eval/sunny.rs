//! A sun-dominated synthetic sequence (issue 14): a Hošek–Wilkie clear sky (turbidity 3,
//! [`crate::sky::hosek`]) with a sun disc holding [`SUN_SHARE`] of the power when clear, and one
//! cloud crossing the sun: the sun's power falls to 3% and comes back over about 20 frames.
//!
//! The sun is a compact source splatted with its exact energy (like [`super::synth`]'s suns); the
//! sky, the cloud and the sun do not move otherwise, so frame-to-frame changes of irradiance come
//! only from the cloud.

use super::synth::{Cloud, Environment};
use crate::sky::hosek::HosekSky;
use glam::{Quat, Vec3};

/// Frames of the sequence.
pub const FRAMES: usize = 40;
/// The frame at which the cloud is centred on the sun.
pub const CLOUD_CENTRE_FRAME: f32 = 20.0;
/// The cloud's angular speed, radians per frame (its diameter, 0.2 rad, in 20 frames).
pub const CLOUD_RAD_PER_FRAME: f32 = 0.01;
/// Share of the power (luminance) in the sun when nothing covers it.
pub const SUN_SHARE: f64 = 0.6;
/// Turbidity of the sky.
pub const TURBIDITY: f64 = 3.0;

/// The sun: elevation 40°, azimuth 150° (north −Z, east +X).
pub fn sun_dir() -> Vec3 {
    let (el, az) = (40f32.to_radians(), 150f32.to_radians());
    Vec3::new(el.cos() * az.sin(), el.sin(), -el.cos() * az.cos())
}

/// A clear Hošek–Wilkie sky with a sun and clouds.
#[derive(Clone, Debug)]
pub struct HosekSunSky {
    sky: HosekSky,
    /// Unit direction to the sun.
    pub sun_dir: Vec3,
    /// Sun irradiance at normal incidence when unoccluded.
    pub sun_irradiance: [f32; 3],
    /// The clouds.
    pub clouds: Vec<Cloud>,
    /// Radiance of a cloud (1.5 × the clear sky's mean radiance, grey).
    pub cloud_rgb: [f32; 3],
}

impl Environment for HosekSunSky {
    fn radiance(&self, d: Vec3) -> [f32; 3] {
        Cloud::over(&self.clouds, d, self.sky.radiance_rgb(d))
    }

    fn suns(&self) -> Vec<(Vec3, [f32; 3])> {
        let t = Cloud::transmission(&self.clouds, self.sun_dir);
        if t <= 0.0 { vec![] } else { vec![(self.sun_dir, self.sun_irradiance.map(|e| e * t))] }
    }
}

/// The clear sky's power `Σ L·ΔΩ` per channel (midpoint rule, 360 × 90 cells).
fn sky_power(sky: &HosekSky) -> [f64; 3] {
    let m = crate::vem::polar::PolarMap::from_fn(360, 90, |d| sky.radiance_rgb(d));
    m.total_power()
}

/// The sequence's sky (cloud-free, sun scaled so that it holds [`SUN_SHARE`] of the luminance
/// power, in the sky's colour at the sun).
pub fn clear_sky() -> HosekSunSky {
    let sun = sun_dir();
    let sky = HosekSky::new(sun, TURBIDITY, [0.2; 3]).expect("turbidity 3 and albedo 0.2 are in the model's range");
    let p = sky_power(&sky);
    let y = 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2];
    let e = SUN_SHARE / (1.0 - SUN_SHARE) * y;
    let colour = [1.0f64, 0.95, 0.85];
    let cy = 0.2126 * colour[0] + 0.7152 * colour[1] + 0.0722 * colour[2];
    let grey = (1.5 * y / std::f64::consts::TAU) as f32;
    HosekSunSky { sky, sun_dir: sun, sun_irradiance: colour.map(|c| (c / cy * e) as f32), clouds: vec![], cloud_rgb: [grey; 3] }
}

/// Frame `k` of the sequence: [`clear_sky`] with a cloud (radius 0.1 rad, opacity 0.97) moving
/// along a great circle through the sun, centred on it at [`CLOUD_CENTRE_FRAME`].
pub fn frame(base: &HosekSunSky, k: usize) -> HosekSunSky {
    let axis = base.sun_dir.cross(Vec3::Y).normalize();
    let angle = (k as f32 - CLOUD_CENTRE_FRAME) * CLOUD_RAD_PER_FRAME;
    let centre = (Quat::from_axis_angle(axis, angle) * base.sun_dir).normalize();
    let cloud = Cloud { centre, radius: 0.1, opacity: 0.97, rgb: base.cloud_rgb };
    HosekSunSky { clouds: vec![cloud], ..base.clone() }
}

/// The sequence's polar maps (`width × height`, 2 × 2 samples per texel).
pub fn polar_maps(width: u32, height: u32, frames: usize) -> Vec<crate::vem::polar::PolarMap> {
    let base = clear_sky();
    (0..frames).map(|k| super::synth::render_polar(&frame(&base, k), width, height, 2)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::vem::polar::luminance;
    use crate::vem::peaks::PEAK_INDEX_BASE;
    use crate::vem::sampling::SamplerKind;
    use crate::vem::{Decomposer, VemConfig};

    /// Zero phase: `process` gives each frame out at once, its window cut to the frame itself, so
    /// the lights are the frame's own (the causal filter would delay the sun's power by 4 frames).
    fn small(peaks: bool, sampler: SamplerKind) -> Decomposer {
        let temporal = crate::vem::fir::Temporal::ZeroPhase;
        Decomposer::new(VemConfig { polar_width: 180, polar_height: 45, lights: 64, peaks: Some(peaks), sampler, temporal, ..VemConfig::default() }).unwrap()
    }

    #[test]
    fn the_decomposer_with_median_cut_gives_n_lights_holding_the_power() {
        let maps = polar_maps(180, 45, 2);
        let mut dec = small(false, SamplerKind::MedianCut);
        for m in &maps {
            let s = dec.process(m);
            assert_eq!(dec.lights().len(), 64);
            let y: f64 = dec.lights().iter().map(|l| luminance(l.rgb) as f64).sum();
            assert!((y - s.power).abs() < 1e-4 * s.power && (s.filtered_power - s.power).abs() < 1e-9 * s.power, "{y} {s:?}");
        }
    }

    #[test]
    fn the_sun_keeps_one_tracked_light_through_the_cloud_and_only_with_peaks() {
        let base = clear_sky();
        let maps = polar_maps(180, 45, FRAMES);
        let mut dec = small(true, SamplerKind::Havran);
        let mut index = None;
        for (k, m) in maps.iter().enumerate() {
            let s = dec.process(m);
            assert_eq!(dec.lights().len(), 64, "frame {k}");
            let peaks: Vec<_> = dec.lights().iter().filter(|l| l.index >= PEAK_INDEX_BASE).collect();
            let sun = frame(&base, k).suns().first().map_or(0.0, |s| luminance(s.1));
            if sun as f64 > 0.2 * s.power {
                assert_eq!(peaks.len(), 1, "frame {k}");
                assert!(peaks[0].dir.dot(base.sun_dir) > 1f32.to_radians().cos(), "frame {k}");
                assert!((luminance(peaks[0].rgb) - sun).abs() < 0.05 * sun, "frame {k}: {:?} vs {sun}", peaks[0].rgb);
                assert_eq!(*index.get_or_insert(peaks[0].index), peaks[0].index, "frame {k}");
            }
        }
        assert!(index.is_some());
        let mut plain = small(false, SamplerKind::Havran);
        plain.process(&maps[0]);
        assert!(plain.lights().iter().all(|l| l.index < PEAK_INDEX_BASE));
    }

    #[test]
    fn the_sun_holds_most_power_and_the_cloud_takes_it_away_and_back() {
        let base = clear_sky();
        let maps = polar_maps(180, 45, FRAMES);
        let share = |k: usize| {
            let p = maps[k].total_power();
            let y = 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2];
            frame(&base, k).suns().first().map_or(0.0, |s| luminance(s.1) as f64) / y
        };
        let shares: Vec<f64> = (0..FRAMES).map(share).collect();
        assert!(shares[0] > 0.5 && shares[FRAMES - 1] > 0.5, "{shares:?}");
        assert!(shares[20] < 0.06, "{shares:?}");
        let covered = shares.iter().filter(|&&s| s < 0.5).count();
        assert!((14..=26).contains(&covered), "{covered}: {shares:?}");
    }
}
