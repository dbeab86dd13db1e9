//! The irradiance volume's transfer from environment texels to probe SH (Jensen §3.3–3.4).
//!
//! # How it works
//! **Offline, per probe.** `K` directions (spherical Fibonacci, `4π/K` sr each) are cast from the
//! probe against the proxy. A direction that hits the proxy at `y` looks up the environment texel
//! that shows `y` from the capture centre (the paper's mapping of the scene onto the model); a
//! direction that escapes above the horizon sees the sky; one that escapes below it sees nothing.
//! Folding with the SH basis gives a sparse transfer per probe: `(texel, Y_lm(ω)·4π/K)` entries
//! (merged per texel) and the sky's SH weights. A probe whose rays mostly hit back faces lies inside
//! closed geometry and is marked invalid.
//!
//! **Online, full path.** `L_lm = Σ_texels T_lm·P(texel) + S_lm·Pa/π` from the relit map `P`, then
//! `E_lm = Â_l·L_lm` ([`super::sh`]). Cost: probes × entries × 9 × 3.
//!
//! **Online, linear path.** Relighting is linear in `Pa` and `Pd`:
//! `P = A·Pa + D·Pd` with the relighter's ambient plane `A` (sky included) and direct plane `D`. So
//! per probe `E = Â·(T·A + S/π)·Pa + Â·(T·D)·Pd`: the two bracketed responses are precomputed (the
//! `D` one whenever the relighter rebuilt its sun planes) and a frame's update is
//! `O(probes × 9 × 2)` per channel. Both paths agree to rounding (tested).
//!
//! **Parallax.** A hit point hidden from the capture centre is shaded with the surface the centre
//! sees in that direction instead; the count of such lookups is reported (`parallax_lookups`).

use super::sh::{self, COSINE_LOBE, ShRgb};
use super::ProbeGrid;
use crate::envmap::bake::Baked;
use crate::envmap::relight::{RelitMap, Relighter};
use crate::geometry::equirect::texel_index;
use crate::geometry::raycast::RayScene;
use crate::geometry::sampling::{sample_cosine_around, sample_stratified_2d, sphere_fibonacci};
use crate::sky::radiance::SkyRadiance;
use glam::{UVec3, Vec3};
use rand::{SeedableRng, rngs::SmallRng};
use rayon::prelude::*;
use std::f32::consts::{FRAC_1_PI, PI};

/// A hit whose baked texel shows a point farther than this fraction of the viewing distance from
/// it counts as a parallax lookup.
const PARALLAX_REL: f32 = 0.05;
/// Back-face hit fraction above which a probe is inside closed geometry.
const INSIDE_FRACTION: f32 = 0.5;

/// Counts of a transfer build.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct TransferStats {
    /// Probes.
    pub probes: usize,
    /// Probes inside geometry.
    pub invalid_probes: usize,
    /// Directions per probe.
    pub directions: usize,
    /// Stored (texel, weights) entries over all probes.
    pub entries: usize,
    /// Directions that hit the proxy.
    pub hits: usize,
    /// Of those, looked up through a texel that shows another point.
    pub parallax_lookups: usize,
    /// Build time, ms.
    pub build_ms: f64,
}

/// Per-probe sparse transfer.
#[derive(Clone, Debug)]
pub struct ProbeTransfer {
    /// Grid geometry and validity (coefficients unused).
    template: ProbeGrid,
    offsets: Vec<u32>,
    texels: Vec<u32>,
    weights: Vec<[f32; sh::N]>,
    sky: Vec<[f32; sh::N]>,
    /// Per probe, the directions that leave the proxy (above and below the horizon), as
    /// `escaped[escaped_offsets[i]..escaped_offsets[i + 1]]`: what a shaped sky and the terrain
    /// light ([`Self::sky_response`]).
    escaped_offsets: Vec<u32>,
    escaped: Vec<u32>,
    /// The directions' SH basis values times their solid angle.
    basis: Vec<[f32; sh::N]>,
    dirs: Vec<Vec3>,
    /// Counts.
    pub stats: TransferStats,
}

