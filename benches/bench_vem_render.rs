//! The GPU half of the VEM mode (issue 5 §4.1, §5): a frame with 300 lights at 320 × 240 on
//! whatever adapter wgpu opens (lavapipe here), with the per-region culling of Havran §4.1 and
//! without it (every light visited per fragment; the paper reports 1.6–1.8×). A 20k-triangle torus
//! fills most of the frame, shadows from 72 clustered maps of 256², tone mapping and both
//! readbacks included.

use criterion::{Criterion, criterion_group, criterion_main};
use glam::{DVec3, Vec3};
use heliar::geometry::{Material, Mesh};
use heliar::io::image::LinearImage;
use heliar::gpu::{Gpu, GpuOptions};
use heliar::camera::{Camera, Intrinsics, Pose};
use heliar::render::vem::{VemLights, VemRenderConfig, VemRenderer};
use heliar::vem::polar::PolarMap;
use heliar::vem::eval::synth::{RATE_HZ, outdoor, render_polar};
use heliar::vem::{Decomposer, VemConfig};
use std::hint::black_box;
use std::sync::Arc;
use std::time::Duration;

/// A closed brass torus of `2·rings·segments` triangles around +Y at `centre`.
fn torus(centre: Vec3, major: f32, minor: f32, rings: u32, segments: u32) -> Mesh {
    let mut m = Mesh::default();
    let mat = m.add_material(Material { name: "brass".into(), base_color: [0.9, 0.7, 0.3, 1.0], base_color_texture: None, metallic: 0.3, roughness: 0.4 });
    let node = m.add_node("torus", false);
    m.push_torus(centre, major, minor, rings, segments, node, mat);
    m
}

fn bench_vem_frame(c: &mut Criterion) {
    let gpu = Arc::new(Gpu::new(GpuOptions { samples: 1 }).expect("a GPU adapter"));
    eprintln!("GPU: {}", gpu.describe());
    let (w, h) = (320u32, 240u32);
    let camera = Camera {
        intrinsics: Intrinsics::brown_conrady(w, h, 300.0, 300.0, 159.5, 119.5, [0.0; 5]),
        pose: Pose::look_at(DVec3::new(0.0, 1.9, 1.9), DVec3::new(0.0, 0.35, 0.0), DVec3::Y).expect("pose"),
    };
    let object = torus(Vec3::new(0.0, 0.35, 0.0), 0.8, 0.35, 100, 100);
    let map: PolarMap = render_polar(&outdoor(0, RATE_HZ), 360, 90, 2);
    let mut dec = Decomposer::new(VemConfig { lights: 300, clusters: Some(72), ..VemConfig::default() }).expect("config");
    let mut status = dec.process(&map).status;
    for _ in 0..8 {
        status = dec.process(&map).status; // fill the filter window
    }
    let background = LinearImage::from_fn(w, h, |_, _| [0.5; 3]);
    // Where the time goes: medians of 5 frames per variant, GPU time (passes until idle).
    for (shadows, culling, glossy) in [(false, true, false), (false, false, false), (true, true, false), (true, false, false)] {
        let cfg = VemRenderConfig { culling, shadows, ..Default::default() };
        let mut r = VemRenderer::new(gpu.clone(), &camera, None, &[&object], cfg).expect("renderer");
        let lights = VemLights::of(&dec, status);
        let mut t: Vec<f64> = (0..5).map(|_| r.render(&lights, &background, 1.0 / RATE_HZ).expect("frame").report.timings.gpu_ms).collect();
        t.sort_by(f64::total_cmp);
        eprintln!("shadows {shadows}, culling {culling}, glossy {glossy}: GPU {:.1} ms (median of 5)", t[2]);
    }
    let mut g = c.benchmark_group("vem_render_320x240_300_lights");
    g.sample_size(10).measurement_time(Duration::from_secs(8)).warm_up_time(Duration::from_secs(2));
    for culling in [true, false] {
        let cfg = VemRenderConfig { culling, ..Default::default() };
        let mut r = VemRenderer::new(gpu.clone(), &camera, None, &[&object], cfg).expect("renderer");
        let lights = VemLights::of(&dec, status);
        let out = r.render(&lights, &background, 1.0 / RATE_HZ).expect("frame");
        eprintln!("culling {culling}: {} shadow maps, list fraction {:.2}, timings {:?}", out.report.shadow_maps, out.report.list_fraction, out.report.timings);
        g.bench_function(if culling { "culling" } else { "all_lights" }, |b| b.iter(|| black_box(r.render(&lights, &background, 1.0 / RATE_HZ).expect("frame").report.timings.gpu_ms)));
    }
    g.finish();
}

criterion_group!(benches, bench_vem_frame);
criterion_main!(benches);
