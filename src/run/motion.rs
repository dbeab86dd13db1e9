//! Moving virtual objects on the frame clock (issue 15 §1, "Augment: objects follow their
//! motion"): each frame's time gives every moving object its pose (`scene::motion`); the
//! objects whose pose changed are handed to the compositor, which brings what it keeps of them
//! to the new place (`render::compositor`'s `move_objects`).
//!
//! The pass report lists the objects that moved (`moved`); each object that did not is reported
//! skipped under `object_motion` with the frame it last moved, its occluder and (when nothing
//! moved) the frame's stored volumes and stencil being reused. An object whose bounds leave the
//! irradiance-volume box gets a warning (once per object, and in the frame's report); the
//! probe lookups clamp to the box's edge (`shaders/virtual_shading.wgsl`, `probe_irradiance`),
//! so its shading stays finite.
//!
//! With the scene's visibility cuts ([`super::motion_cuts`], set with
//! [`MovingObjects::with_cuts`]), a frame where the objects moved rigidly (translated, turned)
//! evaluates them (the objects' ambient per vertex, the receivers' sky visibility) and hands them
//! to the compositor instead of its re-trace; a frame where an object's scale changed re-traces. The
//! report names the pass `visibility_cuts`, with its time when it ran and its reason when not.
//! In a scene where some objects move and others do not, the compositor leaves the movers out of
//! its trace (`render::compositor`'s `kept`) and the first frame hands them over as moved
//! ([`MovingObjects::serve_from_start`]), so the cuts light them from the start while the static
//! objects keep a trace that never saw them.
//!
//! Before evaluating, the frame asks the compositor which objects will keep their traced transfer
//! (`Compositor::cut_ambient_hidden_after`, the `kept` decision taken beforehand): their ambient is
//! not shown, so it is evaluated only as the light they reflect onto the others, or not at all, and
//! what did not change since the last frame is kept (`crate::cuts::reuse`). Each object not wholly
//! evaluated is reported skipped under `object_cuts` with its reason (kept transfer, vertices
//! reused: it did not move, the lighting did not change, no moved object reaches them).

use super::motion_cuts::{CutOutcome, CutState};
use crate::cuts::reuse::ObjectUse;
use crate::envmap::relight::Relighter;
use crate::geometry::Mesh;
use crate::render::frame::pass;
use crate::render::{Compositor, PassReport, RenderError};
use crate::scene::Scene;
use crate::scene::motion::ObjectMotion;
use chrono::{DateTime, FixedOffset};
use glam::{Mat4, Vec3};

/// Steps between two keys at which [`MovingObjects::reach`] takes the objects' boxes.
pub const REACH_STEPS_PER_KEY: usize = 8;

/// One object of the scene, moving or not.
struct Object {
    name: String,
    motion: Option<ObjectMotion>,
    /// Where the scene places it (an object without a motion).
    placed: Mesh,
    /// Where it stands now.
    mesh: Mesh,
    /// World from its rest frame (with a motion) or from its placement (without one, moved by
    /// hand); `None`: as placed.
    pose: Option<Mat4>,
    /// The move by hand (the live window), applied after the object's own pose; the identity
    /// when there is none.
    user: Mat4,
    /// Frame it last moved in (`None`: never since set-up).
    moved_at: Option<usize>,
    warned: bool,
}

impl Object {
    /// Its pose at `seconds` of the motion's clock (the field `pose`).
    fn pose_at(&self, seconds: impl FnOnce(&ObjectMotion) -> f64) -> Option<Mat4> {
        match &self.motion {
            Some(m) => Some(self.user * m.motion.world_from_rest(seconds(m))),
            None => (self.user != Mat4::IDENTITY).then_some(self.user),
        }
    }

    /// The mesh in `pose` (see the field).
    fn posed(&self, pose: Option<Mat4>) -> Mesh {
        match (&self.motion, pose) {
            (Some(m), Some(p)) => crate::scene::motion::posed(&m.rest, p),
            (None, Some(p)) => crate::scene::motion::posed(&self.placed, p),
            (_, None) => self.placed.clone(),
        }
    }
}

