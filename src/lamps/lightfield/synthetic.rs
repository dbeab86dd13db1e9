//! A known near-field emitter and the simulated acquisition of its light field through the
//! filter basis (Granier §2, Eq. 2), for tests, the error curves and the bundled scenes.
//!
//! # The torch
//! [`TorchEmitter`]: a disc of radius `a` on the sampling plane, lit by a reflector. A point at
//! relative radius `ρ = |p|/a` emits around a beam axis tilted outward by `α(ρ) = α_max ρ` with a
//! Gaussian spread `σ` in angle, and with an aperture weight
//! `A(ρ) = S((ρ − ρ_b)/w) · S((1 − ρ)/w) · (1 − c sin²(π k (ρ − ρ_b)/(1 − ρ_b)))`: dark inside the
//! bulb's shadow `ρ < ρ_b`, soft at the rim, and `k` bright reflector rings of contrast `c`
//! (`S` the clamped smoothstep). Near the lamp one sees the rings and the dark centre of the
//! opening; far away, the same structure in angle: rings around a dark centre, since the points
//! that would light the axis are behind the bulb.
//!
//! # The acquisition
//! [`acquire`] evaluates Eq. 2 at every texel centre `(s, t)` of the measurement plane: a midpoint
//! rule over the emitter's square with `g = cos²θ/R²` and the dual filter of each position
//! ([`super::bellq::bellq_dual`]), then stores `E' = E · R_c⁴/d²` (Eq. 8–10). The radiance of a
//! point toward a texel does not depend on the filter, so each is evaluated once and added to
//! every position.
//!
//! [`emitter_irradiance`] is the truth the reconstructions are compared with: the same integral
//! as Eq. 12, over the emitter itself.

use super::bellq::FilterGrid;
use super::{LightField, LightFieldError};
use crate::io::image::LinearImage;
use glam::{DVec2, DVec3};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// A light-emitting patch on the sampling plane, described by its radiance.
pub trait Emitter: Sync {
    /// Radiance (per channel) leaving the sampling-plane point `p` in the unit direction `dir`
    /// (pointing away from the lamp, `dir.z < 0`).
    fn radiance(&self, p: DVec2, dir: DVec3) -> [f64; 3];
    /// Half-width of a square around the axis that holds all the emission (metres).
    fn extent_m(&self) -> f64;
}

/// The torch of the module docs; `truth.toml` in a synthetic light-field folder.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TorchEmitter {
    /// Radius `a` of the opening (metres).
    pub radius_m: f64,
    /// Bulb shadow radius `ρ_b` as a fraction of `a`.
    pub bulb_frac: f64,
    /// Width `w` of the soft edges, as a fraction of `a`.
    pub edge_frac: f64,
    /// Number `k` of reflector rings between bulb and rim.
    pub rings: f64,
    /// Ring contrast `c` in `[0, 1]`.
    pub ring_contrast: f64,
    /// Beam tilt at the rim `α_max` (degrees).
    pub divergence_deg: f64,
    /// Angular spread `σ` of each point's beam (degrees).
    pub spread_deg: f64,
    /// Peak radiance per channel.
    pub radiance: [f64; 3],
}

impl Default for TorchEmitter {
    /// A mini torch: 10 mm opening radius, a bulb shadow over the inner 30 %, one and a half
    /// rings, a 14° beam of 2.5° spread, warm light. (The spread is wide enough for the paper's
    /// relative filter width `s = 0.04`, 2.3°: a narrower beam is blurred by the filters.)
    fn default() -> Self {
        Self { radius_m: 0.01, bulb_frac: 0.3, edge_frac: 0.08, rings: 1.5, ring_contrast: 0.6, divergence_deg: 14.0, spread_deg: 2.5, radiance: [1.0, 0.8, 0.55] }
    }
}

/// The clamped smoothstep `x²(3 − 2x)`.
fn smoothstep(x: f64) -> f64 {
    let x = x.clamp(0.0, 1.0);
    x * x * (3.0 - 2.0 * x)
}

impl TorchEmitter {
    /// The aperture weight `A(ρ)` (module docs).
    pub fn aperture(&self, rho: f64) -> f64 {
        if !(0.0..1.0).contains(&rho) {
            return 0.0;
        }
        let ring_phase = std::f64::consts::PI * self.rings * (rho - self.bulb_frac) / (1.0 - self.bulb_frac);
        smoothstep((rho - self.bulb_frac) / self.edge_frac) * smoothstep((1.0 - rho) / self.edge_frac) * (1.0 - self.ring_contrast * ring_phase.sin().powi(2))
    }
}

