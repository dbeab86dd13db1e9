//! Moving the statue by hand in `heliar live` (issue 15 §1, "Live: drag an object on the
//! proxy's surface with the mouse, turn it with the scroll wheel, and reset it. The pass report
//! says which objects moved this frame"): through the app's methods, and through the window's
//! pointer and wheel events (egui_kittest, headless).
#![cfg(feature = "opencv")]

use crate::live::{Script, bundled, gpu, harness, ldr_frame, scratch_courtyard, window_at};
use egui_kittest::kittest::Queryable;
use glam::{DVec2, DVec3, Vec3};
use heliar::estimate::Estimator;
use heliar::geometry::raycast::RayScene;
use heliar::irradiance::sources::UniformSky;
use heliar::live::source::FrameSource;
use heliar::live::{Capture, CaptureOptions, FEED_ALT_TEXT, FrameClock, LatestSlot, LiveApp};
use heliar::render::frame::pass;
use heliar::render::{Compositor, CompositorConfig};
use heliar::run::outdoor::OutdoorStage;
use heliar::run::session::OutdoorSession;
use heliar::scene::Scene;
use std::path::Path;
use std::sync::Arc;
use std::time::Duration;

/// The live app over the courtyard's sunny frame 0 (repeated), its objects draggable.
fn drag_app(dir: &Path) -> (LiveApp, Scene) {
    let scene = Scene::load(dir).unwrap();
    let ray = Arc::new(RayScene::new(scene.proxy.clone()));
    let est = Estimator::new(&scene, ray.clone()).unwrap();
    let comp = Compositor::for_scene(gpu(), &scene, ray, CompositorConfig::for_scene(&scene)).unwrap();
    let mut session = OutdoorSession::new(OutdoorStage::new(est, Box::new(UniformSky::for_scene(&scene))), comp);
    let ldr = Scene::load(&bundled()).unwrap();
    let seq = ldr.sequence(Some("ldr")).unwrap();
    session.follow_live(&scene, seq.times[0]);
    let frames = vec![ldr_frame(0)];
    let opener: heliar::live::Opener = Box::new(move || Ok(Box::new(Script { frames: frames.clone(), next: 0, fps: 50.0, fail_after: None }) as Box<dyn FrameSource>));
    let capture = Capture::start(opener, Arc::new(LatestSlot::new()), CaptureOptions::default());
    let mut app = LiveApp::new("test", session, None, seq.photometry.clone(), FrameClock::Start { t0: seq.times[0], fps: 25.0 }, capture);
    app.process_in_ui = false;
    (app, scene)
}

fn bounds(app: &LiveApp) -> (Vec3, Vec3) {
    app.session.motion.as_ref().unwrap().mesh(0).unwrap().bounds().unwrap()
}

fn centre((lo, hi): (Vec3, Vec3)) -> Vec3 {
    (lo + hi) / 2.0
}

/// The pixel the statue's bounds' centre projects to, and where that pixel's ray meets the
/// horizontal plane through the statue's base (the drag plane).
fn grab(scene: &Scene, b: (Vec3, Vec3)) -> (DVec2, DVec3) {
    let uv = scene.camera.project_world(centre(b).as_dvec3()).unwrap();
    let (o, d) = scene.camera.ray_at(uv).unwrap();
    let t = (b.0.y as f64 - o.y) / d.y;
    (uv, o + d * t)
}

/// Sum over a 5×5 window around `uv` of the absolute code differences of two 8-bit frames.
fn window_diff(a: &[u8], b: &[u8], width: usize, uv: DVec2) -> i32 {
    window_at(uv, width as u32).into_iter().map(|i| (0..3).map(|c| (a[3 * i + c] as i32 - b[3 * i + c] as i32).abs()).sum::<i32>()).sum()
}

/// The yaw of object 0's move by hand, degrees.
fn yaw_deg(app: &LiveApp) -> f32 {
    let x = app.session.motion.as_ref().unwrap().user(0).unwrap().x_axis;
    (-x.z).atan2(x.x).to_degrees()
}