/// The scene's objects and where they stand (module docs).
pub struct MovingObjects {
    objects: Vec<Object>,
    proxy: Mesh,
    /// The sequence's first frame time (key times in seconds count from it).
    start: DateTime<FixedOffset>,
    /// The irradiance-volume box grown by one probe spacing, when the scene has one (an object
    /// standing on the ground reaches a little below the box; beyond one spacing its lookups are
    /// clamped extrapolations).
    volume_box: Option<(Vec3, Vec3)>,
    /// The visibility cuts, or why there are none.
    cuts: Result<CutState, String>,
    /// The objects may be moved by hand (the live window): every object is here, moving or not.
    draggable: bool,
    /// Per object, left out of the compositor's trace (`Compositor::left_out`), served by the
    /// cuts from the first frame: the next [`Self::apply`] hands them over as moved.
    from_start: Vec<bool>,
}

/// What the motion did in one frame.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FrameMotion {
    /// Per object, whether it moved.
    pub moved: Vec<bool>,
    /// Warnings (an object leaving the box).
    pub warnings: Vec<String>,
}

impl MovingObjects {
    /// The objects of `scene` when at least one moves (`None` otherwise); `start` is the time of
    /// the sequence's first frame. Names are the objects' file names, as the compositor's.
    pub fn for_scene(scene: &Scene, start: DateTime<FixedOffset>) -> Option<Self> {
        if !scene.virtual_objects.iter().any(|o| o.moves()) {
            return None;
        }
        Some(Self::new(scene, start, false))
    }

    /// The objects of `scene` for the live window, where a person drags and turns them
    /// ([`Self::set_user`]) besides their motions: every object, moving or not (`None` when the
    /// scene has none).
    pub fn for_live(scene: &Scene, start: DateTime<FixedOffset>) -> Option<Self> {
        (!scene.virtual_objects.is_empty()).then(|| Self::new(scene, start, true))
    }

    fn new(scene: &Scene, start: DateTime<FixedOffset>, draggable: bool) -> Self {
        let objects = scene
            .virtual_objects
            .iter()
            .map(|o| Object {
                name: o.path.file_name().map(|f| f.to_string_lossy().into_owned()).unwrap_or_else(|| o.path.display().to_string()),
                motion: o.motion.clone(),
                placed: o.mesh.clone(),
                mesh: o.mesh.clone(),
                pose: o.motion.as_ref().map(|m| m.motion.world_from_rest(m.motion.start_seconds())),
                user: Mat4::IDENTITY,
                moved_at: None,
                warned: false,
            })
            .collect();
        let volume_box = scene.manifest.irradiance.as_ref().map(|g| {
            let margin = Vec3::splat(g.spacing_m as f32);
            (Vec3::from(g.min.map(|v| v as f32)) - margin, Vec3::from(g.max.map(|v| v as f32)) + margin)
        });
        let cuts = Err("the visibility cuts were not loaded: every move is re-traced".to_owned());
        Self { objects, proxy: scene.proxy.clone(), start, volume_box, cuts, draggable, from_start: Vec::new() }
    }

    /// Poses every moving object for frame `index` at `time`; returns which moved.
    pub fn advance(&mut self, index: usize, time: &DateTime<FixedOffset>) -> FrameMotion {
        let mut out = FrameMotion::default();
        let start = self.start;
        for o in &mut self.objects {
            let pose = o.pose_at(|m| m.motion.seconds_at(time, &start));
            let moved = o.pose != pose;
            if moved {
                o.mesh = o.posed(pose);
                o.pose = pose;
                o.moved_at = Some(index);
            }
            out.moved.push(moved);
            if o.motion.is_none() && o.moved_at.is_none() {
                // Where the scene placed it: its own business.
                continue;
            }
            if let (Some((lo, hi)), Some((a, b)), false) = (self.volume_box, o.mesh.bounds(), o.warned)
                && (a.cmplt(lo).any() || b.cmpgt(hi).any())
            {
                o.warned = true;
                out.warnings.push(format!(
                    "warning: {} at frame {index} leaves the irradiance-volume box by more than a probe spacing ({:?}..{:?} with the margin; its bounds are {:?}..{:?}): probe lookups are clamped to the box's edge",
                    o.name,
                    lo.to_array(),
                    hi.to_array(),
                    a.to_array(),
                    b.to_array()
                ));
            }
        }
        out
    }

