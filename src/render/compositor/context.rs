//! What one compositor frame is, decided once before any pass: are the virtual objects drawn,
//! is there a sun, do the stored depth, stencil and mask serve it, which passes are switched
//! off. The passes plan from these plain values ([`crate::render::plan`]).
//!
//! # How it works
//! Two frame-level conditions leave several passes out for one reason, the [`Gate`]: without
//! virtual objects (none in the scene, or switched off) everything that draws them is left out
//! and the footage passes through; without sun (below the horizon, `Pd/Pa` under
//! `no_sun_ratio`, or no direction) the volumes and the sun term are. The gate reports its
//! skips first, in the order the report has always had; every pass then adds its own run or
//! skip, in list order, unless the gate reported it already.

use super::{Compositor, PassSwitches};
use crate::lighting::{FrameSky, Lighting};
use crate::render::frame::{PassReport, luma, pass};
use crate::render::plan::{self, Pass};
use glam::Vec3;

/// Passes left out, in report order, when no virtual object is drawn.
const NO_OBJECT_PASSES: [&str; 8] = [
    pass::VOLUME_BUILD,
    pass::DEPTH_PREPASS,
    pass::REAL_VOLUMES,
    pass::VIRTUAL_VOLUMES,
    pass::VIRTUAL_SHADING,
    pass::SHADOW_MASK,
    pass::SUN_TERM,
    pass::OBJECT_TRANSFER,
];
/// Passes left out, in report order, when there is no sun.
const NO_SUN_PASSES: [&str; 4] = [pass::VOLUME_BUILD, pass::REAL_VOLUMES, pass::VIRTUAL_VOLUMES, pass::SUN_TERM];

/// Angle between two unit vectors, degrees.
pub(super) fn angle_deg(a: Vec3, b: Vec3) -> f64 {
    (a.dot(b).clamp(-1.0, 1.0).acos().to_degrees()) as f64
}

/// The facts of one frame that the passes decide on.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameContext {
    /// Why no virtual object is drawn (`None`: they are).
    pub no_objects: Option<String>,
    /// Why there is no sun (`None`: there is one).
    pub no_sun: Option<String>,
    /// Unit direction toward the sun (zero when the lighting has none).
    pub sun_dir: Vec3,
    /// Why the stored depth, stencil and mask serve this frame (`None`: they are rebuilt).
    pub reuse: Option<String>,
    /// The pass switches.
    pub switches: PassSwitches,
    /// The reason a switched-off pass is reported with.
    pub off: String,
    /// The sky the frame's paths see, relative to the scene's ([`Lighting::sky`]).
    pub sky: FrameSky,
}

/// A frame-level condition that leaves several passes out for one reason.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Gate<'a> {
    /// Every pass decides for itself.
    Open,
    /// No virtual object is drawn, for this reason.
    NoObjects(&'a str),
    /// Objects but no sun, for this reason.
    NoSun(&'a str),
}

impl Gate<'_> {
    /// The passes this gate leaves out, in report order.
    pub fn passes(&self) -> &'static [&'static str] {
        match self {
            Gate::Open => &[],
            Gate::NoObjects(_) => &NO_OBJECT_PASSES,
            Gate::NoSun(_) => &NO_SUN_PASSES,
        }
    }

    /// True when the gate leaves `name` out.
    pub fn covers(&self, name: &str) -> bool {
        self.passes().contains(&name)
    }
}

impl FrameContext {
    /// True when the virtual objects are drawn.
    pub fn has_objects(&self) -> bool {
        self.no_objects.is_none()
    }

    /// The sun direction when the frame has a sun term (objects drawn and a sun).
    pub fn sun(&self) -> Option<Vec3> {
        (self.has_objects() && self.no_sun.is_none()).then_some(self.sun_dir)
    }

    /// The sun direction a sky shaped by the sun follows (objects drawn and a direction),
    /// whether or not the frame has a sun term: the sun's position is known from the clock when
    /// its light is not (set, or too low for the estimator to observe `Pd`), and the twilight
    /// sky keeps its shape, as the estimator's sky terms take it (`estimate::sky_terms`).
    pub fn sky_sun(&self) -> Option<Vec3> {
        (self.has_objects() && self.sun_dir != Vec3::ZERO).then_some(self.sun_dir)
    }

    /// The sun direction the stages that trace paths under `sky` (the objects' transfer, the
    /// receivers' `c`, `b`) trace for: under a sky whose shape follows the sun,
    /// [`Self::sky_sun`], so that a frame without sun term keeps the twilight sky's shape; under
    /// one that does not, the sun term's ([`Self::sun`]), as before. What they trace per unit
    /// `Pd` for it is added only with a sun term.
    pub fn traced_sun(&self, sky: &crate::sky::radiance::SkyModel) -> Option<Vec3> {
        if sky.follows_sun() { self.sky_sun() } else { self.sun() }
    }

    /// True when the stored depth, stencil and mask serve this frame.
    pub fn reuses(&self) -> bool {
        self.reuse.is_some()
    }

    /// The frame-level gate.
    pub fn gate(&self) -> Gate<'_> {
        match (&self.no_objects, &self.no_sun) {
            (Some(why), _) => Gate::NoObjects(why),
            (None, Some(why)) => Gate::NoSun(why),
            (None, None) => Gate::Open,
        }
    }

    /// A fresh report: the sun flag and the gate's skips, first.
    pub fn begin_report(&self) -> PassReport {
        let mut report = PassReport { sun: self.sun().is_some(), ..Default::default() };
        let gate = self.gate();
        if let Gate::NoObjects(why) | Gate::NoSun(why) = gate {
            for p in gate.passes() {
                report.skip(p, why);
            }
        }
        report
    }

    /// Asks `unit` for its plan unless the gate covers it, and reports the answer; true when
    /// the unit runs.
    pub fn admit<P: Pass<FrameContext>>(&self, unit: &P, report: &mut PassReport) -> bool {
        if self.gate().covers(P::NAME) {
            return false;
        }
        plan::enter(&mut report.ran, &mut report.skipped, P::NAME, unit.plan(self))
    }
}

