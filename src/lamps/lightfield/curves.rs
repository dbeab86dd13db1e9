//! Approximation-error curves of the light-field reconstructions, and the CPU side of the
//! `heliar bench lamps` sweep.
//!
//! # What is measured
//! - [`geometric_term_error`]: Granier's bound for the shift-invariant approximation (§3.1),
//!   `E_r(θ₀) = (max_F cos⁴θ − min_F cos⁴θ) / cos⁴θ₀` over a support `F` of relative width
//!   `s = 2h/d` seen at angle `θ₀` (planes one unit apart; the paper: below 8 % at `s = 0.04`,
//!   which it reaches at `θ₀ = 45°`).
//! - [`shift_invariant_curve`]: the same approximation measured on the synthetic torch — the
//!   irradiance of Eq. 11 against Eq. 5 on the measurement plane, acquired at several `d`.
//! - [`spot_curve`]: the textured spot lights (Eq. 14) against the exact reconstruction, and the
//!   exact reconstruction against the true emitter, on receiver planes at several depths.
//! - [`sweep`]: error against the filter grid, texture resolution and storage format, with the
//!   CPU times of the acquisition and of both reconstructions (`heliar bench lamps --knob
//!   field` adds the GPU frame time of each grid).
//!
//! Errors compare two irradiance maps on a receiver plane facing the lamp, over the points where
//! the reference exceeds [`LIT_FRACTION`] of its peak: relative RMS `√(Σ(a − b)² / Σ b²)` (per
//! channel, pooled) and the largest `|a − b| / b`.

use super::reconstruct::Method;
use super::synthetic::{acquire, emitter_irradiance, Acquisition, Emitter, TorchEmitter};
use super::{FilterGrid, LightField, LightFieldError};
use crate::lamps::storage::{self, StorageFormat};
use crate::report::Table;
use glam::DVec3;
use rayon::prelude::*;
use std::time::Instant;

/// Receiver points whose reference irradiance is below this fraction of the plane's peak are
/// left out of the error (their relative error says nothing about the lit pattern).
pub const LIT_FRACTION: f64 = 0.05;
/// Receiver points per axis on a plane.
pub const RECEIVERS_PER_AXIS: usize = 24;
/// Half-angle of the receiver planes' extent (the torch's beam stays within 20°).
pub const RECEIVER_HALF_ANGLE_DEG: f64 = 22.0;

/// Granier §3.1: `E_r(θ₀)` for relative filter width `s` (module docs).
pub fn geometric_term_error(theta0_deg: f64, s: f64) -> f64 {
    let x0 = theta0_deg.to_radians().tan();
    let cos4 = |x: f64| 1.0 / (1.0 + x * x).powi(2);
    let (lo, hi) = (x0 - 0.5 * s, x0 + 0.5 * s);
    // cos⁴ falls with |x|: its maximum is at the point of F nearest the axis
    let nearest = if lo <= 0.0 && hi >= 0.0 { 0.0 } else { lo.abs().min(hi.abs()) };
    let farthest = lo.abs().max(hi.abs());
    (cos4(nearest) - cos4(farthest)) / cos4(x0)
}

/// Two irradiance maps compared (module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct MapError {
    /// Relative RMS over the lit points.
    pub rel_rms: f64,
    /// Largest relative error over the lit points.
    pub max_rel: f64,
    /// Number of lit points.
    pub lit: usize,
}

/// Compares `a` with the reference `b` (module docs).
pub fn compare(a: &[[f64; 3]], b: &[[f64; 3]]) -> MapError {
    let peak = b.iter().flat_map(|p| p.iter()).fold(0.0f64, |m, v| m.max(*v));
    let (mut num, mut den, mut max_rel, mut lit) = (0.0, 0.0, 0.0f64, 0);
    for (pa, pb) in a.iter().zip(b) {
        if pb.iter().fold(0.0f64, |m, v| m.max(*v)) < LIT_FRACTION * peak {
            continue;
        }
        lit += 1;
        for c in 0..3 {
            num += (pa[c] - pb[c]).powi(2);
            den += pb[c] * pb[c];
            if pb[c] > 0.0 {
                max_rel = max_rel.max((pa[c] - pb[c]).abs() / pb[c]);
            }
        }
    }
    MapError { rel_rms: if den > 0.0 { (num / den).sqrt() } else { 0.0 }, max_rel, lit }
}

