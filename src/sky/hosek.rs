//! The Hosek–Wilkie sky-dome model: "An analytic model for full spectral sky-dome radiance"
//! (SIGGRAPH 2012), RGB variant, ported from the authors' reference implementation (version 1.4a)
//! with its coefficient tables (`hosek_data/`, BSD licence kept there).
//!
//! # How it works
//! Radiance along a view at zenith angle `θ` and angle `γ` to the sun is the paper's extended
//! Perez formula, as the reference evaluates it:
//!
//! `L = L_M · (1 + A·e^{B/(cos θ + 0.01)}) · (C + D·e^{E·γ} + F·cos²γ + G·χ(H, γ) + I·√cos θ)`,
//! `χ(g, γ) = (1 + cos²γ) / (1 + g² − 2g·cos γ)^{3/2}`
//!
//! (the reference code stores the nine parameters in the order A … G, I, H). The nine parameters
//! and the scale `L_M` of each channel depend on the turbidity `T ∈ [1, 10]`, the ground albedo
//! `a ∈ [0, 1]` and the solar elevation `η`: the tables hold, for `a ∈ {0, 1}` and integer `T`, six
//! control points of a quintic Bézier curve in `(η/(π/2))^{1/3}`; between them the model
//! interpolates linearly in `a` and in `T` (reference `ArHosekSkyModel_CookConfiguration`).
//!
//! The output is linear RGB with sRGB primaries (reference header, "RGB Version of the Model") in
//! the reference's radiometric units. Only the sky dome is modelled (the solar disc is `Pd`'s).
//! The sky is defined for `cos θ ≥ 0` (the `√cos θ` term); below the horizon and for invalid
//! directions [`HosekSky::radiance_rgb`] returns 0, and a sun below the horizon is lifted onto it
//! (see the [module](super) docs: the reference takes `η^{1/3}` and would give NaN).

use super::hosek_data::{DATASET_RGB, DATASET_RGB_RAD};
use super::{ShapeSun, SkyError};
use glam::Vec3;
use std::f64::consts::FRAC_PI_2;

/// Smallest turbidity of the tables.
pub const TURBIDITY_MIN: f64 = 1.0;
/// Largest turbidity of the tables.
pub const TURBIDITY_MAX: f64 = 10.0;
/// Parameters of the radiance function per channel.
const PARAMS: usize = 9;
/// Bézier control points per (albedo, turbidity) pair.
const CONTROL_POINTS: usize = 6;
/// Turbidities in the tables (1 … 10).
const TURBIDITIES: usize = 10;
/// Binomial coefficients of the quintic Bernstein basis.
const BINOMIAL5: [f64; CONTROL_POINTS] = [1.0, 5.0, 10.0, 10.0, 5.0, 1.0];

/// A Hosek–Wilkie RGB sky for one sun position, turbidity and ground albedo.
#[derive(Clone, Debug, PartialEq)]
pub struct HosekSky {
    turbidity: f64,
    albedo: [f64; 3],
    sun: ShapeSun,
    /// The nine parameters per channel, in the reference's storage order (A … G, I, H).
    config: [[f64; PARAMS]; 3],
    /// `L_M` per channel.
    scale: [f64; 3],
}

/// Quintic Bernstein weights at `s ∈ [0, 1]`.
fn bezier_weights(s: f64) -> [f64; CONTROL_POINTS] {
    std::array::from_fn(|k| BINOMIAL5[k] * (1.0 - s).powi((5 - k) as i32) * s.powi(k as i32))
}

/// The `(table offset, weight)` pairs of the bilinear blend in albedo and turbidity: albedo 0 and 1
/// (tables `0` and `1`), turbidity `⌊T⌋` and `⌊T⌋ + 1` (the second dropped at `T = 10`).
fn blend(turbidity: f64, albedo: f64) -> Vec<(usize, usize, f64)> {
    let lo = (turbidity.floor() as usize).clamp(1, TURBIDITIES);
    let rem = turbidity - lo as f64;
    let mut out = Vec::with_capacity(4);
    for (a, wa) in [(0usize, 1.0 - albedo), (1, albedo)] {
        out.push((a, lo - 1, wa * (1.0 - rem)));
        if lo < TURBIDITIES {
            out.push((a, lo, wa * rem));
        }
    }
    out
}

