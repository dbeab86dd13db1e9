//! `heliar live` headless (feature `opencv`; egui_kittest, no renderer, no display): the app
//! over scripted frame sources built from the bundled courtyard's LDR frames, stepped frame by
//! frame; the capture's hand-off and camera loss; and the command over a video the test writes.
#![cfg(feature = "opencv")]

use egui_kittest::Harness;
use egui_kittest::kittest::Queryable;
use heliar::estimate::Estimator;
use heliar::geometry::raycast::RayScene;
use heliar::io::frames::Frame;
use heliar::live::source::{CaptureStatus, FrameSource};
use heliar::live::{Capture, CaptureOptions, FrameClock, LatestSlot, LiveApp, SourceState, TURNED_OFF};
use heliar::run::outdoor::OutdoorStage;
use heliar::run::session::OutdoorSession;
use heliar::run::source::SourceFrame;
use heliar::render::frame::pass;
use heliar::irradiance::sources::UniformSky;
use heliar::render::{Compositor, CompositorConfig};
use heliar::gpu::{Gpu, GpuOptions};
use heliar::scene::Scene;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, OnceLock};
use std::time::{Duration, Instant};

pub(crate) fn bundled() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/courtyard")
}

/// One device for the whole binary (as tests/render does).
pub(crate) fn gpu() -> Arc<Gpu> {
    static GPU: OnceLock<Arc<Gpu>> = OnceLock::new();
    GPU.get_or_init(|| Arc::new(Gpu::new(GpuOptions { samples: 1 }).expect("a GPU adapter (lavapipe or llvmpipe)"))).clone()
}

fn scene() -> Scene {
    Scene::load(&bundled()).unwrap()
}

/// The courtyard's LDR frame `i` (0–5 sunny, 6 behind the cloud).
pub(crate) fn ldr_frame(i: usize) -> Frame {
    Frame::load(&bundled().join(format!("frames/ldr/frame_{i:03}.png"))).unwrap()
}

/// A scripted source: yields `frames` in turn (cycling) at `fps`, until `fail_after` frames
/// when given, then a read error.
pub(crate) struct Script {
    pub(crate) frames: Vec<Frame>,
    pub(crate) next: usize,
    pub(crate) fps: f64,
    pub(crate) fail_after: Option<usize>,
}

impl FrameSource for Script {
    fn label(&self) -> String {
        "scripted camera".into()
    }
    fn read(&mut self) -> anyhow::Result<Option<SourceFrame>> {
        if self.fail_after.is_some_and(|n| self.next >= n) {
            anyhow::bail!("scripted camera: device unplugged");
        }
        let f = self.frames[self.next % self.frames.len()].clone();
        self.next += 1;
        Ok(Some(SourceFrame { frame: f, ts_ms: None, label: "script".into() }))
    }
    fn pace_fps(&self) -> Option<f64> {
        Some(self.fps)
    }
    fn is_file(&self) -> bool {
        false
    }
}

fn app_with(opener: heliar::live::Opener, options: CaptureOptions) -> LiveApp {
    let scene = scene();
    let ray = Arc::new(RayScene::new(scene.proxy.clone()));
    let est = Estimator::new(&scene, ray.clone()).unwrap();
    let comp = Compositor::for_scene(gpu(), &scene, ray, CompositorConfig::for_scene(&scene)).unwrap();
    let pipe = OutdoorSession::new(OutdoorStage::new(est, Box::new(UniformSky::for_scene(&scene))), comp);
    let seq = scene.sequence(Some("ldr")).unwrap();
    // From the sequence's start at 25 frames per second (the scripted sources give no
    // timestamps): the sun stays within a few degrees of frame 0's over a test.
    let clock = FrameClock::Start { t0: seq.times[0], fps: 25.0 };
    let capture = Capture::start(opener, Arc::new(LatestSlot::new()), options);
    let mut app = LiveApp::new("test", pipe, None, seq.photometry.clone(), clock, capture);
    app.process_in_ui = false;
    app
}

pub(crate) fn harness(app: LiveApp) -> Harness<'static, LiveApp> {
    Harness::builder().with_size([1280.0, 860.0]).build_ui_state(|ui, app: &mut LiveApp| app.ui(ui), app)
}

