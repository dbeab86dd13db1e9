//! Frame time of the GPU compositor on the software adapter, split into CPU shadow-volume
//! construction, GPU passes and readback: the bundled courtyard at 640×480 and 1280×720 with a
//! 100k-triangle virtual object (a torus where the statue stands), and at 640×480 with the
//! bundled statue (1292 triangles) and with no object, with volumes rebuilt every
//! frame (the sun moves) and reused (it does not). Also the CPU (rayon) and compute-pass volume
//! builders on 100k and 1M triangles, and one trace of the virtual objects' per-pixel ambient
//! transfer (the bundled statue at 320×240 and 640×480, and the 100k-triangle torus at 640×480,
//! where the automatic lattice stride keeps it within the path budget).
//!
//! Stage benchmarks use `iter_custom` with the compositor's own per-frame timings, so each
//! reports the median of that stage over full frames. Target: ≥ 30 fps at 640×480.

use criterion::{Criterion, criterion_group, criterion_main};
use glam::{DVec2, Vec3};
use heliar::geometry::raycast::RayScene;
use heliar::geometry::{Material, Mesh};
use heliar::io::frames::Frame;
use heliar::render::occluder::Occluder;
use heliar::render::volume::{OPEN_CAP_OFFSET_M, Parts, build};
use heliar::render::volume_compute::ComputeVolumes;
use heliar::lighting::Lighting;
use heliar::render::{Builder, Compositor, CompositorConfig, PassReport, SceneParts, VideoFrame};
use heliar::gpu::{Gpu, GpuOptions};
use heliar::scene::Scene;
use heliar::camera::Camera;
use std::hint::black_box;
use std::path::Path;
use std::sync::Arc;
use std::time::Duration;

/// A closed brass torus of `2·rings·segments` triangles around +Y at `centre`.
fn torus(centre: Vec3, major: f32, minor: f32, rings: u32, segments: u32) -> Mesh {
    let mut m = Mesh::default();
    let mat = m.add_material(Material { name: "brass".into(), base_color: [0.9, 0.7, 0.3, 1.0], base_color_texture: None, metallic: 1.0, roughness: 0.35 });
    let node = m.add_node("torus", false);
    m.push_torus(centre, major, minor, rings, segments, node, mat);
    m
}

fn courtyard() -> Scene {
    Scene::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/courtyard")).expect("bundled scene")
}

/// The courtyard camera scaled to `w × h` (same field of view horizontally).
fn camera_at(scene: &Scene, w: u32, h: u32) -> Camera {
    scene.camera.resized(w, h)
}

/// Frame 0 of the bundled HDR sequence, resampled (nearest) to `w × h`.
fn video_at(scene: &Scene, w: u32, h: u32) -> VideoFrame {
    let seq = &scene.sequences[0];
    let frame = Frame::load(&seq.files[0]).expect("frame");
    let src = VideoFrame::from_frame(&frame, &seq.photometry.linearizer());
    let s = src.width as f64 / w as f64;
    let rgba = (0..w * h)
        .map(|i| {
            let p = DVec2::new((i % w) as f64 + 0.5, (i / w) as f64 + 0.5 + (src.height as f64 / s - h as f64) / 2.0) * s;
            let (x, y) = ((p.x as u32).min(src.width - 1), (p.y as u32).min(src.height - 1));
            src.rgba[(y * src.width + x) as usize]
        })
        .collect();
    VideoFrame { width: w, height: h, rgba }
}

fn sun(k: u32) -> Lighting {
    // Two sun directions 0.1° apart (more than the reuse tolerance).
    let a = (0.1f32 * k as f32).to_radians();
    let base = Vec3::new(-0.486, 0.756, 0.437).normalize();
    let d = Vec3::new(base.x * a.cos() - base.z * a.sin(), base.y, base.x * a.sin() + base.z * a.cos());
    Lighting { sun_dir: d, above_horizon: true, pd: Vec3::new(3.2, 3.0, 2.7), pa: Vec3::new(0.55, 0.62, 0.8), sky: heliar::lighting::FrameSky::Declared, lamps: heliar::lighting::LampScales::NONE }
}

type Stage = fn(&PassReport) -> f64;

