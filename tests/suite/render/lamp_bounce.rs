//! The lamps' light bounced onto the virtual objects (issue 16 §3; `render::object_transfer::lamps`
//! and the compositor's `lamp_bounce`):
//! - the traced `R` of a small face looking down at a lamp-lit Lambertian floor against a
//!   quadrature of the closed-form floor radiance `ρ_g/π · I·h/r³` through the face's glTF BRDF;
//! - the GPU: the shading pass adds `k·R` of the traced lattice to the objects' pixels, and a
//!   frame without a lamp on skips the unit and adds nothing.

use super::lamps::{K, setup, spot};
use glam::Vec3;
use heliar::geometry::ambient::TransportQuality;
use heliar::geometry::brdf::GltfSurface;
use heliar::geometry::{Material, Mesh};
use heliar::lamps::Lamp;
use heliar::lighting::{LampScales, Lighting};
use heliar::render::frame::pass;
use heliar::render::lamps::LampOptions;
use heliar::render::object_transfer::{PixelSurface, TransferScene, trace_lamp_point};
use heliar::render::{CompositorConfig, VideoFrame};
use heliar::scene::lights::world_from_lamp;
use heliar::scene::{Light, LightKind, Schedule};
use std::f32::consts::FRAC_1_PI;
use std::path::Path;

fn point_lamp(at: Vec3, cd: f64) -> Lamp {
    let light = Light {
        name: "lamp".into(),
        field: "lights[0]".into(),
        kind: LightKind::Point { intensity_cd: cd },
        position: at.as_dvec3(),
        world_from_lamp: world_from_lamp(glam::DVec3::NEG_Y, 0.0).unwrap(),
        scale: 1.0,
        schedule: Schedule::Always,
    };
    Lamp::load(Path::new("scene.toml"), &light).unwrap()
}

#[test]
fn a_face_over_a_lamp_lit_floor_gets_the_closed_form_bounce() {
    // A 2 cm face 1 m above an infinite floor of albedo ρ_g, looking down; an isotropic point
    // lamp of I cd at (1, 2, 0), above the face's plane, so the face gets no direct light. The
    // floor's radiance at a point at distance r from the lamp is ρ_g/π·I·h/r³ (h = 2); the
    // face's radiance toward a view straight down is ∫ f(v, l)·cos·L_floor dω over the lower
    // hemisphere, by a midpoint quadrature in (θ, φ) below. The face's own lamp shadow on the
    // floor (4 cm across, 1.4 m away) and the light it sends back are below 0.1% and left out.
    let (rho_g, cd) = (0.5f32, 10.0f64);
    let lamp_at = Vec3::new(1.0, 2.0, 0.0);
    let mut floor = Mesh::default();
    let mat = floor.add_material(Material::diffuse("floor", [rho_g; 3]));
    let node = floor.add_node("floor", true);
    floor.push_quad(Vec3::new(-500.0, 0.0, -500.0), Vec3::Z * 1000.0, Vec3::X * 1000.0, node, mat);
    let mut face = Mesh::default();
    let fm = face.add_material(Material { roughness: 0.6, ..Material::diffuse("face", [0.6, 0.5, 0.4]) });
    let fnode = face.add_node("face", false);
    face.push_quad(Vec3::new(-0.01, 1.0, -0.01), Vec3::X * 0.02, Vec3::Z * 0.02, fnode, fm);
    let scene = TransferScene::new(&floor, &[&face]);
    let tri = scene.first_object_tri;
    let (n, view) = (Vec3::NEG_Y, Vec3::NEG_Y);
    let s = PixelSurface { pixel: 0, point: Vec3::new(0.0, 1.0, 0.0), normal: n, face_normal: n, view, tri, footprint_m: 0.01 };
    let lamp = point_lamp(lamp_at, cd);
    let q = TransportQuality { paths: 16_384, max_bounces: 2 };
    let got = trace_lamp_point(&scene, &s, std::slice::from_ref(&lamp), q, 3)[0];

    let surf = GltfSurface::new(&face.materials[0], Vec3::new(0.6, 0.5, 0.4));
    let (nt, np) = (1024, 256);
    let mut want = Vec3::ZERO;
    for i in 0..nt {
        let th = (i as f32 + 0.5) / nt as f32 * std::f32::consts::FRAC_PI_2;
        for j in 0..np {
            let ph = (j as f32 + 0.5) / np as f32 * std::f32::consts::TAU;
            let l = Vec3::new(th.sin() * ph.cos(), -th.cos(), th.sin() * ph.sin());
            let y = s.point + l / th.cos();
            let r = (lamp_at - y).length();
            let radiance = rho_g * FRAC_1_PI * cd as f32 * lamp_at.y / (r * r * r);
            want += surf.eval_cos(n, view, l) * radiance * th.sin() * (std::f32::consts::FRAC_PI_2 / nt as f32) * (std::f32::consts::TAU / np as f32);
        }
    }
    // 16 384 stratified paths of a smooth integrand: measured well under 1%; 2% is the bound.
    for c in 0..3 {
        assert!((got[c] - want[c]).abs() < 0.02 * want[c], "channel {c}: traced {got} against the quadrature's {want}");
    }
    assert!(want.x > 0.01, "a clear signal: {want}");
    // Deterministic for a seed.
    assert_eq!(got, trace_lamp_point(&scene, &s, std::slice::from_ref(&lamp), q, 3)[0]);
    // Without the floor there is nothing to bounce off.
    let alone = TransferScene::new(&Mesh::default(), &[&face]);
    let s0 = PixelSurface { tri: alone.first_object_tri, ..s };
    assert_eq!(trace_lamp_point(&alone, &s0, std::slice::from_ref(&lamp), q, 3)[0], Vec3::ZERO);
}

