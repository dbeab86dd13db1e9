//! Issue 15 §2, "evaluation where it is fastest here, on the CPU (rayon) or in a compute pass":
//! the objects' per-vertex ambient from the visibility cuts (the first pass, Eq. 3: each vertex's
//! self-visibility cut × the other object's field × the proxy field, times the clustered
//! lighting) for one frame, on the CPU (`FrameCuts::object_ambient`, rayon over the vertices on
//! the global pool) and in the compute pass (`run::cuts_gpu::GpuFrameCuts`: the operands found
//! on the CPU, lighting and operands uploaded, the walk, the rows read back) on Vulkan/lavapipe
//! and on GL/llvmpipe. Same inputs: the courtyard's statue and robot (5 742 vertices) with the
//! robot beside the statue, cuts computed as the frame loop does (`S = 2^10`, 8 spheres × 16²,
//! the proxy field over the `[irradiance]` box), and again at `S = 2^13`.
//!
//! `HELIAR_BENCH_CUTS_LEVELS=10,13` picks the tree depths.

use criterion::{Criterion, criterion_group, criterion_main};
use glam::Vec3;
use heliar::cuts::file::precompute;
use heliar::cuts::flat::{FlatBanks, FrameOps};
use heliar::cuts::frame::{FrameCuts, ObjectAmbient, UnitLighting};
use heliar::cuts::lighting::ClusteredLighting;
use heliar::cuts::rotate::Pose;
use heliar::cuts::{DirectionTree, no_progress};
use heliar::geometry::raycast::RayScene;
use heliar::gpu::{Gpu, GpuOptions};
use heliar::run::cuts_gpu::GpuFrameCuts;
use heliar::run::precompute::{PrecomputeOptions, settings};
use heliar::scene::Scene;
use std::f32::consts::FRAC_1_PI;
use std::hint::black_box;
use std::path::Path;
use std::time::Duration;

/// The courtyard's cuts at `levels` with the frame loop's field sampling.
fn courtyard_cuts(levels: u32) -> FrameCuts {
    let scene = Scene::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/courtyard")).expect("bundled scene");
    let proxy = RayScene::new(scene.proxy.clone());
    let objects: Vec<(&str, &heliar::geometry::Mesh)> = scene.virtual_objects.iter().map(|o| ("object", &o.mesh)).collect();
    let opts = PrecomputeOptions { levels, ..PrecomputeOptions::frame_loop() };
    let t = std::time::Instant::now();
    let cuts = precompute(&objects, Some(&proxy), &settings(&scene, &opts), &no_progress).expect("cuts");
    let svc: f64 = cuts.objects.iter().map(|o| o.svc.cuts.mean_cut_size()).sum::<f64>() / cuts.objects.len() as f64;
    eprintln!("S = 2^{levels}: cuts in {:.1} s, mean SVC {svc:.0} nodes", t.elapsed().as_secs_f64());
    FrameCuts::new(cuts).expect("tree")
}

/// All three parts of the lighting, with structure in every direction (as the test's).
fn lighting(tree: &DirectionTree) -> UnitLighting {
    let sky = |d: Vec3| if d.y > 0.0 { Vec3::new(0.8, 0.9, 1.2) * FRAC_1_PI * (0.6 + 0.4 * d.y + 0.3 * d.x.max(0.0)) } else { Vec3::ZERO };
    let ground = |d: Vec3, s: f32| if d.y <= 0.0 { Vec3::new(0.3, 0.28, 0.25) * s * (1.0 - 0.5 * d.z) } else { Vec3::ZERO };
    UnitLighting {
        sky_pa: ClusteredLighting::from_fn(tree, sky),
        surface_pa: Some(ClusteredLighting::from_fn(tree, |d| ground(d, 0.2))),
        surface_pd: Some(ClusteredLighting::from_fn(tree, |d| ground(d, 0.7))),
        maps: None,
        local: None,
    }
}