    /// Loads (or computes) `scene`'s visibility cuts (`super::motion_cuts`); `proxy` is the
    /// proxy's BVH. Without them every move is re-traced, and the report says why.
    pub fn with_cuts(mut self, scene: &Scene, proxy: &crate::geometry::raycast::RayScene) -> Self {
        self.cuts = CutState::load(scene, proxy, self.draggable);
        self
    }

    /// Loads the cuts ([`Self::with_cuts`], with the proxy's BVH of `compositor`) and readies
    /// `compositor` for the motion: the receivers along the motion get `c`, `b` at set-up (so that
    /// a move costs no trace), and the movers it left out of its trace (static objects beside
    /// them) are served by the cuts from the first frame ([`Self::serve_from_start`]). Without
    /// cuts the compositor is untouched. One set-up for every front end (`heliar augment`,
    /// `heliar live`, the Python compositor).
    pub fn attach(self, scene: &Scene, compositor: &mut Compositor) -> Self {
        let proxy = compositor.proxy_ray().clone();
        let mut m = self.with_cuts(scene, &proxy);
        if m.has_cuts() {
            compositor.reach_motion(m.reach());
            m.serve_from_start(compositor.left_out());
        }
        m
    }

    /// Makes the next [`Self::apply`] serve the objects `left_out` (those the compositor left out
    /// of its trace, `Compositor::left_out`) from the cuts, as if they had moved: without the
    /// cuts they keep the probe grid's ambient until they move (then re-traced).
    pub fn serve_from_start(&mut self, left_out: &[bool]) {
        self.from_start = left_out.to_vec();
    }

    /// True when the objects may be moved by hand ([`Self::for_live`]).
    pub fn draggable(&self) -> bool {
        self.draggable
    }

    /// The objects' names, in the scene's order.
    pub fn names(&self) -> Vec<&str> {
        self.objects.iter().map(|o| o.name.as_str()).collect()
    }

    /// Object `k` where it stands (as of the last [`Self::advance`]).
    pub fn mesh(&self, k: usize) -> Option<&Mesh> {
        self.objects.get(k).map(|o| &o.mesh)
    }

    /// Every object's pose as of the last [`Self::advance`] (world from its rest frame with a
    /// motion, from its placement without one; `None`: as placed), for
    /// `super::motion_cuts::CutState::poses`.
    pub fn poses(&self) -> Vec<Option<Mat4>> {
        self.objects.iter().map(|o| o.pose).collect()
    }

    /// Every object's pose at `time` (its motion's and its move by hand), without moving
    /// anything: for a second renderer that follows the same objects on its own (the live
    /// window's VEM overlay, `crate::live::vem::VemPanel::pose_objects`).
    pub fn poses_at(&self, time: &DateTime<FixedOffset>) -> Vec<Option<Mat4>> {
        let start = self.start;
        self.objects.iter().map(|o| o.pose_at(|m| m.motion.seconds_at(time, &start))).collect()
    }

    /// Every object in `poses` ([`Self::poses_at`]'s order; an object past the list's end as
    /// placed).
    pub fn meshes_in(&self, poses: &[Option<Mat4>]) -> Vec<Mesh> {
        self.objects.iter().enumerate().map(|(k, o)| o.posed(poses.get(k).copied().flatten())).collect()
    }

    /// Object `k`'s move by hand (world from where its own pose puts it).
    pub fn user(&self, k: usize) -> Option<Mat4> {
        self.objects.get(k).map(|o| o.user)
    }

