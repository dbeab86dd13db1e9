//! Moving virtual objects in the captured-VEM mode (issue 15 §1, "objects follow their motion on
//! the frame clock", for the VEM mode as for the outdoor one): the same poses
//! (`crate::scene::motion`, through [`MovingObjects`]) on the VEM run's frame clock, handed to the
//! VEM renderer (`crate::render::vem::VemRenderer::move_objects`), which re-uploads the objects'
//! vertex buffer and bounds; its shadow atlas is drawn every frame anyway.
//!
//! # The frame clock
//! VEM frame `i` is composited over the footage frame `i` of the scene's first sequence, so it
//! takes that frame's time; past the footage's end (the VEM seen through the camera) the
//! times go on at the footage's frame spacing. A scene without a sequence counts from the Unix
//! epoch at the capture rate (`--rate-hz`): key times in seconds from the start work, RFC 3339
//! keys hold the first key's pose.
//!
//! A scene where nothing moves gets no [`VemMotion`] at all: nothing is posed, rebuilt or
//! reported, and its outputs are those of a static scene bit for bit.

use super::motion::{FrameMotion, MovingObjects};
use crate::geometry::Mesh;
use crate::scene::Scene;
use chrono::{DateTime, Duration, FixedOffset};
use serde::Serialize;
use std::collections::BTreeMap;

/// The moving objects of a VEM run and its frame clock (module docs).
pub struct VemMotion {
    objects: MovingObjects,
    /// Times of the footage frames (empty without a sequence).
    times: Vec<DateTime<FixedOffset>>,
    /// Time of frame 0.
    start: DateTime<FixedOffset>,
    /// Spacing of frames past the listed times.
    step: Duration,
    /// Frames each object moved in.
    moved_frames: BTreeMap<String, usize>,
}

/// What the motion did in one frame, for its JSON line.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct MotionRecord {
    /// The frame's time on the clock (RFC 3339).
    pub time: String,
    /// The objects that moved this frame (their file names).
    pub moved: Vec<String>,
    /// Warnings (an object leaving the irradiance-volume box).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub warnings: Vec<String>,
}

/// A spacing of `seconds` (at least a microsecond).
fn spacing(seconds: f64) -> Duration {
    Duration::microseconds(((seconds * 1e6).round() as i64).max(1))
}

impl VemMotion {
    /// The moving objects of `scene` on its clock (`rate_hz`: the capture rate, for a scene
    /// without a sequence), or `None` when nothing moves.
    pub fn for_scene(scene: &Scene, rate_hz: f64) -> Option<Self> {
        let times = scene.sequences.first().map(|s| s.times.clone()).unwrap_or_default();
        let start = times.first().copied().unwrap_or_else(|| DateTime::UNIX_EPOCH.fixed_offset());
        let step = match times.as_slice() {
            [a, b, ..] if b > a => *b - *a,
            _ => spacing(1.0 / rate_hz.max(1e-6)),
        };
        let objects = MovingObjects::for_scene(scene, start)?;
        Some(Self { objects, times, start, step, moved_frames: BTreeMap::new() })
    }

    /// The time of frame `i` (module docs).
    pub fn time(&self, i: usize) -> DateTime<FixedOffset> {
        match (self.times.get(i), self.times.last()) {
            (Some(t), _) => *t,
            (None, Some(last)) => *last + self.step * (i + 1 - self.times.len()) as i32,
            (None, None) => self.start + self.step * i as i32,
        }
    }

    /// Poses the objects for frame `i`: the frame's record, and every object's mesh (set-up
    /// order) when one moved.
    pub fn advance(&mut self, i: usize) -> (MotionRecord, Option<Vec<&Mesh>>) {
        let time = self.time(i);
        let FrameMotion { moved, warnings } = self.objects.advance(i, &time);
        let names: Vec<String> = self.objects.names().into_iter().map(str::to_owned).collect();
        let moved_names: Vec<String> = names.iter().zip(&moved).filter(|(_, m)| **m).map(|(n, _)| n.clone()).collect();
        for n in &moved_names {
            *self.moved_frames.entry(n.clone()).or_default() += 1;
        }
        let meshes = (!moved_names.is_empty()).then(|| (0..names.len()).filter_map(|k| self.objects.mesh(k)).collect());
        (MotionRecord { time: time.to_rfc3339(), moved: moved_names, warnings }, meshes)
    }

    /// Every object's pose as of the last [`Self::advance`] (`MovingObjects::poses`).
    pub fn poses(&self) -> Vec<Option<glam::Mat4>> {
        self.objects.poses()
    }

    /// Frames each object moved in so far (objects that never moved are listed with 0).
    pub fn moved_frames(&self) -> BTreeMap<String, usize> {
        let mut out: BTreeMap<String, usize> = self.objects.names().into_iter().map(|n| (n.to_owned(), 0)).collect();
        out.extend(self.moved_frames.iter().map(|(k, v)| (k.clone(), *v)));
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_clock_follows_the_footage_then_its_spacing() {
        // The courtyard's footage: 12 frames 10 s apart from 15:30:00.
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/courtyard");
        let mut scene = Scene::load(&root).unwrap();
        // Give the statue a motion so that there is something to follow.
        let placed = scene.virtual_objects[0].mesh.clone();
        let motion = crate::scene::motion::Motion {
            clock: crate::scene::motion::MotionClock::FromStart,
            translation: None,
            rotation: None,
            static_translation: glam::Vec3::ZERO,
            static_rotation: glam::Quat::IDENTITY,
            scale: glam::Vec3::ONE,
            left: glam::Mat4::IDENTITY,
            right: glam::Mat4::IDENTITY,
        };
        scene.virtual_objects[0].motion = Some(crate::scene::motion::ObjectMotion { rest: placed, motion });
        let m = VemMotion::for_scene(&scene, 21.0).unwrap();
        let t0 = DateTime::parse_from_rfc3339("2024-06-21T15:30:00+02:00").unwrap();
        assert_eq!(m.time(0), t0);
        assert_eq!(m.time(11), t0 + Duration::seconds(110));
        assert_eq!(m.time(14), t0 + Duration::seconds(140));
        // Without a sequence: the capture rate from the epoch.
        scene.sequences.clear();
        let m = VemMotion::for_scene(&scene, 20.0).unwrap();
        assert_eq!(m.time(3) - m.time(0), Duration::milliseconds(150));
    }
}
