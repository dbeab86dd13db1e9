//! The estimator's sun-dependent terms after a sun move, without a stall (issue 13 part 4).
//!
//! # What depends on the sun
//! Per pool entry ([`super::pool`]): the *direct* terms, sun visibility `s`, `max(n·l, 0)` and
//! the shadow-boundary test (17 shadow rays); the sky's shape term of `a` ([`super::sky_terms`],
//! a quadrature of `sky.directions` sky radiances, evaluated once per shared normal); and the
//! *slow* terms, the sun bounce `b` (a path trace of `bounce.paths` paths) and, under a sky that
//! is not Jensen's, the interreflected part of `c` under that sky (`Δc_ir`, traced along the same
//! paths: the sky's evaluations, no extra ray; about +50% on the bounce's time on the winter
//! scenes in a debug build). On the courtyard at
//! 320×240 a whole rebuild takes ≈ 0.6–0.8 s, nearly all of it the bounce; the sky term takes
//! ≈ 11 ms and the direct terms 3–10 ms (`heliar bench estimate --knob moving-sun`). The bounce
//! changes little when the sun moves by a fraction of a degree; the direct terms decide which
//! entries are sunlit and the sky's shape follows the sun closely (a low sun's circumsolar glow),
//! so those two follow the sun at once.
//!
//! # How it works
//! When the sun has moved more than `sun_rebuild_deg` from the one the direct terms belong to,
//! or crossed the horizon, the direct terms and the sky term are rebuilt whole in that frame. The
//! bounce
//! follow the pattern of the renderer's sliced re-trace (`render::object_transfer`'s `retrace`):
//! each frame takes one [`Step`], decided from the stored state and the frame's sun only (never
//! from wall-clock time or thread timing), so a resumed, chunked or replayed run, which
//! estimates the same frames in the same order, takes the same steps:
//! - **Full**: every entry now: on the first frame, when the sun crosses the horizon, or after a
//!   sun move when `trace_paths_per_frame` is 0 (unbounded) or covers the whole pool.
//! - **Slice**: the sun has moved more than `sun_rebuild_deg` from the one the served bounce
//!   belongs to. A job for the frame's sun starts; each frame (this one first) computes the next
//!   entries, in pool order, within `trace_paths_per_frame` paths, while the served terms keep
//!   serving (with the frame's direct and sky terms). The frame that computes the last slice
//!   swaps the job's values in. A job runs to its end for the sun seen at its start; the next
//!   frame then compares the sun with it again. The served bounce thus lags the sun by at most
//!   one job: `pool_size·bounce.paths/trace_paths_per_frame` frames (64 with the defaults).
//! - **Keep**: nothing to do.
//!
//! Every entry's values are a pure function of its seed and the sun, so a completed job equals a
//! full build for its sun bit for bit.

use super::EstimatorConfig;
use super::pool::{LIT_COS_MIN, NO_HIT, PixelMap, Pool, SunState};
use super::sky_terms::{SkyTerms, SunSky};
use crate::geometry::ambient::{UniformSky, transport, transport_with_bounced};
use crate::geometry::raycast::RayScene;
use crate::sky::SkyError;
use crate::sky::radiance::{ShapeMinusUniform, SkyModel, SkyRadiance};
use glam::Vec3;
use rayon::prelude::*;
use std::f32::consts::PI;
use std::ops::Range;
use std::time::Instant;

/// What the sun-dependent terms read: the estimator's fixed inputs.
pub struct Inputs<'a> {
    /// The pixel map (ring pixels of the boundary test).
    pub map: &'a PixelMap,
    /// The pool.
    pub pool: &'a Pool,
    /// The proxy.
    pub scene: &'a RayScene,
    /// The settings.
    pub cfg: &'a EstimatorConfig,
    /// The sky terms, when the sky is not Jensen's.
    pub sky: Option<&'a SkyTerms>,
}

/// Per-entry direct terms for one sun.
#[derive(Clone, Debug, PartialEq)]
pub struct DirectTerms {
    /// The sun they belong to.
    pub sun: Vec3,
    /// Whether it was above the horizon.
    pub above: bool,
    /// `s·max(n·l, 0)`.
    pub direct: Vec<f32>,
    /// Sunlit (`s = 1` and `n·l ≥` [`LIT_COS_MIN`]).
    pub lit: Vec<bool>,
    /// Away from shadow boundaries.
    pub ok: Vec<bool>,
}

