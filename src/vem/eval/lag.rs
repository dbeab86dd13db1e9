//! The temporal filter's error on a changing sequence (issue 14, part 4): each output frame's
//! lights against the brute-force irradiance of that frame's own map, so a filter that describes
//! an earlier frame (the causal FIR's 4-frame delay) pays for its lag.
//!
//! - **Error** per frame `t` and normal `n`: `|E_t(n) − E_ref,t(n)| / E_ref,t(n)` on luminance,
//!   with `E_t` the irradiance of the lights on frame `t`'s output line and `E_ref,t` the
//!   integral of frame `t`'s map ([`crate::vem::polar::IrradianceReference`]); mean, 95th
//!   percentile and maximum over frames and normals (the measure of `heliar bench vem --what
//!   sun`).
//! - The **unfiltered** lights of each map (no temporal filter) give the floor: the sampling
//!   error alone.

use crate::vem::eval::metrics::{random_normals, reference_irradiance};
use crate::vem::fir::Temporal;
use crate::vem::polar::{IrradianceReference, PolarMap};
use crate::vem::{Decomposer, Light, VemConfig, VemError, irradiance, lights_of_map};
use glam::Vec3;

/// Error of a sequence's output lights against each frame's own map.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct LagError {
    /// Mean of `|ΔE| / E_ref` over frames and normals.
    pub mean: f64,
    /// Its 95th percentile.
    pub p95: f64,
    /// Its largest value.
    pub max: f64,
    /// The filter's delay at DC, frames (0 for zero phase and for unfiltered lights).
    pub delay_frames: f64,
}

/// Upper-hemisphere normals for the measure: `n` uniform sphere normals folded up (seeded).
pub fn upper_normals(n: usize, seed: u64) -> Vec<Vec3> {
    random_normals(n, seed).into_iter().map(|v| Vec3::new(v.x, v.y.abs().max(1e-3), v.z).normalize()).collect()
}

/// Reference irradiance of every map at `normals`.
pub fn references(maps: &[PolarMap], normals: &[Vec3]) -> Vec<Vec<f64>> {
    maps.iter().map(|m| reference_irradiance(&IrradianceReference::new(m, 2), normals)).collect()
}

fn lum(e: [f64; 3]) -> f64 {
    0.2126 * e[0] + 0.7152 * e[1] + 0.0722 * e[2]
}

/// Collects `|ΔE| / E_ref` of `lights` against frame `t`'s references.
fn push_errors(lights: &[Light], normals: &[Vec3], reference: &[f64], rel: &mut Vec<f64>) {
    for (n, r) in normals.iter().zip(reference) {
        rel.push((lum(irradiance(lights, *n)) - r).abs() / r.max(1e-300));
    }
}

fn summarise(rel: &[f64], delay_frames: f64) -> LagError {
    LagError {
        mean: rel.iter().sum::<f64>() / rel.len().max(1) as f64,
        p95: crate::report::percentile(rel, 0.95),
        max: rel.iter().cloned().fold(0.0, f64::max),
        delay_frames,
    }
}

/// Runs the decomposer (`cfg`, whose `temporal` says how it filters) over `maps` with
/// [`Decomposer::push`] and [`Decomposer::flush`] and measures every output line's lights
/// against its own frame's `refs` (from [`references`] at `normals`).
pub fn lag_error(maps: &[PolarMap], cfg: VemConfig, normals: &[Vec3], refs: &[Vec<f64>]) -> Result<LagError, VemError> {
    let temporal = cfg.temporal;
    let mut dec = Decomposer::new(cfg)?;
    let delay = if temporal == Temporal::ZeroPhase { 0.0 } else { dec.filter_design().group_delay_frames() };
    let mut rel = Vec::with_capacity(maps.len() * normals.len());
    for m in maps {
        if let Some(s) = dec.push(m) {
            push_errors(dec.lights(), normals, &refs[s.frame as usize], &mut rel);
        }
    }
    while let Some(s) = dec.flush() {
        push_errors(dec.lights(), normals, &refs[s.frame as usize], &mut rel);
    }
    Ok(summarise(&rel, delay))
}

/// The same measure for each map's own unfiltered lights (`cfg`'s sampler, pattern and count).
pub fn unfiltered_error(maps: &[PolarMap], cfg: &VemConfig, normals: &[Vec3], refs: &[Vec<f64>]) -> LagError {
    let mut rel = Vec::with_capacity(maps.len() * normals.len());
    for (m, r) in maps.iter().zip(refs) {
        push_errors(&lights_of_map(m, cfg.sampler, cfg.pattern, cfg.lights), normals, r, &mut rel);
    }
    summarise(&rel, 0.0)
}
