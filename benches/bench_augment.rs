//! Throughput of recorded-footage augmentation (feature `opencv`): decode a video frame, estimate,
//! relight when needed, composite, encode the frame into a video file; at 640×480 and 1280×720.
//!
//! The footage is the bundled courtyard's LDR sequence resampled (nearest) to the resolution and
//! written once as a lossless FFV1 video; the camera is the courtyard's, scaled to the same
//! horizontal field of view; the virtual object is the scene's statue; output is MPEG-4 Part 2
//! (`.mp4`). Each criterion sample is a number of whole frames; frames per second = 1 / median.
//! The irradiance volume comes from the scene's bake (loaded from `scenes/courtyard/baked` or
//! baked once). Frame times advance at the video's rate (10 fps), so the sun moves as in real
//! footage; the one-off set-up (per-pixel `c`, `b` of the receivers, the first relight) falls in
//! the warm-up. After each resolution a per-stage breakdown (median and mean ms) is printed.

use criterion::{Criterion, criterion_group, criterion_main};
use glam::DVec2;
use heliar::estimate::Estimator;
use heliar::geometry::raycast::RayScene;
use heliar::io::frames::{Frame, FrameData};
use heliar::io::video::{VideoSink, VideoSource};
use heliar::run::outdoor::{Ambient, OutdoorStage, cached_bake, probe_source};
use heliar::run::session::OutdoorSession;
use heliar::render::output::encode_rgb8;
use heliar::render::{Compositor, CompositorConfig, SceneParts};
use heliar::gpu::{Gpu, GpuOptions};
use heliar::scene::Scene;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

fn courtyard() -> Scene {
    Scene::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/courtyard")).expect("bundled scene")
}

/// The courtyard scene with its camera scaled to `w × h` (same horizontal field of view,
/// cropped vertically about the centre).
fn scene_at(w: u32, h: u32) -> Scene {
    let mut s = courtyard();
    s.camera = s.camera.resized(w, h);
    s
}

/// The LDR sequence resampled to `w × h` as a lossless video in a temporary folder.
fn footage(scene: &Scene, w: u32, h: u32, dir: &Path) -> PathBuf {
    let seq = scene.sequence(Some("ldr")).expect("ldr sequence");
    let path = dir.join(format!("courtyard_{w}x{h}.mkv"));
    let mut sink = VideoSink::create(&path, 10.0, w, h).expect("video");
    for f in &seq.files {
        let src = Frame::load(f).expect("frame");
        let FrameData::Ldr { codes, .. } = &src.data else { panic!("8-bit frames") };
        let s = src.width as f64 / w as f64;
        let rgb: Vec<u8> = (0..w * h)
            .flat_map(|i| {
                let p = DVec2::new((i % w) as f64 + 0.5, (i / w) as f64 + 0.5 + (src.height as f64 / s - h as f64) / 2.0) * s;
                let (x, y) = ((p.x as u32).min(src.width - 1), (p.y as u32).min(src.height - 1));
                let k = 3 * (y * src.width + x) as usize;
                [codes[k] as u8, codes[k + 1] as u8, codes[k + 2] as u8]
            })
            .collect();
        sink.write_rgb8(&rgb).expect("write");
    }
    sink.finish().expect("close");
    path
}

fn throughput(c: &mut Criterion) {
    let dir = std::env::temp_dir().join(format!("heliar-bench-augment-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let gpu = Arc::new(Gpu::new(GpuOptions { samples: 4 }).expect("GPU"));
    let mut group = c.benchmark_group("augment_throughput");
    group.sample_size(10).measurement_time(Duration::from_secs(30)).warm_up_time(Duration::from_secs(3));
    for (w, h) in [(640u32, 480u32), (1280, 720)] {
        let scene = scene_at(w, h);
        let ray = Arc::new(RayScene::new(scene.proxy.clone()));
        let video = footage(&scene, w, h, &dir);
        let seq = scene.sequence(Some("ldr")).expect("ldr sequence").clone();
        let lin = seq.photometry.linearizer();
        let objects = SceneParts::object_list(&scene);
        let parts = SceneParts::of(&scene, &objects);
        let comp = Compositor::new(gpu.clone(), &parts, ray.clone(), CompositorConfig::for_scene(&scene)).expect("compositor");
        let probes = probe_source(&scene, ray.clone(), Ambient::Volume, |s, r| cached_bake(s, r, &|_: &str, _: u64, _: u64| {})).expect("probes");
        let mut pipe = OutdoorSession::new(OutdoorStage::new(Estimator::new(&scene, ray.clone()).expect("estimator"), probes), comp);
        let mut src = VideoSource::open_file(&video).expect("open");
        let mut sink = VideoSink::create(&dir.join(format!("out_{w}x{h}.mp4")), 10.0, w, h).expect("sink");
        let mut i = 0usize;
        // Per-frame stage times over every measured frame, for the breakdown printed below.
        let mut stages: Vec<[f64; 8]> = Vec::new();
        group.bench_function(format!("decode_composite_encode_{w}x{h}"), |b| {
            b.iter_custom(|iters| {
                let t = Instant::now();
                for _ in 0..iters {
                    let t_frame = Instant::now();
                    let (frame, _) = match src.read().expect("decode") {
                        Some(x) => x,
                        None => {
                            src = VideoSource::open_file(&video).expect("reopen");
                            src.read().expect("decode").expect("a frame")
                        }
                    };
                    // Real-time footage at 10 fps: the sun moves 0.25° a minute, so the sun-dependent
                    // work (shadow-volume rebuild past 0.5°, sun visibility and bounce of the
                    // receivers and the relit map) happens about once every 2 minutes of video.
                    let time = seq.times[0] + chrono::Duration::milliseconds(100 * i as i64);
                    let decode = t_frame.elapsed().as_secs_f64() * 1e3;
                    let f = pipe.process(i, &time, &frame, &lin).expect("frame");
                    let (out, passes, rec, vf) = (f.rendered, f.passes, f.record, f.video);
                    let t_enc = Instant::now();
                    sink.write_rgb8(&encode_rgb8(&out.image, out.precision, &vf, &frame, &seq.photometry)).expect("encode");
                    let encode = t_enc.elapsed().as_secs_f64() * 1e3;
                    let tm = passes.timings;
                    stages.push([decode, rec.estimate_ms, rec.relight.ms, tm.volume_build_ms + tm.upload_ms, tm.receivers_ms, tm.gpu_ms, tm.readback_ms, encode]);
                    i += 1;
                }
                t.elapsed()
            })
        });
        sink.finish().expect("close");
        let names = ["decode", "estimate", "relight + probes", "volumes + upload", "receivers (c, b of new pixels)", "GPU passes", "readback", "encode"];
        eprintln!("{w}×{h}: median ms per frame over {} frames (criterion's frame time includes all of them):", stages.len());
        for (k, name) in names.iter().enumerate() {
            let mut v: Vec<f64> = stages.iter().map(|s| s[k]).collect();
            v.sort_by(|a, b| a.total_cmp(b));
            let mean = v.iter().sum::<f64>() / v.len().max(1) as f64;
            eprintln!("  {name:32} median {:8.2}  mean {:8.2}", v.get(v.len() / 2).copied().unwrap_or(0.0), mean);
        }
    }
    group.finish();
    std::fs::remove_dir_all(&dir).ok();
}

criterion_group!(benches, throughput);
criterion_main!(benches);