fn bench_frames(c: &mut Criterion) {
    let scene = courtyard();
    let gpu4 = Arc::new(Gpu::new(GpuOptions::default()).expect("GPU adapter"));
    let gpu1 = Arc::new(Gpu::new(GpuOptions { samples: 1 }).expect("GPU adapter"));
    eprintln!("adapter: {} ({} samples)", gpu4.describe(), gpu4.samples);
    let object = torus(Vec3::new(-1.9, 0.7, 0.0), 0.5, 0.18, 250, 200);
    assert_eq!(object.triangles.len(), 100_000);
    let ray = Arc::new(RayScene::new(scene.proxy.clone()));
    let mut g = c.benchmark_group("frame");
    g.sample_size(10).measurement_time(Duration::from_secs(8)).warm_up_time(Duration::from_secs(2));
    // Object: 0 none, 1 the 100k-triangle torus, 2 the bundled statue (1292 triangles).
    let runs = [
        (640u32, 480u32, Builder::Cpu, 4u32, 1u8),
        (640, 480, Builder::Compute, 4, 1),
        (640, 480, Builder::Cpu, 1, 1),
        (640, 480, Builder::Cpu, 4, 0),
        (640, 480, Builder::Cpu, 4, 2),
        (640, 480, Builder::Cpu, 1, 2),
        (1280, 720, Builder::Cpu, 4, 1),
        (1280, 720, Builder::Compute, 4, 1),
    ];
    let statue = &scene.virtual_objects[0].mesh;
    for (w, h, builder, samples, which) in runs {
        let gpu = if samples == 1 { gpu1.clone() } else { gpu4.clone() };
        let cam = camera_at(&scene, w, h);
        let objects = match which {
            1 => vec![("torus100k".to_string(), &object)],
            2 => vec![("statue".to_string(), statue)],
            _ => Vec::new(),
        };
        let parts = SceneParts { camera: &cam, proxy: &scene.proxy, proxy_name: "proxy.glb", objects: &objects };
        let video = video_at(&scene, w, h);
        {
            let mut config = CompositorConfig::for_scene(&scene);
            config.builder = builder;
            let mut comp = Compositor::new(gpu.clone(), &parts, ray.clone(), config).expect("compositor");
            comp.set_probes(&heliar::irradiance::ProbeGrid::filled(Vec3::new(-6.0, 0.1, -6.0), Vec3::new(6.0, 3.0, 6.0), 1.0, heliar::irradiance::sh::uniform_upper_sky(Vec3::new(0.55, 0.62, 0.8))));
            // First frames compute the per-pixel c and b of the shadow region (set-up cost).
            comp.render(&video, &sun(0)).expect("frame");
            comp.render(&video, &sun(1)).expect("frame");
            let tag = format!(
                "{w}x{h}/{}{}{}",
                if builder == Builder::Cpu { "cpu" } else { "compute" },
                if samples == 1 { "/no_msaa" } else { "" },
                match which {
                    1 => "",
                    2 => "/statue",
                    _ => "/no_objects",
                }
            );
            let stages: [(&str, Stage); 4] = [
                ("volume_build", |r| r.timings.volume_build_ms),
                ("upload", |r| r.timings.upload_ms),
                ("gpu_passes", |r| r.timings.gpu_ms),
                ("readback", |r| r.timings.readback_ms),
            ];
            for (name, stage) in stages {
                let mut k = 0;
                g.bench_function(format!("{tag}/rebuild/{name}"), |b| {
                    b.iter_custom(|iters| {
                        let mut total = 0.0;
                        for _ in 0..iters {
                            k += 1;
                            let (_, r) = comp.render(&video, &sun(k % 2)).expect("frame");
                            total += stage(&r);
                        }
                        Duration::from_secs_f64(total / 1e3)
                    })
                });
            }
            // Wall-clock time of whole frames: the sun moving (volumes rebuilt every frame) and
            // still (volumes and stencil reused; shading, masks' consumers and composite rerun).
            let mut k = 0;
            g.bench_function(format!("{tag}/rebuild/total"), |b| {
                b.iter_custom(|iters| {
                    let t = std::time::Instant::now();
                    for _ in 0..iters {
                        k += 1;
                        black_box(comp.render(&video, &sun(k % 2)).expect("frame"));
                    }
                    t.elapsed()
                })
            });
            if builder == Builder::Cpu {
                g.bench_function(format!("{tag}/reuse/total"), |b| {
                    b.iter_custom(|iters| {
                        let t = std::time::Instant::now();
                        for _ in 0..iters {
                            black_box(comp.render(&video, &sun(0)).expect("frame"));
                        }
                        t.elapsed()
                    })
                });
            }
        }
    }
    g.finish();
}