/// Points on a plane at `depth_m` below the lamp, facing it, across the beam.
pub fn receiver_plane(depth_m: f64, half_width_m: f64, per_axis: usize) -> Vec<(DVec3, DVec3)> {
    let w = 2.0 * half_width_m / per_axis as f64;
    (0..per_axis * per_axis)
        .map(|k| (DVec3::new(-half_width_m + w * ((k % per_axis) as f64 + 0.5), -half_width_m + w * ((k / per_axis) as f64 + 0.5), -depth_m), DVec3::Z))
        .collect()
}

/// The receiver plane used by the curves at `depth_m` for an emitter of half-width `extent_m`.
pub fn beam_plane(depth_m: f64, extent_m: f64) -> Vec<(DVec3, DVec3)> {
    receiver_plane(depth_m, extent_m + depth_m * RECEIVER_HALF_ANGLE_DEG.to_radians().tan(), RECEIVERS_PER_AXIS)
}

/// A light field's irradiance at the points (parallel).
pub fn irradiance_map(lf: &LightField, method: Method, points: &[(DVec3, DVec3)]) -> Vec<[f64; 3]> {
    points.par_iter().map(|&(x, n)| lf.irradiance(method, x, n)).collect()
}

/// The emitter's true irradiance at the points (parallel).
pub fn truth_map(em: &dyn Emitter, points: &[(DVec3, DVec3)], emitter_points: usize) -> Vec<[f64; 3]> {
    points.par_iter().map(|&(x, n)| emitter_irradiance(em, x, n, emitter_points)).collect()
}

/// Filter spacing that puts a source of radius `a` where the dual filters of an `M`-wide grid
/// sum to one (`|u| ≤ ((M−1)/2 − 1) h`); grids narrower than five positions get `h = a` and
/// cannot measure the rim completely.
pub fn spacing_for(radius_m: f64, filters: usize) -> f64 {
    radius_m / ((filters as f64 - 1.0) / 2.0 - 1.0).max(1.0)
}

/// The measurement set-up of the curves for `filters²` positions ([`spacing_for`]) at distance
/// `d`, on a plane as wide as the receiver planes at that depth (the beam with margin).
pub fn torch_acquisition(torch: &TorchEmitter, filters: usize, d: f64, resolution: u32, emitter_points: usize) -> Acquisition {
    let h = spacing_for(torch.radius_m, filters);
    let size = 2.0 * (torch.radius_m + d * RECEIVER_HALF_ANGLE_DEG.to_radians().tan());
    Acquisition { grid: FilterGrid { counts: [filters; 2], spacing_m: h }, distance_m: d, size_m: [size; 2], resolution: [resolution; 2], emitter_points }
}

/// Curve (a): for each relative filter width `s`, the bound `E_r` at 0°, 15° and 45° and the
/// shift-invariant reconstruction's error against the exact one on the measurement plane.
pub fn shift_invariant_curve(torch: &TorchEmitter, widths: &[f64], resolution: u32, emitter_points: usize) -> Result<Table, LightFieldError> {
    let mut t = Table::new(&["s", "d_m", "Er_0deg", "Er_15deg", "Er_45deg", "rel_rms", "max_rel"]);
    for &s in widths {
        let acq = torch_acquisition(torch, 5, 2.0 * spacing_for(torch.radius_m, 5) / s, resolution, emitter_points);
        let lf = acquire(torch, &acq)?;
        let pts = beam_plane(acq.distance_m, torch.radius_m);
        let exact = irradiance_map(&lf, Method::Exact(Default::default()), &pts);
        let si = irradiance_map(&lf, Method::ShiftInvariant(Default::default()), &pts);
        let e = compare(&si, &exact);
        let er = |deg: f64| format!("{:.4}", geometric_term_error(deg, s));
        t.push(vec![format!("{s}"), format!("{:.3}", acq.distance_m), er(0.0), er(15.0), er(45.0), format!("{:.3e}", e.rel_rms), format!("{:.3e}", e.max_rel)]);
    }
    Ok(t)
}

/// Curve (b): on receiver planes at each depth, the spot lights (centre lookup and support
/// average) against the exact reconstruction, and the exact reconstruction against the truth.
pub fn spot_curve(torch: &TorchEmitter, lf: &LightField, depths_m: &[f64], emitter_points: usize) -> Table {
    let mut t = Table::new(&["depth_m", "depth_over_h", "spots_centre", "spots_support", "exact_vs_truth", "spots_vs_truth"]);
    for &depth in depths_m {
        let pts = beam_plane(depth, torch.radius_m);
        let exact = irradiance_map(lf, Method::Exact(Default::default()), &pts);
        let centre = irradiance_map(lf, Method::Spots(super::Footprint::Centre), &pts);
        let support = irradiance_map(lf, Method::Spots(super::Footprint::Support(2)), &pts);
        let truth = truth_map(torch, &pts, emitter_points);
        let f = |e: MapError| format!("{:.4}", e.rel_rms);
        t.push(vec![format!("{depth}"), format!("{:.1}", depth / lf.grid().spacing_m), f(compare(&centre, &exact)), f(compare(&support, &exact)), f(compare(&exact, &truth)), f(compare(&centre, &truth))]);
    }
    t
}

