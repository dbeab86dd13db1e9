//! Moving the virtual objects by hand in the live window (issue 15 §1, "Live"): drag an object
//! across the real scene's surface with the mouse, turn it with the scroll wheel, reset it.
//!
//! # How it works
//! - **Pointing** ([`LiveApp::pick_object`]): the pointer's footage pixel gives a world ray through
//!   the lens (`crate::gpu::canvas::Canvas::footage_ray`); the object it hits first is picked.
//! - **Dragging** ([`LiveApp::begin_drag`], [`LiveApp::drag_to`]): the object's base point (the
//!   centre of its bounds' floor) slides in the horizontal plane through it, following where the
//!   pointer's ray meets that plane, so the object stays under the pointer whatever the depth.
//!   It then rests on the proxy: a ray cast down from [`STEP_UP_M`] above the new base finds the
//!   surface below (one that faces up, [`UP_FACING_COS`]), and the object rises or sinks onto it
//!   (a step, a kerb, a ramp). Where there is none (past the proxy's edge), it keeps its height.
//!   Each update is computed from where the drag began, so a long drag does not drift.
//! - **Turning** ([`LiveApp::turn_object`]): about the vertical axis through the centre of the
//!   object's bounds.
//! - A move by hand is a yaw and a translation (`MovingObjects::set_user`), rebuilt from the
//!   yaw's angle after every change, so it stays a rotation however many turns add up: the
//!   visibility cuts serve it without a re-trace (`crate::run::motion_cuts`).
//! - The move shows on the next frame; when the footage is paused or has ended, the last frame
//!   is composited again ([`LiveApp::recompose`]) without estimating.

use super::LiveApp;
use crate::geometry::Mesh;
use crate::geometry::raycast::RayScene;
use crate::run::motion::MovingObjects;
use glam::{DVec3, Mat4, Quat, Vec3};

/// Highest step an object climbs onto while dragged, m (a kerb, a stair; not a wall).
pub const STEP_UP_M: f32 = 0.5;
/// Cosine of the steepest surface an object rests on while dragged (60° from level).
pub const UP_FACING_COS: f32 = 0.5;
/// Farthest point of the drag plane the pointer may reach, m (a ray near the horizon would
/// throw the object kilometres away).
pub const MAX_DRAG_DISTANCE_M: f64 = 200.0;
/// Turn per point of scroll, degrees (a mouse wheel's notch scrolls about 50 points in egui:
/// 10° a notch).
pub const TURN_DEG_PER_SCROLL_POINT: f32 = 0.2;

/// A drag in progress.
#[derive(Clone, Copy, Debug)]
pub(super) struct Drag {
    object: usize,
    /// The object's base point when the drag began.
    base: Vec3,
    /// Where the pointer's ray met the base's horizontal plane then.
    grab: DVec3,
    /// The object's move by hand then.
    user: Mat4,
}

/// The bottom centre of `mesh`'s bounds.
fn base_point(mesh: &Mesh) -> Option<Vec3> {
    let (lo, hi) = mesh.bounds()?;
    Some(Vec3::new((lo.x + hi.x) / 2.0, lo.y, (lo.z + hi.z) / 2.0))
}

/// Where the ray `(o, d)` meets the horizontal plane at height `y`, within
/// [`MAX_DRAG_DISTANCE_M`].
fn on_plane(o: DVec3, d: DVec3, y: f64) -> Option<DVec3> {
    if d.y.abs() < 1e-6 {
        return None;
    }
    let t = (y - o.y) / d.y;
    (t > 0.0 && (d * t).length() <= MAX_DRAG_DISTANCE_M).then(|| o + d * t)
}

/// A yaw and a translation, rebuilt from `m`'s yaw angle (module docs).
fn yaw_translation(m: Mat4) -> Mat4 {
    let x = m.x_axis.truncate();
    let yaw = (-x.z).atan2(x.x);
    Mat4::from_rotation_translation(Quat::from_rotation_y(yaw), m.w_axis.truncate())
}

