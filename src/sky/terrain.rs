//! Light from below the horizon: distant Lambertian terrain lit by the same sun and sky.
//!
//! A direction below the horizon that leaves the proxy sees the terrain beyond it (snow, a street,
//! fields). heliar models it as a flat, horizontal, Lambertian plane of albedo `ρ_t` (RGB) under an
//! open sky, far enough that the proxy neither shadows it nor is seen from it. Such a plane is an
//! unoccluded horizontal surface, so its sky irradiance is `Pa` by the very definition of `Pa`
//! (crate docs), and its sun irradiance `max(cos θ_sun, 0)·Pd`. Its radiance is therefore
//!
//! `L_t = ρ_t/π · (E_sky_per_Pa·Pa + max(cos θ_sun, 0)·Pd)`,  `E_sky_per_Pa = 1`,
//!
//! linear in `Pa` and `Pd`, so the estimator keeps its unknowns: the terrain adds
//! `ρ_t/π · E_below` to `c` and `ρ_t/π · max(l_y, 0) · E_below` to the sun-bounce `b`, with `E_below`
//! the visible below-horizon irradiance of [`super::quadrature::Irradiance::below_horizon`].
//! Assumptions: flat, open, Lambertian terrain; no light between it and the proxy; the
//! interreflection of terrain and sky is the sky model's (Hosek's ground albedo), not added here.
//!
//! # Albedo from the environment map
//! [`estimate_albedo`] inverts the same formula on the texels of an equirect HDR map that lie
//! below the horizon (by at least [`AlbedoSettings::min_depression_deg`], away from the haze at
//! the horizon) and that a mask marks as not covered by the proxy: per texel
//! `ρ = π·L / (Pa + max(cos θ_sun, 0)·Pd)` with the lighting at capture time, per channel. The
//! estimate is the solid-angle-weighted median of those ratios (robust to cars and people),
//! clamped to `[0, 1]`. Fewer usable texels than [`AlbedoSettings::min_texels`], or no light on
//! the terrain at capture, give the fallback albedo and say so.

use super::{SkyError, unit_dir};
use crate::geometry::equirect::{dir_from_texel_centre, texel_solid_angle};
use glam::Vec3;
use std::f32::consts::PI;

/// Sky irradiance on flat, open terrain per unit `Pa`: 1 by the definition of `Pa`.
pub const TERRAIN_SKY_IRRADIANCE_PER_PA: f32 = 1.0;
/// Terrain irradiance at capture below which a channel's albedo cannot be measured.
const MIN_CAPTURE_IRRADIANCE: f32 = 1e-6;

/// Flat distant terrain of RGB albedo `ρ_t` (module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Terrain {
    albedo_rgb: [f32; 3],
}

/// Radiance of the terrain per unit `Pa` and per unit `Pd` (RGB).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TerrainRadiance {
    /// `ρ_t/π · E_sky_per_Pa`.
    pub per_pa: [f32; 3],
    /// `ρ_t/π · max(cos θ_sun, 0)`.
    pub per_pd: [f32; 3],
}

impl TerrainRadiance {
    /// `per_pa·Pa + per_pd·Pd` per channel.
    pub fn radiance(&self, pa: [f32; 3], pd: [f32; 3]) -> [f32; 3] {
        std::array::from_fn(|c| self.per_pa[c] * pa[c] + self.per_pd[c] * pd[c])
    }

    /// The irradiance `E·L_t` it gives a surface whose visible below-horizon irradiance per unit
    /// radiance is `below_horizon`, as `(per Pa, per Pd)`: the terrain's share of `c` and `b`.
    pub fn irradiance(&self, below_horizon: f32) -> TerrainRadiance {
        TerrainRadiance { per_pa: self.per_pa.map(|v| v * below_horizon), per_pd: self.per_pd.map(|v| v * below_horizon) }
    }
}

impl Terrain {
    /// Terrain of albedo `albedo_rgb`, each channel finite and in `[0, 1]`.
    pub fn new(albedo_rgb: [f32; 3]) -> Result<Self, SkyError> {
        if !albedo_rgb.iter().all(|a| (0.0..=1.0).contains(a)) {
            return Err(SkyError::Albedo { what: "terrain albedo_rgb", value: albedo_rgb.map(f64::from) });
        }
        Ok(Self { albedo_rgb })
    }

    /// The albedo.
    pub fn albedo_rgb(&self) -> [f32; 3] {
        self.albedo_rgb
    }

    /// Radiance per unit `Pa` and `Pd` for the sun toward `sun_dir_world` (need not be unit). A sun
    /// below the horizon lights nothing; an invalid direction is an error.
    pub fn radiance(&self, sun_dir_world: Vec3) -> Result<TerrainRadiance, SkyError> {
        let sun = unit_dir(sun_dir_world).ok_or(SkyError::BadDirection { what: "terrain sun_dir_world", value: sun_dir_world.to_array() })?;
        let cos_sun = sun.y.max(0.0) as f32;
        Ok(TerrainRadiance {
            per_pa: self.albedo_rgb.map(|a| a / PI * TERRAIN_SKY_IRRADIANCE_PER_PA),
            per_pd: self.albedo_rgb.map(|a| a / PI * cos_sun),
        })
    }
}