    /// Moves object `k` by hand: `user` (a rotation and a translation, world from where its own
    /// pose puts it) applies from the next [`Self::advance`]. An error when `k` is out of range,
    /// when the objects are not draggable, or when `user` is not rigid or not finite.
    pub fn set_user(&mut self, k: usize, user: Mat4) -> Result<(), String> {
        if !self.draggable {
            return Err("the objects are not draggable here (only the live window moves them by hand)".into());
        }
        let n = self.objects.len();
        let o = self.objects.get_mut(k).ok_or_else(|| format!("there is no object {k} (the scene has {n})"))?;
        if !user.is_finite() {
            return Err(format!("{}: the move is not finite", o.name));
        }
        crate::cuts::rotate::Pose::from_parts(glam::Mat3::from_mat4(user), user.w_axis.truncate()).map_err(|e| format!("{}: {e}", o.name))?;
        o.user = user;
        Ok(())
    }

    /// Puts every object back where the scene places it (and on its motion).
    pub fn reset_users(&mut self) {
        for o in &mut self.objects {
            o.user = Mat4::IDENTITY;
        }
    }

    /// True when the visibility cuts are loaded.
    pub fn has_cuts(&self) -> bool {
        self.cuts.is_ok()
    }

    /// The objects' bounding boxes along their motion where they move rigidly (where the cuts
    /// serve): at every key and at [`REACH_STEPS_PER_KEY`] steps between keys
    /// (the region whose receivers the compositor prepares at set-up, `Compositor::reach_motion`).
    pub fn reach(&self) -> Vec<(Vec3, Vec3)> {
        let mut boxes = Vec::new();
        for o in &self.objects {
            let Some(m) = &o.motion else {
                boxes.extend(o.mesh.bounds());
                continue;
            };
            let mut keys: Vec<f64> = m.motion.translation.iter().flat_map(|t| t.times.clone()).collect();
            keys.extend(m.motion.rotation.iter().flat_map(|t| t.times.clone()));
            keys.sort_by(f64::total_cmp);
            keys.dedup();
            let mut times = keys.clone();
            for w in keys.windows(2) {
                times.extend((1..REACH_STEPS_PER_KEY).map(|k| w[0] + (w[1] - w[0]) * k as f64 / REACH_STEPS_PER_KEY as f64));
            }
            if times.is_empty() {
                times.push(m.motion.start_seconds());
            }
            let origin = m.motion.world_from_rest(m.motion.start_seconds()).inverse();
            for t in times {
                let pose = m.motion.world_from_rest(t);
                // Only where the cuts serve: the object moved rigidly (translated, turned).
                let d = pose * origin;
                if crate::cuts::rotate::Pose::from_parts(glam::Mat3::from_mat4(d), d.w_axis.truncate()).is_err() {
                    continue;
                }
                let pts = m.rest.positions.iter().map(|p| pose.transform_point3(*p));
                if let Some(b) = pts.fold(None, |acc: Option<(Vec3, Vec3)>, p| Some(acc.map_or((p, p), |(lo, hi)| (lo.min(p), hi.max(p))))) {
                    boxes.push(b);
                }
            }
        }
        boxes
    }

