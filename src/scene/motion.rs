//! How a virtual object moves: keyframes from `scene.toml` or a glTF node animation, turned into
//! the object's world pose at any time of the sequence (issue 15 §1).
//!
//! # How it works
//! A motion is up to two tracks over time, a translation and a rotation, each a list of keys in
//! strictly increasing time. Between two keys the translation is interpolated linearly and the
//! rotation by spherical linear interpolation (slerp, the shorter way round: a turn of more
//! than 180° between two keys needs a key in between); before the first key and after the last
//! the end key holds. This is glTF 2.0's `LINEAR` sampler (the spec's appendix on animation
//! interpolation), which is also what the manifest's keyframes mean.
//!
//! The pose is `world_from_rest(t) = left · T(t) · R(t) · S · right`, with the object's mesh
//! kept in its *rest* frame (the glTF file as written):
//! - manifest keyframes: `left = right = I`, `T`, `R = R_y(rotation_y_deg)` from the keys, and
//!   `S` the object's uniform `scale` (identity factors multiply exactly, so a key at the
//!   manifest's placement gives the static object's matrix bit for bit);
//! - a glTF animation of node `N` with parent transform `G`: `left = P · G` (`P` the manifest's
//!   placement), `T`, `R` the node's animated translation and rotation (its static value for a
//!   channel the animation lacks), `S` the node's own scale, and `right = (G · M_rest)⁻¹`, so
//!   the node's rest pose maps the object where the manifest puts it.
//!
//! Times are seconds from the sequence's first frame, or RFC 3339 times (stored as seconds from
//! the first key); [`MotionClock`] says which, and [`Motion::seconds_at`] converts a frame time.

use crate::geometry::Mesh;
use chrono::{DateTime, FixedOffset};
use glam::{Mat3, Mat4, Quat, Vec3};

/// What a motion's key times are measured from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum MotionClock {
    /// Seconds from the sequence's first frame.
    FromStart,
    /// Seconds from this absolute time (the first RFC 3339 key).
    Absolute(DateTime<FixedOffset>),
}

/// Keys of one channel, times in seconds (strictly increasing, at least one key).
#[derive(Clone, Debug, PartialEq)]
pub struct Track<T> {
    /// Key times, s.
    pub times: Vec<f64>,
    /// One value per key.
    pub values: Vec<T>,
}

impl<T: Copy + PartialEq> Track<T> {
    /// The value at `t`: `mix(a, b, s)` between the two keys around `t` (`s ∈ [0, 1]`), the end
    /// key outside the keys' span. A time on a key, or between two equal keys, gives the key's
    /// value exactly (slerp at `s = 0` is not exact in floating point, and an object held still
    /// must not count as moved).
    pub fn sample(&self, t: f64, mix: impl Fn(T, T, f32) -> T) -> T {
        let (times, values) = (&self.times, &self.values);
        let last = times.len() - 1;
        if !(t > times[0]) {
            return values[0];
        }
        if t >= times[last] {
            return values[last];
        }
        // First key after t: times[k - 1] < t < times[k] (t is inside the span).
        let k = times.partition_point(|&x| x <= t);
        if t == times[k - 1] || values[k - 1] == values[k] {
            return values[k - 1];
        }
        let s = ((t - times[k - 1]) / (times[k] - times[k - 1])) as f32;
        mix(values[k - 1], values[k], s)
    }

    /// Time of the first key, s.
    pub fn start(&self) -> f64 {
        self.times[0]
    }
}

/// Linear interpolation of translations.
pub fn lerp_translation(a: Vec3, b: Vec3, s: f32) -> Vec3 {
    a.lerp(b, s)
}

/// Slerp of rotations (the shorter way).
pub fn slerp_rotation(a: Quat, b: Quat, s: f32) -> Quat {
    a.slerp(b, s).normalize()
}

/// An object's motion (module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct Motion {
    /// What the key times count from.
    pub clock: MotionClock,
    /// Translation keys (`None`: `static_translation`).
    pub translation: Option<Track<Vec3>>,
    /// Rotation keys (`None`: `static_rotation`).
    pub rotation: Option<Track<Quat>>,
    /// Translation where no track is given.
    pub static_translation: Vec3,
    /// Rotation where no track is given.
    pub static_rotation: Quat,
    /// The animated node's own scale (1 for manifest keyframes).
    pub scale: Vec3,
    /// Left factor of the pose.
    pub left: Mat4,
    /// Right factor of the pose.
    pub right: Mat4,
}

