//! One frame's samples (Jensen §3.1, "500 random pixels"): draw the pool entries, read and
//! linearise their pixels, and keep the rows of the fit. Clipped and invalid pixels are
//! dropped, and so are the unclipped pixels of a surface class that is partly clipped
//! (censoring, see `CENSOR_FRACTION`).

use super::pool::SunState;
use super::{CENSOR_FRACTION, Estimator, SampleCounts};
use super::surface_flags::SurfaceFlagsReport;
use crate::io::frames::{Frame, Linearizer, PixelState};
use rand::rngs::SmallRng;

/// What [`Estimator::gather`] leaves besides the rows.
pub(super) struct Gathered {
    /// Sample accounting.
    pub counts: SampleCounts,
    /// Clipped samples that were sunlit.
    pub clipped_lit: usize,
    /// More than `saturated_fraction` of the drawn samples clipped.
    pub saturated: bool,
}

impl Estimator {
    /// Draws the frame's samples and fills `rows`, `lit`, `bounce_only` and `rho_over_pi`.
    pub(super) fn gather(&mut self, frame: &Frame, lin: &Linearizer, rng: &mut SmallRng) -> Gathered {
        let overcast = self.overcast();
        self.clear_rows(overcast);
        let Some(sun) = self.sun.as_ref() else { unreachable!("ensure_sun always sets the state") };
        let sun: &SunState = sun;
        let available = sun.available();
        // Flagged surfaces are left out of the draw (`super::surface_flags`).
        let (excluded, flagged, cap) = self.flags.as_ref().map_or((None, 0, 0), |f| f.exclusion(sun.valid()));
        let left_out = excluded.as_ref().map_or(0, |x| x.iter().filter(|&&x| x).count());
        self.flag_report = self.flags.as_ref().map(|_| SurfaceFlagsReport { flagged, excluded: left_out, cap, ..Default::default() });
        self.flag_pd = None;
        let n = self.config.samples.min(available - left_out);
        let mut drawn = std::mem::take(&mut self.drawn);
        sun.draw_excluding(n, rng, &mut drawn, excluded.as_deref());
        let mut counts = SampleCounts { available, drawn: n, ..Default::default() };
        let mut clipped_lit = 0;
        // Censoring: count drawn and clipped samples per (node, lit, lamp band) group first (the
        // band is 0 without lamps; `super::lamps`).
        let band = |e: usize| self.lamps.as_ref().map_or(0, |l| l.band[e]);
        let mut groups: Vec<(u32, bool, u8, u32, u32)> = Vec::new(); // (node, lit, band, drawn, clipped)
        let mut states = std::mem::take(&mut self.states);
        states.clear();
        for &e in &drawn {
            let e = e as usize;
            let (v, state) = lin.radiance(frame, self.pool.pixel[e] as usize);
            states.push((v, state));
            let key = (self.pool.node[e], sun.lit[e], band(e));
            let g = match groups.iter().position(|g| (g.0, g.1, g.2) == key) {
                Some(g) => g,
                None => {
                    groups.push((key.0, key.1, key.2, 0, 0));
                    groups.len() - 1
                }
            };
            groups[g].3 += 1;
            groups[g].4 += (state == PixelState::Clipped) as u32;
        }
        let censored = |node: u32, lit: bool, band: u8| {
            groups.iter().any(|g| g.0 == node && g.1 == lit && g.2 == band && g.4 as f64 > CENSOR_FRACTION * g.3 as f64)
        };
        for (&e, &(v, state)) in drawn.iter().zip(&states) {
            let e = e as usize;
            match state {
                PixelState::Invalid => counts.invalid += 1,
                PixelState::Clipped => {
                    counts.clipped += 1;
                    clipped_lit += sun.lit[e] as usize;
                }
                PixelState::Ok if censored(self.pool.node[e], sun.lit[e], band(e)) => counts.censored += 1,
                PixelState::Ok => {
                    let (a, b) = self.entry_columns(sun, e, overcast);
                    for c in 0..3 {
                        self.rows[c].push(a[c] as f64, b[c] as f64, v[c] as f64);
                    }
                    self.lit.push(sun.lit[e]);
                    self.entries.push(e as u32);
                    if let Some(band) = self.sun_sky.as_ref().and_then(|s| s.band.as_ref()).filter(|_| self.band.on) {
                        self.band_rows.push(band[e].map(f64::from));
                    }
                    // The part of b that is bounce light only (for held-Pd subtraction).
                    let bo = if sun.lit[e] { [0.0; 3] } else { [b[0] as f64, b[1] as f64, b[2] as f64] };
                    self.bounce_only.push(bo);
                    let rho = self.pool.albedo[e] / std::f32::consts::PI;
                    self.rho_over_pi.push([rho.x as f64, rho.y as f64, rho.z as f64]);
                }
            }
        }
        self.states = states;
        self.drawn = drawn;
        counts.usable = self.rows[0].len();
        counts.lit = self.lit.iter().filter(|&&l| l).count();
        let saturated = n > 0 && counts.clipped as f64 > self.config.saturated_fraction * n as f64;
        Gathered { counts, clipped_lit, saturated }
    }

    /// The sky's and the sun's coefficients (`a`, `b`) of pool entry `e` in this frame's model.
    pub(super) fn entry_columns(&self, sun: &SunState, e: usize, overcast: bool) -> ([f32; 3], [f32; 3]) {
        match &self.sun_sky {
            Some(sky) => {
                let a = match self.turbidity_pick.and_then(|i| sky.by_turbidity.get(i)) {
                    _ if overcast => sky.a_overcast[e],
                    Some((_, a_t)) => a_t[e],
                    None => sky.a[e],
                };
                (a, std::array::from_fn(|c| sun.b[e][c] + sky.b[e][c]))
            }
            None => (self.pool.a[e], sun.b[e]),
        }
    }

    /// Empties the last frame's rows and decides whether this frame fits the twilight band.
    fn clear_rows(&mut self, overcast: bool) {
        for r in &mut self.rows {
            r.clear();
        }
        self.lit.clear();
        self.bounce_only.clear();
        self.rho_over_pi.clear();
        self.entries.clear();
        self.band_rows.clear();
        // The horizon band is a column at twilight under the shaped sky (`super::sky_band`).
        self.band = super::sky_band::BandFrame { on: !overcast && self.sun_sky.as_ref().is_some_and(|s| s.band.is_some()), ..Default::default() };
        if !self.band.on {
            // Past twilight (or under an overcast sky) the band's prior starts afresh.
            self.band_track = None;
        }
    }
}
