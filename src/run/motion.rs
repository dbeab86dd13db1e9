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

use crate::geometry::Mesh;
use crate::render::frame::pass;
use crate::render::{Compositor, PassReport, RenderError};
use crate::scene::Scene;
use crate::scene::motion::ObjectMotion;
use chrono::{DateTime, FixedOffset};
use glam::{Mat4, Vec3};

/// One object of the scene, moving or not.
struct Object {
    name: String,
    motion: Option<ObjectMotion>,
    mesh: Mesh,
    pose: Option<Mat4>,
    /// Frame it last moved in (`None`: never since set-up).
    moved_at: Option<usize>,
    warned: bool,
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
        let objects = scene
            .virtual_objects
            .iter()
            .map(|o| Object {
                name: o.path.file_name().map(|f| f.to_string_lossy().into_owned()).unwrap_or_else(|| o.path.display().to_string()),
                motion: o.motion.clone(),
                mesh: o.mesh.clone(),
                pose: o.motion.as_ref().map(|m| m.motion.world_from_rest(m.motion.start_seconds())),
                moved_at: None,
                warned: false,
            })
            .collect();
        let volume_box = scene.manifest.irradiance.as_ref().map(|g| {
            let margin = Vec3::splat(g.spacing_m as f32);
            (Vec3::from(g.min.map(|v| v as f32)) - margin, Vec3::from(g.max.map(|v| v as f32)) + margin)
        });
        Some(Self { objects, proxy: scene.proxy.clone(), start, volume_box })
    }

    /// Poses every moving object for frame `index` at `time`; returns which moved.
    pub fn advance(&mut self, index: usize, time: &DateTime<FixedOffset>) -> FrameMotion {
        let mut out = FrameMotion::default();
        for o in &mut self.objects {
            let Some(m) = &o.motion else {
                out.moved.push(false);
                continue;
            };
            let pose = m.motion.world_from_rest(m.motion.seconds_at(time, &self.start));
            let moved = o.pose != Some(pose);
            if moved {
                o.mesh = crate::scene::motion::posed(&m.rest, pose);
                o.pose = Some(pose);
                o.moved_at = Some(index);
            }
            out.moved.push(moved);
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

    /// Hands the objects that moved to `compositor`.
    pub fn apply(&self, compositor: &mut Compositor, frame: &FrameMotion) -> Result<(), RenderError> {
        let list: Vec<(String, &Mesh)> = self.objects.iter().map(|o| (o.name.clone(), &o.mesh)).collect();
        compositor.move_objects(&self.proxy, &list, &frame.moved)
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
                (None, _) => "it has no motion".to_owned(),
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
    }
}
