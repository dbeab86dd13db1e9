//! The lamps' pre-pass: before a recording is rendered, its frames are estimated once to the end
//! of the input, and each lamp's scale `k` is smoothed forward and backward over them
//! ([`crate::estimate::hindsight`]), so that a frame's lamp light also uses the frames after it
//! (a switch-on frame at dusk, where one fit is uncertain, takes the better-lit frames that
//! follow). The frame loop then renders every frame with that `k` (`k_hindsight`).
//!
//! The pass starts where the run's estimator starts (frame 0, or a chunk's first warm-up frame)
//! and goes to the end of the input whatever `max_frames` or a chunk's end say, so a resumed run,
//! a run cut short and a chunk with the whole warm-up all see the same `k` on the frames they
//! share. It stops early, without an error, at the first frame it cannot read or estimate (the
//! frame loop meets the same frame and says why) or at an interrupt; the frames after that keep
//! the forward filter's `k`.
//!
//! It is left out, with the reason in the summary, when the scene has no `[[lights]]`, when no
//! lamp is on in any frame, or with `--no-hindsight`. Its cost is the estimator's (tens of ms per
//! frame) and a second decode of every frame.

use super::super::session::OutdoorSession;
use super::super::source::Input;
use super::super::Observer;
use crate::estimate::LampStatus;
use crate::estimate::hindsight::LampHindsight;
use crate::scene::Scene;
use anyhow::{Context, Result, bail};
use serde::Serialize;
use std::sync::atomic::{AtomicUsize, Ordering};

/// What the pre-pass did (`summary.json`'s `lamp_hindsight`).
#[derive(Clone, Debug, Default, Serialize)]
pub struct HindsightSummary {
    /// It ran and the frame loop uses its `k`.
    pub ran: bool,
    /// Why it ran or was left out.
    pub reason: String,
    /// Frames it estimated.
    pub frames: usize,
    /// Its wall time, ms.
    pub ms: f64,
}

/// Runs the pre-pass over `input` from frame `from` (module docs) and hands its `k` to the
/// session's outdoor stage.
pub(super) fn hindsight_pass(scene: &Scene, input: &Input, session: &mut OutdoorSession, from: usize, enabled: bool, obs: &mut dyn Observer, stop: &AtomicUsize) -> Result<HindsightSummary> {
    let skipped = |reason: &str| Ok(HindsightSummary { reason: reason.into(), ..HindsightSummary::default() });
    if !enabled {
        return skipped("turned off (--no-hindsight)");
    }
    if scene.lights.is_empty() {
        return skipped("the scene has no [[lights]]");
    }
    let started = std::time::Instant::now();
    let mut est = session.stage.estimator.fresh(scene).with_context(|| format!("setting up the lamps' pre-pass for {}", scene.root.display()))?;
    let lin = input.photometry.linearizer();
    let mut source = input.open()?;
    for i in 0..from {
        if !source.skip()? {
            bail!("{}: the input has {i} frames; the run starts at frame {from}", input.label);
        }
    }
    let (w, h) = (scene.camera.intrinsics.width, scene.camera.intrinsics.height);
    obs.start("lamps in hindsight: estimating to the end of the input first", input.count.map(|n| n.saturating_sub(from)), 0);
    let mut frames = Vec::new();
    let mut t0 = None;
    let mut stopped = None;
    for i in from.. {
        if stop.load(Ordering::SeqCst) > 0 {
            stopped = Some("interrupted".to_owned());
            break;
        }
        let f = match source.read() {
            Ok(Some(f)) => f,
            Ok(None) => break,
            Err(e) => {
                stopped = Some(format!("frame {i} unreadable: {e:#}"));
                break;
            }
        };
        if f.frame.check_size(std::path::Path::new(&f.label), w, h).is_err() {
            stopped = Some(format!("frame {i} is not {w}×{h}"));
            break;
        }
        let estimate = input.clock.time(i, f.ts_ms, None).map_err(anyhow::Error::from).and_then(|time| Ok((time, est.estimate(i, &time, &f.frame, &lin)?)));
        let (time, e) = match estimate {
            Ok(v) => v,
            Err(e) => {
                stopped = Some(format!("frame {i}: {e:#}"));
                break;
            }
        };
        let t0 = *t0.get_or_insert(time);
        frames.push((i, (time - t0).num_milliseconds() as f64 / 1e3, e.lamps));
        obs.advance();
    }
    obs.finish();
    let ms = started.elapsed().as_secs_f64() * 1e3;
    if !frames.iter().any(|(_, _, lamps)| lamps.iter().any(|l| l.status != LampStatus::Off)) {
        return Ok(HindsightSummary { reason: "no lamp is on in any frame".into(), frames: frames.len(), ms, ..HindsightSummary::default() });
    }
    let n = frames.len();
    session.stage.set_hindsight(LampHindsight::from_reports(scene, frames.iter().map(|(i, t, l)| (*i, *t, &l[..]))));
    let reason = match stopped {
        Some(why) => format!("frames {from}..{} estimated ahead; stopped there ({why}): later frames keep the forward filter's k", from + n),
        None => format!("frames {from}..{} estimated ahead (to the end of the input)", from + n),
    };
    Ok(HindsightSummary { ran: true, reason, frames: n, ms })
}
