//! The sky heliar's estimator fits: a few shapes that follow the sun, each normalised to unit
//! irradiance on an unoccluded horizontal surface, scaled by fitted RGB weights.
//!
//! # How it works
//! A [`SkyBasis`] holds up to four shapes `S_k(ω)` over the upper hemisphere (0 below it):
//!
//! - **uniform**: `S = 1/π`, the sky heliar assumed so far;
//! - **circumsolar**: a von Mises–Fisher lobe `e^{κ(cos γ − 1)}` around the sun (`γ` the angle to
//!   the sun), `κ = 1/(1 − cos w)` for an e-folding width `w` — the smooth counterpart of the
//!   Perez circumsolar term `C·e^{Dγ}` (Preetham §3.2), clipped by the horizon;
//! - **horizon band**: `e^{−μ/sin w}` with `μ = cos θ`, brightening toward the horizon (the
//!   Perez gradation term's effect for a clear sky), e-folding at elevation `w`;
//! - **Preetham** at a chosen turbidity ([`super::preetham`], luminance only).
//!
//! Each raw shape is divided by its horizontal irradiance `∫_{y>0} S_k(ω) ω_y dω`: closed forms for
//! the uniform (`π`) and horizon (`2π sin²w (1 − e^{−1/sin w}(1 + 1/sin w))`) shapes, and
//! [`hemisphere_integral`] for the others. A [`SkyModel`] `L(ω) = Σ_k w_k S_k(ω)` then has
//! horizontal irradiance `Σ_k w_k`: the fitted weights add up to `Pa` (crate docs), whatever the
//! shapes. Per sample the estimator's `c` becomes one irradiance per shape
//! ([`super::quadrature::irradiance`]).
//!
//! # Conditioning and the recommended basis
//! [`super::conditioning`] measures the design of the shapes' irradiances over typical sample
//! sets, with the sun fitted jointly. Every shape gives 1 on an unoccluded horizontal surface, so
//! ground samples alone cannot tell them apart; walls of several orientations and partly occluded
//! ground can. Recommended ([`SkyBasisSpec::recommended`]): uniform + horizon 12° for every sun,
//! plus circumsolar 25° for a sun up to 15° high. The horizon band costs little conditioning at
//! any sun (design condition 4–13 against 1.4–6.4 for the uniform sky alone); the circumsolar lobe
//! resembles the sun's own `max(n·l, 0)` term more and more as the sun climbs (U+C+H: 8 at 3–15°,
//! 12 at 20°, 15–20 at 30–60°), and a low sun is where it matters (the worst `Pa` errors).
//! A Preetham shape on top is nearly a combination of the others (condition 100–235 with all
//! four) and alone beside the uniform one is worse than the horizon band (22–29); it is offered
//! for experiments, not recommended.

use super::preetham::PreethamSky;
use super::quadrature::hemisphere_integral;
use super::{ShapeSun, SkyError, unit_dir};
use glam::{DVec3, Vec3};
use std::f64::consts::PI;

/// Narrowest circumsolar width accepted, degrees (narrower lobes need finer normalisation grids).
pub const CIRCUMSOLAR_WIDTH_MIN_DEG: f64 = 5.0;
/// Widest circumsolar width accepted, degrees (wider is nearly uniform).
pub const CIRCUMSOLAR_WIDTH_MAX_DEG: f64 = 90.0;
/// Narrowest horizon band accepted, degrees.
pub const HORIZON_WIDTH_MIN_DEG: f64 = 2.0;
/// Widest horizon band accepted, degrees.
pub const HORIZON_WIDTH_MAX_DEG: f64 = 60.0;

/// Which shapes a basis has besides the uniform one (always first).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SkyBasisSpec {
    /// E-folding width (degrees) of the circumsolar lobe; `None` leaves it out.
    pub circumsolar_width_deg: Option<f64>,
    /// E-folding elevation (degrees) of the horizon band; `None` leaves it out.
    pub horizon_width_deg: Option<f64>,
    /// Turbidity of a Preetham shape; `None` leaves it out.
    pub preetham_turbidity: Option<f64>,
}

/// Suns up to this elevation (degrees) get the circumsolar shape in [`SkyBasisSpec::recommended`].
pub const CIRCUMSOLAR_MAX_SUN_ELEVATION_DEG: f64 = 15.0;
/// Circumsolar width of the recommended basis, degrees.
pub const RECOMMENDED_CIRCUMSOLAR_WIDTH_DEG: f64 = 25.0;
/// Horizon band of the recommended basis, degrees.
pub const RECOMMENDED_HORIZON_WIDTH_DEG: f64 = 12.0;

