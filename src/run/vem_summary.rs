//! The VEM run's render summary (`report.json` of `heliar vem --scene`, written by
//! [`super::vem::VemScene::finish`]).

use serde::Serialize;
use std::collections::BTreeMap;

#[derive(Serialize)]
pub(super) struct SkipCount {
    pub(super) pass: &'static str,
    pub(super) reason: String,
    pub(super) frames: usize,
}

#[derive(Serialize)]
pub(super) struct ConfigOut {
    pub(super) shadow_slots: usize,
    pub(super) tile: u32,
    pub(super) culling: bool,
    pub(super) shadows: bool,
}

#[derive(Serialize)]
pub(super) struct RenderSummary<'a> {
    pub(super) scene: String,
    pub(super) adapter: String,
    pub(super) frames: usize,
    pub(super) receivers: &'static str,
    pub(super) virtual_objects: usize,
    pub(super) backgrounds: &'a BTreeMap<&'static str, usize>,
    /// Lights in H and L, and shadow maps, per frame (median over the run).
    pub(super) median_lights: f64,
    pub(super) median_glossy_lights: f64,
    pub(super) median_shadow_maps: f64,
    pub(super) config: ConfigOut,
    pub(super) passes_run: BTreeMap<&'static str, usize>,
    pub(super) passes_skipped: Vec<SkipCount>,
    pub(super) median_ms: BTreeMap<&'static str, f64>,
    pub(super) mean_list_fraction: f64,
    pub(super) contact_sheet: String,
    /// Frames each object moved in (only in scenes where some object moves).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(super) moved_frames: Option<BTreeMap<String, usize>>,
    /// "cuts" with `--object-light cuts` (absent with the lights).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(super) object_light: Option<&'static str>,
    /// Median time of the cuts' evaluation per frame, ms (with `--object-light cuts`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(super) median_cuts_ms: Option<f64>,
    /// Per object, its vertices' visibility products kept between frames over the run (with
    /// `--object-light cuts`; `crate::cuts::products`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(super) visibility_products: Option<BTreeMap<String, ProductTotal>>,
}

/// One object's visibility products over a VEM run (`crate::cuts::products`).
#[derive(Clone, Debug, Default, Serialize)]
pub(super) struct ProductTotal {
    /// Vertex-frames whose product was kept from the frame before and summed under the new
    /// VEM frame.
    pub(super) vertices_reused: usize,
    /// Vertex-frames whose product was walked.
    pub(super) vertices_walked: usize,
    /// Frames in which every vertex reused its product.
    pub(super) frames_all_reused: usize,
    /// Receiver pixels that reused their product, over the run (the same for every object).
    pub(super) receivers_reused: usize,
    /// Why.
    pub(super) reason: &'static str,
}

impl ProductTotal {
    pub(super) fn add(&mut self, reused: usize, walked: usize, receivers_reused: usize) {
        self.vertices_reused += reused;
        self.vertices_walked += walked;
        self.frames_all_reused += usize::from(walked == 0 && reused > 0);
        self.receivers_reused += receivers_reused;
        self.reason = "a vertex reuses its visibility product (SVC × Π VCF × proxy field) in a frame where its object did not move and no moved object's cut field reaches it at its old or new pose; the VEM frame's light changes every frame, so the product is summed with it (bit for bit a fresh walk); the first frame and the vertices a moved object reaches walk it";
    }
}

