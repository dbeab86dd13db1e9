//! Objects that keep their traced transfer while others move under the visibility cuts (issue 15
//! §5, "virtual objects that move: visibility cuts"; cyberworlds §V-B: an object's field matters
//! only within its outermost sphere, `../shared/papers/cyberworlds-captured-lighting-cuts.txt`).
//!
//! # How it works
//! The per-pixel transfer of the objects and the receivers' `c_v`, `b_v` are traced once, with
//! every object at its set-up place. When some objects move under the cuts, a moved object can
//! change the ambient light of what lies within the reach of its visibility cut field (its
//! outermost sphere, `outer·r` about its bounding sphere, `crate::cuts::vcf`: 10 r in the
//! paper); beyond it the cuts leave it out (the paper culls distant objects). So after a move:
//! - an object that has not moved since set-up **keeps the trace** when, for every object that
//!   has moved, its box lies farther than that object's reach from the moved object's box both
//!   at set-up (the place the trace saw it at) and now, and the moved object's set-up box does
//!   not overlap it on the canvas (the trace would have no entries for the pixels the moved
//!   object hid then). Its vertices are left unserved by the cuts (`w = 0`, `motion`), so the
//!   shading pass reads its traced transfer exactly as before the move; the moved objects'
//!   vertices are served by the cuts (`w = 1`), which the shader prefers to any transfer entry,
//!   so a moved object passing in front of a kept one never takes the kept one's transfer. The
//!   direct effects of a move (the sun's stencil shadow volumes) apply as before;
//! - every other object **takes the cuts** (the per-vertex ambient);
//! - receivers (proxy pixels) within the reach of a moved object, at set-up or now, forget
//!   their traced `c_v`, `b_v` and take `c·V`, `b·V` from the visibility fields from then on
//!   (`Receivers::forget_objects_at`); the others keep their traced values (traced again with
//!   the objects at their set-up places when the sun moves past `bounce_rebuild_deg`, as
//!   without motion).
//!
//! **Movers left out of the trace.** In a scene where some objects have a motion and the others
//! do not (`Compositor::for_scene`), the transfer, the objects' ambient occlusion and `c_v`,
//! `b_v` are traced with the static objects only, and the frame loop serves the movers from the
//! cuts from the first frame on (`run::motion`), as if they had moved: they are never in the
//! trace, so their set-up place counts for nothing above (only where they stand now), and a
//! static object and the receivers beyond every mover's reach get exactly the values of the same
//! scene without the movers, bit for bit (`tests/suite/object_cuts_far.rs`). The receivers within
//! a mover's reach take `c·V`, `b·V` with the objects' fields (the mover's contact shadow).
//!
//! Distances are between boxes (the gap between the axis-aligned boxes), a little more cautious
//! than the field's sphere. The light a moved object reflects beyond its reach is left out as
//! the cuts leave out its occlusion there: at 10 r it subtends 0.25 % of the sphere. When no
//! object keeps the trace (one object moving, or every object moved or reached), everything
//! takes the cuts as before: the transfer is dropped and every receiver forgets `c_v`, `b_v`.
//! The lamps' ground bounce is forgotten on any move (traced again with the objects).

use super::Compositor;
use crate::gpu::canvas::Canvas;
use glam::{DVec2, Vec3};

/// What keeps the trace while objects move under the cuts (module docs).
#[derive(Clone, Debug, Default)]
pub(super) struct KeptTrace {
    /// Per object, its box when the transfer and `c_v`, `b_v` were traced (set-up).
    traced: Vec<(Vec3, Vec3)>,
    /// Per object, moved since set-up.
    displaced: Vec<bool>,
    /// Per object, keeps the traced transfer.
    keeps: Vec<bool>,
    /// Per object, why it takes the cuts (`None`: it keeps the trace), for the report.
    why: Vec<Option<String>>,
    /// The objects' names.
    names: Vec<String>,
    /// Per object, left out of the trace (a mover among static objects: the cuts serve it from
    /// the first frame).
    left_out: Vec<bool>,
}

/// Distance between two axis-aligned boxes (0 when they overlap), metres.
pub(super) fn box_gap(a: &(Vec3, Vec3), b: &(Vec3, Vec3)) -> f32 {
    (a.0 - b.1).max(b.0 - a.1).max(Vec3::ZERO).length()
}