/// One row of [`sweep`].
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct SweepRow {
    /// Filter positions per axis.
    pub filters: usize,
    /// Texels per axis.
    pub resolution: u32,
    /// Storage format of the images.
    pub format: StorageFormat,
    /// Bytes of all the images in that format on a GPU.
    pub bytes: usize,
    /// Exact reconstruction against the truth.
    pub exact: MapError,
    /// Textured spot lights (centre lookup) against the truth.
    pub spots: MapError,
    /// Wall time of the simulated acquisition (once per grid and resolution), ms.
    pub acquire_ms: f64,
    /// Wall time of the exact reconstruction over the receiver plane (parallel), ms.
    pub exact_ms: f64,
    /// Wall time of the spot reconstruction over the receiver plane (parallel), ms.
    pub spots_ms: f64,
}

/// The sweep of `heliar bench lamps` (CPU side): for each grid and resolution, acquire the torch
/// at `distance_m`, store the images in each format, and compare the exact and the spot
/// reconstructions with the truth on a receiver plane at `depth_m`.
pub fn sweep(torch: &TorchEmitter, filters: &[usize], resolutions: &[u32], formats: &[StorageFormat], distance_m: f64, depth_m: f64, emitter_points: usize) -> Result<Vec<SweepRow>, LightFieldError> {
    let pts = beam_plane(depth_m, torch.radius_m);
    let truth = truth_map(torch, &pts, emitter_points);
    let mut rows = Vec::new();
    for &m in filters {
        for &res in resolutions {
            let started = Instant::now();
            let lf = acquire(torch, &torch_acquisition(torch, m, distance_m, res, emitter_points))?;
            let acquire_ms = ms(started);
            for &format in formats {
                let stored = lf.map_images(|img| format.round_trip_image(img))?;
                let started = Instant::now();
                let exact = compare(&irradiance_map(&stored, Method::Exact(Default::default()), &pts), &truth);
                let exact_ms = ms(started);
                let started = Instant::now();
                let spots = compare(&irradiance_map(&stored, Method::Spots(super::Footprint::Centre), &pts), &truth);
                let spots_ms = ms(started);
                let bytes = m * m * (res * res) as usize * format.bytes_per_texel();
                rows.push(SweepRow { filters: m, resolution: res, format, bytes, exact, spots, acquire_ms, exact_ms, spots_ms });
            }
        }
    }
    Ok(rows)
}

/// Milliseconds since `t`.
fn ms(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

/// The sweep as a table.
pub fn sweep_table(rows: &[SweepRow]) -> Table {
    let mut t = Table::new(&["filters", "texels", "format", "bytes", "exact_rel_rms", "spots_rel_rms", "acquire_ms", "exact_ms", "spots_ms"]);
    for r in rows {
        t.push(vec![
            format!("{0}x{0}", r.filters),
            format!("{0}x{0}", r.resolution),
            r.format.name().into(),
            r.bytes.to_string(),
            format!("{:.4}", r.exact.rel_rms),
            format!("{:.4}", r.spots.rel_rms),
            format!("{:.0}", r.acquire_ms),
            format!("{:.1}", r.exact_ms),
            format!("{:.1}", r.spots_ms),
        ]);
    }
    t
}

/// Each storage format's texel error on a light field's images, as a table.
pub fn format_table(lf: &LightField) -> Table {
    let mut t = Table::new(&["format", "bytes_per_texel", "signed", "mean_rel", "max_rel", "mean_of_peak", "max_of_peak", "negative_texels"]);
    for f in StorageFormat::ALL {
        let e = storage::measure(f, lf.images());
        t.push(vec![f.name().into(), f.bytes_per_texel().to_string(), f.is_signed().to_string(), format!("{:.2e}", e.mean_rel), format!("{:.2e}", e.max_rel), format!("{:.2e}", e.mean_of_peak), format!("{:.2e}", e.max_of_peak), format!("{:.3}", e.negative_fraction)]);
    }
    t
}
