//! Shaded virtual pixels against a CPU evaluation of the same shading equation at the same
//! surface points (CPU ray casts for the points, sun visibility by shadow rays, the CPU
//! `ProbeGrid::irradiance` for the ambient, the BRDF written again in Rust).

use super::support::*;
use glam::{UVec3, Vec3};
use heliar::geometry::{Material, Mesh};
use heliar::irradiance::{ProbeGrid, sh};
use heliar::lighting::Lighting;
use heliar::render::{CompositorConfig, VideoFrame};

/// Mean absolute error allowed, as a fraction of the range of the reference values (issue 4, §6).
const MAX_MEAN_ERROR_OF_RANGE: f64 = 0.01;

fn material(rgb: [f32; 3], metallic: f32, roughness: f32, name: &str) -> Material {
    Material { name: name.into(), base_color: [rgb[0], rgb[1], rgb[2], 1.0], base_color_texture: None, metallic, roughness }
}

/// A probe grid with structure in every band, and a few invalid probes.
fn structured_grid() -> ProbeGrid {
    let mut g = ProbeGrid::filled(Vec3::new(-6.0, 0.1, -6.0), Vec3::new(6.0, 3.0, 6.0), 1.0, sh::uniform_upper_sky(Vec3::new(0.55, 0.62, 0.8)));
    let dims: UVec3 = g.dims;
    for z in 0..dims.z {
        for y in 0..dims.y {
            for x in 0..dims.x {
                let i = g.index(x, y, z);
                let p = g.position(x, y, z);
                for k in 2..9 {
                    for c in 0..3 {
                        g.coeffs[i][k][c] += 0.05 * ((p.x * 0.7 + p.z * 0.3 + k as f32 + c as f32).sin());
                    }
                }
                // Probes inside the wall (x ≈ -3, low, |z| < 1.5) are invalid, as a bake marks them.
                if x == 3 && p.y < 2.4 && p.z.abs() < 1.5 {
                    g.valid[i] = false;
                }
            }
        }
    }
    g
}

#[test]
fn shaded_pixels_match_a_cpu_evaluation() {
    let sun = courtyard_sun();
    let objects: Vec<(String, Mesh)> = vec![
        ("sphere".into(), icosphere(Vec3::new(-1.9, 0.85, 0.0), 0.35, 2, material([0.6, 0.12, 0.08], 0.0, 0.45, "paint"), "sphere")),
        ("pedestal".into(), cube(Vec3::new(-2.2, 0.0, -0.3), Vec3::new(-1.6, 0.5, 0.3), material([0.7, 0.7, 0.68], 0.0, 0.9, "stone"), "pedestal")),
        ("ball".into(), icosphere(Vec3::new(0.4, 0.5, 1.6), 0.5, 2, material([0.9, 0.7, 0.3], 1.0, 0.3, "brass"), "ball")),
        ("crate".into(), cube(Vec3::new(-0.8, 0.0, 2.2), Vec3::new(-0.2, 0.6, 2.8), material([0.4, 0.5, 0.3], 0.0, 0.6, "crate"), "crate")),
    ];
    let setup = Setup { camera: camera([1.5, 1.6, 5.0], [-1.2, 0.4, 0.2], 320, 240, [-0.08, 0.012, 0.0005, -0.0003, 0.0]), proxy: yard_proxy(), objects };
    let grid = structured_grid();
    let (pd, pa) = (Vec3::new(3.2, 3.0, 2.7), Vec3::new(0.55, 0.62, 0.8));
    // The objects' own ambient occlusion is a Monte Carlo factor per canvas pixel, tested on its
    // own (src/render/occlusion.rs); here the probe path of the shading equation is compared
    // without it and without the per-pixel transfer (tested in transfer.rs).
    let mut config = CompositorConfig::from_estimator_settings(&Default::default());
    config.occlusion_rays = 0;
    config.transfer_paths = 0;
    let mut comp = setup.compositor(config);
    comp.set_probes(&grid);
    let (w, h) = (320, 240);
    let video = VideoFrame { width: w, height: h, rgba: vec![[0.0, 0.0, 0.0, 1.0]; (w * h) as usize] };
    let (frame, _) = comp.render(&video, &Lighting { sun_dir: sun, above_horizon: true, pd, pa, sky: heliar::lighting::FrameSky::Declared, lamps: heliar::lighting::LampScales::NONE }).expect("render");

    let r = reference(&setup, sun);
    let lit: Vec<(u32, bool)> = r.iter().map(|p| (p.tri, p.real_shadow || p.virtual_shadow)).collect();
    let edge = edges(w, h, &lit);
    let eye = setup.camera.pose.translation.as_vec3();
    let (mut want, mut got) = (Vec::new(), Vec::new());
    for i in 0..(w * h) as usize {
        let p = &r[i];
        if p.kind != 2 || edge[i] {
            continue;
        }
        let mesh = &setup.objects[p.object].1;
        let m = &mesh.materials[mesh.tri_material[(p.tri % 1_000_000) as usize] as usize];
        let base = Vec3::new(m.base_color[0], m.base_color[1], m.base_color[2]);
        let (n, v) = (p.normal, (eye - p.point).normalize());
        let r_dir = (2.0 * n.dot(v) * n - v).normalize();
        let e = |d: Vec3| grid.irradiance(p.point, d).unwrap_or(Vec3::ZERO);
        let mut l = ambient_radiance(base, m.metallic, m.roughness, n.dot(v), e(n), e(r_dir));
        if !(p.real_shadow || p.virtual_shadow) {
            l += pd * brdf_cos(base, m.metallic, m.roughness, n, v, sun);
        }
        want.push(l);
        got.push(Vec3::from(frame.image.data[i]));
    }
    assert!(want.len() > 3000, "only {} interior virtual pixels", want.len());
    for c in 0..3 {
        let (lo, hi) = want.iter().fold((f32::MAX, f32::MIN), |(a, b), v| (a.min(v[c]), b.max(v[c])));
        let mean = want.iter().zip(&got).map(|(a, b)| (a[c] - b[c]).abs() as f64).sum::<f64>() / want.len() as f64;
        let rel = mean / (hi - lo) as f64;
        eprintln!("channel {c}: {} pixels, range {lo:.4}..{hi:.4}, mean error {mean:.5} = {:.3}% of the range", want.len(), 100.0 * rel);
        assert!(rel < MAX_MEAN_ERROR_OF_RANGE, "channel {c}: mean error {:.3}% of the range", 100.0 * rel);
    }
}
