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
use heliar::camera::Camera;
use rand::{Rng, SeedableRng, rngs::SmallRng};
use rayon::prelude::*;
use std::f32::consts::PI;

/// The true albedo of a point: the mesh albedo times a procedural variation.
pub trait TrueAlbedo: Sync {
    /// Albedo at `point` on triangle `tri` with mesh albedo `base`.
    fn albedo(&self, tri: u32, point: Vec3, base: Vec3) -> Vec3;
    /// The glTF metallic–roughness material of triangle `tri` when it is not a plain Lambertian
    /// surface (the virtual object of the reference frames); `None` for the real scene.
    fn glossy(&self, _tri: u32) -> Option<Glossy> {
        None
    }
}

/// A glTF 2.0 metallic–roughness surface (specification, Appendix B).
#[derive(Clone, Copy, Debug)]
pub struct Glossy {
    /// Linear base colour.
    pub base: Vec3,
    /// Metallic factor.
    pub metallic: f32,
    /// Perceptual roughness.
    pub roughness: f32,
}

impl Glossy {
    /// The BRDF `f(v, l)` (not multiplied by the cosine) for unit `n`, `v`, `l` on the same side.
    pub fn brdf(&self, n: Vec3, v: Vec3, l: Vec3) -> Vec3 {
        let (nl, nv) = (n.dot(l), n.dot(v));
        if nl <= 0.0 || nv <= 0.0 {
            return Vec3::ZERO;
        }
        let h = (v + l).normalize();
        let (nh, vh) = (n.dot(h).max(0.0), v.dot(h).max(0.0));
        let a = (self.roughness * self.roughness).max(1e-3);
        let a2 = a * a;
        let f0 = Vec3::splat(0.04) * (1.0 - self.metallic) + self.base * self.metallic;
        let f = f0 + (Vec3::ONE - f0) * (1.0 - vh).powi(5);
        let denom = nh * nh * (a2 - 1.0) + 1.0;
        let d = a2 / (PI * denom * denom);
        // Height-correlated Smith visibility V = G / (4 n·l n·v).
        let vis = 0.5 / (nl * (nv * nv * (1.0 - a2) + a2).sqrt() + nv * (nl * nl * (1.0 - a2) + a2).sqrt());
        let diffuse = (Vec3::ONE - f) * self.base * (1.0 - self.metallic) / PI;
        diffuse + f * d * vis
    }
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
        if let Some(g) = albedo.glossy(hit.tri) {
            // Glossy surface: next-event sun with the full BRDF, then a cosine-weighted bounce
            // with weight f·cos/pdf = π·f.
            let v = -d;
            let cos = hit.normal.dot(sun);
            if cos > 0.0 && scene.sees_direction(hit.point, hit.normal, sun) {
                sun_l += throughput * g.brdf(hit.normal, v, sun) * cos;
            }
            let next = sample_cosine_around(hit.normal, Vec2::new(rng.random(), rng.random()));
            throughput *= g.brdf(hit.normal, v, next) * PI;
            if depth >= 3 {
                let q = throughput.max_element().min(0.95);
                if rng.random::<f32>() >= q {
                    break;
                }
                throughput /= q;
            }
            o = hit.point;
            offset = hit.normal * RAY_EPSILON_M;
            d = next;
            continue;
        }
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
    render_basis_region(scene, albedo, camera, sun, spp, seed, (0, 0, w, h))
}

/// [`render_basis`] over the pixels `(x0, y0, width, height)` only (row-major within the region).
pub fn render_basis_region(
    scene: &RayScene,
    albedo: &dyn TrueAlbedo,
    camera: &Camera,
    sun: Vec3,
    spp: u32,
    seed: u64,
    (x0, y0, w, h): (u32, u32, u32, u32),
) -> (Vec<Vec3>, Vec<Vec3>) {
    let rows: Vec<Vec<(Vec3, Vec3)>> = (y0..y0 + h)
        .into_par_iter()
        .map(|y| {
            (x0..x0 + w)
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
                        let d = heliar::geometry::equirect::dir_from_texel(x as f32 + rng.random::<f32>(), y as f32 + rng.random::<f32>(), width, height);
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