fn bench_volume_builders(c: &mut Criterion) {
    let gpu = Gpu::new(GpuOptions::default()).expect("GPU adapter");
    let compute = ComputeVolumes::new(&gpu.device).expect("pipelines");
    let l = sun(0).sun_dir;
    let mut g = c.benchmark_group("volume_build");
    g.sample_size(10).measurement_time(Duration::from_secs(6)).warm_up_time(Duration::from_secs(1));
    for (name, rings, segs) in [("100k", 250u32, 200u32), ("1M", 1000, 500)] {
        let mesh = torus(Vec3::new(-1.9, 0.7, 0.0), 0.5, 0.18, rings, segs);
        let t = std::time::Instant::now();
        let occ = Occluder::new(&mesh, name);
        eprintln!("{name}: adjacency set-up {:.0} ms, {} edges", t.elapsed().as_secs_f64() * 1e3, occ.edges.len());
        let mut out = Vec::new();
        g.bench_function(format!("cpu_rayon/{name}"), |b| {
            b.iter(|| {
                out.clear();
                black_box(build(&occ, l, OPEN_CAP_OFFSET_M, Parts::All, &mut out))
            })
        });
        // The CPU path also uploads its triangles; the compute path does not.
        let buf = gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: None,
            size: (out.len() * 16).max(16) as u64,
            usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        g.bench_function(format!("cpu_rayon_and_upload/{name}"), |b| {
            b.iter(|| {
                out.clear();
                build(&occ, l, OPEN_CAP_OFFSET_M, Parts::All, &mut out);
                gpu.queue.write_buffer(&buf, 0, bytemuck::cast_slice(&out));
                gpu.queue.submit([]);
                gpu.wait().expect("wait");
            })
        });
        match compute.upload(&gpu.device, &occ) {
            Ok(gocc) => {
                g.bench_function(format!("compute_pass/{name}"), |b| {
                    b.iter(|| {
                        let mut enc = gpu.device.create_command_encoder(&Default::default());
                        compute.record(&gpu.queue, &mut enc, &gocc, l, OPEN_CAP_OFFSET_M);
                        gpu.queue.submit([enc.finish()]);
                        gpu.wait().expect("wait");
                    })
                });
            }
            Err(e) => eprintln!("compute_pass/{name}: {e}"),
        }
    }
    g.finish();
}

fn bench_transfer(c: &mut Criterion) {
    use heliar::geometry::ambient::TransportQuality;
    use heliar::gpu::canvas::Canvas;
    use heliar::render::object_transfer::{ObjectTransfer, TRANSFER_BOUNCES, TRANSFER_PATHS, TransferScene};
    let scene = courtyard();
    let statue = &scene.virtual_objects[0].mesh;
    let torus = torus(Vec3::new(-1.9, 0.7, 0.0), 0.5, 0.18, 250, 200);
    let mut g = c.benchmark_group("transfer");
    g.sample_size(10).measurement_time(Duration::from_secs(10)).warm_up_time(Duration::from_secs(1));
    let q = TransportQuality { paths: TRANSFER_PATHS, max_bounces: TRANSFER_BOUNCES };
    for (name, object, w, h) in [("statue", statue, 320u32, 240u32), ("statue", statue, 640, 480), ("torus100k", &torus, 640, 480)] {
        let canvas = Canvas::new(&camera_at(&scene, w, h), 1.0);
        let ts = TransferScene::new(&scene.proxy, &[object]);
        let mut t = ObjectTransfer::new(&canvas, &ts, q, 0, 1);
        eprintln!(
            "transfer {name} {w}x{h}: {} object pixels, stride {}, {} traced × {} paths",
            t.object_pixels(),
            t.stride(),
            t.surfaces().len(),
            TRANSFER_PATHS
        );
        let mut k = 0;
        g.bench_function(format!("trace/{name}/{w}x{h}"), |b| {
            b.iter(|| {
                // Alternate between two suns 0.1° apart with a zero tolerance: one full trace
                // per iteration.
                k += 1;
                black_box(t.ensure(&ts, Some(sun(k % 2).sun_dir), 0.0))
            })
        });
    }
    g.finish();
}

criterion_group!(benches, bench_volume_builders, bench_transfer, bench_frames);
criterion_main!(benches);
