//! The stored depth, stencil and shadow mask, and whether they serve a frame.
//!
//! # How it works
//! The depth prepass, the volumes and the mask depend only on the geometry (static: placements
//! come from the manifest), the sun direction and whether the debug masks are drawn. After a
//! frame has drawn them, [`StencilCache::store`] keeps what they were drawn for; a later frame
//! reuses them when its sun is within `reuse_sun_deg` of that one (or neither has a sun) and
//! the same masks are drawn ([`StencilCache::serves`], which gives the report's reason). The
//! canvas region of the 3D passes ([`crate::render::region`]) is recomputed with the stencil
//! and kept with it.

use super::Compositor;
use super::context::{FrameContext, angle_deg};
use crate::render::frame::PassReport;
use crate::render::region::{Rect, canvas_region};
use glam::Vec3;

/// What the stored stencil and mask were drawn for.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Stored {
    sun: Option<Vec3>,
    debug: bool,
    frame: u64,
}

/// The stored depth, stencil and mask, and their canvas region.
#[derive(Clone, Debug, Default)]
pub struct StencilCache {
    stored: Option<Stored>,
    /// The canvas region of the stored stencil's frame (`None`: the whole canvas).
    region: Option<Rect>,
}

impl StencilCache {
    /// Why the stored stencil serves a frame with objects, sun `sun` (`None`: no sun term) and
    /// debug masks on or off; `None` when it does not (or nothing is stored).
    pub fn serves(&self, sun: Option<Vec3>, debug: bool, tolerance_deg: f64) -> Option<String> {
        let s = self.stored.filter(|s| s.debug == debug)?;
        match (s.sun, sun) {
            (Some(a), Some(b)) if angle_deg(a, b) <= tolerance_deg => Some(format!(
                "sun moved {:.4}° ≤ {}° since frame {} and the objects are static: its volumes and stencil are reused",
                angle_deg(a, b),
                tolerance_deg,
                s.frame
            )),
            (None, None) => Some(format!("no sun now or at frame {} and the objects are static: its depth and stencil are reused", s.frame)),
            _ => None,
        }
    }

    /// Keeps what frame `frame` drew the stencil and mask for.
    pub fn store(&mut self, sun: Option<Vec3>, debug: bool, frame: u64) {
        self.stored = Some(Stored { sun, debug, frame });
    }

    /// Forgets the stored stencil (the region stays until the next rebuild replaces it).
    pub fn invalidate(&mut self) {
        self.stored = None;
    }

    /// The canvas region of the stored stencil.
    pub fn region(&self) -> Option<Rect> {
        self.region
    }
}

impl Compositor {
    /// Recomputes the canvas region of the 3D passes when the stencil is rebuilt (objects drawn,
    /// nothing reused), and reports it.
    pub(super) fn update_region(&mut self, ctx: &FrameContext, report: &mut PassReport) {
        if ctx.has_objects() && !ctx.reuses() {
            let t = std::time::Instant::now();
            self.stencil.region = if self.config.scissor && !self.config.debug_masks {
                canvas_region(&self.canvas, &self.receivers, &self.virtual_bounds, ctx.sun())
            } else {
                None
            };
            report.timings.region_ms = t.elapsed().as_secs_f64() * 1e3;
        }
        report.canvas_region = if ctx.has_objects() { self.stencil.region } else { None };
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_stored_stencil_serves_the_same_sun_and_masks_only() {
        let mut c = StencilCache::default();
        assert_eq!(c.serves(None, false, 0.05), None, "nothing stored");
        let sun = Vec3::new(0.3, 0.8, 0.1).normalize();
        c.store(Some(sun), false, 7);
        let why = c.serves(Some(sun), false, 0.05).expect("same sun");
        assert!(why.contains("since frame 7") && why.contains("reused"), "{why}");
        // 0.01 rad ≈ 0.57° is past a 0.05° tolerance.
        assert_eq!(c.serves(Some((sun + Vec3::new(0.01, 0.0, 0.0)).normalize()), false, 0.05), None);
        assert_eq!(c.serves(Some(sun), true, 0.05), None, "other masks");
        assert_eq!(c.serves(None, false, 0.05), None, "sun then, none now");
        c.store(None, false, 8);
        assert!(c.serves(None, false, 0.05).is_some_and(|w| w.starts_with("no sun now or at frame 8")));
        c.invalidate();
        assert_eq!(c.serves(None, false, 0.05), None);
    }
}