/// Per-entry slow terms for one sun.
#[derive(Clone, Debug, PartialEq)]
pub struct SlowTerms {
    /// The sun they belong to.
    pub sun: Vec3,
    /// Whether it was above the horizon.
    pub above: bool,
    /// Sun-bounce irradiance per unit `Pd` (zero when `sun_bounce` is off or no sun); under a
    /// sky with terrain it includes the sunlit terrain seen after a bounce.
    pub bounce: Vec<Vec3>,
    /// Under a sky that is not Jensen's (with `sun_bounce` on): per entry, the change of `c`'s
    /// interreflected part that the sky's shape and the terrain bring, per unit `Pa` (`Δc_ir`,
    /// see [`super::sky_terms`]); empty otherwise.
    pub sky_bounced: Vec<Vec3>,
    /// Under `turbidity = "fit"`: the same for each candidate turbidity (each candidate's own
    /// sky along the same paths).
    pub sky_bounced_fit: Vec<(f64, Vec<Vec3>)>,
}

/// Where one frame's time on the sun-dependent terms went, ms, and what was done.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SunTimings {
    /// Shadow rays of the entries' own pixels.
    pub visibility_ms: f64,
    /// Shadow rays of the boundary rings.
    pub rings_ms: f64,
    /// Sun-bounce path traces.
    pub bounce_ms: f64,
    /// The sky's shape (its normalisation and the quadrature).
    pub sky_ms: f64,
    /// Putting the served terms together.
    pub assemble_ms: f64,
    /// The direct terms were rebuilt.
    pub direct_rebuilt: bool,
    /// Entries whose slow terms were computed.
    pub slow_entries: usize,
    /// The served slow terms changed (a full build, or a job's last slice).
    pub swapped: bool,
}

impl SunTimings {
    /// All of it, ms.
    pub fn total_ms(&self) -> f64 {
        self.visibility_ms + self.rings_ms + self.bounce_ms + self.sky_ms + self.assemble_ms
    }
}

/// A re-trace of the bounce for a new sun, done a slice per frame.
#[derive(Clone, Debug)]
struct Job {
    terms: SlowTerms,
}

/// One frame's step for the slow terms (module docs).
#[derive(Clone, Debug, PartialEq)]
enum Step {
    Keep,
    Full,
    Slice(Range<usize>),
}

