//! The outdoor lighting stage: estimate → (relight → probes), Jensen §3.1, §3.3–3.4 and §4.2.
//!
//! [`OutdoorStage`] owns the estimator (with its temporal state) and the probe source. Per frame
//! it estimates the sun and sky, and on frames whose estimate says `relight` (the smoothed
//! lighting moved past the change detector's thresholds, or the sun moved past the relighter's
//! rebuild angle), and on the first frame, it relights the irradiance volume; other frames
//! reuse the probes and say why. It emits one [`OutdoorLight`]: the estimate, the [`Lighting`]
//! the renderer uses, and the relit probe grid when there is a new one.

use crate::envmap::bake::{Baked, Progress};
use crate::estimate::hindsight::LampHindsight;
use crate::estimate::{Estimator, FrameEstimate, LampReport, LampStatus};
use crate::geometry::raycast::RayScene;
use crate::io::frames::{Frame, Linearizer};
use crate::irradiance::ProbeGrid;
use crate::irradiance::sources::{ProbeSource, UniformSky, VolumeProbes};
use crate::lighting::{FrameSky, LampScales, Lighting};
use crate::scene::Scene;
use chrono::{DateTime, FixedOffset};
use glam::Vec3;
use serde::Serialize;
use std::sync::Arc;

/// Where the virtual objects' ambient light comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Ambient {
    /// The irradiance volume when the scene has an `[envmap]`, else the uniform sky.
    Auto,
    /// The baked irradiance volume, relit per frame.
    Volume,
    /// A uniform, unoccluded sky of the frame's `Pa` everywhere.
    Uniform,
}

/// Whether the relight → probe-update hook ran this frame, and why (not).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RelightReport {
    /// The hook ran.
    pub ran: bool,
    /// The probe source (`irradiance_volume` or `uniform_sky`).
    pub source: &'static str,
    /// Why it ran, or why not.
    pub reason: String,
    /// Time of the relight and probe update, ms (0 when it did not run).
    pub ms: f64,
}

/// What the stage gives the renderer for one frame.
#[derive(Clone, Debug)]
pub struct OutdoorLight<'a> {
    /// The estimator's output.
    pub estimate: FrameEstimate,
    /// The lighting the renderer uses.
    pub lighting: Lighting,
    /// The relight hook.
    pub relight: RelightReport,
    /// Estimation time, ms.
    pub estimate_ms: f64,
    /// The relit probe grid, when the hook ran this frame.
    pub grid: Option<&'a ProbeGrid>,
}

/// The lighting the renderer uses for an estimate: the smoothed values, else the frame's own,
/// else none (a frame the estimator could not use). Each lamp of the scene gets the estimate's
/// `k` ([`lamp_scales`]).
pub fn lighting_of(e: &FrameEstimate) -> Lighting {
    let v = |a: [f64; 3]| Vec3::new(a[0] as f32, a[1] as f32, a[2] as f32);
    let (pd, pa) = match (&e.smoothed, e.pd, e.pa) {
        (Some(s), _, _) => (v(s.pd), v(s.pa)),
        (None, pd, pa) => (pd.map(v).unwrap_or(Vec3::ZERO), pa.map(v).unwrap_or(Vec3::ZERO)),
    };
    Lighting { sun_dir: Vec3::from(e.sun.dir_world), above_horizon: e.sun.above_horizon, pd, pa, sky: frame_sky(e), lamps: lamp_scales(&e.lamps) }
}

/// The sky the estimate used, for the renderer's stages: uniform on an overcast frame (the
/// report's `sky_model` is `"uniform"`; it is absent under Jensen's model, uniform already), the
/// turbidity chosen by residual under `turbidity = "fit"`, else the scene's declared sky.
pub fn frame_sky(e: &FrameEstimate) -> FrameSky {
    match (e.sky_model.as_deref(), &e.turbidity_fit) {
        (Some("uniform"), _) => FrameSky::Uniform,
        (_, Some(fit)) => FrameSky::Turbidity(fit.chosen),
        _ => FrameSky::Declared,
    }
}