impl Emitter for TorchEmitter {
    fn radiance(&self, p: DVec2, dir: DVec3) -> [f64; 3] {
        let r = p.length();
        let a = self.aperture(r / self.radius_m);
        if a == 0.0 {
            return [0.0; 3];
        }
        let tilt = (self.divergence_deg * r / self.radius_m).to_radians().tan();
        let axis = (p / r * tilt).extend(-1.0).normalize();
        let psi = dir.dot(axis).clamp(-1.0, 1.0).acos();
        let sigma = self.spread_deg.to_radians();
        let k = a * (-0.5 * (psi / sigma).powi(2)).exp();
        self.radiance.map(|c| c * k)
    }

    fn extent_m(&self) -> f64 {
        self.radius_m
    }
}

/// Midpoint nodes `(p, area)` over the emitter's square, `n × n` of them.
fn emitter_nodes(em: &dyn Emitter, n: usize) -> Vec<(DVec2, f64)> {
    let a = em.extent_m();
    let w = 2.0 * a / n as f64;
    (0..n * n).map(|k| (DVec2::new(-a + w * ((k % n) as f64 + 0.5), -a + w * ((k / n) as f64 + 0.5)), w * w)).collect()
}

/// The true irradiance at `x` (luminaire frame, depth `−x_z > 0`) on a surface of unit normal
/// `n`: `∫ L cos θ_S cos θ_x / δ² dA` over the emitter, midpoint rule on `points_per_axis²` nodes.
pub fn emitter_irradiance(em: &dyn Emitter, x: DVec3, n: DVec3, points_per_axis: usize) -> [f64; 3] {
    if x.z.is_nan() || x.z >= 0.0 {
        return [0.0; 3];
    }
    let mut acc = [0.0; 3];
    for (p, area) in emitter_nodes(em, points_per_axis) {
        let r = x - p.extend(0.0);
        let delta2 = r.length_squared();
        let delta = delta2.sqrt();
        let dir = r / delta;
        let cos_x = -n.dot(dir);
        if cos_x <= 0.0 {
            continue;
        }
        let l = em.radiance(p, dir);
        let w = area * (-dir.z) * cos_x / delta2;
        for c in 0..3 {
            acc[c] += w * l[c];
        }
    }
    acc
}

/// What [`acquire`] measures.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Acquisition {
    /// The filter grid.
    pub grid: FilterGrid,
    /// Distance `d` of the measurement plane (metres).
    pub distance_m: f64,
    /// Extent of the measurement plane (metres).
    pub size_m: [f64; 2],
    /// Image size (texels).
    pub resolution: [u32; 2],
    /// Midpoint nodes per axis over the emitter's square.
    pub emitter_points: usize,
}

/// An emitter node, its area, and the filters that see it with their transmittances.
type SeenNode = (DVec2, f64, Vec<(usize, f64)>);

/// Simulates the measurement of `em` (module docs). Deterministic; parallel over image rows.
pub fn acquire(em: &dyn Emitter, acq: &Acquisition) -> Result<LightField, LightFieldError> {
    let g = acq.grid;
    let d = acq.distance_m;
    let [w, h] = acq.resolution;
    // emitter nodes that some filter sees, with the filter weights of each
    // (filter index, transmittance) of the filters that see each node; most see none or few
    let nodes: Vec<SeenNode> = emitter_nodes(em, acq.emitter_points)
        .into_iter()
        .map(|(p, area)| (p, area, (0..g.len()).map(|k| (k, g.dual(k % g.counts[0], k / g.counts[0], p))).filter(|&(_, v)| v != 0.0).collect::<Vec<_>>()))
        .filter(|(_, _, duals)| !duals.is_empty())
        .collect();
    let texel = |i: u32, j: u32| DVec2::new((i as f64 + 0.5) * acq.size_m[0] / w as f64 - 0.5 * acq.size_m[0], (j as f64 + 0.5) * acq.size_m[1] / h as f64 - 0.5 * acq.size_m[1]);
    // rows[j] = per filter, the W texels of row j
    let rows: Vec<Vec<Vec<[f32; 3]>>> = (0..h)
        .into_par_iter()
        .map(|j| {
            let mut out = vec![vec![[0.0f32; 3]; w as usize]; g.len()];
            let mut e = vec![[0.0f64; 3]; g.len()];
            for i in 0..w {
                let st = texel(i, j);
                e.iter_mut().for_each(|v| *v = [0.0; 3]);
                for (p, area, duals) in &nodes {
                    let r = st.extend(-d) - p.extend(0.0);
                    let r2 = r.length_squared();
                    let dir = r / r2.sqrt();
                    let l = em.radiance(*p, dir);
                    if l == [0.0; 3] {
                        continue;
                    }
                    let geo = area * (d * d / r2) / r2;
                    for &(k, phi) in duals {
                        for c in 0..3 {
                            e[k][c] += geo * phi * l[c];
                        }
                    }
                }
                for (k, ek) in e.iter().enumerate() {
                    let rc2 = (st - g.centre(k % g.counts[0], k / g.counts[0])).length_squared() + d * d;
                    out[k][i as usize] = ek.map(|v| (v * rc2 * rc2 / (d * d)) as f32);
                }
            }
            out
        })
        .collect();
    let images = (0..g.len()).map(|k| LinearImage { width: w, height: h, data: rows.iter().flat_map(|r| r[k].iter().copied()).collect() }).collect();
    LightField::new(g, d, acq.size_m, images, std::path::Path::new("<synthetic acquisition>"))
}