/// The canvas rectangle a box covers (`None`: a corner lies behind the camera).
fn canvas_rect(canvas: &Canvas, b: &(Vec3, Vec3)) -> Option<(DVec2, DVec2)> {
    let mut lo = DVec2::splat(f64::INFINITY);
    let mut hi = DVec2::splat(f64::NEG_INFINITY);
    for k in 0..8 {
        let c = Vec3::new(if k & 1 == 0 { b.0.x } else { b.1.x }, if k & 2 == 0 { b.0.y } else { b.1.y }, if k & 4 == 0 { b.0.z } else { b.1.z });
        let p = canvas.canvas_from_world(c.as_dvec3())?;
        lo = lo.min(p);
        hi = hi.max(p);
    }
    Some((lo, hi))
}

/// True when the boxes' canvas rectangles may overlap (also when one is not wholly in front of
/// the camera).
fn overlap_on_canvas(canvas: &Canvas, a: &(Vec3, Vec3), b: &(Vec3, Vec3)) -> bool {
    match (canvas_rect(canvas, a), canvas_rect(canvas, b)) {
        (Some((alo, ahi)), Some((blo, bhi))) => alo.x <= bhi.x && blo.x <= ahi.x && alo.y <= bhi.y && blo.y <= ahi.y,
        _ => true,
    }
}

impl KeptTrace {
    /// Nothing moved yet; `traced` holds the objects' boxes at set-up, `left_out` (empty: none)
    /// the objects the trace left out.
    pub(super) fn new(traced: Vec<(Vec3, Vec3)>, left_out: &[bool]) -> Self {
        let n = traced.len();
        let left_out = (0..n).map(|k| left_out.get(k).copied().unwrap_or(false)).collect();
        Self { traced, displaced: vec![false; n], keeps: vec![false; n], why: vec![None; n], names: Vec::new(), left_out }
    }

    /// Per object, left out of the trace (see [`Self::new`]).
    pub(super) fn left_out(&self) -> &[bool] {
        &self.left_out
    }

    /// Per object, keeps the traced transfer (empty or all false: none does).
    pub(super) fn keeps(&self) -> &[bool] {
        &self.keeps
    }

    /// True when some object keeps the traced transfer.
    pub(super) fn any(&self) -> bool {
        self.keeps.iter().any(|k| *k)
    }

    /// Per object, moved since set-up.
    pub(super) fn displaced(&self) -> &[bool] {
        &self.displaced
    }

    /// Each object's box at set-up.
    pub(super) fn traced(&self) -> &[(Vec3, Vec3)] {
        &self.traced
    }

    /// Decides for the objects at boxes `now` (names `names`), after `moved` moved, each moved
    /// object reaching `reach_m` (`None`: a re-trace, nothing keeps it); `traced`: the transfer
    /// is still there to keep. Returns true when some object keeps it.
    pub(super) fn decide(&mut self, canvas: &Canvas, names: &[&str], now: &[(Vec3, Vec3)], moved: &[bool], reach_m: Option<&[f32]>, traced: bool) -> bool {
        let n = names.len();
        self.names = names.iter().map(|s| (*s).to_owned()).collect();
        self.displaced.resize(n, false);
        for (d, m) in self.displaced.iter_mut().zip(moved) {
            *d |= *m;
        }
        self.why = (0..n).map(|j| self.why_cuts(canvas, j, now, reach_m, traced)).collect();
        self.keeps = self.why.iter().map(Option::is_none).collect();
        self.any()
    }

    /// Why object `j` takes the cuts, or `None` when it keeps the trace.
    fn why_cuts(&self, canvas: &Canvas, j: usize, now: &[(Vec3, Vec3)], reach_m: Option<&[f32]>, traced: bool) -> Option<String> {
        if self.left_out[j] {
            return Some("has a motion: left out of the trace, the cuts serve it from the first frame".into());
        }
        if self.displaced[j] {
            return Some("moved".into());
        }
        let Some(reach_m) = reach_m else { return Some("re-traced".into()) };
        if !traced {
            return Some("the traced transfer was dropped earlier".into());
        }
        let Some(bj) = now.get(j) else { return Some("no bounds".into()) };
        for (k, name) in self.names.iter().enumerate().filter(|(k, _)| self.displaced[*k] || self.left_out[*k]) {
            let (Some(r), Some(then), Some(bk)) = (reach_m.get(k), self.traced.get(k), now.get(k)) else {
                return Some(format!("{name}'s reach is not known"));
            };
            // A mover left out of the trace: its set-up place is not in the trace either.
            let left_out = self.left_out[k];
            let gap = if left_out { box_gap(bj, bk) } else { box_gap(bj, then).min(box_gap(bj, bk)) };
            if gap <= *r {
                return Some(format!("{name} came within {gap:.2} m, its cut field reaching {r:.2} m"));
            }
            if !left_out && overlap_on_canvas(canvas, then, bj) {
                return Some(format!("{name} covered part of it on screen when the transfer was traced"));
            }
        }
        None
    }

