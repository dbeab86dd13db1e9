//! A small, independent path tracer for ground-truth frames.
//!
//! It does not use heliar's lighting model: radiance is integrated by Monte Carlo path tracing
//! (cosine-weighted bounces, next-event estimation of the directional sun, Russian roulette), with
//! the true, spatially varying albedo of every surface, anti-aliased pixels, and objects the proxy
//! does not know about. Light is linear in the sky and sun intensities, so a frame is rendered as
//! two basis images (unit sky, unit sun) that the caller scales per channel.

use glam::{DVec2, Vec2, Vec3};
use heliar::geometry::raycast::{RAY_EPSILON_M, RayScene};
use heliar::geometry::sampling::sample_cosine_around;
use heliar::scene::camera::Camera;
use rand::{Rng, SeedableRng, rngs::SmallRng};
use rayon::prelude::*;
use std::f32::consts::PI;

/// The true albedo of a point: the mesh albedo times a procedural variation.
pub trait TrueAlbedo: Sync {
    /// Albedo at `point` on triangle `tri` with mesh albedo `base`.
    fn albedo(&self, tri: u32, point: Vec3, base: Vec3) -> Vec3;
}

/// Radiance basis along one ray: `(sky, sun)` per unit `Pa` and unit `Pd`.
pub fn trace(scene: &RayScene, albedo: &dyn TrueAlbedo, origin: Vec3, dir: Vec3, sun: Vec3, rng: &mut SmallRng) -> (Vec3, Vec3) {
    let (mut sky, mut sun_l) = (Vec3::ZERO, Vec3::ZERO);
    let mut throughput = Vec3::ONE;
    let (mut o, mut d) = (origin, dir);
    let mut offset = Vec3::ZERO;
    for depth in 0..12 {
        let Some(hit) = scene.intersect(o + offset, d, f32::MAX) else {
            // The sky dome over the upper hemisphere: radiance Pa/π per unit Pa.
            if d.y > 0.0 {
                sky += throughput / PI;
            }
            break;
        };
        let base = scene.albedo(&hit);
        let rho = albedo.albedo(hit.tri, hit.point, base);
        // Next-event estimation of the sun (radiance ρ/π · Pd · cos).
        let cos = hit.normal.dot(sun);
        if cos > 0.0 && scene.sees_direction(hit.point, hit.normal, sun) {
            sun_l += throughput * rho / PI * cos;
        }
        // Cosine-weighted continuation: the estimator weight f·cos/pdf is ρ.
        throughput *= rho;
        if depth >= 3 {
            let q = throughput.max_element().min(0.95);
            if rng.random::<f32>() >= q {
                break;
            }
            throughput /= q;
        }
        o = hit.point;
        offset = hit.normal * RAY_EPSILON_M;
        d = sample_cosine_around(hit.normal, Vec2::new(rng.random(), rng.random()));
    }
    (sky, sun_l)
}

/// Renders the `(sky, sun)` basis images of `camera` with `spp` jittered samples per pixel.
pub fn render_basis(scene: &RayScene, albedo: &dyn TrueAlbedo, camera: &Camera, sun: Vec3, spp: u32, seed: u64) -> (Vec<Vec3>, Vec<Vec3>) {
    let (w, h) = (camera.intrinsics.width, camera.intrinsics.height);
    let rows: Vec<Vec<(Vec3, Vec3)>> = (0..h)
        .into_par_iter()
        .map(|y| {
            (0..w)
                .map(|x| {
                    let mut rng = SmallRng::seed_from_u64(seed ^ ((y as u64) << 32 | x as u64).wrapping_mul(0x2545_f491_4f6c_dd1d));
                    let (mut a, mut b) = (Vec3::ZERO, Vec3::ZERO);
                    for _ in 0..spp {
                        let uv = DVec2::new(x as f64 + rng.random::<f64>() - 0.5, y as f64 + rng.random::<f64>() - 0.5);
                        if let Some((o, d)) = camera.ray_at(uv) {
                            let (s, l) = trace(scene, albedo, o.as_vec3(), d.as_vec3(), sun, &mut rng);
                            a += s;
                            b += l;
                        }
                    }
                    (a / spp as f32, b / spp as f32)
                })
                .collect()
        })
        .collect();
    rows.into_iter().flatten().unzip()
}

/// Renders the `(sky, sun)` basis of an equirect environment map seen from `centre`.
pub fn render_env_basis(
    scene: &RayScene,
    albedo: &dyn TrueAlbedo,
    centre: Vec3,
    width: u32,
    height: u32,
    sun: Vec3,
    spp: u32,
    seed: u64,
) -> (Vec<Vec3>, Vec<Vec3>) {
    let rows: Vec<Vec<(Vec3, Vec3)>> = (0..height)
        .into_par_iter()
        .map(|y| {
            (0..width)
                .map(|x| {
                    let mut rng = SmallRng::seed_from_u64(seed ^ ((y as u64) << 32 | x as u64).wrapping_mul(0x9e37_79b9));
                    let (mut a, mut b) = (Vec3::ZERO, Vec3::ZERO);
                    for _ in 0..spp {
                        let d = heliar::envmap::dir_from_texel(x as f32 + rng.random::<f32>(), y as f32 + rng.random::<f32>(), width, height);
                        let (s, l) = trace(scene, albedo, centre, d, sun, &mut rng);
                        a += s;
                        b += l;
                    }
                    (a / spp as f32, b / spp as f32)
                })
                .collect()
        })
        .collect();
    rows.into_iter().flatten().unzip()
}