    /// Hands the objects that moved to `compositor`: by the visibility cuts when they serve
    /// (objects moved rigidly), else by its re-trace. `relighter` is the probe source's (the
    /// lighting the cuts shade with).
    pub fn apply(&mut self, compositor: &mut Compositor, frame: &FrameMotion, relighter: Option<&Relighter>) -> Result<(), RenderError> {
        let list: Vec<(String, &Mesh)> = self.objects.iter().map(|o| (o.name.clone(), &o.mesh)).collect();
        // The movers the compositor left out of its trace count as moved on the first frame.
        let from_start = std::mem::take(&mut self.from_start);
        let moved: Vec<bool> = frame.moved.iter().enumerate().map(|(k, m)| *m || from_start.get(k).copied().unwrap_or(false)).collect();
        let any = moved.iter().any(|m| *m);
        let Ok(cuts) = &mut self.cuts else {
            return compositor.move_objects(&self.proxy, &list, &moved);
        };
        if !any && !(compositor.cuts_serve() && cuts.lighting_changed(relighter)) {
            cuts.outcome = CutOutcome::Skipped(match compositor.cuts_serve() {
                true => "nothing moved and the lighting's sun planes did not change: the last ambient and receiver visibility serve".into(),
                false => "nothing moved and the cuts are not serving (no move yet, or the last one was re-traced): the objects' ambient stays as it is".into(),
            });
            return Ok(());
        }
        let poses: Vec<Option<Mat4>> = self.objects.iter().map(|o| o.pose).collect();
        let rigid = match cuts.poses(&poses) {
            Ok(t) => t,
            Err((k, why)) => {
                let name = self.objects.get(k).map_or("an object", |o| o.name.as_str());
                cuts.outcome = CutOutcome::Skipped(format!("{name} is not moved rigidly since its first key ({why}) and the cuts hold for rigid motion only: re-traced"));
                return compositor.move_objects(&self.proxy, &list, &moved);
            }
        };
        let t = std::time::Instant::now();
        let reach_m = cuts.reach_m();
        // Which objects will keep their traced transfer, decided before evaluating: their
        // ambient is not shown (`crate::cuts::reuse`).
        let hidden = compositor.cut_ambient_hidden_after(&list, &moved, &reach_m);
        match cuts.evaluate(&rigid, relighter, compositor.eye_world(), &hidden) {
            Ok((ambient, receivers)) => {
                // The objects' part; the receivers' part is timed where it runs (the compositor's
                // receiver step) and added to the same `cuts_ms`.
                cuts.outcome = CutOutcome::Ran(t.elapsed().as_secs_f64() * 1e3);
                compositor.move_objects_with_cuts(&list, &moved, &ambient.vertices, Box::new(receivers), &reach_m)?;
                let now = compositor.cut_ambient_hidden();
                if now.iter().zip(&hidden).any(|(n, h)| *h && !*n) {
                    // The decision beforehand left out an object that is shown after all (it
                    // should not happen): evaluate it again with every object shown.
                    match cuts.evaluate(&rigid, relighter, compositor.eye_world(), &now) {
                        Ok((ambient, receivers)) => {
                            cuts.outcome = CutOutcome::Ran(t.elapsed().as_secs_f64() * 1e3);
                            compositor.set_cuts(&ambient.vertices, Box::new(receivers));
                        }
                        // The same poses evaluated a moment ago: a failure now is reported.
                        Err(e) => cuts.outcome = CutOutcome::Skipped(format!("the cuts could not be evaluated again for an object shown after all ({e})")),
                    }
                }
                Ok(())
            }
            Err(e) => {
                cuts.outcome = CutOutcome::Skipped(format!("the cuts could not be evaluated ({e}): re-traced"));
                cuts.uses.clear();
                compositor.move_objects(&self.proxy, &list, &moved)
            }
        }
    }