impl Default for SkyBasisSpec {
    /// Uniform, circumsolar 25° and horizon 12°: the full recommended basis of a low sun.
    fn default() -> Self {
        Self { circumsolar_width_deg: Some(RECOMMENDED_CIRCUMSOLAR_WIDTH_DEG), horizon_width_deg: Some(RECOMMENDED_HORIZON_WIDTH_DEG), preetham_turbidity: None }
    }
}

impl SkyBasisSpec {
    /// The recommended basis for a sun at `sun_elevation_deg` (module docs): uniform and horizon
    /// 12°, plus circumsolar 25° when the sun is at most [`CIRCUMSOLAR_MAX_SUN_ELEVATION_DEG`]
    /// high (a higher sun makes the lobe too similar to the sun's own term).
    pub fn recommended(sun_elevation_deg: f64) -> Self {
        let circumsolar = (sun_elevation_deg <= CIRCUMSOLAR_MAX_SUN_ELEVATION_DEG).then_some(RECOMMENDED_CIRCUMSOLAR_WIDTH_DEG);
        Self { circumsolar_width_deg: circumsolar, horizon_width_deg: Some(RECOMMENDED_HORIZON_WIDTH_DEG), preetham_turbidity: None }
    }

    /// The uniform sky alone (heliar's model so far; the overcast fallback).
    pub fn uniform() -> Self {
        Self { circumsolar_width_deg: None, horizon_width_deg: None, preetham_turbidity: None }
    }
}

/// One raw (unnormalised) shape.
#[derive(Clone, Debug, PartialEq)]
enum Shape {
    Uniform,
    Circumsolar { kappa: f64 },
    Horizon { inv_mu0: f64 },
    Preetham(Box<PreethamSky>),
}

impl Shape {
    /// Raw value for a unit direction `d` with `d.y ≥ 0` whose cosine to the sun is `cos_gamma`.
    fn raw(&self, d: DVec3, cos_gamma: f64) -> f64 {
        match self {
            Shape::Uniform => 1.0,
            Shape::Circumsolar { kappa } => (kappa * (cos_gamma - 1.0)).exp(),
            Shape::Horizon { inv_mu0 } => (-d.y * inv_mu0).exp(),
            Shape::Preetham(sky) => sky.luminance_kcd(d.as_vec3()),
        }
    }

    fn name(&self) -> &'static str {
        match self {
            Shape::Uniform => "uniform",
            Shape::Circumsolar { .. } => "circumsolar",
            Shape::Horizon { .. } => "horizon",
            Shape::Preetham(_) => "preetham",
        }
    }
}

/// Shapes of a sky that follow one sun position (module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct SkyBasis {
    sun: ShapeSun,
    shapes: Vec<Shape>,
    /// `1 / ∫ raw·ω_y dω` per shape.
    inv_norm: Vec<f64>,
}

fn width_rad(value: Option<f64>, field: &'static str, (min, max): (f64, f64)) -> Result<Option<f64>, SkyError> {
    match value {
        None => Ok(None),
        Some(w) if (min..=max).contains(&w) => Ok(Some(w.to_radians())),
        Some(w) => Err(SkyError::Parameter { field, reason: "is outside its range (see the CIRCUMSOLAR_/HORIZON_WIDTH constants)", value: w }),
    }
}

impl SkyBasis {
    /// The basis of `spec` for the sun toward `sun_dir_world` (world frame; a sun below the
    /// horizon is lifted onto it, [`super`] docs).
    pub fn new(sun_dir_world: Vec3, spec: &SkyBasisSpec) -> Result<Self, SkyError> {
        let sun = ShapeSun::from_dir(sun_dir_world)?;
        let mut shapes = vec![Shape::Uniform];
        let mut inv_norm = vec![1.0 / PI];
        if let Some(w) = width_rad(spec.circumsolar_width_deg, "SkyBasisSpec::circumsolar_width_deg", (CIRCUMSOLAR_WIDTH_MIN_DEG, CIRCUMSOLAR_WIDTH_MAX_DEG))? {
            shapes.push(Shape::Circumsolar { kappa: 1.0 / (1.0 - w.cos()) });
            inv_norm.push(0.0);
        }
        if let Some(w) = width_rad(spec.horizon_width_deg, "SkyBasisSpec::horizon_width_deg", (HORIZON_WIDTH_MIN_DEG, HORIZON_WIDTH_MAX_DEG))? {
            let mu0 = w.sin();
            let k = 1.0 / mu0;
            shapes.push(Shape::Horizon { inv_mu0: k });
            inv_norm.push(1.0 / (2.0 * PI * (1.0 - (-k).exp() * (1.0 + k)) / (k * k)));
        }
        if let Some(t) = spec.preetham_turbidity {
            shapes.push(Shape::Preetham(Box::new(PreethamSky::new(sun.dir.as_vec3(), t)?)));
            inv_norm.push(0.0);
        }
        for k in 0..shapes.len() {
            if inv_norm[k] == 0.0 {
                let shape = &shapes[k];
                inv_norm[k] = 1.0 / hemisphere_integral(|d| shape.raw(d, d.dot(sun.dir)));
            }
        }
        Ok(Self { sun, shapes, inv_norm })
    }

