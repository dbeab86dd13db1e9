//! The app driven headless (egui_kittest, no renderer, no display) on copies of the bundled
//! courtyard and on synthetic chessboards and exposures: clicks go in as pointer events at the
//! screen position of a pixel, buttons are pressed through the accessibility tree, and the files
//! on disk are checked afterwards.

use super::view::Transform;
use super::{CalibApp, Level, Tab};
use egui::{Event, Modifiers, PointerButton, Pos2};
use egui_kittest::Harness;
use egui_kittest::kittest::Queryable;
use glam::{DMat3, DVec2, DVec3};
use heliar::opencv_calib::chessboard::{Board, render_board};
use heliar::scene::Scene;
use heliar::camera::{Camera, Pose};
use std::path::{Path, PathBuf};

fn bundled() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/courtyard")
}

/// An empty temporary folder for one test.
fn temp(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("heliar-calib-ui-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        if e.file_type().unwrap().is_dir() {
            copy_dir(&e.path(), &to.join(e.file_name()));
        } else {
            std::fs::copy(e.path(), to.join(e.file_name())).unwrap();
        }
    }
}

/// A copy of the bundled courtyard (never edit the original).
fn courtyard_copy(tag: &str) -> PathBuf {
    let dir = temp(tag).join("courtyard");
    copy_dir(&bundled(), &dir);
    dir
}

fn harness(app: CalibApp) -> Harness<'static, CalibApp> {
    Harness::builder().with_size([1400.0, 860.0]).build_ui_state(|ui, app: &mut CalibApp| app.ui(ui), app)
}

/// A primary click at a screen position (hover, press, release, as a mouse does).
fn click_at(h: &mut Harness<'_, CalibApp>, pos: Pos2) {
    h.hover_at(pos);
    for pressed in [true, false] {
        h.event(Event::PointerButton { pos, button: PointerButton::Primary, pressed, modifiers: Modifiers::NONE });
    }
    h.run();
}

/// A primary-button drag from one screen position to another.
fn drag(h: &mut Harness<'_, CalibApp>, from: Pos2, to: Pos2) {
    h.hover_at(from);
    h.event(Event::PointerButton { pos: from, button: PointerButton::Primary, pressed: true, modifiers: Modifiers::NONE });
    for k in 1..=6 {
        h.event(Event::PointerMoved(from + (to - from) * (k as f32 / 6.0)));
    }
    h.event(Event::PointerButton { pos: to, button: PointerButton::Primary, pressed: false, modifiers: Modifiers::NONE });
    h.run();
}

fn click_button(h: &mut Harness<'_, CalibApp>, label: &str) {
    h.get_by_label(label).click();
    h.run();
}

/// Presses a button that starts a background job, waits for the job, and settles.
fn click_and_wait(h: &mut Harness<'_, CalibApp>, label: &str) {
    h.get_by_label(label).click();
    h.step(); // the queued hover, press and release, one frame each
    h.state_mut().wait_for_jobs();
    h.run();
}

/// A file dropped on the window.
#[derive(Debug)]
struct Dropped(PathBuf);

impl egui::DroppedFile for Dropped {
    fn path(&self) -> &Path {
        &self.0
    }

    fn bytes(&self) -> Result<Vec<u8>, String> {
        std::fs::read(&self.0).map_err(|e| e.to_string())
    }
}

fn errors(m: &super::Messages) -> Vec<String> {
    m.0.iter().filter(|(l, _)| *l == Level::Error).map(|(_, s)| s.clone()).collect()
}

/// No `.scene.edit-*` copies or `*.tmp-*` files left beside or in the scene.
fn assert_no_leftovers(dir: &Path) {
    for d in [dir, dir.parent().unwrap()] {
        for e in std::fs::read_dir(d).unwrap() {
            let n = e.unwrap().file_name().to_string_lossy().into_owned();
            assert!(!n.contains(".edit-") && !n.contains(".tmp-"), "leftover {n} in {}", d.display());
        }
    }
}