    /// Writes the frame's motion into `report`: the objects that moved, the others skipped with
    /// their reason, and the warnings.
    pub fn report(&self, frame: &FrameMotion, report: &mut PassReport) {
        let any = frame.moved.iter().any(|m| *m);
        for (o, moved) in self.objects.iter().zip(&frame.moved) {
            if *moved {
                report.moved.push(o.name.clone());
                continue;
            }
            let since = match (&o.motion, o.moved_at) {
                (None, Some(k)) => format!("it was last moved by hand at frame {k}"),
                (None, None) => "it has no motion".to_owned(),
                (Some(_), Some(k)) => format!("it has not moved since frame {k}"),
                (Some(_), None) => "it has not moved yet".to_owned(),
            };
            let reused = if any {
                "its occluder is kept (the objects' buffers, bounds and ambient occlusion follow the moved ones)"
            } else {
                "nothing is rebuilt for it; the compositor's caches serve as for static objects"
            };
            report.skip(pass::OBJECT_MOTION, format!("{}: {since}: {reused}", o.name));
        }
        report.warnings.extend(frame.warnings.iter().cloned());
        match &self.cuts {
            Ok(c) => match &c.outcome {
                CutOutcome::Ran(ms) => {
                    report.ran.insert(0, pass::VISIBILITY_CUTS);
                    report.timings.cuts_ms += ms;
                    for (o, u) in self.objects.iter().zip(&c.uses) {
                        if let Some(why) = object_cuts_note(*u) {
                            report.skip(pass::OBJECT_CUTS, format!("{}: {why}", o.name));
                        }
                    }
                    for (o, p) in self.objects.iter().zip(c.product_uses()) {
                        if let Some(why) = product_note(p) {
                            report.skip(pass::OBJECT_CUTS, format!("{}: {why}", o.name));
                        }
                    }
                }
                CutOutcome::Skipped(reason) => report.skip(pass::VISIBILITY_CUTS, reason.clone()),
            },
            Err(reason) => report.skip(pass::VISIBILITY_CUTS, reason.clone()),
        }
    }
}

/// What an object's vertices did with their visibility products this frame
/// (`crate::cuts::products`), for the report; `None` when nothing was kept or left out.
fn product_note(p: &crate::cuts::products::ProductUse) -> Option<String> {
    let mut out = (p.reused > 0).then(|| {
        format!(
            "{} of {} vertices evaluated sum their kept visibility product (SVC × Π VCF × proxy field) under the new lighting: it did not move and no moved object's cut field reaches them",
            p.reused,
            p.reused + p.walked
        )
    });
    if let Some(n) = &p.not_kept {
        out = Some(match out {
            Some(o) => format!("{o}; {n}"),
            None => n.clone(),
        });
    }
    out
}

/// Why an object's per-vertex ambient was not (all) evaluated this frame, for the report
/// (`crate::cuts::reuse`); `None` when it was.
fn object_cuts_note(u: ObjectUse) -> Option<String> {
    const SAME: &str = "it did not move, the lighting and the eye did not change and no moved object's cut field reaches them";
    let counts = |evaluated: usize, reused: usize| match reused {
        0 => format!("all {evaluated} vertices evaluated"),
        _ => format!("{reused} of {} vertices reuse their last value ({SAME})", evaluated + reused),
    };
    match u {
        ObjectUse::Skipped => Some("it keeps its traced per-pixel transfer and its cut field reaches no object the cuts shade: its per-vertex ambient is not evaluated".into()),
        ObjectUse::SourceOnly { evaluated, reused } => Some(format!(
            "it keeps its traced per-pixel transfer: its per-vertex ambient serves only as the light it reflects onto the objects the cuts shade, and the light onto it is not computed; {}",
            counts(evaluated, reused)
        )),
        ObjectUse::Shown { evaluated, reused } if reused > 0 => Some(counts(evaluated, reused)),
        ObjectUse::Shown { .. } => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cuts::products::ProductUse;

    /// The pass report names the vertices that summed their kept product and why, and a product
    /// not kept for its budget; nothing when every product was walked and kept.
    #[test]
    fn the_report_says_which_vertices_reused_their_visibility_product() {
        let note = product_note(&ProductUse { reused: 3000, walked: 1060, not_kept: None }).unwrap();
        assert!(note.starts_with("3000 of 4060 vertices evaluated sum their kept visibility product") && note.contains("did not move"), "{note}");
        assert_eq!(product_note(&ProductUse { reused: 0, walked: 4060, not_kept: None }), None);
        let over = product_note(&ProductUse { reused: 0, walked: 10, not_kept: Some("its products need 900 bytes and the budget of 0 bytes has 0 left: not kept for the next frame".into()) }).unwrap();
        assert!(over.contains("budget"), "{over}");
    }
}