/// The linear path's precomputed responses (irradiance SH per unit `Pa` and per unit `Pd`).
#[derive(Clone, Debug, Default)]
pub struct LinearBasis {
    /// Per probe, irradiance SH per unit `Pa` (channel-wise).
    pub ambient: Vec<ShRgb>,
    /// Per probe, irradiance SH per unit `Pd`; empty until a sun is set.
    pub direct: Vec<ShRgb>,
}

impl ProbeTransfer {
    /// Builds the transfer for probes over `[min, max]` every `spacing` metres.
    pub fn build(min: Vec3, max: Vec3, spacing: f32, baked: &Baked, ray: &RayScene, directions: usize) -> Self {
        let t0 = std::time::Instant::now();
        let mut template = ProbeGrid::filled(min, max, spacing, [[0.0; 3]; sh::N]);
        let dirs = sphere_fibonacci(directions);
        let basis: Vec<[f32; sh::N]> = dirs.iter().map(|d| sh::basis(*d).map(|y| y * 4.0 * PI / directions as f32)).collect();
        let dims = template.dims;
        let n = (dims.x * dims.y * dims.z) as usize;
        let rows: Vec<ProbeRows> = (0..n)
            .into_par_iter()
            .map(|i| {
                let (x, y, z) = (i as u32 % dims.x, (i as u32 / dims.x) % dims.y, i as u32 / (dims.x * dims.y));
                trace_probe(template.position(x, y, z), &dirs, &basis, baked, ray)
            })
            .collect();
        let mut out = ProbeTransfer {
            template: ProbeGrid { coeffs: Vec::new(), ..template.clone() },
            offsets: Vec::with_capacity(n + 1),
            texels: Vec::new(),
            weights: Vec::new(),
            sky: Vec::with_capacity(n),
            escaped_offsets: vec![0],
            escaped: Vec::new(),
            basis,
            dirs,
            stats: TransferStats { probes: n, directions, ..Default::default() },
        };
        out.offsets.push(0);
        for (i, r) in rows.into_iter().enumerate() {
            template.valid[i] = r.valid;
            out.stats.invalid_probes += (!r.valid) as usize;
            out.stats.hits += r.hits;
            out.stats.parallax_lookups += r.parallax;
            for (t, wv) in r.entries {
                out.texels.push(t);
                out.weights.push(wv);
            }
            out.offsets.push(out.texels.len() as u32);
            out.sky.push(r.sky);
            out.escaped.extend(r.escaped);
            out.escaped_offsets.push(out.escaped.len() as u32);
        }
        out.template.valid = template.valid;
        out.stats.entries = out.texels.len();
        out.stats.build_ms = t0.elapsed().as_secs_f64() * 1e3;
        out
    }

    /// Number of probes.
    pub fn probes(&self) -> usize {
        self.sky.len()
    }

    /// An empty grid with this transfer's geometry and validity.
    pub fn grid(&self) -> ProbeGrid {
        ProbeGrid { coeffs: vec![[[0.0; 3]; sh::N]; self.probes()], ..self.template.clone() }
    }

    /// Full path: probe SH from a relit map (surface texels) and the sky radiance `Pa/π`.
    pub fn full_into(&self, relit: &RelitMap, pa: Vec3, out: &mut ProbeGrid) {
        if out.coeffs.len() != self.probes() {
            *out = self.grid();
        }
        let sky_l = pa * FRAC_1_PI;
        out.coeffs.par_iter_mut().enumerate().for_each(|(i, c)| {
            let (s, e) = (self.offsets[i] as usize, self.offsets[i + 1] as usize);
            let mut acc = [[0.0f32; 3]; sh::N];
            for k in s..e {
                let t = self.texels[k] as usize;
                let (r, g, b) = (relit.rgb[0][t], relit.rgb[1][t], relit.rgb[2][t]);
                let wv = &self.weights[k];
                for m in 0..sh::N {
                    acc[m][0] += wv[m] * r;
                    acc[m][1] += wv[m] * g;
                    acc[m][2] += wv[m] * b;
                }
            }
            for m in 0..sh::N {
                for ch in 0..3 {
                    c[m][ch] = COSINE_LOBE[m] * (acc[m][ch] + self.sky[i][m] * sky_l[ch]);
                }
            }
        });
    }

