//! A lamp's light at a surface point with the proxy's shadow: the shared next-event estimate of
//! the estimator's lamp column (`estimate::lamp_bounce`, Jensen §3.1's known shape per light
//! source) and the renderer's lamp bounce on the objects (`render::object_transfer::lamps`).
//! The irradiance is the lamp model's ([`super::model`]; Granier §3–4,
//! `../shared/papers/granier-2003-complex-light-sources.txt`).

use super::Lamp;
use crate::geometry::raycast::{RAY_EPSILON_M, RayScene};
use glam::Vec3;

/// Shadow rays toward a lamp stop this short of it (metres), so the luminaire's own housing in
/// the proxy does not shadow its light.
pub const LAMP_CLEARANCE_M: f32 = 0.02;

/// The lamp model's irradiance at `p` (facing unit normal `n`) when the proxy lets its light
/// through, per channel in model units; zero behind the surface or in the proxy's shadow.
pub fn direct_irradiance(lamp: &Lamp, scene: &RayScene, p: Vec3, n: Vec3) -> [f64; 3] {
    let d = lamp.light.position.as_vec3() - p;
    let dist = d.length();
    if !(dist > LAMP_CLEARANCE_M + RAY_EPSILON_M) || n.dot(d) <= 0.0 {
        return [0.0; 3];
    }
    let irr = lamp.irradiance(p.as_dvec3(), n.as_dvec3());
    if irr.iter().all(|&v| v <= 0.0) || scene.occluded(p + n * RAY_EPSILON_M, d / dist, dist - LAMP_CLEARANCE_M) {
        return [0.0; 3];
    }
    irr
}

