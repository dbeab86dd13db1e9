//! A lamp's light at a surface point with the proxy's shadow: the shared next-event estimate of
//! the estimator's lamp column (`estimate::lamp_bounce`, Jensen §3.1's known shape per light
//! source) and the renderer's lamp bounce on the objects (`render::object_transfer::lamps`);
//! the bounce off the proxy ([`bounce_irradiance`]) is the estimator's column's and the real
//! receivers' (`render::lamps::ground_bounce`).
//! The irradiance is the lamp model's ([`super::model`]; Granier §3–4,
//! `../shared/papers/granier-2003-complex-light-sources.txt`).

use super::Lamp;
use crate::geometry::ambient::TransportQuality;
use crate::geometry::raycast::{RAY_EPSILON_M, RayScene};
use crate::geometry::sampling::{sample_cosine_around, sample_stratified_2d};
use glam::{Vec2, Vec3};
use rand::{Rng, SeedableRng, rngs::SmallRng};

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

/// The irradiance at `p` (facing unit normal `n`) from the lamp's light reflected by the proxy
/// (module docs), per channel in model units, with `quality.paths` paths of up to
/// `quality.max_bounces` proxy hits.
pub fn bounce_irradiance(lamp: &Lamp, scene: &RayScene, p: Vec3, n: Vec3, quality: TransportQuality, seed: u64) -> [f64; 3] {
    let mut rng = SmallRng::seed_from_u64(seed ^ 0x1a3b_5c7d_9e0f_2468);
    let k = quality.paths.max(1);
    let mut sum = [0.0f64; 3];
    for i in 0..k {
        let mut dir = sample_cosine_around(n, sample_stratified_2d(i, k, &mut rng));
        let (mut origin, mut normal) = (p, n);
        let mut throughput = Vec3::ONE;
        for _ in 0..quality.max_bounces {
            let Some(hit) = scene.intersect(origin + normal * RAY_EPSILON_M, dir, f32::MAX) else { break };
            throughput *= scene.albedo(&hit);
            let e = direct_irradiance(lamp, scene, hit.point, hit.normal);
            for c in 0..3 {
                sum[c] += throughput[c] as f64 * e[c];
            }
            if throughput.max_element() < 1e-4 {
                break;
            }
            origin = hit.point;
            normal = hit.normal;
            dir = sample_cosine_around(normal, Vec2::new(rng.random(), rng.random()));
        }
    }
    sum.map(|s| s / k as f64)
}
