//! The VEM renderer's report of a frame (part of `vem --scene`'s JSON lines) and its output.

use super::frame::{VemFrame, VemLights};
use crate::io::image::LinearImage;
use crate::render::frame::Skipped;
use crate::render::plan::{self, Pass};
use crate::vem::reinhard::ToneParams;
use serde::Serialize;

/// Where a frame's time went, ms.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct VemTimings {
    /// Slots, shadow views, list buffers (CPU).
    pub prepare_ms: f64,
    /// Uploads (lights, lists, background).
    pub upload_ms: f64,
    /// Atlas, prepass, shading and composite on the GPU, until idle.
    pub gpu_ms: f64,
    /// HDR readback.
    pub readback_ms: f64,
    /// Tone-mapping parameters, pass and readback.
    pub tonemap_ms: f64,
    /// The whole frame.
    pub total_ms: f64,
}

/// The renderer's report of a frame.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct VemReport {
    /// Passes that ran, in order.
    pub ran: Vec<&'static str>,
    /// Passes left out, with the reason.
    pub skipped: Vec<Skipped>,
    /// Lights in `H`.
    pub lights: usize,
    /// Lights in `L` (0 without the glossy set).
    pub glossy_lights: usize,
    /// Shadow maps drawn.
    pub shadow_maps: usize,
    /// Per-region culling on.
    pub culling: bool,
    /// Mean list length of `H` over regions, as a fraction of `H` (the work left by culling).
    pub list_fraction: f64,
    /// The tone-mapping parameters used.
    pub tone: Option<ToneParams>,
    /// Timings.
    pub timings: VemTimings,
}

impl VemReport {
    /// A fresh report of `frame`, prepared from `lights` with culling on or off.
    pub fn begin(lights: &VemLights<'_>, frame: &VemFrame, culling: bool) -> Self {
        Self {
            culling,
            lights: lights.h.1.lights.len(),
            glossy_lights: lights.glossy.map_or(0, |(_, l)| l.lights.len()),
            list_fraction: lights.h.1.mean_fraction(),
            shadow_maps: frame.views.len(),
            ..Default::default()
        }
    }

    /// Asks `unit` for its plan of `frame` and reports the answer; true when the unit runs.
    pub fn admit<P: Pass<VemFrame>>(&mut self, frame: &VemFrame, unit: &P) -> bool {
        plan::enter(&mut self.ran, &mut self.skipped, P::NAME, unit.plan(frame))
    }

    /// The reason `pass` was skipped, if it was.
    pub fn skip_reason(&self, pass: &str) -> Option<&str> {
        self.skipped.iter().find(|s| s.pass == pass).map(|s| s.reason.as_str())
    }
}

/// A rendered frame.
#[derive(Clone, Debug)]
pub struct VemOutput {
    /// The composite, linear radiance, in the camera's pixel grid.
    pub hdr: LinearImage,
    /// The tone-mapped frame: 8-bit sRGB RGBA, row-major.
    pub srgb: Vec<u8>,
    /// What ran and how long it took.
    pub report: VemReport,
}
