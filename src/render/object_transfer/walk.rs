//! The paths of the objects' transfer, walked once for every light they gather: the sky and the
//! sun (`trace_point`, `R_a` and `R_d`) and the lamps' bounce ([`super::lamps`]).
//!
//! # How it works
//! From a pixel's surface point the first direction is drawn from its glTF BRDF (stratified,
//! `√N × √N` jittered strata), then each path goes on through the real proxy (Lambertian, the
//! proxy's albedo, cosine-sampled) and the virtual objects (their BRDF, lobe mixture) for up to
//! `max_bounces` surface hits. A [`Vertices`] sees each vertex after the first with the path's
//! throughput so far (next-event estimation is its business: the sun for `R_d`, the lamps for
//! their bounce) and each escape into the sky. The random numbers do not depend on what the
//! visitor does, so every light's estimate takes the same paths for the same seed.

use super::{PixelSurface, TransferScene, MIN_THROUGHPUT};
use crate::geometry::ambient::TransportQuality;
use crate::geometry::brdf::GltfSurface;
use crate::geometry::raycast::{Hit, RAY_EPSILON_M};
use crate::geometry::sampling::{sample_cosine_around, sample_stratified_2d};
use glam::{Vec2, Vec3};
use rand::{Rng, SeedableRng, rngs::SmallRng};

/// What a walk reports to the light it gathers.
pub(super) trait Vertices {
    /// A path left the scene along `dir` carrying `throughput`.
    fn escape(&mut self, throughput: Vec3, dir: Vec3);
    /// A vertex on a virtual surface `surf` with shading normal `n`, `v` pointing back along the
    /// path, reached with `throughput`.
    fn object(&mut self, throughput: Vec3, hit: &Hit, surf: &GltfSurface, n: Vec3, v: Vec3);
    /// A vertex on the real proxy of albedo `rho`, reached with `throughput`.
    fn proxy(&mut self, throughput: Vec3, hit: &Hit, rho: Vec3);
}

/// Walks `quality.paths` paths from `s` with the random numbers of `rng_seed`, reporting to
/// `visit`; returns the number of paths, which every estimate divides by.
pub(super) fn walk(scene: &TransferScene, s: &PixelSurface, quality: TransportQuality, rng_seed: u64, visit: &mut impl Vertices) -> u32 {
    let world = &scene.world;
    let mut rng = SmallRng::seed_from_u64(rng_seed);
    let k = quality.paths.max(1);
    let first = scene.surface(s.tri, world.barycentric(s.tri, s.point));
    for i in 0..k {
        let u0 = sample_stratified_2d(i, k, &mut rng);
        let Some(mut dir) = first.sample(s.normal, s.view, u0, rng.random()) else { continue };
        let pdf = first.sample_pdf(s.normal, s.view, dir);
        if pdf.is_nan() || pdf <= 0.0 {
            continue;
        }
        let mut throughput = first.eval_cos(s.normal, s.view, dir) / pdf;
        // Offset along the geometric normal: the shading normal may tilt below the face.
        let (mut origin, mut offset) = (s.point, s.face_normal * RAY_EPSILON_M);
        for bounce in 0..=quality.max_bounces {
            let Some(hit) = world.intersect(origin + offset, dir, f32::MAX) else {
                visit.escape(throughput, dir);
                break;
            };
            if bounce == quality.max_bounces {
                break;
            }
            let v = -dir;
            let next = if scene.is_object(hit.tri) {
                let surf = scene.surface(hit.tri, hit.bary);
                let n = scene.shading_normal(hit.tri, hit.bary, hit.normal);
                visit.object(throughput, &hit, &surf, n, v);
                let u = Vec2::new(rng.random(), rng.random());
                let Some(next) = surf.sample(n, v, u, rng.random()) else { break };
                let pdf = surf.sample_pdf(n, v, next);
                if pdf.is_nan() || pdf <= 0.0 || next.dot(hit.normal) <= 0.0 {
                    break;
                }
                throughput *= surf.eval_cos(n, v, next) / pdf;
                next
            } else {
                let rho = world.albedo(&hit);
                visit.proxy(throughput, &hit, rho);
                throughput *= rho;
                sample_cosine_around(hit.normal, Vec2::new(rng.random(), rng.random()).min(Vec2::splat(0.999_999)))
            };
            if throughput.max_element() < MIN_THROUGHPUT {
                break;
            }
            origin = hit.point;
            offset = hit.normal * RAY_EPSILON_M;
            dir = next;
        }
    }
    k
}