#[test]
fn a_person_drags_turns_and_resets_the_statue_and_the_cuts_serve_every_move() {
    let dir = scratch_courtyard("drag");
    let (mut app, scene) = drag_app(&dir);
    assert!(app.can_move_objects());
    assert!(app.process_next(Duration::from_secs(30)), "a first frame");
    let first = app.last().unwrap().clone();
    assert!(app.error().is_none(), "{:?}", app.error());
    assert!(first.passes.moved.is_empty(), "{:?}", first.passes.moved);
    let width = first.composited.width as usize;
    let placed = scene.virtual_objects[0].mesh.clone();
    let b0 = placed.bounds().unwrap();
    let (uv, on_plane) = grab(&scene, b0);

    // Pointing: the statue under its own centre, nothing at the frame's top-left (the sky or a
    // wall far from it).
    assert_eq!(app.pick_object(uv.x, uv.y), Some(0));
    assert_eq!(app.pick_object(2.0, 2.0), None);

    // Drag it 0.8 m along +x and 0.5 m along +z: the pointer goes to where that point of the
    // drag plane projects.
    let shift = DVec3::new(0.8, 0.0, 0.5);
    let to = scene.camera.project_world(on_plane + shift).unwrap();
    assert_eq!(app.begin_drag(uv.x, uv.y), Some(0));
    app.drag_to(to.x, to.y).unwrap();
    app.end_drag();
    assert!(app.process_next(Duration::from_secs(10)));
    let dragged = app.last().unwrap().clone();
    assert!(app.error().is_none(), "{:?}", app.error());
    assert_eq!(dragged.passes.moved, vec!["statue.glb".to_owned()]);
    assert!(dragged.passes.ran.contains(&pass::VISIBILITY_CUTS), "the cuts serve a move by hand: {:?}", dragged.passes.ran);
    let t = &dragged.passes.timings;
    eprintln!("drag frame: cuts {:.0} ms (receivers {:.0} ms: {:?}), receivers' c, b {:.0} ms, GPU {:.0} ms", t.cuts_ms, t.cut_receivers_ms, dragged.passes.cut_receivers, t.receivers_ms, t.gpu_ms);
    let b1 = bounds(&app);
    let moved = centre(b1) - centre(b0);
    // The pointer's pixels are exact projections; the ray back through the lens is
    // interpolated from the canvas warp (≤ 0.01 px, ≈ 0.3 mm at 8 m): 1 cm covers it.
    assert!((moved.x - 0.8).abs() < 0.01 && (moved.z - 0.5).abs() < 0.01, "moved by {moved}");
    // The courtyard's paving is level: the statue stays on it.
    assert!((b1.0.y - b0.0.y).abs() < 1e-3, "base from {} to {}", b0.0.y, b1.0.y);
    // The footage shows it there: where it stood, the paving again; where it went, the statue.
    let new_uv = scene.camera.project_world(centre(b1).as_dvec3()).unwrap();
    let (old_px, new_px) = (window_diff(&first.composited.data, &dragged.composited.data, width, uv), window_diff(&dragged.composited.data, &dragged.input.data, width, new_uv));
    // A mean of 5 codes per channel over the 25 pixels (the statue against paving is ≫ that).
    assert!(old_px > 25 * 3 * 5 && new_px > 25 * 3 * 5, "old place {old_px}, new place {new_px}");

    // Turn it a quarter: about its own vertical axis, so its box's centre stays and its x and z
    // extents swap. With no new frame, the last one is composited again.
    app.turn_object(0, 90.0).unwrap();
    assert!(app.recompose());
    let turned = app.last().unwrap().clone();
    assert_eq!(turned.passes.moved, vec!["statue.glb".to_owned()]);
    assert!(turned.passes.ran.contains(&pass::VISIBILITY_CUTS), "{:?}", turned.passes.ran);
    let b2 = bounds(&app);
    let (e1, e2) = (b1.1 - b1.0, b2.1 - b2.0);
    assert!((centre(b2) - centre(b1)).length() < 1e-4, "{} vs {}", centre(b2), centre(b1));
    assert!((e2.x - e1.z).abs() < 1e-4 && (e2.z - e1.x).abs() < 1e-4, "{e1} → {e2}");
    assert!((yaw_deg(&app) - 90.0).abs() < 1e-3, "{}", yaw_deg(&app));

    // Reset: where the scene places it, to the float.
    app.reset_objects();
    assert!(app.recompose());
    assert_eq!(app.last().unwrap().passes.moved, vec!["statue.glb".to_owned()]);
    let back = app.session.motion.as_ref().unwrap().mesh(0).unwrap();
    assert_eq!(back.positions, placed.positions);

    // A frame where nothing moved says so, and why.
    assert!(app.process_next(Duration::from_secs(10)));
    let still = app.last().unwrap();
    assert!(still.passes.moved.is_empty());
    let why = still.passes.skipped.iter().find(|s| s.pass == pass::OBJECT_MOTION).map(|s| s.reason.clone()).unwrap_or_default();
    assert!(why.contains("last moved by hand"), "{why}");
    drop(app);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn the_window_drags_the_statue_under_the_pointer_turns_it_with_the_wheel_and_resets_it() {
    let dir = scratch_courtyard("drag-ui");
    let (app, scene) = drag_app(&dir);
    let mut h = harness(app);
    assert!(h.state_mut().process_next(Duration::from_secs(30)));
    // The panels settle over the first frames (the feed grows as they do).
    h.run_steps(60);
    let width = h.state().last().unwrap().composited.width as f32;
    let rect = h.get_by_label(FEED_ALT_TEXT).rect();
    h.run_steps(5);
    assert_eq!(rect, h.get_by_label(FEED_ALT_TEXT).rect(), "the layout has not settled");
    let scale = rect.width() / width;
    let at = |uv: DVec2| egui::pos2(rect.min.x + (uv.x as f32 + 0.5) * scale, rect.min.y + (uv.y as f32 + 0.5) * scale);
    let b0 = scene.virtual_objects[0].mesh.bounds().unwrap();
    let (uv, on_plane) = grab(&scene, b0);
    let to = scene.camera.project_world(on_plane + DVec3::new(-0.6, 0.0, 0.7)).unwrap();

    h.hover_at(at(uv));
    h.run();
    h.drag_at(at(uv));
    h.run();
    // Through a point halfway, as a hand would.
    h.hover_at(at((uv + to) / 2.0));
    h.run();
    h.hover_at(at(to));
    h.run();
    h.drop_at(at(to));
    h.run();
    assert!(h.state().error().is_none(), "{:?}", h.state().error());
    assert!(h.state_mut().process_next(Duration::from_secs(10)));
    h.run();
    assert_eq!(h.state().last().unwrap().passes.moved, vec!["statue.glb".to_owned()]);
    let moved = centre(bounds(h.state())) - centre(b0);
    // egui positions are f32 points at `scale` points per pixel: a few hundredths of a pixel,
    // under a centimetre at 8 m.
    assert!((moved.x + 0.6).abs() < 0.02 && (moved.z - 0.7).abs() < 0.02, "moved by {moved}");

    // One notch of the wheel over the statue (50 points, smoothed over a few frames by egui):
    // turns it by TURN_DEG_PER_SCROLL_POINT per point.
    let over = scene.camera.project_world(centre(bounds(h.state())).as_dvec3()).unwrap();
    h.hover_at(at(over));
    h.run();
    h.event(egui::Event::MouseWheel { unit: egui::MouseWheelUnit::Point, delta: egui::vec2(0.0, 50.0), phase: egui::TouchPhase::Move, source: egui::MouseWheelSource::Wheel, modifiers: egui::Modifiers::NONE });
    h.run_steps(40);
    let yaw = yaw_deg(h.state());
    let full = 50.0 * heliar::live::app::TURN_DEG_PER_SCROLL_POINT;
    assert!(yaw.abs() > 0.5 * full && yaw.abs() <= full * 1.001, "turned by {yaw}° for a notch of {full}°");

    // The button puts it back.
    h.get_by_label("Reset objects").click();
    h.run();
    assert!(h.state_mut().process_next(Duration::from_secs(10)));
    h.run();
    assert_eq!(h.state().last().unwrap().passes.moved, vec!["statue.glb".to_owned()]);
    assert_eq!(h.state().session.motion.as_ref().unwrap().mesh(0).unwrap().positions, scene.virtual_objects[0].mesh.positions);
    drop(h);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn the_vem_overlay_shows_the_statue_where_it_is_dragged_and_turned() {
    use heliar::live::vem::VemPanel;
    use heliar::render::vem::VemRenderConfig;
    use heliar::run::vem::VemOverlay;
    let dir = scratch_courtyard("drag-vem");
    let (mut app, scene) = drag_app(&dir);
    let vem = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/vem/outdoor");
    let mut panel = VemPanel::open(&vem.join("frames"), Some(&vem.join("calib/fisheye.toml")), 64, 0.0).unwrap();
    panel.advance().unwrap();
    let overlay = VemOverlay::new(app.session.compositor.gpu().clone(), &scene, VemRenderConfig::default()).unwrap();
    app.vem = Some(panel.with_overlay(overlay));
    assert!(app.process_next(Duration::from_secs(30)), "a first frame");
    assert!(app.error().is_none(), "{:?}", app.error());
    let first = app.last().unwrap().clone();
    assert!(first.vem.is_some(), "the VEM overlay composes");
    assert!(first.passes.moved.is_empty(), "{:?}", first.passes.moved);
    let width = first.composited.width as usize;
    let b0 = scene.virtual_objects[0].mesh.bounds().unwrap();
    let (uv, on_plane) = grab(&scene, b0);
    assert_eq!(app.pick_object(uv.x, uv.y), Some(0));

    // Dragged 0.8 m along +x, 0.5 m along +z, as in the outdoor test above: the overlay draws it
    // there on the next frame, and the report says it moved.
    let to = scene.camera.project_world(on_plane + DVec3::new(0.8, 0.0, 0.5)).unwrap();
    assert_eq!(app.begin_drag(uv.x, uv.y), Some(0));
    app.drag_to(to.x, to.y).unwrap();
    app.end_drag();
    assert!(app.process_next(Duration::from_secs(10)));
    assert!(app.error().is_none(), "{:?}", app.error());
    let dragged = app.last().unwrap().clone();
    assert!(dragged.vem.is_some());
    assert_eq!(dragged.passes.moved, vec!["statue.glb".to_owned()]);
    // A mean of 5 codes per channel over 25 pixels: where it stood, the paving again; where it
    // went, the statue over the paving.
    let new_uv = scene.camera.project_world(centre(b0).as_dvec3() + DVec3::new(0.8, 0.0, 0.5)).unwrap();
    let (old_px, new_px) = (window_diff(&first.composited.data, &dragged.composited.data, width, uv), window_diff(&dragged.composited.data, &dragged.input.data, width, new_uv));
    assert!(old_px > 25 * 3 * 5 && new_px > 25 * 3 * 5, "old place {old_px}, new place {new_px}");
    // Picking follows what the window shows: the statue is under the pointer where it was dropped,
    // no longer where it stood.
    assert_eq!(app.pick_object(new_uv.x, new_uv.y), Some(0));
    let (old_ray, new_ray) = (RayScene::new(scene.virtual_objects[0].mesh.clone()), RayScene::new(app.vem.as_ref().unwrap().object_mesh(0).unwrap().clone()));
    let hits = |r: &RayScene, p: DVec2| scene.camera.ray_at(p).and_then(|(o, d)| r.intersect(o.as_vec3(), d.as_vec3(), f32::MAX)).is_some();
    let (mut only_new, mut only_old) = (0, 0);
    for y in (0..scene.camera.intrinsics.height).step_by(3) {
        for x in (0..scene.camera.intrinsics.width).step_by(3) {
            let p = DVec2::new(x as f64 + 0.5, y as f64 + 0.5);
            // Away from the silhouettes (the window's ray through the lens is interpolated from
            // the canvas warp, within 0.01 px of the camera's).
            let near = [DVec2::ZERO, DVec2::new(0.3, 0.3), DVec2::new(-0.3, -0.3)].map(|o| (hits(&old_ray, p + o), hits(&new_ray, p + o)));
            if near.iter().any(|h| *h != near[0]) {
                continue;
            }
            match near[0] {
                (false, true) => {
                    only_new += 1;
                    assert_eq!(app.pick_object(p.x, p.y), Some(0), "pixel {p} shows the dragged statue");
                }
                (true, false) => {
                    only_old += 1;
                    assert_eq!(app.pick_object(p.x, p.y), None, "pixel {p} shows where it stood");
                }
                _ => {}
            }
        }
    }
    assert!(only_new > 20 && only_old > 20, "{only_new} pixels on the statue's new place only, {only_old} on its old place only");
    // The outdoor compositor's objects were left as they were: it catches up on its next frame.
    assert_eq!(app.session.motion.as_ref().unwrap().mesh(0).unwrap().positions, scene.virtual_objects[0].mesh.positions);

    // A turn with no new frame composites the last one again through the overlay.
    app.turn_object(0, 90.0).unwrap();
    assert!(app.recompose());
    let turned = app.last().unwrap().clone();
    assert!(app.error().is_none(), "{:?}", app.error());
    assert_eq!(turned.passes.moved, vec!["statue.glb".to_owned()]);
    assert_ne!(turned.composited.data, dragged.composited.data, "the turned statue shows");
    // A frame with nothing moved reports nothing moved.
    assert!(app.process_next(Duration::from_secs(10)));
    assert!(app.last().unwrap().passes.moved.is_empty());

    // With the overlay switched off, the outdoor compositor brings the statue to the same place.
    app.vem.as_mut().unwrap().compose = false;
    assert!(app.process_next(Duration::from_secs(10)));
    assert!(app.error().is_none(), "{:?}", app.error());
    assert_eq!(app.last().unwrap().passes.moved, vec!["statue.glb".to_owned()]);
    let (b_out, b_vem) = (bounds(&app), app.vem.as_ref().unwrap().object_mesh(0).unwrap().bounds().unwrap());
    assert!((b_out.0 - b_vem.0).length() < 1e-5 && (b_out.1 - b_vem.1).length() < 1e-5, "{b_out:?} vs {b_vem:?}");
    drop(app);
    std::fs::remove_dir_all(&dir).ok();
}

/// The bundled courtyard's robot (issue 15 §5), which crosses the yard on its keyframes, can be
/// picked and dragged like the statue: the move by hand adds to its motion, the cuts serve it.
#[test]
fn a_person_drags_the_bundled_robot_along_its_way() {
    let dir = crate::common::scratch_courtyard_with_robot("drag-robot");
    let (mut app, scene) = drag_app(&dir);
    assert!(app.process_next(Duration::from_secs(60)), "a first frame");
    assert!(app.error().is_none(), "{:?}", app.error());
    let robot = |app: &LiveApp| app.session.motion.as_ref().unwrap().mesh(1).unwrap().bounds().unwrap();
    let b0 = robot(&app);
    let (uv, on_plane) = grab(&scene, b0);
    assert_eq!(app.pick_object(uv.x, uv.y), Some(1), "the robot under its own centre");
    let shift = DVec3::new(-0.6, 0.0, 0.4);
    let to = scene.camera.project_world(on_plane + shift).unwrap();
    assert_eq!(app.begin_drag(uv.x, uv.y), Some(1));
    app.drag_to(to.x, to.y).unwrap();
    app.end_drag();
    // The same frame composited again: its motion stands where it was, the hand's move adds.
    assert!(app.recompose());
    let dragged = app.last().unwrap().clone();
    assert!(app.error().is_none(), "{:?}", app.error());
    assert_eq!(dragged.passes.moved, vec!["robot.glb".to_owned()]);
    assert!(dragged.passes.ran.contains(&pass::VISIBILITY_CUTS), "{:?}", dragged.passes.ran);
    let moved = centre(robot(&app)) - centre(b0);
    // As for the statue: the ray back through the lens is interpolated (≤ 0.01 px): 1 cm.
    assert!((moved.x + 0.6).abs() < 0.01 && (moved.z - 0.4).abs() < 0.01 && moved.y.abs() < 1e-3, "moved by {moved}");
    drop(app);
    std::fs::remove_dir_all(&dir).ok();
}
