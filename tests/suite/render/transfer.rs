//! The virtual objects shaded with the per-pixel ambient transfer, against an independent CPU
//! path tracer of the whole radiance (direct sun with shadow rays, sky, interreflection between
//! the objects and the proxy), written here with the test's own BRDF and plain cosine sampling.
//!
//! This checks the transfer's physics (glTF BRDF sampling, bounces, the sun after a bounce, the
//! objects' shadows on the ground that lights them) and its plumbing to the GPU (texture layout,
//! the per-fragment lookup, scaling by `Pa` and `Pd`) at once.

use super::support::*;
use glam::{Vec2, Vec3};
use heliar::geometry::raycast::{RAY_EPSILON_M, RayScene};
use heliar::geometry::sampling::sample_cosine_around;
use heliar::geometry::{Material, Mesh};
use heliar::lighting::Lighting;
use heliar::render::{CompositorConfig, VideoFrame};
use rand::{Rng, SeedableRng, rngs::SmallRng};
use std::f32::consts::PI;

/// Relative RMSE allowed over the compared pixels: twice the measured worst case (0.6% in sun,
/// 2.0% with sky light alone, where the glossy metal ball's cosine-sampled reference is the
/// noisier side). Both sides are Monte Carlo estimates: 512 importance-sampled paths per pixel
/// in the compositor (averaged over the matching 3×3 lattice entries), 4096 cosine-sampled ones
/// here.
const MAX_RELATIVE_RMSE: f64 = 0.04;
/// Allowed relative difference of the mean radiances (measured: within 0.1%). Both estimates
/// are unbiased, so a wrong factor of the sky, the sun bounce or the BRDF shows here first; a
/// 10% error in the sky light alone would move the sky-only mean by 10%.
const MAX_MEAN_BIAS: f64 = 0.01;

fn material(rgb: [f32; 3], metallic: f32, roughness: f32, name: &str) -> Material {
    Material { name: name.into(), base_color: [rgb[0], rgb[1], rgb[2], 1.0], base_color_texture: None, metallic, roughness }
}

/// Radiance toward `-d` from the first hit along `o + t·d` (proxy first, then the objects in
/// `world`): sun by next-event estimation at every vertex, sky `Pa/π` above the horizon,
/// cosine-weighted continuation with weight `π·f`.
fn radiance(world: &RayScene, first_object_tri: u32, o: Vec3, d: Vec3, sun: Vec3, pd: Vec3, pa: Vec3, rng: &mut SmallRng) -> Vec3 {
    let mesh = world.mesh();
    let (mut o, mut d, mut off) = (o, d, Vec3::ZERO);
    let (mut acc, mut thr) = (Vec3::ZERO, Vec3::ONE);
    for _ in 0..6 {
        let Some(hit) = world.intersect(o + off, d, f32::MAX) else {
            if d.y > 0.0 {
                acc += thr * pa / PI;
            }
            break;
        };
        let n = hit.normal;
        let lit = n.dot(sun) > 0.0 && world.sees_direction(hit.point, n, sun);
        let next = sample_cosine_around(n, Vec2::new(rng.random(), rng.random()).min(Vec2::splat(0.999_999)));
        if hit.tri >= first_object_tri {
            let m = &mesh.materials[mesh.tri_material[hit.tri as usize] as usize];
            let base = Vec3::new(m.base_color[0], m.base_color[1], m.base_color[2]);
            if lit {
                acc += thr * brdf_cos(base, m.metallic, m.roughness, n, -d, sun) * pd;
            }
            thr *= brdf_cos(base, m.metallic, m.roughness, n, -d, next) / n.dot(next).max(1e-6) * PI;
        } else {
            let rho = world.albedo(&hit);
            if lit {
                acc += thr * rho / PI * pd * n.dot(sun);
            }
            thr *= rho;
        }
        o = hit.point;
        off = n * RAY_EPSILON_M;
        d = next;
    }
    acc
}