fn wait_for(what: &str, timeout: Duration, mut f: impl FnMut() -> bool) {
    let t = Instant::now();
    while !f() {
        assert!(t.elapsed() < timeout, "timed out waiting for {what}");
        std::thread::sleep(Duration::from_millis(10));
    }
}

/// A scratch copy of the courtyard without its sequences and its robot (what the live window caches, the bake
/// and the cuts, goes into the scene folder).
pub(crate) fn scratch_courtyard(tag: &str) -> PathBuf {
    let src = bundled();
    let dst = std::env::temp_dir().join(format!("heliar-live-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dst);
    for d in ["calib", "objects"] {
        std::fs::create_dir_all(dst.join(d)).unwrap();
    }
    for f in ["scene.toml", "proxy.glb", "calib/camera.toml", "env.exr", "objects/statue.glb"] {
        std::fs::copy(src.join(f), dst.join(f)).unwrap();
    }
    let m = crate::common::without_robot(&std::fs::read_to_string(dst.join("scene.toml")).unwrap());
    std::fs::write(dst.join("scene.toml"), &m[..m.find("[[sequences]]").unwrap()]).unwrap();
    dst
}

/// Pixels around the projection of the statue's bounding-box centre.
fn statue_window(scene: &Scene) -> Vec<usize> {
    let (lo, hi) = scene.virtual_objects[0].mesh.bounds().unwrap();
    let c = ((lo + hi) / 2.0).as_dvec3();
    window_at(scene.camera.project_world(c).unwrap(), scene.camera.intrinsics.width)
}

/// The 5×5 pixels (row-major indices) around pixel coordinates `uv` of a frame `width` wide.
pub(crate) fn window_at(uv: glam::DVec2, width: u32) -> Vec<usize> {
    let w = width as i64;
    let (u, v) = (uv.x.round() as i64, uv.y.round() as i64);
    (-2..=2).flat_map(|dy| (-2..=2).map(move |dx| ((v + dy) * w + u + dx) as usize)).collect()
}

#[test]
fn the_feed_is_composited_with_status_and_switched_passes_are_reported() {
    let frames = vec![ldr_frame(0)];
    let opener: heliar::live::Opener = Box::new(move || Ok(Box::new(Script { frames: frames.clone(), next: 0, fps: 50.0, fail_after: None }) as Box<dyn FrameSource>));
    let mut h = harness(app_with(opener, CaptureOptions::default()));
    assert!(h.state_mut().process_next(Duration::from_secs(20)), "a first frame");
    h.run_steps(2);

    // The composite differs from the input where the statue stands.
    let scene = scene();
    let shown = h.state().last().unwrap().clone();
    assert!(h.state().error().is_none(), "{:?}", h.state().error());
    let diff: Vec<i32> = statue_window(&scene)
        .iter()
        .map(|&i| (0..3).map(|c| (shown.composited.data[3 * i + c] as i32 - shown.input.data[3 * i + c] as i32).abs()).sum())
        .collect();
    let changed = diff.iter().filter(|&&d| d > 30).count();
    assert!(changed >= 20, "statue pixels should differ from the footage: {diff:?}");
    // ... and is the footage elsewhere (a corner far from the statue and its shadow).
    assert_eq!(&shown.composited.data[..30], &shown.input.data[..30]);

    // The estimator's status is on screen.
    let status = h.state().estimator_status().unwrap();
    assert_eq!(status, "status ok", "a sunny frame");
    h.get_by_label(&status);
    h.get_by_label("condition number");
    h.get_by_label_contains("processed 1");
    assert!(shown.passes.ran(pass::VIRTUAL_VOLUMES) && shown.passes.ran(pass::REAL_VOLUMES), "{:?}", shown.passes);

    // Switch the virtual shadows off in the window: the next frame's report says so.
    h.get_by_label("Virtual shadows (shadow volumes)").click();
    h.run_steps(2);
    assert!(!h.state().switches.virtual_volumes);
    assert!(h.state_mut().process_next(Duration::from_secs(10)));
    h.run_steps(2);
    let r = &h.state().last().unwrap().passes;
    assert_eq!(r.skip_reason(pass::VIRTUAL_VOLUMES), Some(TURNED_OFF), "{r:?}");
    assert!(r.ran(pass::REAL_VOLUMES), "{r:?}");
    h.get_by_label_contains(&format!("skipped {}: {TURNED_OFF}", pass::VIRTUAL_VOLUMES));

    // The darkening model follows the window's choice on the next frame.
    h.get_by_label("constant").click();
    h.run_steps(2);
    assert!(h.state_mut().process_next(Duration::from_secs(10)));
    assert_eq!(h.state().session.compositor.config().darkening, heliar::render::Darkening::Constant);
    // No irradiance volume was given: the ambient choice stays on the uniform sky.
    assert!(!h.state().can_switch_ambient());
    assert!(!h.state_mut().set_ambient(heliar::live::AmbientChoice::Volume));
    assert_eq!(h.state().ambient(), heliar::live::AmbientChoice::Uniform);

    // The objects off: the footage comes through unchanged and every object pass is skipped.
    h.get_by_label("Virtual objects").click();
    h.run_steps(2);
    assert!(h.state_mut().process_next(Duration::from_secs(10)));
    h.run_steps(2);
    let s = h.state().last().unwrap();
    for p in [pass::DEPTH_PREPASS, pass::VIRTUAL_SHADING, pass::SUN_TERM] {
        assert_eq!(s.passes.skip_reason(p), Some(TURNED_OFF), "{p}: {:?}", s.passes);
    }
    let differ: Vec<(usize, [u8; 3], [u8; 3])> = (0..s.input.data.len() / 3)
        .filter(|&i| s.composited.data[3 * i..3 * i + 3] != s.input.data[3 * i..3 * i + 3])
        .map(|i| (i, std::array::from_fn(|c| s.composited.data[3 * i + c]), std::array::from_fn(|c| s.input.data[3 * i + c])))
        .collect();
    assert!(differ.is_empty(), "with the objects off the feed is the footage: {} pixels differ, e.g. {:?}", differ.len(), &differ[..differ.len().min(8)]);

    // The plots got one point per frame.
    assert_eq!(h.state().history().len(), 4);
    assert!(h.state().history().iter().all(|p| p.pd.is_some_and(|v| v > 1.0) && p.pa.is_some_and(|v| v > 0.3)));
}

#[test]
fn a_slow_consumer_drops_stale_frames_and_the_window_counts_them() {
    // 100 frames/s in, about 3 frames/s out.
    let frames = vec![ldr_frame(0)];
    let opener: heliar::live::Opener = Box::new(move || Ok(Box::new(Script { frames: frames.clone(), next: 0, fps: 100.0, fail_after: None }) as Box<dyn FrameSource>));
    let mut h = harness(app_with(opener, CaptureOptions::default()));
    let mut indices = Vec::new();
    for _ in 0..3 {
        std::thread::sleep(Duration::from_millis(300));
        assert!(h.state_mut().process_next(Duration::from_secs(10)));
        indices.push(h.state().last().unwrap().index);
    }
    h.run_steps(2);
    let counts = h.state().slot().counts();
    let dropped = h.state().dropped();
    assert!(dropped >= 10, "frames captured while the pipeline was busy are dropped: {counts:?}");
    // The pipeline always got the newest frame: indices jump by more than one.
    assert!(indices.windows(2).all(|w| w[1] > w[0] + 1), "{indices:?}");
    // Every frame put was taken, dropped, or is waiting in the slot.
    assert!(counts.put - counts.taken - counts.dropped <= 1, "{counts:?}");
    h.get_by_label_contains("dropped ");
}

/// Opener of a camera that gives 3 frames and is unplugged, then cannot be opened until
/// `plugged` is set again.
fn flaky_camera(opens: Arc<AtomicUsize>, plugged: Arc<AtomicBool>) -> heliar::live::Opener {
    let frame = ldr_frame(1);
    Box::new(move || {
        let n = opens.fetch_add(1, Ordering::SeqCst);
        if n == 0 {
            plugged.store(false, Ordering::SeqCst);
            Ok(Box::new(Script { frames: vec![frame.clone()], next: 0, fps: 30.0, fail_after: Some(3) }) as Box<dyn FrameSource>)
        } else if !plugged.load(Ordering::SeqCst) {
            anyhow::bail!("camera 0: cannot be opened (no such device)")
        } else {
            Ok(Box::new(Script { frames: vec![frame.clone()], next: 0, fps: 30.0, fail_after: None }) as Box<dyn FrameSource>)
        }
    })
}

#[test]
fn a_lost_camera_shows_lost_retrying_and_recovers() {
    let opens = Arc::new(AtomicUsize::new(0));
    let plugged = Arc::new(AtomicBool::new(true));
    let options = CaptureOptions { retry: Duration::from_millis(150), ..Default::default() };
    let mut h = harness(app_with(flaky_camera(opens.clone(), plugged.clone()), options));
    assert!(h.state_mut().process_next(Duration::from_secs(20)));
    let status = |h: &Harness<'_, LiveApp>| -> CaptureStatus { h.state().capture_status() };
    wait_for("the camera to be lost", Duration::from_secs(10), || matches!(status(&h).state, SourceState::Lost { .. }));
    h.run_steps(2);
    h.get_by_label_contains("Camera lost — retrying");
    h.get_by_label_contains("camera lost, retrying");
    let s = status(&h);
    let SourceState::Lost { reason, .. } = &s.state else { panic!("{s:?}") };
    assert!(reason.contains("unplugged") || reason.contains("no such device"), "{reason}");
    // It keeps trying (every 150 ms here, every second by default) ...
    wait_for("two failed reopenings", Duration::from_secs(10), || opens.load(Ordering::SeqCst) >= 3);
    assert!(matches!(status(&h).state, SourceState::Lost { retries, .. } if retries >= 1), "{:?}", status(&h));
    h.run_steps(2);
    h.get_by_label("Camera lost — retrying every 150 ms. camera 0: cannot be opened (no such device)");
    // ... and once the camera is back, frames flow again.
    plugged.store(true, Ordering::SeqCst);
    wait_for("frames after the camera came back", Duration::from_secs(20), || status(&h).state == SourceState::Running);
    assert!(h.state_mut().process_next(Duration::from_secs(10)));
    h.run_steps(2);
    assert!(h.query_by_label_contains("Camera lost").is_none(), "the loss message goes away");
    h.get_by_label_contains("running: scripted camera");
    h.get_by_label_contains("lost 1 times");
    assert_eq!(status(&h).losses, 1, "one loss, however many attempts it took");
    assert!(h.state().error().is_none());
}

/// A stream whose read blocks forever after two frames (a vanished server).
struct Hanging {
    frame: Frame,
    n: usize,
    gate: Arc<Mutex<()>>,
}

impl FrameSource for Hanging {
    fn label(&self) -> String {
        "hanging stream".into()
    }
    fn read(&mut self) -> anyhow::Result<Option<SourceFrame>> {
        self.n += 1;
        if self.n > 2 {
            // Blocks until the test releases the gate.
            let _g = self.gate.lock().unwrap();
        }
        Ok(Some(SourceFrame { frame: self.frame.clone(), ts_ms: None, label: "stall".into() }))
    }
    fn pace_fps(&self) -> Option<f64> {
        Some(50.0)
    }
    fn is_file(&self) -> bool {
        false
    }
}

#[test]
fn a_stalled_stream_is_abandoned_and_reopened_by_the_watchdog() {
    let gate = Arc::new(Mutex::new(()));
    let held = gate.lock().unwrap();
    let opens = Arc::new(AtomicUsize::new(0));
    let (g, o) = (gate.clone(), opens.clone());
    let frame = Frame { width: 4, height: 2, data: heliar::io::frames::FrameData::Ldr { bits: 8, codes: vec![100; 24] } };
    let opener: heliar::live::Opener = Box::new(move || {
        o.fetch_add(1, Ordering::SeqCst);
        Ok(Box::new(Hanging { frame: frame.clone(), n: 0, gate: g.clone() }) as Box<dyn FrameSource>)
    });
    let slot = Arc::new(LatestSlot::new());
    let mut cap = Capture::start(opener, slot.clone(), CaptureOptions { stall: Duration::from_millis(200), ..Default::default() });
    wait_for("two frames", Duration::from_secs(10), || cap.status().captured >= 2);
    assert!(!cap.watchdog(), "not stalled yet");
    std::thread::sleep(Duration::from_millis(300));
    assert!(cap.watchdog(), "no frame for longer than the stall time");
    assert!(matches!(cap.status().state, SourceState::Lost { ref reason, .. } if reason.contains("no frame for")), "{:?}", cap.status());
    wait_for("the reopened stream's frames", Duration::from_secs(10), || opens.load(Ordering::SeqCst) >= 2 && cap.status().state == SourceState::Running);
    assert!(cap.status().captured >= 3);
    drop(held);
    cap.stop();

    // A file paced slower than the stall time is not a stall: 2 frames/s against 200 ms.
    let frame = Frame { width: 4, height: 2, data: heliar::io::frames::FrameData::Ldr { bits: 8, codes: vec![100; 24] } };
    let opener: heliar::live::Opener = Box::new(move || Ok(Box::new(Script { frames: vec![frame.clone()], next: 0, fps: 2.0, fail_after: None }) as Box<dyn FrameSource>));
    let mut cap = Capture::start(opener, Arc::new(LatestSlot::new()), CaptureOptions { stall: Duration::from_millis(200), ..Default::default() });
    let t = Instant::now();
    while t.elapsed() < Duration::from_millis(1300) {
        assert!(!cap.watchdog(), "a slow file is not stalled: {:?}", cap.status());
        std::thread::sleep(Duration::from_millis(20));
    }
    assert!(cap.status().captured >= 2 && cap.status().losses == 0, "{:?}", cap.status());
}

#[test]
fn heliar_live_plays_a_video_file_headless() {
    use heliar::io::frames::FrameData;
    let dir = std::env::temp_dir().join(format!("heliar-live-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let video = dir.join("courtyard.mkv");
    let mut sink = heliar::io::video::VideoSink::create(&video, 5.0, 320, 240).unwrap();
    for i in 0..6 {
        let FrameData::Ldr { codes, .. } = ldr_frame(i).data else { panic!() };
        sink.write_rgb8(&codes.iter().map(|&c| c as u8).collect::<Vec<_>>()).unwrap();
    }
    sink.finish().unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_heliar"))
        .args(["live", bundled().to_str().unwrap(), "--input", video.to_str().unwrap(), "--sequence", "ldr", "--start", "2024-06-21T15:30:00+02:00", "--ambient", "uniform", "--headless-frames", "6"])
        .output()
        .unwrap();
    let (stdout, stderr) = (String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    assert!(out.status.success(), "{stderr}");
    let lines: Vec<&str> = stdout.lines().filter(|l| l.starts_with("frame ")).collect();
    // Paced at 5 fps, a frame takes well under 200 ms here, but a loaded machine may drop some.
    assert!(lines.len() >= 2, "{stdout}\n{stderr}");
    assert!(lines[0].contains("2024-06-21T15:30:00") && lines[0].contains("status "), "{}", lines[0]);
    assert!(stderr.contains("processed ") && stderr.contains("frame time median"), "{stderr}");
    eprintln!("{stderr}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn the_vem_panel_decomposes_with_the_slider_s_light_count() {
    use heliar::live::vem::VemPanel;
    let vem = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/vem/outdoor");
    let mut panel = VemPanel::open(&vem.join("frames"), Some(&vem.join("calib/fisheye.toml")), 64, 0.0).unwrap();
    panel.advance().unwrap();
    assert_eq!(panel.lights().len(), 64);
    // The synthetic outdoor sky has a sun well above the horizon: every light is in the upper
    // hemisphere, and the brightest ones cluster together.
    assert!(panel.lights().iter().all(|l| l.dir.y >= -1e-3 && (l.dir.length() - 1.0).abs() < 1e-3));
    let mut h = Harness::builder().with_size([400.0, 600.0]).build_ui_state(|ui, p: &mut VemPanel| p.ui(ui), panel);
    h.run();
    h.get_by_label_contains("64 lights, frame 1 of 24");
    // What the slider does: the decomposer re-runs on the same map with the new count.
    h.state_mut().set_light_count(300).unwrap();
    h.run();
    assert_eq!(h.state().lights().len(), 300);
    h.get_by_label_contains("300 lights, frame 1 of 24");
    h.state_mut().advance().unwrap();
    h.run();
    h.get_by_label_contains("300 lights, frame 2 of 24");
}

#[test]
fn the_ambient_source_switches_between_the_irradiance_volume_and_the_uniform_sky() {
    use heliar::live::AmbientChoice;
    use heliar::irradiance::sources::VolumeProbes;
    let dst = scratch_courtyard("ambient");

    let scene = Scene::load(&dst).unwrap();
    let ray = Arc::new(RayScene::new(scene.proxy.clone()));
    let baked = heliar::run::outdoor::cached_bake(&scene, ray.clone(), &|_, _, _| {}).unwrap();
    let volume = Box::new(VolumeProbes::new(&scene, ray.clone(), &baked));
    let est = Estimator::new(&scene, ray.clone()).unwrap();
    // The probe source lights the statue only where its per-pixel transfer does not: off here,
    // so the probe source is what the statue shows.
    let comp = Compositor::for_scene(gpu(), &scene, ray, CompositorConfig { transfer_paths: 0, ..CompositorConfig::for_scene(&scene) }).unwrap();
    let pipe = OutdoorSession::new(OutdoorStage::new(est, volume), comp);
    let ldr = self::scene();
    let seq = ldr.sequence(Some("ldr")).unwrap();
    let frames = vec![ldr_frame(0)];
    let opener: heliar::live::Opener = Box::new(move || Ok(Box::new(Script { frames: frames.clone(), next: 0, fps: 50.0, fail_after: None }) as Box<dyn FrameSource>));
    let capture = Capture::start(opener, Arc::new(LatestSlot::new()), CaptureOptions::default());
    let mut app = LiveApp::new("test", pipe, Some(Box::new(UniformSky::for_scene(&scene))), seq.photometry.clone(), FrameClock::Start { t0: seq.times[0], fps: 25.0 }, capture);
    app.process_in_ui = false;
    let mut h = harness(app);

    let relight = |h: &Harness<'_, LiveApp>| h.state().last().unwrap().record.relight.clone();
    assert!(h.state_mut().process_next(Duration::from_secs(20)));
    assert_eq!(h.state().ambient(), AmbientChoice::Volume);
    assert_eq!(relight(&h).source, "irradiance_volume");
    let with_volume = h.state().last().unwrap().composited.clone();

    // The uniform sky from the window: the next frame relights with it.
    h.run_steps(2);
    h.get_by_label("uniform sky").click();
    h.run_steps(2);
    assert_eq!(h.state().ambient(), AmbientChoice::Uniform);
    assert!(h.state_mut().process_next(Duration::from_secs(10)));
    let r = relight(&h);
    assert!(r.ran && r.source == "uniform_sky", "{r:?}");
    // The statue's ambient light differs between the two (the volume has the wall's occlusion
    // and the ground's bounce).
    let window = statue_window(&scene);
    let now = &h.state().last().unwrap().composited;
    let diff: i32 = window.iter().map(|&i| (0..3).map(|c| (now.data[3 * i + c] as i32 - with_volume.data[3 * i + c] as i32).abs()).sum::<i32>()).sum();
    // Measured: 4529 over the 25 pixels (≈ 60 codes per channel; the uniform sky is 20–33% off
    // on the statue, DEVELOPERS.md). Ask for a mean of 5 codes per channel.
    assert!(diff > 25 * 3 * 5, "the two ambient sources give nearly the same statue: {diff}");

    // And back.
    assert!(h.state_mut().set_ambient(AmbientChoice::Volume));
    assert!(h.state_mut().process_next(Duration::from_secs(10)));
    let r = relight(&h);
    assert!(r.ran && r.source == "irradiance_volume", "{r:?}");
    drop(h);
    std::fs::remove_dir_all(&dst).ok();
}