/// An equirect map in the crate's layout ([`crate::geometry::equirect`]): row-major linear RGB texels.
#[derive(Clone, Copy, Debug)]
pub struct EquirectView<'a> {
    /// Width in texels.
    pub width: u32,
    /// Height in texels.
    pub height: u32,
    /// `width × height` texels.
    pub texels: &'a [[f32; 3]],
}

/// Lighting when the environment map was captured.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CaptureLighting {
    /// Sun irradiance on a surface facing the sun (RGB).
    pub pd: [f32; 3],
    /// Sky irradiance on an unoccluded horizontal surface (RGB).
    pub pa: [f32; 3],
    /// Direction toward the sun (world frame).
    pub sun_dir_world: Vec3,
}

/// Settings of [`estimate_albedo`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AlbedoSettings {
    /// Fewest usable texels for an estimate; below, the fallback is returned.
    pub min_texels: usize,
    /// Texels whose centre is less than this far below the horizon are left out (degrees).
    pub min_depression_deg: f32,
    /// Albedo returned when there is no estimate.
    pub fallback_rgb: [f32; 3],
}

impl Default for AlbedoSettings {
    fn default() -> Self {
        // 32 texels keep the median's standard error near 1.25·σ/√32 ≈ 0.2σ; 2° skips the
        // horizon's haze row of a 256-wide map (0.7° per texel); 0.2 is a typical ground albedo.
        Self { min_texels: 32, min_depression_deg: 2.0, fallback_rgb: [0.2; 3] }
    }
}

/// Why an albedo estimate is the fallback.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub enum AlbedoFallback {
    /// Fewer usable texels than [`AlbedoSettings::min_texels`].
    TooFewTexels,
    /// The terrain received no light at capture (channel index).
    NoCaptureLight(usize),
}

/// An albedo measured on an environment map.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AlbedoEstimate {
    /// Albedo per channel, in `[0, 1]`.
    pub albedo_rgb: [f32; 3],
    /// Texels the median used.
    pub texels_used: usize,
    /// Texels below the horizon, unmasked, but skipped because not finite or negative.
    pub texels_invalid: usize,
    /// `Some` when [`Self::albedo_rgb`] is the fallback.
    pub fallback: Option<AlbedoFallback>,
}

/// The terrain albedo seen in `env` (module docs). `open_below[i]` marks texel `i` as not covered
/// by the proxy (only texels below the horizon are read).
pub fn estimate_albedo(env: EquirectView, open_below: &[bool], capture: CaptureLighting, settings: &AlbedoSettings) -> Result<AlbedoEstimate, SkyError> {
    let n = env.width as usize * env.height as usize;
    if env.texels.len() != n {
        return Err(SkyError::Size { what: "estimate_albedo env texels", expected: n, got: env.texels.len() });
    }
    if open_below.len() != n {
        return Err(SkyError::Size { what: "estimate_albedo open_below mask", expected: n, got: open_below.len() });
    }
    if !settings.fallback_rgb.iter().all(|a| (0.0..=1.0).contains(a)) {
        return Err(SkyError::Albedo { what: "AlbedoSettings::fallback_rgb", value: settings.fallback_rgb.map(f64::from) });
    }
    let lit = Terrain::new([1.0; 3])?.radiance(capture.sun_dir_world)?;
    let e_capture: [f32; 3] = std::array::from_fn(|c| PI * (lit.per_pa[c] * capture.pa[c] + lit.per_pd[c] * capture.pd[c]));
    let fallback = |fallback, used, invalid| AlbedoEstimate { albedo_rgb: settings.fallback_rgb, texels_used: used, texels_invalid: invalid, fallback: Some(fallback) };
    if let Some(c) = (0..3).find(|&c| e_capture[c].is_nan() || e_capture[c] <= MIN_CAPTURE_IRRADIANCE) {
        return Ok(fallback(AlbedoFallback::NoCaptureLight(c), 0, 0));
    }
    let max_y = -settings.min_depression_deg.to_radians().sin();
    let mut samples: [Vec<(f32, f32)>; 3] = Default::default();
    let mut invalid = 0;
    for j in 0..env.height {
        let omega = texel_solid_angle(j, env.width, env.height);
        for i in 0..env.width {
            let k = (j * env.width + i) as usize;
            if !open_below[k] || dir_from_texel_centre(i, j, env.width, env.height).y > max_y {
                continue;
            }
            let l = env.texels[k];
            if !l.iter().all(|v| v.is_finite() && *v >= 0.0) {
                invalid += 1;
                continue;
            }
            for c in 0..3 {
                samples[c].push((PI * l[c] / e_capture[c], omega));
            }
        }
    }
    let used = samples[0].len();
    if used < settings.min_texels.max(1) {
        return Ok(fallback(AlbedoFallback::TooFewTexels, used, invalid));
    }
    let albedo_rgb = samples.map(|mut s| weighted_median(&mut s).clamp(0.0, 1.0));
    Ok(AlbedoEstimate { albedo_rgb, texels_used: used, texels_invalid: invalid, fallback: None })
}

/// The value at which the cumulative weight of `(value, weight)` pairs reaches half (non-empty).
fn weighted_median(samples: &mut [(f32, f32)]) -> f32 {
    samples.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
    let half = samples.iter().map(|s| s.1 as f64).sum::<f64>() / 2.0;
    let mut acc = 0.0f64;
    for s in samples.iter() {
        acc += s.1 as f64;
        if acc >= half {
            return s.0;
        }
    }
    samples.last().map_or(0.0, |s| s.0)
}

#[cfg(test)]
mod tests;