    /// The report's text: which objects keep the trace and which take the cuts.
    pub(super) fn note(&self) -> String {
        let list = |keep: bool| self.names.iter().zip(&self.why).filter(|(_, w)| w.is_none() == keep).map(|(n, w)| w.as_ref().map_or(n.clone(), |w| format!("{n} ({w})"))).collect::<Vec<_>>().join(", ");
        let kept = list(true);
        let cuts = list(false);
        match (kept.is_empty(), cuts.is_empty()) {
            (false, false) => format!("kept for {kept} (no moved object within reach); the visibility cuts per vertex for {cuts}"),
            (false, true) => format!("kept for {kept}"),
            (true, _) => format!("the visibility cuts per vertex for {cuts}"),
        }
    }
}

impl Compositor {
    /// Per object, true while its per-vertex cut ambient is not shown: it keeps the traced
    /// transfer (`motion`'s upload leaves it unserved).
    pub fn cut_ambient_hidden(&self) -> Vec<bool> {
        let traced = self.transfer.transfer().is_some();
        (0..self.vertex_sources.len()).map(|k| traced && self.kept.keeps().get(k).copied().unwrap_or(false)).collect()
    }

    /// [`Self::cut_ambient_hidden`] as it will be after [`Self::move_objects_with_cuts`] with
    /// the same `objects`, `moved` and `reach_m`: the decision above taken beforehand, so that
    /// the frame loop need not evaluate what will not be shown (`crate::cuts::reuse`).
    pub fn cut_ambient_hidden_after(&self, objects: &[(String, &crate::geometry::Mesh)], moved: &[bool], reach_m: &[f32]) -> Vec<bool> {
        if !moved.iter().any(|m| *m) {
            // Only the ambient is replaced (`set_cuts`): the last decision stands.
            return self.cut_ambient_hidden();
        }
        let names: Vec<&str> = objects.iter().map(|(n, _)| n.as_str()).collect();
        let bounds: Vec<(Vec3, Vec3)> = objects.iter().filter_map(|(_, m)| m.bounds()).collect();
        let mut kept = self.kept.clone();
        kept.decide(&self.canvas, &names, &bounds, moved, Some(reach_m), self.transfer.transfer().is_some());
        (0..objects.len()).map(|k| kept.keeps().get(k).copied().unwrap_or(false)).collect()
    }

    /// Proxy pixels within the reach of an object of `moved`, at set-up or now (module docs).
    pub(super) fn reached_pixels(&self, moved: &[bool], reach_m: &[f32]) -> Vec<u32> {
        let mut pixels = Vec::new();
        for (k, _) in moved.iter().enumerate().filter(|(_, m)| **m) {
            let (Some(r), Some(now)) = (reach_m.get(k), self.virtual_bounds.get(k)) else { continue };
            let boxes: Vec<(Vec3, Vec3)> = self.kept.traced().get(k).into_iter().copied().chain([*now]).collect();
            pixels.extend(self.receivers.near(&boxes, *r));
        }
        pixels.sort_unstable();
        pixels.dedup();
        pixels
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Boxes apart along one axis are their gap apart; along two, the diagonal (Pythagoras);
    /// overlapping or touching boxes are 0 apart.
    #[test]
    fn box_gap_is_the_distance_between_boxes() {
        let a = (Vec3::ZERO, Vec3::ONE);
        assert_eq!(box_gap(&a, &(Vec3::new(3.0, 0.0, 0.0), Vec3::new(4.0, 1.0, 1.0))), 2.0);
        assert_eq!(box_gap(&a, &(Vec3::new(4.0, 5.0, 0.5), Vec3::new(5.0, 6.0, 0.7))), 5.0);
        assert_eq!(box_gap(&a, &(Vec3::splat(0.5), Vec3::splat(2.0))), 0.0);
        assert_eq!(box_gap(&(Vec3::new(3.0, 0.0, 0.0), Vec3::new(4.0, 1.0, 1.0)), &a), 2.0);
    }
}