#[test]
fn clicking_the_courtyard_frame_marks_the_node_under_it() {
    let dir = courtyard_copy("mark");
    let truth = Scene::load(&bundled()).unwrap();
    let mut app = CalibApp::new(Some(&dir));
    app.tab = Tab::Mark;
    let mut h = harness(app);
    h.run();
    let t: Transform = h.state().mark.view.last.expect("the frame is shown");
    // A point on the free-standing wall's east face, which the proxy's extras do not mark.
    let on_wall = truth.camera.project_world(DVec3::new(-2.8, 1.2, 0.0)).unwrap();
    let wall = truth.proxy.nodes.iter().position(|n| n.name == "wall").unwrap();
    h.hover_at(t.screen_from_pixel(on_wall));
    h.run();
    assert_eq!(h.state().mark.hovered, Some(wall), "hovering highlights the wall");

    let manifest = dir.join("scene.toml");
    let before = std::fs::read_to_string(&manifest).unwrap();
    #[cfg(unix)]
    let inode = std::os::unix::fs::MetadataExt::ino(&std::fs::metadata(&manifest).unwrap());
    click_at(&mut h, t.screen_from_pixel(on_wall));
    assert!(errors(&h.state().mark.messages).is_empty(), "{:?}", h.state().mark.messages);
    let after = std::fs::read_to_string(&manifest).unwrap();
    // Only `proxy.diffuse_nodes` changed: the generator's comment and every other line survive.
    assert!(after.contains("diffuse_nodes = [\"wall\"]"), "{after}");
    assert_eq!(after.lines().filter(|l| !l.contains("diffuse_nodes")).collect::<Vec<_>>(), before.lines().collect::<Vec<_>>());
    // Replaced by a rename (a new file), not rewritten in place; nothing left over.
    #[cfg(unix)]
    assert_ne!(inode, std::os::unix::fs::MetadataExt::ino(&std::fs::metadata(&manifest).unwrap()));
    assert_no_leftovers(&dir);
    let s = Scene::load(&dir).unwrap();
    assert!(s.proxy.nodes[wall].diffuse);
    assert!(h.state().scene.as_ref().unwrap().scene.proxy.nodes[wall].diffuse, "the app reloaded the scene");
    h.get_by_label_contains("marked 'wall'");

    // A node marked by the glTF extras cannot be unmarked here: an error, the manifest untouched.
    let on_brick = truth.camera.project_world(DVec3::new(3.0, 5.0, -8.0)).unwrap();
    click_at(&mut h, t.screen_from_pixel(on_brick));
    let e = errors(&h.state().mark.messages);
    assert!(e.len() == 1 && e[0].contains("north_building") && e[0].contains("glTF extras"), "{e:?}");
    assert_eq!(std::fs::read_to_string(&manifest).unwrap(), after);
    // The sky sees no proxy: an error, nothing written.
    let rays = heliar::geometry::raycast::RayScene::new(truth.proxy.clone());
    let sky = (0..320).map(|u| DVec2::new(u as f64, 2.0)).find(|uv| crate::ops::mark::node_at_pixel(&truth, &rays, *uv).is_err()).expect("sky in the top row");
    click_at(&mut h, t.screen_from_pixel(sky));
    assert!(errors(&h.state().mark.messages)[0].contains("sees no proxy geometry"), "{:?}", h.state().mark.messages);

    // A second click on the wall unmarks it.
    click_at(&mut h, t.screen_from_pixel(on_wall));
    assert!(errors(&h.state().mark.messages).is_empty(), "{:?}", h.state().mark.messages);
    assert!(std::fs::read_to_string(&manifest).unwrap().contains("diffuse_nodes = []"));
    assert!(!Scene::load(&dir).unwrap().proxy.nodes[wall].diffuse);

    // The environment map: the texel looking at the wall's face from the capture centre.
    h.state_mut().mark.on_env = true;
    h.run();
    let t_env = h.state().mark.view.last.unwrap();
    let centre = DVec3::from(truth.manifest.envmap.as_ref().unwrap().capture_center);
    let (x, y) = heliar::geometry::equirect::texel_from_dir((DVec3::new(-2.8, 1.2, 0.0) - centre).as_vec3(), t_env.size[0], t_env.size[1]);
    click_at(&mut h, t_env.screen_from_pixel(DVec2::new(x as f64 - 0.5, y as f64 - 0.5)));
    assert!(errors(&h.state().mark.messages).is_empty(), "{:?}", h.state().mark.messages);
    assert!(Scene::load(&dir).unwrap().proxy.nodes[wall].diffuse);
    std::fs::remove_dir_all(dir.parent().unwrap()).ok();
}