impl HosekSky {
    /// The sky of sun direction `sun_dir_world` (world frame, toward the sun; a sun below the
    /// horizon is lifted onto it), `turbidity` in [[`TURBIDITY_MIN`], [`TURBIDITY_MAX`]] and ground
    /// albedo per channel (RGB) in `[0, 1]`.
    pub fn new(sun_dir_world: Vec3, turbidity: f64, ground_albedo: [f64; 3]) -> Result<Self, SkyError> {
        let sun = ShapeSun::from_dir(sun_dir_world)?;
        Self::from_elevation(sun, turbidity, ground_albedo)
    }

    /// [`Self::new`] for an already validated sun.
    pub fn from_elevation(sun: ShapeSun, turbidity: f64, ground_albedo: [f64; 3]) -> Result<Self, SkyError> {
        if !(TURBIDITY_MIN..=TURBIDITY_MAX).contains(&turbidity) {
            return Err(SkyError::Turbidity { model: "hosek", value: turbidity, min: TURBIDITY_MIN, max: TURBIDITY_MAX });
        }
        if !ground_albedo.iter().all(|a| (0.0..=1.0).contains(a)) {
            return Err(SkyError::Albedo { what: "hosek ground_albedo", value: ground_albedo });
        }
        let s = (sun.elevation_rad.clamp(0.0, FRAC_PI_2) / FRAC_PI_2).cbrt();
        let w = bezier_weights(s);
        let mut config = [[0.0; PARAMS]; 3];
        let mut scale = [0.0; 3];
        for ch in 0..3 {
            for (a, t, weight) in blend(turbidity, ground_albedo[ch]) {
                let base = (a * TURBIDITIES + t) * CONTROL_POINTS;
                for (k, wk) in w.iter().enumerate() {
                    let p = &DATASET_RGB[ch][(base + k) * PARAMS..(base + k + 1) * PARAMS];
                    for i in 0..PARAMS {
                        config[ch][i] += weight * wk * p[i];
                    }
                    scale[ch] += weight * wk * DATASET_RGB_RAD[ch][base + k];
                }
            }
        }
        Ok(Self { turbidity, albedo: ground_albedo, sun, config, scale })
    }

    /// The turbidity.
    pub fn turbidity(&self) -> f64 {
        self.turbidity
    }

    /// The ground albedo per channel.
    pub fn ground_albedo(&self) -> [f64; 3] {
        self.albedo
    }

    /// The sun the shape uses (lifted onto the horizon when it was below).
    pub fn sun(&self) -> ShapeSun {
        self.sun
    }

    /// Radiance of channel `ch` for view zenith angle `theta` and angle to the sun `gamma`
    /// (radians), exactly as the reference `arhosek_tristim_skymodel_radiance` (NaN for
    /// `cos θ < 0`, as there).
    pub fn radiance_theta_gamma(&self, ch: usize, theta: f64, gamma: f64) -> f64 {
        self.eval(ch, theta.cos(), gamma)
    }

    fn eval(&self, ch: usize, cos_theta: f64, gamma: f64) -> f64 {
        self.eval_cos(ch, cos_theta, gamma, gamma.cos())
    }

    /// [`Self::eval`] with `cos γ` given (the hot path has it from a dot product).
    #[inline]
    fn eval_cos(&self, ch: usize, cos_theta: f64, gamma: f64, cg: f64) -> f64 {
        let c = &self.config[ch];
        let base = 1.0 + c[8] * c[8] - 2.0 * c[8] * cg;
        let mie = (1.0 + cg * cg) / (base * base.sqrt());
        let horizon = 1.0 + c[0] * (c[1] / (cos_theta + 0.01)).exp();
        horizon * (c[2] + c[3] * (c[4] * gamma).exp() + c[5] * cg * cg + c[6] * mie + c[7] * cos_theta.sqrt()) * self.scale[ch]
    }

    /// Linear RGB radiance (sRGB primaries) along `dir`; 0 below the horizon or for an invalid
    /// direction. With the sun on the horizon the RGB fit (and the reference) dips below zero
    /// just at the horizon, away from the sun: down to −0.30 in blue at T = 1, ground albedo 0,
    /// and −0.18 in red at T = 10 (where the sky toward the sun is ≈ 1.4); such values are
    /// clamped to 0.
    pub fn radiance_rgb(&self, dir: Vec3) -> [f32; 3] {
        match super::unit_dir(dir).filter(|v| v.y >= 0.0) {
            Some(v) => {
                // cos γ from the dot product, γ once for the three channels.
                let cg = v.dot(self.sun.dir).clamp(-1.0, 1.0);
                let gamma = cg.acos();
                std::array::from_fn(|ch| self.eval_cos(ch, v.y, gamma, cg).max(0.0) as f32)
            }
            None => [0.0; 3],
        }
    }
}

#[cfg(test)]
mod tests;