    fn respond(&self, plane: &[Vec<f32>; 3], extra: Option<&[f32]>, with_sky: bool) -> Vec<ShRgb> {
        (0..self.probes())
            .into_par_iter()
            .map(|i| {
                let (s, e) = (self.offsets[i] as usize, self.offsets[i + 1] as usize);
                let mut acc = [[0.0f32; 3]; sh::N];
                for k in s..e {
                    let t = self.texels[k] as usize;
                    let add = extra.map_or(0.0, |x| x[t]);
                    for m in 0..sh::N {
                        for ch in 0..3 {
                            acc[m][ch] += self.weights[k][m] * (plane[ch][t] + add);
                        }
                    }
                }
                std::array::from_fn(|m| {
                    std::array::from_fn(|ch| COSINE_LOBE[m] * (acc[m][ch] + if with_sky { self.sky[i][m] * FRAC_1_PI } else { 0.0 }))
                })
            })
            .collect()
    }

    /// The irradiance SH per unit `Pa` and per unit `Pd` of the light that reaches each probe
    /// through its escaping directions under `sky` (its shape above the horizon, the terrain
    /// below).
    pub fn sky_response(&self, sky: &SkyRadiance) -> (Vec<ShRgb>, Vec<ShRgb>) {
        let light: Vec<(Vec3, Vec3)> = self.dirs.iter().map(|d| sky.escape(*d).map_or((Vec3::ZERO, Vec3::ZERO), |(a, b)| (a * FRAC_1_PI, b * FRAC_1_PI))).collect();
        (0..self.probes())
            .into_par_iter()
            .map(|i| {
                let (mut pa, mut pd) = ([[0.0f32; 3]; sh::N], [[0.0f32; 3]; sh::N]);
                for &k in &self.escaped[self.escaped_offsets[i] as usize..self.escaped_offsets[i + 1] as usize] {
                    let (a, b) = light[k as usize];
                    for m in 0..sh::N {
                        let y = self.basis[k as usize][m];
                        for ch in 0..3 {
                            pa[m][ch] += y * a[ch];
                            pd[m][ch] += y * b[ch];
                        }
                    }
                }
                let lobe = |v: [[f32; 3]; sh::N]| -> ShRgb { std::array::from_fn(|m| v[m].map(|x| COSINE_LOBE[m] * x)) };
                (lobe(pa), lobe(pd))
            })
            .unzip()
    }

    /// The ambient response of the linear path (per unit `Pa`). Under a shaped sky or with
    /// terrain, for the relighter's current sun.
    pub fn ambient_response(&self, relighter: &Relighter) -> Vec<ShRgb> {
        match relighter.sky_plane().filter(|_| relighter.sky_model().is_uniform()) {
            Some(sky) => self.respond(relighter.ambient_plane(), Some(sky), true),
            None => {
                let surfaces = self.respond(relighter.ambient_plane(), relighter.sky_plane(), false);
                let (sky, _) = self.sky_response(&relighter.sky_for_current_sun());
                add(surfaces, &sky)
            }
        }
    }

    /// The direct response of the linear path (per unit `Pd`) for the relighter's current sun;
    /// empty when no sun planes are built. With terrain, its sunlit share is included.
    pub fn direct_response(&self, relighter: &Relighter) -> Vec<ShRgb> {
        let Some(d) = relighter.direct_plane() else { return Vec::new() };
        let surfaces = self.respond(d, None, false);
        if relighter.sky_model().is_uniform() {
            return surfaces;
        }
        let (_, terrain) = self.sky_response(&relighter.sky_for_current_sun());
        add(surfaces, &terrain)
    }

    /// Linear path: `E = ambient·Pa + direct·Pd` per probe and channel.
    pub fn linear_into(&self, basis: &LinearBasis, pd: Vec3, pa: Vec3, out: &mut ProbeGrid) {
        if out.coeffs.len() != self.probes() {
            *out = self.grid();
        }
        let (pa, pd) = (pa.to_array(), pd.to_array());
        let with_direct = basis.direct.len() == basis.ambient.len();
        for (i, c) in out.coeffs.iter_mut().enumerate() {
            let a = &basis.ambient[i];
            for m in 0..sh::N {
                for ch in 0..3 {
                    c[m][ch] = a[m][ch] * pa[ch] + if with_direct { basis.direct[i][m][ch] * pd[ch] } else { 0.0 };
                }
            }
        }
    }
}