/// Proxy corners seen by the courtyard camera (as in `tests/suite/calib_tool.rs`).
const CORNERS: [[f64; 3]; 12] = [
    [-8.0, 0.0, -8.0], [-8.0, 6.0, -8.0], [-2.8, 2.4, 1.5], [-2.8, 0.0, 1.5], [-2.8, 2.4, -1.5], [5.0, 0.0, -8.0],
    [-8.0, 0.0, 4.0], [3.0, 5.0, -8.0], [0.0, 0.0, 0.0], [4.0, 0.0, 3.0], [-8.0, 4.0, -2.0], [8.0, 7.0, -8.0],
];

/// A courtyard copy whose camera file has a wrong (placeholder) pose.
fn courtyard_with_unknown_pose(tag: &str) -> PathBuf {
    let dir = courtyard_copy(tag);
    let cam = dir.join("calib/camera.toml");
    let text = std::fs::read_to_string(&cam).unwrap().replace("position = [4.5, 1.7, 9.0]", "position = [0.0, 1.6, 0.0]").replace("look_at = [-2.5, 0.6, -4.0]", "look_at = [0.0, 1.6, -1.0]");
    std::fs::write(&cam, text).unwrap();
    dir
}

/// Clicks the projections of proxy corners on the frame and pairs each with its corner (as a
/// pick in the 3D view does); returns the number of pairs added.
fn click_pairs(h: &mut Harness<'_, CalibApp>, truth: &Camera, corners: &[[f64; 3]]) -> usize {
    let t = h.state().pose.view.last.expect("the frame is shown");
    let before = h.state().pose.pairs.len();
    h.state_mut().pose.selected = None;
    let k = &truth.intrinsics;
    let mut n = 0;
    for c in corners {
        let Some(uv) = truth.project_world(DVec3::from(*c)).filter(|uv| uv.x > 2.0 && uv.y > 2.0 && uv.x < k.width as f64 - 3.0 && uv.y < k.height as f64 - 3.0) else { continue };
        click_at(h, t.screen_from_pixel(uv));
        let pose = &mut h.state_mut().pose;
        assert_eq!(pose.pairs.len(), before + n + 1, "the click added a pair");
        let got = pose.pairs[before + n].pixel.unwrap();
        assert!((got - uv).length() < 0.01, "clicked {got} for {uv}");
        pose.add_world(DVec3::from(*c));
        n += 1;
    }
    n
}