/// The scale of each lamp for the render (issue 16 §3): `k` in hindsight when the run has it
/// (`k_hindsight`, [`crate::estimate::hindsight`]: a recording's later frames included), else, as
/// for `Pd` and `Pa`, the smoothed `k`
/// when there is one (`k_smoothed`, [`crate::estimate::smoother::LampSmoother`]), else the
/// report's `k` (the frame's fit, or the prior when the lamp was unreached, not separable or no
/// frame since its switch-on was fitted), and zero for a lamp off by its schedule. A negative or
/// non-finite `k` gives no light.
pub fn lamp_scales(lamps: &[LampReport]) -> LampScales {
    let k: Vec<[f32; 3]> = lamps
        .iter()
        .map(|l| match l.status {
            LampStatus::Off => [0.0; 3],
            _ => l.k_hindsight.or(l.k_smoothed).unwrap_or(l.k).map(|k| if k.is_finite() && k > 0.0 { k as f32 } else { 0.0 }),
        })
        .collect();
    LampScales::from_slice(&k)
}

/// Builds the probe source `ambient` asks for. `bake` supplies the scene's bake (cached or
/// fresh) when the irradiance volume is wanted.
pub fn probe_source(
    scene: &Scene,
    ray: Arc<RayScene>,
    ambient: Ambient,
    bake: impl FnOnce(&Scene, Arc<RayScene>) -> anyhow::Result<Baked>,
) -> anyhow::Result<Box<dyn ProbeSource + Send>> {
    let volume = match ambient {
        Ambient::Uniform => false,
        Ambient::Volume => true,
        Ambient::Auto => scene.manifest.envmap.is_some(),
    };
    if !volume {
        return Ok(Box::new(UniformSky::for_scene(scene)));
    }
    let baked = bake(scene, ray.clone())?;
    Ok(Box::new(VolumeProbes::new(scene, ray, &baked)))
}

/// A bake from the scene's cache, or a fresh one saved to it.
pub fn cached_bake(scene: &Scene, ray: Arc<RayScene>, progress: Progress) -> anyhow::Result<Baked> {
    use anyhow::Context;
    Ok(crate::envmap::bake::bake_cached(scene, ray, false, progress).with_context(|| format!("baking {}", scene.root.display()))?.0)
}

/// The estimator and the probe source of one scene.
pub struct OutdoorStage {
    /// The estimator (its temporal state spans the frames given to it).
    pub estimator: Estimator,
    /// The probe source.
    pub probes: Box<dyn ProbeSource + Send>,
    relit_once: bool,
    relights: usize,
    /// The lamps' `k` in hindsight over the run's frames, when a pre-pass computed it.
    hindsight: Option<LampHindsight>,
}

impl OutdoorStage {
    /// Joins the estimator and the probe source.
    pub fn new(estimator: Estimator, probes: Box<dyn ProbeSource + Send>) -> Self {
        Self { estimator, probes, relit_once: false, relights: 0, hindsight: None }
    }

    /// Probe updates so far.
    pub fn relights(&self) -> usize {
        self.relights
    }

    /// Forces a relight on the next frame (after a jump in the footage, or a new probe source).
    pub fn force_relight(&mut self) {
        self.relit_once = false;
    }

    /// Swaps the probe source for `other` (the live window's ambient switch) and relights on
    /// the next frame.
    pub fn swap_probes(&mut self, other: &mut Box<dyn ProbeSource + Send>) {
        std::mem::swap(other, &mut self.probes);
        self.force_relight();
    }

    /// Gives every later frame's lamps their `k` in hindsight from `h` (`k_hindsight`, which the
    /// render prefers), for the frames it covers.
    pub fn set_hindsight(&mut self, h: LampHindsight) {
        self.hindsight = Some(h);
    }

