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

/// Sub-pixel rays per axis of the crease test's CPU box filter.
const CREASE_SUBSAMPLES: u32 = 8;
/// Largest relative difference between the crease pixels' summed radiance and the CPU's
/// box-filtered sum: the GPU's 4 samples quantise each pixel's coverage to quarters, which
/// averages out over the crease (measured −0.31% over 57 pixels, lavapipe); weighting each
/// fragment by the whole pixel's lit fraction, as the shading pass did before, gave −5.56%.
const MAX_CREASE_ERROR: f64 = 0.02;

/// A face in the sun and one turned away from it meeting inside a pixel (a block's edges seen
/// obliquely, as the winter statue's pedestal is): each face's fragment takes the sun's
/// visibility of the samples it covers, so the crease pixels carry the lit face's covered share
/// of its radiance, as a path tracer's box filter over the pixel does (the CPU side: 8×8
/// sub-pixel rays, the BRDF written again in Rust, no ambient light on either side).
#[test]
fn a_crease_between_a_sunlit_and_a_shaded_face_keeps_the_lit_faces_share() {
    use glam::DVec2;
    use heliar::geometry::raycast::RayScene;
    let sun = Vec3::new(0.8, 0.5, -0.3).normalize();
    let base = Vec3::new(0.7, 0.7, 0.68);
    let (setup, block, frame) = sunlit_block(sun, base, [0.0; 5], None);
    let pd = Vec3::splat(3.0);
    let (w, h) = (setup.camera.intrinsics.width, setup.camera.intrinsics.height);

    // Per pixel: the box-filtered sun radiance, or None unless every sub-pixel ray meets the block
    // and both a face in the sun and one turned away from it show.
    let (objects, proxy) = (RayScene::new(block), RayScene::new(setup.proxy.clone()));
    let eye = setup.camera.pose.translation.as_vec3();
    let crease = |x: u32, y: u32| -> Option<f32> {
        let k = CREASE_SUBSAMPLES;
        let (mut sum, mut lit, mut dark) = (0.0f32, 0, 0);
        for j in 0..k * k {
            let uv = DVec2::new(x as f64 - 0.5 + ((j % k) as f64 + 0.5) / k as f64, y as f64 - 0.5 + ((j / k) as f64 + 0.5) / k as f64);
            let (o, d) = setup.camera.ray_at(uv)?;
            let (o, d) = (o.as_vec3(), d.as_vec3());
            let hit = objects.intersect(o, d, f32::MAX)?;
            if proxy.intersect(o, d, f32::MAX).is_some_and(|p| p.t < hit.t) {
                return None;
            }
            if hit.normal.dot(sun) > 0.0 {
                lit += 1;
                sum += (pd * brdf_cos(base, 0.0, 0.9, hit.normal, (eye - hit.point).normalize(), sun)).x;
            } else {
                dark += 1;
            }
        }
        (lit > 0 && dark > 0).then_some(sum / (k * k) as f32)
    };
    let (mut want, mut got, mut pixels) = (0.0f64, 0.0f64, 0);
    for y in 0..h {
        for x in 0..w {
            if let Some(l) = crease(x, y) {
                want += l as f64;
                got += frame.image.data[(y * w + x) as usize][0] as f64;
                pixels += 1;
            }
        }
    }
    let rel = (got - want) / want;
    eprintln!("crease: {pixels} pixels, summed radiance {got:.3} against {want:.3} box-filtered ({:+.2}%)", 100.0 * rel);
    assert!(pixels >= 40, "only {pixels} crease pixels");
    assert!(rel.abs() < MAX_CREASE_ERROR, "the crease pixels carry {:+.2}% of the lit face's box-filtered radiance", 100.0 * rel);
}