/// One probe's rays: the merged texel entries, the sky's SH weights, the escaping directions,
/// validity and counts.
struct ProbeRows {
    entries: Vec<(u32, [f32; sh::N])>,
    sky: [f32; sh::N],
    escaped: Vec<u32>,
    valid: bool,
    hits: usize,
    parallax: usize,
}

/// Casts `dirs` from the probe at `p` (module docs, "Offline, per probe").
fn trace_probe(p: Vec3, dirs: &[Vec3], basis: &[[f32; sh::N]], baked: &Baked, ray: &RayScene) -> ProbeRows {
    let (w, h) = (baked.width, baked.height);
    let directions = dirs.len();
    let mut entries: Vec<(u32, [f32; sh::N])> = Vec::with_capacity(directions / 2);
    let mut sky = [0.0f32; sh::N];
    let mut escaped = Vec::new();
    let (mut hits, mut back, mut parallax) = (0usize, 0usize, 0usize);
    for (k, &d) in dirs.iter().enumerate() {
        match ray.intersect(p, d, f32::MAX) {
            Some(hit) => {
                hits += 1;
                back += (ray.face_normal(hit.tri).dot(d) > 0.0) as usize;
                let to = hit.point - baked.centre;
                let t = texel_index(to, w, h);
                if (baked.position[t] - hit.point).length() > PARALLAX_REL * to.length() {
                    parallax += 1;
                }
                entries.push((t as u32, basis[k]));
            }
            None if d.y > 0.0 => {
                escaped.push(k as u32);
                for m in 0..sh::N {
                    sky[m] += basis[k][m];
                }
            }
            None => escaped.push(k as u32),
        }
    }
    entries.sort_unstable_by_key(|e| e.0);
    let mut merged: Vec<(u32, [f32; sh::N])> = Vec::with_capacity(entries.len());
    for (t, wv) in entries {
        match merged.last_mut() {
            Some(last) if last.0 == t => {
                for m in 0..sh::N {
                    last.1[m] += wv[m];
                }
            }
            _ => merged.push((t, wv)),
        }
    }
    let valid = !(hits > 0 && back as f32 > INSIDE_FRACTION * hits as f32);
    ProbeRows { entries: merged, sky, escaped, valid, hits, parallax }
}

/// `a + b` probe by probe.
fn add(mut a: Vec<ShRgb>, b: &[ShRgb]) -> Vec<ShRgb> {
    for (x, y) in a.iter_mut().zip(b) {
        for m in 0..sh::N {
            for ch in 0..3 {
                x[m][ch] += y[m][ch];
            }
        }
    }
    a
}

/// Brute-force irradiance at `p` with unit normal `n`: `samples` cosine-weighted rays (stratified)
/// that look up the relit map through the proxy exactly as the transfer does (hit → texel seen
/// from the capture centre; escape above the horizon → `Pa/π`; below → 0).
pub fn brute_force_irradiance(ray: &RayScene, centre: Vec3, relit: &RelitMap, pa: Vec3, p: Vec3, n: Vec3, samples: u32, seed: u64) -> Vec3 {
    let mut rng = SmallRng::seed_from_u64(seed);
    let mut sum = Vec3::ZERO;
    for k in 0..samples {
        let d = sample_cosine_around(n, sample_stratified_2d(k, samples, &mut rng));
        sum += match ray.intersect(p, d, f32::MAX) {
            Some(hit) => relit.get(texel_index(hit.point - centre, relit.width, relit.height)),
            None if d.y > 0.0 => pa * FRAC_1_PI,
            None => Vec3::ZERO,
        };
    }
    sum * PI / samples as f32
}

impl ProbeTransfer {
    /// Probe dimensions.
    pub fn dims(&self) -> UVec3 {
        self.template.dims
    }
}