impl LiveApp {
    fn objects(&self) -> Option<&MovingObjects> {
        self.session.motion.as_ref().filter(|m| m.draggable())
    }

    /// Object `k` as the window shows it: where the VEM overlay put it when that composes,
    /// else where the outdoor compositor has it.
    fn shown_mesh(&self, k: usize) -> Option<&Mesh> {
        let vem = self.vem.as_ref().filter(|v| v.composes()).and_then(|v| v.object_mesh(k));
        vem.or_else(|| self.objects()?.mesh(k))
    }

    /// The object under footage pixel `(x, y)` (nearest hit), if any.
    pub fn pick_object(&self, x: f64, y: f64) -> Option<usize> {
        let objects = self.objects()?;
        let (o, d) = self.session.compositor.canvas().footage_ray(x, y)?;
        let (o, d) = (o.as_vec3(), d.as_vec3());
        (0..objects.names().len())
            .filter_map(|k| {
                let mesh = self.shown_mesh(k)?;
                // A BVH per pick: a click, not a frame (1 292 triangles for the statue).
                let hit = RayScene::new(mesh.clone()).intersect(o, d, f32::MAX)?;
                Some((k, hit.t))
            })
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(k, _)| k)
    }

    /// Starts dragging the object under footage pixel `(x, y)`; returns it, or `None` when the
    /// pointer is on no object.
    pub fn begin_drag(&mut self, x: f64, y: f64) -> Option<usize> {
        let object = self.pick_object(x, y)?;
        let base = base_point(self.shown_mesh(object)?)?;
        let (o, d) = self.session.compositor.canvas().footage_ray(x, y)?;
        let grab = on_plane(o, d, base.y as f64)?;
        let user = self.objects()?.user(object)?;
        self.drag = Some(Drag { object, base, grab, user });
        self.selected = Some(object);
        Some(object)
    }

    /// Moves the dragged object so that it follows the pointer at footage pixel `(x, y)`
    /// (module docs). Does nothing without a drag, or where the pointer's ray does not meet the
    /// drag plane in front of the camera.
    pub fn drag_to(&mut self, x: f64, y: f64) -> Result<(), String> {
        let Some(drag) = self.drag else { return Ok(()) };
        let Some((o, d)) = self.session.compositor.canvas().footage_ray(x, y) else { return Ok(()) };
        let Some(p) = on_plane(o, d, drag.base.y as f64) else { return Ok(()) };
        let shift = (p - drag.grab).as_vec3();
        let mut to = drag.base + Vec3::new(shift.x, 0.0, shift.z);
        let proxy = self.session.compositor.proxy_ray();
        if let Some(h) = proxy.intersect(to + Vec3::Y * STEP_UP_M, Vec3::NEG_Y, f32::MAX)
            && h.normal.y >= UP_FACING_COS
        {
            to.y = h.point.y;
        }
        let user = yaw_translation(Mat4::from_translation(to - drag.base) * drag.user);
        self.set_user(drag.object, user)
    }

    /// Ends the drag.
    pub fn end_drag(&mut self) {
        self.drag = None;
    }

    /// Turns object `k` by `degrees` (counter-clockwise seen from above) about the vertical
    /// through its bounds' centre.
    pub fn turn_object(&mut self, k: usize, degrees: f32) -> Result<(), String> {
        if !degrees.is_finite() {
            return Err(format!("a turn of {degrees}° is not a number"));
        }
        let objects = self.objects().ok_or("no object can be moved by hand here")?;
        let user = objects.user(k).ok_or_else(|| format!("there is no object {k}"))?;
        let (lo, hi) = self.shown_mesh(k).and_then(Mesh::bounds).ok_or_else(|| format!("object {k} has no vertices"))?;
        let c = Vec3::new((lo.x + hi.x) / 2.0, 0.0, (lo.z + hi.z) / 2.0);
        let turn = Mat4::from_translation(c) * Mat4::from_rotation_y(degrees.to_radians()) * Mat4::from_translation(-c);
        self.selected = Some(k);
        self.set_user(k, yaw_translation(turn * user))
    }

    /// Puts every object back where the scene places it.
    pub fn reset_objects(&mut self) {
        if let Some(m) = self.session.motion.as_mut() {
            m.reset_users();
            self.objects_dirty = true;
        }
        self.drag = None;
    }

    fn set_user(&mut self, k: usize, user: Mat4) -> Result<(), String> {
        let m = self.session.motion.as_mut().ok_or("no object can be moved by hand here")?;
        m.set_user(k, user)?;
        self.objects_dirty = true;
        Ok(())
    }

    /// True when the objects can be moved by hand (`OutdoorSession::follow_live`).
    pub fn can_move_objects(&self) -> bool {
        self.objects().is_some()
    }

    /// The object last dragged or turned.
    pub fn selected_object(&self) -> Option<usize> {
        self.selected
    }

    /// Composites the last frame again with the objects where they stand now (a move by hand
    /// while no new frame comes), through the VEM overlay when it composes; false when there is
    /// no frame yet.
    pub fn recompose(&mut self) -> bool {
        self.objects_dirty = false;
        let (Some(c), Some(last)) = (&self.last_input, &self.last) else { return false };
        let video = crate::render::VideoFrame::from_frame(&c.frame, &self.lin);
        if self.vem.as_ref().is_some_and(|v| v.composes()) {
            let (index, time) = (c.index, last.time);
            return match self.compose_vem(&time, &video, 0.0) {
                Ok((passes, report, composited)) => {
                    if let Some(last) = &mut self.last {
                        (last.passes, last.vem, last.composited) = (passes, Some(report), composited);
                    }
                    self.texture_dirty = true;
                    true
                }
                Err(e) => {
                    self.error = Some(format!("frame {index} composited again: {e:#}"));
                    false
                }
            };
        }
        let (Some(c), Some(last)) = (&self.last_input, &mut self.last) else { return false };
        match self.session.recompose(c.index as usize, &last.time, &video, &last.record.lighting) {
            Ok((rendered, passes)) => {
                let img = crate::render::output::encode_rgb8(&rendered.image, rendered.precision, &video, &c.frame, &self.photometry);
                last.composited = super::rgb8(img, video.width, video.height);
                last.passes = passes;
                self.texture_dirty = true;
                true
            }
            Err(e) => {
                self.error = Some(format!("frame {} composited again: {e:#}", c.index));
                false
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_yaw_and_translation_survive_being_rebuilt_and_many_turns_stay_rigid() {
        let m = Mat4::from_rotation_translation(Quat::from_rotation_y(0.7), Vec3::new(1.0, 0.2, -3.0));
        assert!(yaw_translation(m).abs_diff_eq(m, 1e-6));
        let step = Mat4::from_translation(Vec3::new(0.3, 0.0, 0.1)) * Mat4::from_rotation_y(0.1745) * Mat4::from_translation(Vec3::new(-0.3, 0.0, -0.1));
        let mut u = Mat4::IDENTITY;
        for _ in 0..3600 {
            u = yaw_translation(step * u);
        }
        let r = glam::Mat3::from_mat4(u);
        assert!((r.transpose() * r).abs_diff_eq(glam::Mat3::IDENTITY, 1e-5), "{r:?}");
    }

    #[test]
    fn the_drag_plane_is_met_in_front_of_the_camera_only() {
        let o = DVec3::new(0.0, 2.0, 0.0);
        let p = on_plane(o, DVec3::new(0.0, -1.0, -1.0).normalize(), 0.0).unwrap();
        assert!((p - DVec3::new(0.0, 0.0, -2.0)).length() < 1e-12);
        assert!(on_plane(o, DVec3::new(0.0, 1.0, -1.0).normalize(), 0.0).is_none(), "behind");
        assert!(on_plane(o, DVec3::new(0.0, -1e-3, -1.0).normalize(), 0.0).is_none(), "2 km away");
    }
}