#[test]
fn the_pose_tab_solves_the_courtyard_camera_and_saves_it() {
    let dir = courtyard_with_unknown_pose("pose");
    let truth = Scene::load(&bundled()).unwrap().camera;
    let mut app = CalibApp::new(Some(&dir));
    app.tab = Tab::Pose;
    let mut h = harness(app);
    h.run();
    // The first pair's proxy point comes from the vertex list (a click on its row).
    let t = h.state().pose.view.last.unwrap();
    let first = DVec3::new(-2.8, 2.4, 1.5);
    click_at(&mut h, t.screen_from_pixel(truth.project_world(first).unwrap()));
    h.get_by_label("wall: -2.80, 2.40, 1.50").click_accesskit();
    h.run();
    assert!(h.state().pose.pairs[0].world.is_some_and(|w| (w - first).length() < 1e-5), "{:?}", h.state().pose.pairs[0]);
    let others: Vec<[f64; 3]> = CORNERS.iter().filter(|c| DVec3::from(**c) != first).copied().collect();
    let n = 1 + click_pairs(&mut h, &truth, &others);
    assert!(n >= 6, "only {n} pairs in view");

    click_button(&mut h, "Solve");
    let pose = &h.state().pose;
    assert!(errors(&pose.messages).is_empty(), "{:?}", pose.messages);
    let s = pose.solution.as_ref().unwrap();
    assert!(s.fit.rms_px < 0.05 && s.errors_px.len() == n, "{:?}", s.fit);
    assert!((s.camera.pose.translation - truth.pose.translation).length() < 0.05);

    let cam_file = dir.join("calib/camera.toml");
    click_button(&mut h, "Save pose");
    assert!(errors(&h.state().pose.messages).is_empty(), "{:?}", h.state().pose.messages);
    let saved = Scene::load(&dir).unwrap();
    let err_m = (saved.camera.pose.translation - truth.pose.translation).length();
    assert!(err_m < 0.05, "saved camera {err_m} m from the truth");
    let text = std::fs::read_to_string(&cam_file).unwrap();
    assert!(text.contains("rvec_camera_from_world") && text.contains("# Camera calibration of the courtyard scene"), "{text}");
    assert_no_leftovers(&dir);
    // The saved pose is what the app now shows as the scene's.
    assert_eq!(h.state().scene.as_ref().unwrap().scene.camera, saved.camera);

    // Export and re-import the pairs (the CLI's format).
    let csv = dir.parent().unwrap().join("pairs.csv");
    assert!(h.state().pose.export(&csv).is_ok());
    let (px, world) = crate::ops::pose::read_pairs(&csv).unwrap();
    assert_eq!((px.len(), world.len()), (n, n));
    // Once imported, the pairs file is an input: Export does not overwrite it, nor a file of the
    // scene, unless the app was started with --force.
    assert!(h.state_mut().pose.import(&csv).is_ok());
    let before = std::fs::read(&csv).unwrap();
    let e = format!("{:#}", h.state().pose.export(&csv).unwrap_err());
    assert!(e.contains("pairs.csv") && e.contains("is the input") && e.contains("--force"), "{e}");
    let manifest = dir.join("scene.toml");
    let manifest_before = std::fs::read(&manifest).unwrap();
    let e = format!("{:#}", h.state().pose.export(&manifest).unwrap_err());
    assert!(e.contains("scene.toml") && e.contains("file of the scene") && e.contains("--force"), "{e}");
    assert_eq!((std::fs::read(&csv).unwrap(), std::fs::read(&manifest).unwrap()), (before, manifest_before));
    h.state_mut().pose.force = true;
    assert!(h.state().pose.export(&csv).is_ok());
    std::fs::remove_dir_all(dir.parent().unwrap()).ok();
}

#[test]
fn three_pairs_are_refused_and_the_scene_is_untouched() {
    let dir = courtyard_with_unknown_pose("few");
    let truth = Scene::load(&bundled()).unwrap().camera;
    let cam_file = dir.join("calib/camera.toml");
    let before = std::fs::read(&cam_file).unwrap();
    let mut app = CalibApp::new(Some(&dir));
    app.tab = Tab::Pose;
    let mut h = harness(app);
    h.run();
    assert_eq!(click_pairs(&mut h, &truth, &CORNERS[..3]), 3);
    // A point can be dragged to where it belongs.
    let t = h.state().pose.view.last.unwrap();
    let p0 = h.state().pose.pairs[0].pixel.unwrap();
    drag(&mut h, t.screen_from_pixel(p0), t.screen_from_pixel(p0 + DVec2::new(4.0, 2.5)));
    let moved = h.state().pose.pairs[0].pixel.unwrap();
    assert!((moved - p0 - DVec2::new(4.0, 2.5)).length() < 0.01, "{p0} -> {moved}");
    assert_eq!(h.state().pose.pairs.len(), 3, "a drag adds no pair");
    click_button(&mut h, "Solve");
    let e = errors(&h.state().pose.messages);
    assert!(e.len() == 1 && e[0].contains("at least 4"), "{e:?}");
    h.get_by_label_contains("at least 4");
    assert!(h.state().pose.solution.is_none());
    // Save is disabled without a solution; pressing it changes nothing.
    h.get_by_label("Save pose").click();
    h.run();
    // An incomplete pair is named.
    h.state_mut().pose.selected = None;
    let t = h.state().pose.view.last.unwrap();
    click_at(&mut h, t.screen_from_pixel(DVec2::new(100.0, 100.0)));
    click_button(&mut h, "Solve");
    assert!(errors(&h.state().pose.messages)[0].contains("pair 4 has no proxy point"), "{:?}", h.state().pose.messages);
    // A typed point that is not x, y, z is named too.
    h.state_mut().pose.pairs[3].world_text = "1, 2".into();
    click_button(&mut h, "Solve");
    assert!(errors(&h.state().pose.messages)[0].contains("'1, 2' is not a proxy point"), "{:?}", h.state().pose.messages);
    assert_eq!(std::fs::read(&cam_file).unwrap(), before);
    assert_no_leftovers(&dir);
    std::fs::remove_dir_all(dir.parent().unwrap()).ok();
}