    /// The estimator's output for frame `index`, with the lamps' `k` in hindsight when set.
    fn estimate(&mut self, index: usize, time: &DateTime<FixedOffset>, frame: &Frame, lin: &Linearizer) -> anyhow::Result<FrameEstimate> {
        let mut e = self.estimator.estimate(index, time, frame, lin)?;
        if let Some(h) = &self.hindsight {
            h.apply(index, &mut e.lamps);
        }
        Ok(e)
    }

    /// Estimates frame `index` (taken at `time`) without relighting: keeps the estimator's
    /// temporal state going over frames whose output exists already (a resumed run).
    pub fn estimate_only(&mut self, index: usize, time: &DateTime<FixedOffset>, frame: &Frame, lin: &Linearizer) -> anyhow::Result<FrameEstimate> {
        self.estimate(index, time, frame, lin)
    }

    /// Estimates the frame and runs the relight hook.
    pub fn light(&mut self, index: usize, time: &DateTime<FixedOffset>, frame: &Frame, lin: &Linearizer) -> anyhow::Result<OutdoorLight<'_>> {
        let t = std::time::Instant::now();
        let estimate = self.estimate(index, time, frame, lin)?;
        let estimate_ms = t.elapsed().as_secs_f64() * 1e3;
        let lighting = lighting_of(&estimate);
        let source = self.probes.name();
        if self.relit_once && !estimate.relight {
            let relight = RelightReport { ran: false, source, reason: "lighting unchanged (relight = false)".into(), ms: 0.0 };
            return Ok(OutdoorLight { estimate, lighting, relight, estimate_ms, grid: None });
        }
        let t = std::time::Instant::now();
        let reason = if !self.relit_once { "first frame".to_owned() } else { format!("{:?}", estimate.change) };
        self.relit_once = true;
        self.relights += 1;
        let grid = self.probes.relight(&lighting);
        let relight = RelightReport { ran: true, source, reason, ms: t.elapsed().as_secs_f64() * 1e3 };
        Ok(OutdoorLight { estimate, lighting, relight, estimate_ms, grid: Some(grid) })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_frame_carries_a_scale_for_every_lamp_a_scene_may_declare() {
        assert_eq!(crate::lighting::MAX_LAMPS, crate::scene::lights::MAX_LIGHTS);
        let k: Vec<[f32; 3]> = (0..crate::scene::lights::MAX_LIGHTS).map(|i| [i as f32; 3]).collect();
        let s = LampScales::from_slice(&k);
        assert_eq!(s.as_slice(), &k[..]);
    }

    #[test]
    fn each_lamp_gets_its_k_and_an_off_lamp_none() {
        let report = |status, k: f64| LampReport { name: "l".into(), status, k: [k, 0.5 * k, f64::NAN], k_se: None, k_smoothed: None, k_hindsight: None, samples: 0, condition_number: None, reason: None };
        let s = lamp_scales(&[report(LampStatus::Fitted, 2.0), report(LampStatus::Off, 3.0), report(LampStatus::Unreached, 1.0), report(LampStatus::NotFitted, -1.0)]);
        // fitted and prior scales pass; off, negative and NaN give no light
        assert_eq!(s.as_slice(), &[[2.0, 1.0, 0.0], [0.0; 3], [1.0, 0.5, 0.0], [0.0; 3]]);
        assert!(lamp_scales(&[]).is_empty());
        // The smoothed scale, when there is one, is the one rendered (as for Pd and Pa).
        let smoothed = LampReport { k_smoothed: Some([0.9, 0.8, 0.7]), ..report(LampStatus::Fitted, 2.0) };
        assert_eq!(lamp_scales(&[smoothed.clone()]).as_slice(), &[[0.9, 0.8, 0.7]]);
        // In hindsight, when a run has it, before the forward filter.
        let hindsight = LampReport { k_hindsight: Some([1.0, 1.1, 1.2]), ..smoothed };
        assert_eq!(lamp_scales(&[hindsight]).as_slice(), &[[1.0, 1.1, 1.2]]);
    }
}
