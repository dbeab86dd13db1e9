//! The lamps' light that reaches the virtual objects after bouncing off the real proxy or the
//! objects themselves (issue 16 §3, "virtual objects are lit by the lamps"): per traced pixel
//! and lamp, the radiance `R_i` per unit lamp scale `k_i`, so that a frame adds `Σ k_i·R_i` to
//! the objects' ambient.
//!
//! Jensen §3.1 and §4.2 (`../shared/papers/jensen-outdoor-ar-ibl.txt`) relight the scene per
//! frame as a sum of fixed shapes times the estimated scales of the light sources (`Pd` for the
//! sun's share after any bounce). A lamp's light after its first bounce is linear in its scale
//! `k_i` in the same way, with the lamp's irradiance from its model (Granier §3–4, Eq. 14 for a
//! light field; `../shared/papers/granier-2003-complex-light-sources.txt`). The lamp's direct
//! light on the objects is the lamp term's (`render::lamps`); this module is the rest.
//!
//! # How it works
//! The transfer's own paths ([`super::walk`]): at every vertex after the first, next-event
//! estimation toward each lamp with the estimator's shadowed lamp irradiance
//! ([`crate::lamps::visibility::direct_irradiance`], against the proxy and the objects
//! together, so the objects' lamp shadows on the ground take their bounce away):
//! - on the proxy, `ρ/π · E_i(y, n_y)·V_i(y)` (the estimator's lamp bounce `B`, seen from the
//!   object);
//! - on an object, its BRDF toward the lamp times `E_i` on a surface facing the lamp (so the
//!   statue's light onto itself is in it).
//!
//! `R_i` depends on neither the sun nor the sky, and the lamps and objects are static: it is
//! traced once, on the first frame with a lamp on, for all lamps, with the transfer's quality and
//! lattice. A frame's `Σ k_i·R_i` is formed on the CPU when the scales change.

use super::walk::{Vertices, walk};
use super::{PixelSurface, TransferScene};
use crate::lamps::visibility::direct_irradiance;
use crate::geometry::ambient::TransportQuality;
use crate::geometry::brdf::GltfSurface;
use crate::geometry::raycast::{Hit, RayScene};
use crate::lamps::Lamp;
use crate::lighting::LampScales;
use glam::Vec3;
use rayon::prelude::*;
use std::f32::consts::FRAC_1_PI;

/// Next-event estimation toward each lamp at the vertices of the walk.
struct LampVertices<'a> {
    world: &'a RayScene,
    lamps: &'a [Lamp],
    sum: Vec<Vec3>,
}

fn vec3(e: [f64; 3]) -> Vec3 {
    Vec3::new(e[0] as f32, e[1] as f32, e[2] as f32)
}

impl Vertices for LampVertices<'_> {
    fn escape(&mut self, _throughput: Vec3, _dir: Vec3) {}

    fn object(&mut self, throughput: Vec3, hit: &Hit, surf: &GltfSurface, n: Vec3, v: Vec3) {
        for (lamp, acc) in self.lamps.iter().zip(&mut self.sum) {
            let l = (lamp.light.position.as_vec3() - hit.point).normalize_or_zero();
            if l.dot(hit.normal) <= 0.0 {
                continue;
            }
            // The irradiance on a surface facing the lamp; the BRDF holds the cosine.
            let e = direct_irradiance(lamp, self.world, hit.point, l);
            *acc += throughput * surf.eval_cos(n, v, l) * vec3(e);
        }
    }

    fn proxy(&mut self, throughput: Vec3, hit: &Hit, rho: Vec3) {
        for (lamp, acc) in self.lamps.iter().zip(&mut self.sum) {
            let e = direct_irradiance(lamp, self.world, hit.point, hit.normal);
            *acc += throughput * rho * FRAC_1_PI * vec3(e);
        }
    }
}

/// The radiance toward the camera at `s` of each lamp's light after one or more bounces, per
/// unit scale `k_i` (module docs). Deterministic for a given `seed`.
pub fn trace_lamp_point(scene: &TransferScene, s: &PixelSurface, lamps: &[Lamp], quality: TransportQuality, seed: u64) -> Vec<Vec3> {
    let mut visit = LampVertices { world: &scene.world, lamps, sum: vec![Vec3::ZERO; lamps.len()] };
    let k = walk(scene, s, quality, seed ^ 0x1a4b_0b0c_e5ed_0016, &mut visit);
    visit.sum.into_iter().map(|r| r / k as f32).collect()
}

/// The lamps' bounce of every traced pixel, and the texels of the frame's `Σ k_i·R_i`.
pub struct LampBounce {
    /// Canvas pixel of each traced surface.
    pixels: Vec<u32>,
    /// `R_i` per traced surface and lamp (`values[surface][lamp]`).
    values: Vec<Vec<Vec3>>,
    /// `Σ k_i·R_i` per canvas pixel (texture layout; zero off the lattice).
    pub texels: Vec<[f32; 4]>,
    /// The scales `texels` were formed with (`None`: not yet formed).
    applied: Option<LampScales>,
    /// Time the trace took, ms.
    pub trace_ms: f64,
}

impl LampBounce {
    /// Traces `R_i` of `lamps` at `surfaces` (the transfer's lattice) on a canvas of
    /// `canvas_pixels` pixels, each pixel with its transfer seed.
    pub fn trace(scene: &TransferScene, surfaces: &[PixelSurface], canvas_pixels: usize, lamps: &[Lamp], quality: TransportQuality, seed: impl Fn(u32) -> u64 + Sync) -> Self {
        let t = std::time::Instant::now();
        let values: Vec<Vec<Vec3>> = surfaces.par_iter().map(|s| trace_lamp_point(scene, s, lamps, quality, seed(s.pixel))).collect();
        Self { pixels: surfaces.iter().map(|s| s.pixel).collect(), values, texels: vec![[0.0; 4]; canvas_pixels], applied: None, trace_ms: t.elapsed().as_secs_f64() * 1e3 }
    }

    /// `R_i` of lamp `lamp` at traced surface `index` (in the order of the surfaces traced).
    pub fn radiance(&self, index: usize, lamp: usize) -> Vec3 {
        self.values.get(index).and_then(|v| v.get(lamp)).copied().unwrap_or(Vec3::ZERO)
    }

    /// The scales the texels hold (`None` before the first [`Self::apply`]).
    pub fn applied(&self) -> Option<&LampScales> {
        self.applied.as_ref()
    }

    /// Forms `texels = Σ k_i·R_i` for the scales `k` (a lamp past `k`'s end gives no light).
    pub fn apply(&mut self, k: &LampScales) {
        for (pixel, r) in self.pixels.iter().zip(&self.values) {
            let mut sum = Vec3::ZERO;
            for (i, r) in r.iter().enumerate() {
                sum += Vec3::from(k.get(i)) * *r;
            }
            self.texels[*pixel as usize] = [sum.x, sum.y, sum.z, 0.0];
        }
        self.applied = Some(*k);
    }
}

impl super::ObjectTransfer {
    /// The lamps' bounce at this transfer's lattice, with its quality and per-pixel seeds.
    pub fn trace_lamps(&self, scene: &TransferScene, lamps: &[Lamp]) -> LampBounce {
        LampBounce::trace(scene, &self.surfaces, self.sky.len(), lamps, self.quality, |p| super::retrace::pixel_seed(self.seed, p))
    }
}