/// An emitter inside the span of the exact basis (Eq. 3): `L = R²/cos²θ · Φ_mn(u, v) · ℓ(s, t)`
/// with one basis function `Φ_mn` of `grid` and a Gaussian `ℓ` of width `sigma_m` on the
/// measurement plane at `distance_m`. Its measurement is known in closed form,
/// `E_mn = h² ℓ(s, t)` and zero for every other position (Eq. 4), and the exact reconstruction
/// (Eq. 5) returns it unchanged: a check of both.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BasisEmitter {
    /// The grid of the basis.
    pub grid: FilterGrid,
    /// The position `(m, n)` whose basis function carries the light.
    pub position: [usize; 2],
    /// Distance `d` of the plane on which `ℓ` is defined (metres).
    pub distance_m: f64,
    /// Width of `ℓ` (metres).
    pub sigma_m: f64,
}

impl BasisEmitter {
    /// `ℓ(s, t)`.
    pub fn profile(&self, st: DVec2) -> f64 {
        (-0.5 * st.length_squared() / (self.sigma_m * self.sigma_m)).exp()
    }
}

impl Emitter for BasisEmitter {
    fn radiance(&self, p: DVec2, dir: DVec3) -> [f64; 3] {
        let cos = -dir.z;
        if cos <= 0.0 {
            return [0.0; 3];
        }
        let st = p + dir.truncate() * (self.distance_m / cos);
        // R²/cos²θ with R = d / cos θ
        let geo = self.distance_m * self.distance_m / cos.powi(4);
        let v = geo * self.grid.basis(self.position[0], self.position[1], p) * self.profile(st);
        [v; 3]
    }

    fn extent_m(&self) -> f64 {
        let c = self.grid.centre(self.position[0], self.position[1]);
        c.x.abs().max(c.y.abs()) + self.grid.spacing_m
    }
}

/// The name of the true emitter's file in a synthetic light-field folder.
pub const TRUTH_FILE: &str = "truth.toml";

/// `truth.toml`: the emitter a synthetic folder measured, and how.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Truth {
    /// The measured torch.
    pub torch: TorchEmitter,
    /// Midpoint nodes per axis the acquisition used over the emitter.
    pub emitter_points: usize,
}

/// Acquires `torch` and writes the light-field folder with `truth.toml` beside the images.
pub fn write_synthetic_folder(dir: &std::path::Path, torch: &TorchEmitter, acq: &Acquisition) -> Result<LightField, LightFieldError> {
    let lf = acquire(torch, acq)?;
    lf.save(dir)?;
    let path = dir.join(TRUTH_FILE);
    let text = toml::to_string(&Truth { torch: torch.clone(), emitter_points: acq.emitter_points }).map_err(|e| LightFieldError::Toml { path: path.clone(), message: e.to_string() })?;
    std::fs::write(&path, text).map_err(|source| LightFieldError::Io { path, source })?;
    Ok(lf)
}

/// Reads `truth.toml` of a synthetic folder.
pub fn read_truth(dir: &std::path::Path) -> Result<Truth, LightFieldError> {
    let path = dir.join(TRUTH_FILE);
    let text = std::fs::read_to_string(&path).map_err(|source| LightFieldError::Io { path: path.clone(), source })?;
    toml::from_str(&text).map_err(|e| LightFieldError::Toml { path, message: e.to_string() })
}