/// Why `lighting` gives no sun term (`None`: it gives one), and the unit sun direction (zero
/// without one). `no_sun_ratio` is the smallest `Pd/Pa` (luminance) with a sun.
pub fn sun_of(lighting: &Lighting, no_sun_ratio: f64) -> (Vec3, Option<String>) {
    let l = lighting.sun_dir.normalize_or_zero();
    let (pd, pa) = (luma(lighting.pd), luma(lighting.pa));
    let why = if !lighting.above_horizon {
        Some("the sun is below the horizon".into())
    } else if pd.is_nan() || pd <= 0.0 || (pd as f64) < no_sun_ratio * pa as f64 {
        Some(format!("Pd ≈ 0 (Pd/Pa = {:.3} < {})", if pa > 0.0 { pd / pa } else { 0.0 }, no_sun_ratio))
    } else if l == Vec3::ZERO {
        Some("no sun direction".into())
    } else {
        None
    };
    (l, why)
}

impl Compositor {
    /// The facts of the frame lit by `lighting`.
    pub(super) fn frame_context(&self, lighting: &Lighting) -> FrameContext {
        let off = if self.switched_off_reason.is_empty() { "switched off".to_owned() } else { self.switched_off_reason.clone() };
        let no_objects = if self.virt.index_count == 0 {
            Some("the scene has no virtual objects".to_owned())
        } else if !self.switches.virtual_objects {
            Some(off.clone())
        } else {
            None
        };
        let (sun_dir, no_sun) = sun_of(lighting, self.config.no_sun_ratio);
        let sun = (no_objects.is_none() && no_sun.is_none()).then_some(sun_dir);
        // A change of the sky (an overcast frame, the first clear one after, or a fitted
        // turbidity) recomputes the receivers, so the stored stencil does not serve.
        let reuse = match no_objects {
            None if self.receivers.sky_switch_pending(lighting.sky) => None,
            None => self.stencil.serves(sun, self.config.debug_masks, self.config.reuse_sun_deg),
            Some(_) => None,
        };
        FrameContext { no_objects, no_sun, sun_dir, reuse, switches: self.switches, off, sky: lighting.sky }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn context(no_objects: Option<&str>, no_sun: Option<&str>) -> FrameContext {
        FrameContext {
            no_objects: no_objects.map(str::to_owned),
            no_sun: no_sun.map(str::to_owned),
            sun_dir: Vec3::Y,
            reuse: None,
            switches: PassSwitches::default(),
            off: "off".into(),
            sky: FrameSky::Declared,
        }
    }

    #[test]
    fn the_gate_reports_its_skips_first_and_no_objects_outranks_no_sun() {
        let r = context(Some("none"), Some("night")).begin_report();
        assert_eq!(r.skipped.iter().map(|s| s.pass).collect::<Vec<_>>(), NO_OBJECT_PASSES);
        assert!(r.skipped.iter().all(|s| s.reason == "none") && !r.sun);
        let c = context(None, Some("night"));
        assert_eq!(c.gate(), Gate::NoSun("night"));
        assert_eq!(c.begin_report().skipped.len(), NO_SUN_PASSES.len());
        assert_eq!(c.sun(), None);
        // Without a sun term the sky's shape still follows the sun's direction.
        assert_eq!(c.sky_sun(), Some(Vec3::Y));
        assert_eq!(context(Some("none"), None).sky_sun(), None);
        // The stages that trace paths: a shaped sky keeps the direction, the uniform one (whose
        // paths do not depend on the sun) takes the sun term's, none.
        let shaped = crate::sky::radiance::SkyModel { hosek_turbidity: Some(3.0), terrain_albedo: [0.2; 3] };
        assert_eq!((c.traced_sun(&shaped), c.traced_sun(&crate::sky::radiance::SkyModel::uniform())), (Some(Vec3::Y), None));
        let c = context(None, None);
        assert!(c.begin_report().skipped.is_empty() && c.sun() == Some(Vec3::Y) && c.begin_report().sun);
    }

    #[test]
    fn the_sun_is_missing_below_the_horizon_without_power_or_without_direction() {
        let l = |dir: Vec3, above: bool, pd: f32| Lighting { sun_dir: dir, above_horizon: above, pd: Vec3::splat(pd), pa: Vec3::splat(1.0), sky: FrameSky::Declared, lamps: crate::lighting::LampScales::NONE };
        assert!(sun_of(&l(Vec3::Y, false, 3.0), 0.05).1.unwrap().contains("below the horizon"));
        // Pd/Pa = 0.01 < 0.05; NaN power is no power.
        assert!(sun_of(&l(Vec3::Y, true, 0.01), 0.05).1.unwrap().contains("Pd/Pa = 0.010"));
        assert!(sun_of(&l(Vec3::Y, true, f32::NAN), 0.05).1.unwrap().starts_with("Pd ≈ 0"));
        assert_eq!(sun_of(&l(Vec3::ZERO, true, 3.0), 0.05).1.as_deref(), Some("no sun direction"));
        let (dir, why) = sun_of(&l(Vec3::new(0.0, 2.0, 0.0), true, 3.0), 0.05);
        assert_eq!((dir, why), (Vec3::Y, None));
    }
}