#[test]
fn the_intrinsics_tab_recovers_the_courtyard_lens_from_synthetic_boards() {
    let tmp = temp("intrinsics");
    let boards = tmp.join("boards");
    std::fs::create_dir_all(&boards).unwrap();
    let k = Scene::load(&bundled()).unwrap().camera.intrinsics;
    let cam = Camera { intrinsics: k.clone(), pose: Pose { rotation: DMat3::IDENTITY, translation: DVec3::ZERO } };
    let board = Board { cols: 9, rows: 6, square_m: 0.03 };
    let centre = DVec3::new(-0.15, -0.1, 0.0);
    // The views of `tests/suite/calib_tool.rs`: tilted every way, and near the four image corners.
    for (i, (ax, ay, dist, ox, oy)) in [
        (0.0, 0.0, 0.7, 0.0, 0.0), (0.35, 0.0, 0.75, 0.0, 0.0), (-0.35, 0.1, 0.75, 0.0, 0.0), (0.0, 0.4, 0.65, 0.0, 0.0), (0.1, -0.4, 0.8, 0.0, 0.0),
        (0.3, 0.3, 0.85, 0.0, 0.0), (-0.25, -0.3, 0.65, 0.0, 0.0), (0.2, 0.2, 0.75, 0.27, 0.19), (-0.2, 0.2, 0.75, -0.27, 0.19), (0.2, -0.2, 0.75, 0.27, -0.19), (-0.2, -0.2, 0.75, -0.27, -0.19),
    ]
    .into_iter()
    .enumerate()
    {
        let rot = DMat3::from_rotation_x(ax) * DMat3::from_rotation_y(ay) * DMat3::from_rotation_z(0.1 * i as f64);
        let pose = Pose { rotation: rot, translation: DVec3::new(ox, oy, dist) + rot * centre };
        let img = render_board(&cam, &board, &pose, 4);
        image::save_buffer(boards.join(format!("v{i:02}.png")), &img.data, img.width, img.height, image::ExtendedColorType::Rgb8).unwrap();
    }
    // A view of another size and a file that is not an image: listed with their problem, skipped.
    image::save_buffer(boards.join("w_small.png"), &[128u8; 3 * 16 * 12], 16, 12, image::ExtendedColorType::Rgb8).unwrap();
    std::fs::write(boards.join("x_broken.png"), b"not a png").unwrap();

    let mut h = harness(CalibApp::new(None));
    // Bad inputs first: each is an error in the tab, nothing starts.
    h.state_mut().intrinsics.folder = boards.display().to_string();
    h.state_mut().intrinsics.board = "9".into();
    click_button(&mut h, "Detect corners");
    assert!(errors(&h.state().intrinsics.messages)[0].contains("COLSxROWS"), "{:?}", h.state().intrinsics.messages);
    h.state_mut().intrinsics.board = "9x6".into();
    h.state_mut().intrinsics.square_mm = "thirty".into();
    click_button(&mut h, "Detect corners");
    assert!(errors(&h.state().intrinsics.messages)[0].contains("square size"), "{:?}", h.state().intrinsics.messages);
    h.state_mut().intrinsics.square_mm = "30".into();

    click_and_wait(&mut h, "Detect corners");
    let tab = &h.state().intrinsics;
    assert!(errors(&tab.messages).is_empty(), "{:?}", tab.messages);
    assert_eq!(tab.views.len(), 13);
    let found = tab.views.iter().filter(|v| v.corners.is_some()).count();
    assert!(found >= 9, "board found in {found} views");
    assert!(tab.views[11].problem.as_deref().is_some_and(|p| p.contains("16×12")), "{:?}", tab.views[11].problem);
    assert!(tab.views[12].problem.as_deref().is_some_and(|p| p.contains("unreadable")), "{:?}", tab.views[12].problem);
    assert!(tab.views[0].corners.as_ref().is_some_and(|c| c.len() == 54));

    click_and_wait(&mut h, "Calibrate");
    let tab = &h.state().intrinsics;
    assert!(errors(&tab.messages).is_empty(), "{:?}", tab.messages);
    let Some(super::intrinsics::CalibResult { model: super::intrinsics::Calibration::Pinhole(c), size }) = &tab.result else { panic!("no pinhole result") };
    assert_eq!(*size, (k.width, k.height));
    // The acceptance: focal within 0.5%, principal point within 2 px.
    assert!((c.fx / k.fx - 1.0).abs() < 0.005 && (c.fy / k.fy - 1.0).abs() < 0.005, "{c:?}");
    assert!((c.cx - k.cx).abs() < 2.0 && (c.cy - k.cy).abs() < 2.0, "{c:?}");
    let c = c.clone();
    h.get_by_label_contains("RMS reprojection error");

    let out = tmp.join("camera.toml");
    h.state_mut().intrinsics.output = out.display().to_string();
    click_button(&mut h, "Save camera file");
    assert!(errors(&h.state().intrinsics.messages).is_empty(), "{:?}", h.state().intrinsics.messages);
    let cf: heliar::scene::CameraFile = toml::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    assert_eq!((cf.width, cf.height, cf.fx, cf.cx), (k.width, k.height, c.fx, c.cx));
    // Not over one of the views (a file of the input folder), nor over the camera file of a scene
    // that is not the open one, without --force.
    let view = boards.join("v00.png");
    let other = tmp.join("other");
    std::fs::create_dir_all(other.join("calib")).unwrap();
    std::fs::write(other.join("scene.toml"), "# a scene\n").unwrap();
    std::fs::copy(&out, other.join("calib/camera.toml")).unwrap();
    for (target, words) in [(view.clone(), ["v00.png", "overlaps the input"]), (other.join("calib/camera.toml"), ["camera.toml", "file of the scene"])] {
        let before = std::fs::read(&target).unwrap();
        h.state_mut().intrinsics.output = target.display().to_string();
        click_button(&mut h, "Save camera file");
        let e = errors(&h.state().intrinsics.messages).join(" ");
        assert!(words.iter().all(|w| e.contains(w)) && e.contains("--force"), "{e}");
        assert_eq!(std::fs::read(&target).unwrap(), before, "{} changed", target.display());
    }

    // Fewer than three views in use: refused.
    for v in h.state_mut().intrinsics.views.iter_mut().skip(2) {
        v.use_it = false;
    }
    click_button(&mut h, "Calibrate");
    assert!(errors(&h.state().intrinsics.messages)[0].contains("at least 3"), "{:?}", h.state().intrinsics.messages);
    std::fs::remove_dir_all(&tmp).ok();
}