fn night(k: [f32; 3]) -> Lighting {
    Lighting { sun_dir: Vec3::Y, above_horizon: false, pd: Vec3::ZERO, pa: Vec3::ZERO, sky: heliar::lighting::FrameSky::Declared, lamps: LampScales::from_slice(&[k]) }
}

fn transfer_config() -> CompositorConfig {
    let mut c = CompositorConfig::from_estimator_settings(&Default::default());
    c.occlusion_rays = 0;
    c.transfer_paths = 16;
    c.transfer_bounces = 2;
    c.transfer_stride = 1;
    c
}

#[test]
fn the_shading_adds_k_times_the_traced_bounce() {
    // The lamp over the objects toward the wall (the lamp_ground scene): the ground and the
    // wall are lit, so the objects get bounce light. Render at night (Pa = Pd = 0: no other
    // ambient) with and without the bounce; the difference at a traced pixel whose 3×3 lattice
    // neighbours all lie on its face is the mean of their k·R (the shading's lookup weights
    // are normalised), which is compared with the CPU's traced values.
    let s = setup(false, [0.6, 2.4, 3.4]);
    let lamp = spot(Vec3::new(2.5, 3.0, 0.0), Vec3::new(-0.5, 0.0, 0.0));
    let (w, h) = (s.camera.intrinsics.width, s.camera.intrinsics.height);
    let video = VideoFrame { width: w, height: h, rgba: vec![[0.0, 0.0, 0.0, 1.0]; (w * h) as usize] };
    let mut with = s.compositor(transfer_config());
    with.set_lamps(std::slice::from_ref(&lamp), LampOptions::default()).expect("lamps");
    let mut without = s.compositor(transfer_config());
    without.set_lamps(std::slice::from_ref(&lamp), LampOptions { bounce: false, ..Default::default() }).expect("lamps");
    let (a, report) = with.render(&video, &night(K)).expect("render");
    assert!(report.ran.contains(&pass::LAMP_BOUNCE), "{report:?}");
    let (b, report_b) = without.render(&video, &night(K)).expect("render");
    assert!(!report_b.ran.contains(&pass::LAMP_BOUNCE) && report_b.skip_reason(pass::LAMP_BOUNCE).is_none(), "no unit without the option");

    let t = with.transfer().expect("transfer on");
    assert_eq!(t.stride(), 1);
    let bounce = with.lamp_bounce().expect("traced on the first lit frame");
    let surfaces = t.surfaces();
    let (w_canvas, h_canvas) = (with.canvas().intrinsics.width, with.canvas().intrinsics.height);
    let by_pixel: std::collections::HashMap<u32, usize> = surfaces.iter().enumerate().map(|(i, s)| (s.pixel, i)).collect();
    // k·R at the canvas pixels whose value the shading's lookup gives.
    let mut want_canvas: std::collections::HashMap<u32, Vec3> = std::collections::HashMap::new();
    for sfc in surfaces {
        let (x, y) = ((sfc.pixel % w_canvas) as i32, (sfc.pixel / w_canvas) as i32);
        // The shading's lookup (shaders/virtual_shading.wgsl, `transfer_lookup`) at the pixel's
        // own point and normal: weights exp(−d²)·(n·n_j − 0.9)/0.1 over the 3×3 entries.
        let (mut sum, mut wsum, mut all) = (Vec3::ZERO, 0.0f32, true);
        for dy in -1..=1 {
            for dx in -1..=1 {
                let q = (x + dx, y + dy);
                let found = (q.0 >= 0 && q.1 >= 0 && q.0 < w_canvas as i32 && q.1 < h_canvas as i32).then(|| by_pixel.get(&((q.1 as u32) * w_canvas + q.0 as u32))).flatten();
                let Some(&j) = found.filter(|&&j| surfaces[j].tri == sfc.tri) else {
                    all = false;
                    continue;
                };
                let e = &surfaces[j];
                let d = (e.point - sfc.point).length() / e.footprint_m.max(1e-6);
                let nd = e.normal.dot(sfc.normal);
                if nd < 0.9 || d > 2.5 {
                    continue;
                }
                let wt = (-d * d).exp() * (nd - 0.9) / (1.0 - 0.9 + 1e-6);
                sum += wt * bounce.radiance(j, 0);
                wsum += wt;
            }
        }
        // Interior pixels only: all nine entries on the pixel's own triangle.
        if all && wsum > 0.0 {
            want_canvas.insert(sfc.pixel, sum / wsum * Vec3::from(K));
        }
    }
    // The composite samples the canvas bilinearly at each footage pixel's warp point (texel
    // centres at integers, `shaders/composite.wgsl`).
    let warp = &with.canvas().warp;
    let (mut compared, mut got_sum, mut want_sum) = (0usize, Vec3::ZERO, Vec3::ZERO);
    for (o, q) in warp.iter().enumerate() {
        if q[0] < 0.0 {
            continue;
        }
        let (x0, y0) = (q[0].floor(), q[1].floor());
        let (fx, fy) = (q[0] - x0, q[1] - y0);
        let at = |dx: u32, dy: u32| want_canvas.get(&((y0 as u32 + dy) * w_canvas + x0 as u32 + dx)).copied();
        let (Some(a00), Some(a10), Some(a01), Some(a11)) = (at(0, 0), at(1, 0), at(0, 1), at(1, 1)) else { continue };
        want_sum += (a00 * (1.0 - fx) + a10 * fx) * (1.0 - fy) + (a01 * (1.0 - fx) + a11 * fx) * fy;
        got_sum += Vec3::from(a.image.data[o]) - Vec3::from(b.image.data[o]);
        compared += 1;
    }
    // Summed over the compared pixels, so that the traced values' Monte Carlo noise and the
    // bilinear taps average out: the GPU's bounce against k·R within 3% per channel (what is
    // left is half floats, 2⁻¹¹, and the fragments' interpolated points against the centre
    // rays'); a missing or doubled bounce is off by 100%.
    assert!(compared > 500, "only {compared} interior pixels");
    for c in 0..3 {
        assert!(want_sum[c] > 0.0, "the bounce is there: {want_sum}");
        assert!((got_sum[c] - want_sum[c]).abs() < 0.03 * want_sum[c], "channel {c}: GPU {got_sum} against k·R {want_sum} over {compared} pixels");
    }

    // A frame with the lamp off: the unit is skipped and the objects go back to black.
    let (c, report) = with.render(&video, &night([0.0; 3])).expect("render");
    assert!(report.ran.contains(&pass::LAMP_BOUNCE), "zeros uploaded once: {report:?}");
    assert!(c.image.data.iter().all(|p| p.iter().all(|&v| v == 0.0)), "nothing without a lamp on");
    let (_, report) = with.render(&video, &night([0.0; 3])).expect("render");
    assert_eq!(report.skip_reason(pass::LAMP_BOUNCE), Some("no lamp is on"));
}
