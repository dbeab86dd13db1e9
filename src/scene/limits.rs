//! Size caps checked at load, before anything is allocated from a scene's numbers.
//!
//! The probe grid of the irradiance volume has `⌈extent/spacing⌉ + 1` probes per axis (as
//! `irradiance::ProbeGrid::filled` lays it out), and its transfer stores up to one
//! `(texel, SH weights)` entry per probe and direction; `spacing_m = 0.001` over the courtyard
//! asked for 4·10¹¹ probes and aborted in the allocator. [`check_probe_grid`] refuses such grids
//! with the field and the size.

use super::{SceneError, invalid};
use glam::DVec3;
use std::path::Path;

/// Most probes in an irradiance-volume grid (2²⁰: a 100 × 10 × 100 m region at 1 m is 0.1 M).
pub const MAX_PROBES: u64 = 1 << 20;
/// Most bytes of the probe transfer, counted as probes × directions × one stored entry (a texel
/// index and nine SH weights, 40 bytes): 8 GiB.
pub const MAX_TRANSFER_BYTES: u64 = 8 << 30;
/// Bytes of one stored transfer entry.
const ENTRY_BYTES: u64 = 40;

/// Probes per axis of a grid over `[min, max]` every `spacing` metres (floating point, so that
/// absurd grids do not overflow while they are counted).
pub fn probe_grid_dims(min: DVec3, max: DVec3, spacing: f64) -> DVec3 {
    ((max - min) / spacing).ceil() + DVec3::ONE
}

/// Refuses a probe grid over the caps; `field` is the manifest field that sets its size.
pub(crate) fn check_probe_grid(manifest: &Path, field: &str, min: DVec3, max: DVec3, spacing: f64, directions: usize) -> Result<(), SceneError> {
    let d = probe_grid_dims(min, max, spacing);
    let probes = d.x * d.y * d.z;
    let bytes = probes * directions as f64 * ENTRY_BYTES as f64;
    let size = format!("{}×{}×{} = {probes:.3e} probes", d.x, d.y, d.z);
    if probes.is_nan() || probes > MAX_PROBES as f64 {
        return Err(invalid(manifest, field, format!("the probe grid would be {size}, over the cap of {MAX_PROBES} (MAX_PROBES); use a larger spacing or a smaller region")));
    }
    if bytes.is_nan() || bytes > MAX_TRANSFER_BYTES as f64 {
        return Err(invalid(
            manifest,
            field,
            format!(
                "the probe transfer of {size} × {directions} directions could need {:.1} GiB, over the cap of {} GiB (MAX_TRANSFER_BYTES); use a larger spacing, a smaller region or fewer bake.probe_directions",
                bytes / (1u64 << 30) as f64,
                MAX_TRANSFER_BYTES >> 30
            ),
        ));
    }
    Ok(())
}