#[test]
fn the_hdr_tab_merges_bracketed_exposures_and_saves_them() {
    let tmp = temp("hdr");
    let (w, h_px) = (96u32, 64u32);
    let radiance = |x: u32, y: u32| 0.02 * 10f32.powf(2.5 * x as f32 / w as f32) * (0.6 + 0.4 * y as f32 / h_px as f32);
    let times = ["1/250", "1/60", "1/15", "1/4"];
    let mut app = CalibApp::new(None);
    app.tab = Tab::Hdr;
    let mut h = harness(app);
    h.run();
    // The files are dropped on the window; their times are typed.
    for (i, t) in times.iter().enumerate() {
        let secs = crate::ops::hdr::parse_exposure_time(t).unwrap();
        let data: Vec<u8> = (0..h_px).flat_map(|y| (0..w).flat_map(move |x| [heliar::io::image::srgb_u8_from_linear(8.0 * secs * radiance(x, y)); 3])).collect();
        let p = tmp.join(format!("e{i}.png"));
        image::save_buffer(&p, &data, w, h_px, image::ExtendedColorType::Rgb8).unwrap();
        h.input_mut().dropped_files.push(std::sync::Arc::new(Dropped(p)));
    }
    h.run();
    assert_eq!(h.state().hdr.rows.len(), 4, "three empty rows filled, one added");
    for (r, t) in h.state_mut().hdr.rows.iter_mut().zip(times) {
        r.time = t.to_string();
    }
    // A bad time is named, nothing merges.
    h.state_mut().hdr.rows[1].time = "fast".into();
    click_button(&mut h, "Merge (Debevec)");
    assert!(errors(&h.state().hdr.messages)[0].contains("exposure 2: time 'fast'"), "{:?}", h.state().hdr.messages);
    h.state_mut().hdr.rows[1].time = "1/60".into();
    // A reflection without its clean patch is refused.
    h.state_mut().hdr.reflection = Some([10, 10, 12, 12]);
    click_button(&mut h, "Merge (Debevec)");
    assert!(errors(&h.state().hdr.messages)[0].contains("clean rectangle"), "{:?}", h.state().hdr.messages);
    h.state_mut().hdr.reflection = None;
    // The reflection's rectangle is dragged on the shown exposure, the clean patch placed by a click.
    click_button(&mut h, "Load");
    h.state_mut().hdr.drawing = super::hdr::Draw::Reflection;
    h.run();
    let t = h.state().hdr.view_transform().expect("the exposure is shown");
    drag(&mut h, t.screen_from_pixel(DVec2::new(10.0, 10.0)), t.screen_from_pixel(DVec2::new(25.0, 22.0)));
    assert_eq!(h.state().hdr.reflection, Some([10, 10, 16, 13]));
    h.state_mut().hdr.drawing = super::hdr::Draw::Clean;
    h.run();
    click_at(&mut h, t.screen_from_pixel(DVec2::new(60.0, 30.0)));
    assert_eq!(h.state().hdr.clean, Some([52, 24, 16, 13]));

    click_and_wait(&mut h, "Merge (Debevec)");
    assert!(errors(&h.state().hdr.messages).is_empty(), "{:?}", h.state().hdr.messages);
    let out = tmp.join("env.exr");
    h.state_mut().hdr.output = out.display().to_string();
    click_button(&mut h, "Save EXR + response");
    assert!(errors(&h.state().hdr.messages).is_empty(), "{:?}", h.state().hdr.messages);
    let m = heliar::io::image::LinearImage::read_exr(&out).unwrap();
    let ratio = m.get(90, 32)[1] / m.get(5, 32)[1];
    let want = radiance(90, 32) / radiance(5, 32);
    assert!((ratio / want - 1.0).abs() < 0.05, "ratio {ratio} vs {want}");
    assert!(tmp.join("env.response.csv").exists());
    // Not over a file of a scene (its environment map) without --force; with it, yes.
    let scene = tmp.join("scene");
    std::fs::create_dir_all(&scene).unwrap();
    std::fs::write(scene.join("scene.toml"), "# a scene\n").unwrap();
    std::fs::copy(&out, scene.join("env.exr")).unwrap();
    let before = std::fs::read(scene.join("env.exr")).unwrap();
    h.state_mut().hdr.output = scene.join("env.exr").display().to_string();
    click_button(&mut h, "Save EXR + response");
    let e = errors(&h.state().hdr.messages).join(" ");
    assert!(e.contains("env.exr") && e.contains("file of the scene") && e.contains("--force"), "{e}");
    assert_eq!(std::fs::read(scene.join("env.exr")).unwrap(), before);
    assert!(!scene.join("env.response.csv").exists(), "the response was written beside a refused EXR");
    h.state_mut().hdr.force = true;
    click_button(&mut h, "Save EXR + response");
    assert!(errors(&h.state().hdr.messages).is_empty(), "{:?}", h.state().hdr.messages);
    std::fs::remove_dir_all(&tmp).ok();
}