fn ms_since(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

/// The terms for sun `(sun, above)` are stale for the frame's `(dir, now_above)`.
fn stale(sun: Vec3, above: bool, dir: Vec3, now_above: bool, deg: f64) -> bool {
    above != now_above || (now_above && (sun.dot(dir).clamp(-1.0, 1.0).acos().to_degrees() as f64) > deg)
}

/// Entries per slice for `cfg` (0: unbounded, or nothing to trace).
pub fn slice_entries(cfg: &EstimatorConfig) -> usize {
    if cfg.trace_paths_per_frame == 0 || !cfg.sun_bounce {
        return 0;
    }
    (cfg.trace_paths_per_frame / (cfg.bounce.paths as u64).max(1)).max(1) as usize
}

impl DirectTerms {
    /// Traces the direct terms of every entry for sun `l`; returns them with the times of the
    /// entries' own shadow rays and of the rings'.
    pub fn trace(inp: &Inputs, l: Vec3, above: bool) -> (Self, f64, f64) {
        let n = inp.pool.len();
        if !above {
            return (Self { sun: l, above, direct: vec![0.0; n], lit: vec![false; n], ok: vec![true; n] }, 0.0, 0.0);
        }
        let (map, scene) = (inp.map, inp.scene);
        let visible = |i: usize| -> bool { map.tri[i] != NO_HIT && map.normal[i].dot(l) > 0.0 && scene.sees_direction(map.point[i], map.normal[i], l) };
        let t = Instant::now();
        let s: Vec<bool> = inp.pool.pixel.par_iter().map(|&px| visible(px as usize)).collect();
        let visibility_ms = ms_since(t);
        let t = Instant::now();
        let (w, h) = (map.width as i64, map.height as i64);
        let r = inp.cfg.edge_margin_px as i64;
        let ok: Vec<bool> = (0..n)
            .into_par_iter()
            .map(|k| {
                // Shadow-boundary test on two square rings (`pool` module docs).
                let px = inp.pool.pixel[k] as i64;
                let (x0, y0) = (px % w, px / w);
                for rad in [r, (r + 1) / 2] {
                    if rad == 0 {
                        continue;
                    }
                    for (dx, dy) in [(-1, -1), (0, -1), (1, -1), (-1, 0), (1, 0), (-1, 1), (0, 1), (1, 1)] {
                        let (x, y) = (x0 + dx * rad, y0 + dy * rad);
                        if x >= 0 && y >= 0 && x < w && y < h && visible((y * w + x) as usize) != s[k] {
                            return false;
                        }
                    }
                }
                true
            })
            .collect();
        let rings_ms = ms_since(t);
        let cos = |k: usize| inp.pool.normal[k].dot(l).max(0.0);
        let direct = (0..n).map(|k| if s[k] { cos(k) } else { 0.0 }).collect();
        let lit = (0..n).map(|k| s[k] && cos(k) >= LIT_COS_MIN).collect();
        (Self { sun: l, above, direct, lit, ok }, visibility_ms, rings_ms)
    }
}

impl SlowTerms {
    /// Empty terms for sun `l`, to be filled in pool order.
    fn empty(l: Vec3, above: bool) -> Self {
        Self { sun: l, above, bounce: Vec::new(), sky_bounced: Vec::new(), sky_bounced_fit: Vec::new() }
    }

    /// Computes the entries of `range` for this sun and appends them; returns the time.
    fn extend(&mut self, inp: &Inputs, range: Range<usize>) -> f64 {
        let (l, cfg, pool) = (self.sun, inp.cfg, inp.pool);
        let t = Instant::now();
        let seed = |k: usize| cfg.seed.wrapping_add(pool.pixel[k] as u64) ^ 0xb0b0;
        let bounce_on = cfg.sun_bounce && self.above;
        // The sky the paths see after a bounce (the same paths as the sun's bounce: no extra ray),
        // then each candidate turbidity's under `turbidity = "fit"`.
        let sky = inp.sky.filter(|_| cfg.sun_bounce).map(|s| (s, s.model())).filter(|(_, m)| !m.is_uniform());
        if let Some((terms, model)) = sky {
            let fit = terms.fit_candidates();
            let skies: Vec<SkyRadiance> = std::iter::once(model.hosek_turbidity)
                .chain(fit.iter().map(|&t| Some(t)))
                .map(|t| SkyModel { hosek_turbidity: t, ..model.clone() }.for_sun(Some(l)))
                .collect();
            let deltas: Vec<ShapeMinusUniform> = skies.iter().map(ShapeMinusUniform).collect();
            let traced: Vec<(Vec3, Vec<Vec3>)> = range
                .clone()
                .into_par_iter()
                .map(|k| {
                    let (t, d) = transport_with_bounced(inp.scene, pool.point[k], pool.normal[k], bounce_on.then_some(l), &UniformSky, &deltas, cfg.bounce, seed(k));
                    (if bounce_on { t.b + d[0].b } else { Vec3::ZERO }, d.iter().map(|x| x.c).collect())
                })
                .collect();
            if self.sky_bounced_fit.len() != fit.len() {
                self.sky_bounced_fit = fit.iter().map(|&t| (t, Vec::new())).collect();
            }
            for (b, c) in traced {
                self.bounce.push(b);
                self.sky_bounced.push(c[0]);
                for (slot, v) in self.sky_bounced_fit.iter_mut().zip(&c[1..]) {
                    slot.1.push(*v);
                }
            }
        } else if bounce_on {
            let traced: Vec<Vec3> = range.clone().into_par_iter().map(|k| transport(inp.scene, pool.point[k], pool.normal[k], Some(l), cfg.bounce, seed(k)).b).collect();
            self.bounce.extend(traced);
        } else {
            self.bounce.resize(range.end, Vec3::ZERO);
        }
        ms_since(t)
    }

    /// Every entry for sun `l`; returns the terms with the time.
    pub fn full(inp: &Inputs, l: Vec3, above: bool) -> (Self, f64) {
        let mut terms = Self::empty(l, above);
        let ms = terms.extend(inp, 0..inp.pool.len());
        (terms, ms)
    }
}

/// The sky's ambient coefficient of every entry for sun `l` (`None` without sky terms).
fn sky_ambient(inp: &Inputs, l: Vec3) -> Result<Option<Vec<[f32; 3]>>, SkyError> {
    inp.sky.map(|s| Ok(s.ambient(inp.pool, &s.shape(l)?, 0..inp.pool.len()))).transpose()
}

/// Every sun-dependent term for sun `l` built whole, as a completed re-trace serves it: the
/// state and, with sky terms, the sky's terms with the interreflected part of the same sun.
pub fn whole(inp: &Inputs, l: Vec3, above: bool) -> Result<(SunState, Option<SunSky>), SkyError> {
    let (direct, _, _) = DirectTerms::trace(inp, l, above);
    let (slow, _) = SlowTerms::full(inp, l, above);
    let state = assemble(inp.pool, &direct, &slow.bounce);
    let sky = match (inp.sky, sky_ambient(inp, l)?) {
        (Some(s), Some(a)) => {
            let mut sky = s.assemble(inp.pool, a, l, above);
            sky.add_bounced(inp.pool, &slow.sky_bounced, &slow.sky_bounced_fit);
            Some(sky)
        }
        _ => None,
    };
    Ok((state, sky))
}

/// The served state of one sun: the entries' coefficients (`ρ·(s·max(n·l,0) + b)/π`), from the
/// direct terms of one sun and the bounce of the same or an earlier one.
pub fn assemble(pool: &Pool, direct: &DirectTerms, bounce: &[Vec3]) -> SunState {
    let mut st = SunState {
        dir: direct.sun,
        above_horizon: direct.above,
        b: Vec::with_capacity(pool.len()),
        lit: direct.lit.clone(),
        valid_lit: Vec::new(),
        valid_unlit: Vec::new(),
        near_shadow_boundary: 0,
        build_ms: 0.0,
    };
    for k in 0..pool.len() {
        let coef = if direct.above {
            let bounce = bounce.get(k).copied().unwrap_or(Vec3::ZERO);
            pool.albedo[k] * (Vec3::splat(direct.direct[k]) + bounce) / PI
        } else {
            Vec3::ZERO
        };
        st.b.push(coef.to_array());
        match (direct.ok[k], direct.lit[k]) {
            (true, true) => st.valid_lit.push(k as u32),
            (true, false) => st.valid_unlit.push(k as u32),
            (false, _) => st.near_shadow_boundary += 1,
        }
    }
    st
}

/// The estimator's sun-dependent terms across frames (module docs).
#[derive(Clone, Debug, Default)]
pub struct SunTerms {
    direct: Option<DirectTerms>,
    /// The sky's ambient coefficients for the direct terms' sun.
    sky_a: Option<Vec<[f32; 3]>>,
    slow: Option<SlowTerms>,
    job: Option<Job>,
}

impl SunTerms {
    /// The step the slow terms take this frame (no change to the state).
    fn next_step(&self, inp: &Inputs, dir: Vec3, above: bool) -> Step {
        let n = inp.pool.len();
        let slice = match slice_entries(inp.cfg) {
            0 => n,
            s => s,
        };
        match (&self.slow, &self.job) {
            (None, _) => Step::Full,
            (Some(s), _) if s.above != above => Step::Full,
            (Some(_), Some(job)) => {
                let done = job.terms.bounce.len();
                Step::Slice(done..(done + slice).min(n))
            }
            (Some(s), None) if stale(s.sun, s.above, dir, above, inp.cfg.sun_rebuild_deg) => {
                if slice >= n { Step::Full } else { Step::Slice(0..slice) }
            }
            _ => Step::Keep,
        }
    }

    /// A re-trace in progress: its sun and the fraction of the pool done.
    pub fn retrace_progress(&self, pool_len: usize) -> Option<(Vec3, f64)> {
        self.job.as_ref().map(|j| (j.terms.sun, j.terms.bounce.len() as f64 / pool_len.max(1) as f64))
    }

    /// Moves the terms on to the frame's sun `(dir, above)`: the direct terms rebuilt when stale,
    /// the slow terms' step taken. Returns the served state and sky terms when they changed.
    pub fn update(&mut self, inp: &Inputs, dir: Vec3, above: bool) -> Result<(SunTimings, Option<(SunState, Option<SunSky>)>), SkyError> {
        let mut t = SunTimings::default();
        let direct_stale = self.direct.as_ref().is_none_or(|d| stale(d.sun, d.above, dir, above, inp.cfg.sun_rebuild_deg));
        if direct_stale {
            let (d, vis, rings) = DirectTerms::trace(inp, dir, above);
            (self.direct, t.visibility_ms, t.rings_ms, t.direct_rebuilt) = (Some(d), vis, rings, true);
            let t0 = Instant::now();
            self.sky_a = sky_ambient(inp, dir)?;
            t.sky_ms = ms_since(t0);
        }
        match self.next_step(inp, dir, above) {
            Step::Keep => {}
            Step::Full => {
                let (terms, ms) = SlowTerms::full(inp, dir, above);
                (self.job, self.slow) = (None, Some(terms));
                (t.bounce_ms, t.slow_entries, t.swapped) = (ms, inp.pool.len(), true);
            }
            Step::Slice(range) => {
                let job = self.job.get_or_insert_with(|| Job { terms: SlowTerms::empty(dir, above) });
                t.slow_entries = range.len();
                t.bounce_ms = job.terms.extend(inp, range);
                if job.terms.bounce.len() == inp.pool.len() {
                    self.slow = self.job.take().map(|j| j.terms);
                    t.swapped = true;
                }
            }
        }
        if !(t.direct_rebuilt || t.swapped) {
            return Ok((t, None));
        }
        let t0 = Instant::now();
        let (Some(direct), Some(slow)) = (&self.direct, &self.slow) else { unreachable!("both are set on the first frame") };
        let mut state = assemble(inp.pool, direct, &slow.bounce);
        let sky = inp.sky.zip(self.sky_a.as_ref()).map(|(s, a)| {
            let mut sky = s.assemble(inp.pool, a.clone(), direct.sun, direct.above);
            sky.add_bounced(inp.pool, &slow.sky_bounced, &slow.sky_bounced_fit);
            sky
        });
        t.assemble_ms = ms_since(t0);
        state.build_ms = t.total_ms();
        Ok((t, Some((state, sky))))
    }
}