/// A device on one backend, or `None` (with a message) when it has no adapter.
fn device(backends: wgpu::Backends) -> Option<Gpu> {
    let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
    desc.backends = backends;
    let instance = wgpu::Instance::new(desc);
    let adapter = match pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions::default())) {
        Ok(a) => a,
        Err(e) => {
            eprintln!("no {backends:?} adapter ({e}): not measured");
            return None;
        }
    };
    let gpu = Gpu::from_adapter(instance, adapter, GpuOptions { samples: 1 }).ok()?;
    eprintln!("{backends:?}: {}", gpu.describe());
    Some(gpu)
}

/// The largest difference of `b` from `a`, relative to each row's largest channel (as the test
/// `object_cuts_gpu` measures it), for `E_n` (rows 0, 2) and `E_r` (rows 1, 3), and where.
fn difference(a: &ObjectAmbient, b: &ObjectAmbient) -> String {
    let mut worst = [(0.0f32, 0, 0, 0, [0.0f32; 4], [0.0f32; 4]); 2];
    for (k, (oa, ob)) in a.vertices.iter().zip(&b.vertices).enumerate() {
        for (v, (ra, rb)) in oa.iter().zip(ob).enumerate() {
            for r in 0..4 {
                let scale = ra[r][..3].iter().fold(1e-6f32, |m, x| m.max(x.abs()));
                let e = (0..3).map(|c| (ra[r][c] - rb[r][c]).abs()).fold(0.0, f32::max) / scale;
                if e > worst[r % 2].0 {
                    worst[r % 2] = (e, k, v, r, ra[r], rb[r]);
                }
            }
        }
    }
    let [(en, ..), (er, ..)] = worst;
    format!("worst difference to the CPU relative to each row's largest channel: E_n {en:.1e}, E_r {er:.1e}; worst rows (relative, object, vertex, row, CPU, GPU): {worst:?}")
}

fn bench_cuts(c: &mut Criterion) {
    let levels: Vec<u32> = std::env::var("HELIAR_BENCH_CUTS_LEVELS").ok().map(|s| s.split(',').filter_map(|v| v.trim().parse().ok()).collect()).unwrap_or_else(|| vec![10, 13]);
    let devices: Vec<(&str, Gpu)> = [("vulkan", wgpu::Backends::VULKAN), ("gl", wgpu::Backends::GL)].into_iter().filter_map(|(n, b)| device(b).map(|g| (n, g))).collect();
    // The robot (cut at [5, 0, −3]) beside the statue; the eye where the courtyard's camera is.
    let translations = [Vec3::ZERO, Vec3::new(-5.8, 0.0, 4.2)];
    let eye = Vec3::new(0.5, 1.6, 9.0);
    for l in levels {
        let frame = courtyard_cuts(l);
        let light = lighting(&frame.tree);
        let mut g = c.benchmark_group(format!("cuts_object_ambient_s2^{l}"));
        g.sample_size(10).measurement_time(Duration::from_secs(10)).warm_up_time(Duration::from_secs(1));
        g.bench_function(format!("cpu_rayon_{}_threads", rayon::current_num_threads()), |b| b.iter(|| black_box(frame.object_ambient(&light, &translations, eye).expect("cpu"))));
        let banks = FlatBanks::new(&frame).expect("banks");
        let poses = translations.map(Pose::translated);
        g.bench_function("operands_on_cpu_only", |b| b.iter(|| black_box(FrameOps::new(&frame, &banks, &poses, eye).expect("ops"))));
        for (name, gpu) in &devices {
            let mut pass = GpuFrameCuts::new(gpu, &frame).expect("upload");
            let cpu = frame.object_ambient(&light, &translations, eye).expect("cpu");
            let got = pass.object_ambient(gpu, &frame, &light, &translations, eye).expect("gpu");
            eprintln!("{name}: {}", difference(&cpu, &got));
            g.bench_function(format!("compute_pass_{name}"), |b| b.iter(|| black_box(pass.object_ambient(gpu, &frame, &light, &translations, eye).expect("gpu"))));
        }
        g.finish();
    }
}

criterion_group!(benches, bench_cuts);
criterion_main!(benches);