#[test]
fn transfer_shading_matches_an_independent_path_tracer() {
    use rayon::prelude::*;
    let sun = courtyard_sun();
    let objects: Vec<(String, Mesh)> = vec![
        ("sphere".into(), icosphere(Vec3::new(-1.9, 0.85, 0.0), 0.35, 2, material([0.6, 0.12, 0.08], 0.0, 0.45, "paint"), "sphere")),
        ("pedestal".into(), cube(Vec3::new(-2.2, 0.0, -0.3), Vec3::new(-1.6, 0.5, 0.3), material([0.7, 0.7, 0.68], 0.0, 0.9, "stone"), "pedestal")),
        ("ball".into(), icosphere(Vec3::new(0.4, 0.5, 1.6), 0.5, 2, material([0.9, 0.7, 0.3], 1.0, 0.5, "brass"), "ball")),
    ];
    let setup = Setup { camera: camera([1.5, 1.6, 5.0], [-1.0, 0.4, 0.4], 240, 180, [-0.06, 0.01, 0.0, 0.0, 0.0]), proxy: yard_proxy(), objects };
    let (pd, pa) = (Vec3::new(3.2, 3.0, 2.7), Vec3::new(0.55, 0.62, 0.8));
    let mut comp = setup.compositor(CompositorConfig::from_estimator_settings(&Default::default()));
    let (w, h) = (240u32, 180u32);
    let video = VideoFrame { width: w, height: h, rgba: vec![[0.0, 0.0, 0.0, 1.0]; (w * h) as usize] };
    let (frame, report) = comp.render(&video, &Lighting { sun_dir: sun, above_horizon: true, pd, pa, sky: heliar::lighting::FrameSky::Declared, lamps: heliar::lighting::LampScales::NONE }).expect("render");
    assert!(report.ran("object_transfer"), "{report:?}");
    assert!(report.transfer_traced > 1000, "{} pixels traced", report.transfer_traced);

    let r = reference(&setup, sun);
    let key: Vec<(u32, bool)> = r.iter().map(|p| (p.tri, p.real_shadow || p.virtual_shadow)).collect();
    let edge = edges(w, h, &key);
    let mut world = setup.proxy.clone();
    let first = world.triangles.len() as u32;
    for (_, m) in &setup.objects {
        world.append(m);
    }
    let world = RayScene::new(world);
    // Every interior virtual pixel (away from facet, object and shadow edges).
    let pixels: Vec<usize> = (0..(w * h) as usize).filter(|&i| r[i].kind == 2 && !edge[i]).collect();
    assert!(pixels.len() > 300, "only {} pixels", pixels.len());
    let paths = 4096;
    // The reference radiance of every compared pixel's centre ray under sun `pd` and sky `pa`.
    let traced = |pd: Vec3, seed: u64| -> Vec<Vec3> {
        pixels
            .par_iter()
            .map(|&i| {
                let (o, d) = setup.camera.pixel_ray(i as u32 % w, i as u32 / w).expect("pixel ray");
                let mut rng = SmallRng::seed_from_u64(seed ^ i as u64);
                let mut acc = Vec3::ZERO;
                for _ in 0..paths {
                    acc += radiance(&world, first, o.as_vec3(), d.as_vec3(), sun, pd, pa, &mut rng);
                }
                acc / paths as f32
            })
            .collect()
    };
    let want = traced(pd, 0x51);
    let compare = |what: &str, got: &[Vec3], want: &[Vec3]| {
        let (mut num, mut den, mut sg, mut sw) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
        for (a, b) in got.iter().zip(want) {
            for c in 0..3 {
                num += ((a[c] - b[c]) as f64).powi(2);
                den += (b[c] as f64).powi(2);
                sg += a[c] as f64;
                sw += b[c] as f64;
            }
        }
        let (rel, bias) = ((num / den).sqrt(), sg / sw - 1.0);
        eprintln!("transfer shading, {what}: {} pixels, relative RMSE {:.2}%, mean {:+.2}% against {paths} independent paths per pixel", got.len(), 100.0 * rel, 100.0 * bias);
        assert!(rel < MAX_RELATIVE_RMSE, "{what}: relative RMSE {:.2}%", 100.0 * rel);
        assert!(bias.abs() < MAX_MEAN_BIAS, "{what}: mean bias {:+.2}%", 100.0 * bias);
    };
    let got: Vec<Vec3> = pixels.iter().map(|&i| Vec3::from(frame.image.data[i])).collect();
    compare("sun and sky", &got, &want);

    // Every second canvas pixel traced (a quarter of the paths): the lookup reconstructs the
    // pixels between the lattice points from their neighbours on the same face.
    let mut coarse = setup.compositor(CompositorConfig { transfer_stride: 2, ..CompositorConfig::from_estimator_settings(&Default::default()) });
    let (frame2, report2) = coarse.render(&video, &Lighting { sun_dir: sun, above_horizon: true, pd, pa, sky: heliar::lighting::FrameSky::Declared, lamps: heliar::lighting::LampScales::NONE }).expect("render");
    assert!(report2.transfer_traced < report.transfer_traced / 3, "{} of {} traced", report2.transfer_traced, report.transfer_traced);
    let got: Vec<Vec3> = pixels.iter().map(|&i| Vec3::from(frame2.image.data[i])).collect();
    compare("sun and sky, stride 2", &got, &want);

    // Sky light alone (the sun below the horizon): R_a by itself, and the sun term and R_d off.
    let (frame, report) = comp.render(&video, &Lighting { sun_dir: sun, above_horizon: false, pd, pa, sky: heliar::lighting::FrameSky::Declared, lamps: heliar::lighting::LampScales::NONE }).expect("render");
    assert!(!report.ran("object_transfer"), "no sun: the traced transfer is reused");
    let want = traced(Vec3::ZERO, 0x52);
    let got: Vec<Vec3> = pixels.iter().map(|&i| Vec3::from(frame.image.data[i])).collect();
    compare("sky only", &got, &want);
}