impl Motion {
    /// Seconds into the motion at frame time `time`, for a sequence whose first frame is at
    /// `start`.
    pub fn seconds_at(&self, time: &DateTime<FixedOffset>, start: &DateTime<FixedOffset>) -> f64 {
        let origin = match &self.clock {
            MotionClock::FromStart => start,
            MotionClock::Absolute(t0) => t0,
        };
        // Division by the exact 1e9 (not a product with the inexact 1e-9): whole seconds stay exact.
        (*time - *origin).num_nanoseconds().map_or_else(|| (*time - *origin).num_milliseconds() as f64 / 1e3, |ns| ns as f64 / 1e9)
    }

    /// The first key's time, s (where the object stands before the motion starts).
    pub fn start_seconds(&self) -> f64 {
        let a = self.translation.as_ref().map(Track::start);
        let b = self.rotation.as_ref().map(Track::start);
        match (a, b) {
            (Some(a), Some(b)) => a.min(b),
            (a, b) => a.or(b).unwrap_or(0.0),
        }
    }

    /// Translation and rotation of the tracks at `t` seconds.
    pub fn translation_rotation_at(&self, t: f64) -> (Vec3, Quat) {
        let tr = self.translation.as_ref().map_or(self.static_translation, |k| k.sample(t, lerp_translation));
        let rot = self.rotation.as_ref().map_or(self.static_rotation, |k| k.sample(t, slerp_rotation));
        (tr, rot)
    }

    /// `world_from_rest` at `t` seconds (module docs).
    pub fn world_from_rest(&self, t: f64) -> Mat4 {
        let (tr, rot) = self.translation_rotation_at(t);
        self.left * Mat4::from_scale_rotation_translation(self.scale, rot, tr) * self.right
    }
}

/// A moving object: its mesh in the rest frame and its motion.
#[derive(Clone, Debug, PartialEq)]
pub struct ObjectMotion {
    /// The mesh in its rest frame (the glTF file as written).
    pub rest: Mesh,
    /// How it moves.
    pub motion: Motion,
}

impl ObjectMotion {
    /// The mesh in world coordinates at `t` seconds, and its pose.
    pub fn mesh_at(&self, t: f64) -> (Mesh, Mat4) {
        let m = self.motion.world_from_rest(t);
        (posed(&self.rest, m), m)
    }
}

/// `mesh` moved by `world_from_rest`: positions transformed, normals by the inverse transpose
/// (renormalised), windings flipped when the transform mirrors.
pub fn posed(mesh: &Mesh, world_from_rest: Mat4) -> Mesh {
    let mut out = mesh.clone();
    let linear = Mat3::from_mat4(world_from_rest);
    let normal_matrix = linear.inverse().transpose();
    for p in &mut out.positions {
        *p = world_from_rest.transform_point3(*p);
    }
    for n in &mut out.normals {
        *n = (normal_matrix * *n).normalize_or_zero();
    }
    if linear.determinant() < 0.0 {
        for t in &mut out.triangles {
            t.swap(1, 2);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn keys() -> Motion {
        Motion {
            clock: MotionClock::FromStart,
            translation: Some(Track { times: vec![0.0, 2.0], values: vec![Vec3::ZERO, Vec3::new(4.0, 0.0, -2.0)] }),
            rotation: Some(Track { times: vec![0.0, 2.0], values: vec![Quat::IDENTITY, Quat::from_rotation_y(90f32.to_radians())] }),
            static_translation: Vec3::ZERO,
            static_rotation: Quat::IDENTITY,
            scale: Vec3::ONE,
            left: Mat4::IDENTITY,
            right: Mat4::IDENTITY,
        }
    }

    #[test]
    fn midpoint_and_ends_hold() {
        let m = keys();
        let (t, r) = m.translation_rotation_at(1.0);
        // Closed forms: the midpoint of a straight move, half the 90° turn.
        assert!((t - Vec3::new(2.0, 0.0, -1.0)).length() < 1e-6);
        assert!((r.angle_between(Quat::IDENTITY).to_degrees() - 45.0).abs() < 1e-3);
        assert_eq!(m.translation_rotation_at(-5.0).0, Vec3::ZERO);
        assert_eq!(m.translation_rotation_at(9.0).0, Vec3::new(4.0, 0.0, -2.0));
    }

    #[test]
    fn posed_mesh_moves_points_and_turns_normals() {
        let mut mesh = Mesh::default();
        mesh.positions = vec![Vec3::X];
        mesh.normals = vec![Vec3::X];
        let m = Mat4::from_rotation_translation(Quat::from_rotation_y(90f32.to_radians()), Vec3::new(0.0, 1.0, 0.0));
        let p = posed(&mesh, m);
        // R_y(90°) takes +x to −z.
        assert!((p.positions[0] - Vec3::new(0.0, 1.0, -1.0)).length() < 1e-6);
        assert!((p.normals[0] - Vec3::NEG_Z).length() < 1e-6);
    }
}