    /// Number of shapes (at least 1: the uniform one is always first).
    pub fn len(&self) -> usize {
        self.shapes.len()
    }

    /// Always false.
    pub fn is_empty(&self) -> bool {
        self.shapes.is_empty()
    }

    /// Name of shape `k` (`uniform`, `circumsolar`, `horizon`, `preetham`); panics past
    /// [`Self::len`].
    pub fn name(&self, k: usize) -> &'static str {
        self.shapes[k].name()
    }

    /// The sun the shapes follow.
    pub fn sun(&self) -> ShapeSun {
        self.sun
    }

    /// Normalised radiance of shape `k` along `dir`: 0 below the horizon, for an invalid
    /// direction, and for `k ≥ len()`.
    pub fn radiance(&self, k: usize, dir: Vec3) -> f32 {
        let (Some(shape), Some(d)) = (self.shapes.get(k), unit_dir(dir)) else { return 0.0 };
        if d.y < 0.0 {
            return 0.0;
        }
        (shape.raw(d, d.dot(self.sun.dir)) * self.inv_norm[k]) as f32
    }

    /// All normalised radiances along `dir` into `out` (`out.len()` values are written, extra
    /// entries get 0).
    pub fn radiances(&self, dir: Vec3, out: &mut [f32]) {
        out.fill(0.0);
        let Some(d) = unit_dir(dir).filter(|d| d.y >= 0.0) else { return };
        let cos_gamma = d.dot(self.sun.dir);
        for ((o, shape), inv) in out.iter_mut().zip(&self.shapes).zip(&self.inv_norm) {
            *o = (shape.raw(d, cos_gamma) * inv) as f32;
        }
    }
}

/// A fitted sky: a basis and one RGB weight per shape. Its horizontal irradiance is the sum of the
/// weights, i.e. `Pa`.
#[derive(Clone, Debug, PartialEq)]
pub struct SkyModel {
    /// The shapes.
    pub basis: SkyBasis,
    /// RGB weight of every shape (irradiance on an unoccluded horizontal surface it contributes).
    pub weights_rgb: Vec<[f32; 3]>,
}

impl SkyModel {
    /// A model from `basis` and one finite RGB weight per shape.
    pub fn new(basis: SkyBasis, weights_rgb: Vec<[f32; 3]>) -> Result<Self, SkyError> {
        if weights_rgb.len() != basis.len() {
            return Err(SkyError::Size { what: "SkyModel weights_rgb", expected: basis.len(), got: weights_rgb.len() });
        }
        if let Some(w) = weights_rgb.iter().flatten().find(|w| !w.is_finite()) {
            return Err(SkyError::Parameter { field: "SkyModel weights_rgb", reason: "must be finite", value: *w as f64 });
        }
        Ok(Self { basis, weights_rgb })
    }

    /// The uniform sky of horizontal irradiance `pa_rgb`.
    pub fn uniform(sun_dir_world: Vec3, pa_rgb: [f32; 3]) -> Result<Self, SkyError> {
        Self::new(SkyBasis::new(sun_dir_world, &SkyBasisSpec::uniform())?, vec![pa_rgb])
    }

    /// RGB radiance along `dir` (0 below the horizon and for invalid directions).
    pub fn radiance(&self, dir: Vec3) -> [f32; 3] {
        let mut s = vec![0.0f32; self.basis.len()];
        self.basis.radiances(dir, &mut s);
        let mut out = [0.0f32; 3];
        for (sk, w) in s.iter().zip(&self.weights_rgb) {
            for c in 0..3 {
                out[c] += sk * w[c];
            }
        }
        out
    }

    /// Irradiance on an unoccluded horizontal surface (`Pa`): the sum of the weights.
    pub fn horizontal_irradiance(&self) -> [f32; 3] {
        let mut out = [0.0f32; 3];
        for w in &self.weights_rgb {
            for c in 0..3 {
                out[c] += w[c];
            }
        }
        out
    }
}

#[cfg(test)]
mod tests;
