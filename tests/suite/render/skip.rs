//! The skip logic: every pass a frame does not need is left out with a reason, and leaving it
//! out does not change the picture.

use super::support::*;
use glam::Vec3;
use heliar::geometry::{Material, Mesh};
use heliar::render::frame::pass;
use heliar::lighting::Lighting;
use heliar::render::{CompositorConfig, VideoFrame};

fn video(w: u32, h: u32) -> VideoFrame {
    // A gradient, so that pass-through is checked pixel by pixel.
    VideoFrame { width: w, height: h, rgba: (0..w * h).map(|i| [0.1 + (i % w) as f32 * 1e-3, 0.2 + (i / w) as f32 * 1e-3, 0.3, 1.0]).collect() }
}

fn statue_near_wall() -> Vec<(String, Mesh)> {
    vec![("sphere".into(), icosphere(Vec3::new(-1.9, 0.85, 0.0), 0.35, 2, Material::diffuse("red", [0.6, 0.12, 0.08]), "sphere"))]
}

fn setup(objects: Vec<(String, Mesh)>) -> Setup {
    Setup { camera: camera([1.5, 1.6, 5.0], [-1.2, 0.4, 0.2], 160, 120, [0.0; 5]), proxy: yard_proxy(), objects }
}

fn lighting(sun: Vec3, pd: f32) -> Lighting {
    Lighting { sun_dir: sun, above_horizon: sun.y > 0.0, pd: Vec3::splat(pd), pa: Vec3::new(0.55, 0.62, 0.8), sky: heliar::lighting::FrameSky::Declared, lamps: heliar::lighting::LampScales::NONE }
}

fn config() -> CompositorConfig {
    let mut c = CompositorConfig::from_estimator_settings(&Default::default());
    c.debug_masks = true;
    c
}

#[test]
fn no_sun_means_no_volumes_and_no_sun_term() {
    let s = setup(statue_near_wall());
    // The normal-aware model changes nothing without sun (the differential one still darkens
    // the sky light the objects take, which is right but not what this test is about).
    let mut c = config();
    c.darkening = heliar::render::Darkening::Normal;
    let mut comp = s.compositor(c);
    let v = video(160, 120);
    for (l, why) in [(lighting(Vec3::new(-0.5, -0.1, 0.4).normalize(), 3.0), "below the horizon"), (lighting(courtyard_sun(), 0.01), "Pd ≈ 0")] {
        comp.invalidate();
        let (frame, r) = comp.render(&v, &l).unwrap();
        assert!(!r.sun);
        for p in [pass::VOLUME_BUILD, pass::REAL_VOLUMES, pass::VIRTUAL_VOLUMES, pass::SUN_TERM] {
            let reason = r.skip_reason(p).unwrap_or_else(|| panic!("{p} not skipped: {r:?}"));
            assert!(reason.contains(why), "{p}: {reason}");
        }
        assert!(r.ran(pass::DEPTH_PREPASS) && r.ran(pass::VIRTUAL_SHADING) && r.ran(pass::COMPOSITE));
        // No real pixel is darkened.
        let masks = frame.masks.unwrap();
        for (i, px) in frame.image.data.iter().enumerate() {
            if masks[i][3] == 0 {
                let same = (0..3).all(|c| (px[c] - v.rgba[i][c]).abs() <= frame.precision * v.rgba[i][c]);
                assert!(same, "pixel {i} changed without sun: {px:?} vs {:?}", v.rgba[i]);
            }
        }
    }
}

#[test]
fn no_real_occluder_in_reach_means_no_real_volume_pass() {
    // A ball out in the open, south-west of the wall, toward the sun: the wall's shadow reaches
    // neither the ball nor the ground its shadow falls on.
    let s = setup(vec![("ball".into(), icosphere(Vec3::new(1.0, 0.4, 2.5), 0.4, 2, Material::diffuse("b", [0.5; 3]), "ball"))]);
    let mut comp = s.compositor(config());
    let (_, r) = comp.render(&video(160, 120), &lighting(courtyard_sun(), 3.0)).unwrap();
    assert!(r.ran(pass::VIRTUAL_VOLUMES), "{r:?}");
    let reason = r.skip_reason(pass::REAL_VOLUMES).unwrap_or_else(|| panic!("real volumes ran: {r:?}"));
    assert!(reason.contains("no part of the real proxy"), "{reason}");
    assert_eq!(r.volumes.real_parts, 0);
    // The statue by the wall needs the wall's volume.
    let mut comp = setup(statue_near_wall()).compositor(config());
    let (_, r) = comp.render(&video(160, 120), &lighting(courtyard_sun(), 3.0)).unwrap();
    assert!(r.ran(pass::REAL_VOLUMES) && r.volumes.real_parts == 1, "{r:?}");
}

#[test]
fn unchanged_sun_reuses_volumes_and_stencil_with_the_same_picture() {
    let s = setup(statue_near_wall());
    let v = video(160, 120);
    let sun = courtyard_sun();
    let mut comp = s.compositor(config());
    let (first, r1) = comp.render(&v, &lighting(sun, 3.0)).unwrap();
    assert!(r1.ran(pass::VOLUME_BUILD) && !r1.volumes.reused);
    // A cloud dims the sun: volumes and stencil are reused, shading reruns, and the picture is
    // the one a fresh compositor draws.
    let (second, r2) = comp.render(&v, &lighting(sun, 1.5)).unwrap();
    assert!(r2.volumes.reused, "{r2:?}");
    for p in [pass::VOLUME_BUILD, pass::DEPTH_PREPASS, pass::REAL_VOLUMES, pass::VIRTUAL_VOLUMES, pass::SHADOW_MASK] {
        assert!(r2.skip_reason(p).is_some_and(|r| r.contains("reused")), "{p}: {r2:?}");
    }
    assert!(r2.ran(pass::VIRTUAL_SHADING) && r2.ran(pass::SUN_TERM));
    // The objects' transfer, traced on the first frame, is reused as well.
    assert!(r1.ran(pass::OBJECT_TRANSFER) && r1.transfer_traced > 0, "{r1:?}");
    assert!(r2.skip_reason(pass::OBJECT_TRANSFER).is_some_and(|r| r.contains("reused")), "{r2:?}");
    assert!(first.masks == second.masks);
    let mut fresh = s.compositor(config());
    let (want, _) = fresh.render(&v, &lighting(sun, 1.5)).unwrap();
    let differ = want.image.data.iter().zip(&second.image.data).filter(|(a, b)| a != b).count();
    assert_eq!(differ, 0, "{differ} pixels differ from a fresh compositor's");
    assert!(first.image.data != second.image.data, "the dimmer sun changed nothing");
    // The sun moves by 0.01°: still reused.
    let moved = (sun + Vec3::new(1.7e-4, 0.0, 0.0)).normalize();
    let (_, r3) = comp.render(&v, &lighting(moved, 1.5)).unwrap();
    assert!(r3.volumes.reused, "{r3:?}");
    // A sun that moved more than the tolerance rebuilds.
    let far = (sun + Vec3::new(0.01, 0.0, 0.0)).normalize();
    let (_, r4) = comp.render(&v, &lighting(far, 1.5)).unwrap();
    assert!(r4.ran(pass::VOLUME_BUILD) && !r4.volumes.reused, "{r4:?}");
    // 0.5° is past the transfer's tolerance (`bounce_rebuild_deg`, 0.25° by default) too.
    assert!(r4.ran(pass::OBJECT_TRANSFER), "{r4:?}");
}

#[test]
fn no_virtual_objects_pass_the_footage_through() {
    let s = setup(Vec::new());
    let mut comp = s.compositor(config());
    let v = video(160, 120);
    let (frame, r) = comp.render(&v, &lighting(courtyard_sun(), 3.0)).unwrap();
    assert!(r.skip_reason(pass::DEPTH_PREPASS).is_some_and(|s| s.contains("no virtual objects")), "{r:?}");
    // Bit for bit with a 32-bit float output; within half-float rounding on GL.
    let changed = frame.image.data.iter().zip(&v.rgba).filter(|(a, b)| (0..3).any(|c| (a[c] - b[c]).abs() > frame.precision * b[c])).count();
    assert_eq!(changed, 0);
}

#[test]
fn switched_off_passes_are_reported_and_change_the_picture_as_they_should() {
    use heliar::render::PassSwitches;
    const WHY: &str = "turned off in the live view";
    let s = setup(statue_near_wall());
    let mut comp = s.compositor(config());
    let v = video(160, 120);
    let l = lighting(courtyard_sun(), 3.0);
    let (all, r) = comp.render(&v, &l).unwrap();
    assert!(r.ran(pass::VIRTUAL_VOLUMES) && r.ran(pass::REAL_VOLUMES), "{r:?}");
    let masks = all.masks.clone().unwrap();
    let shadowed = masks.iter().filter(|m| m[0] > 0).count();
    // Most of the sphere's shadow falls into the wall's (25 px stay outside at 160×120).
    assert!(shadowed > 10, "the sphere casts a virtual shadow ({shadowed} px)");

    // Virtual shadows off: the volume pass is skipped with the reason, no virtual shadow mask,
    // and the sphere itself stays drawn.
    comp.set_switches(PassSwitches { virtual_volumes: false, ..Default::default() }, WHY);
    let (f, r) = comp.render(&v, &l).unwrap();
    assert_eq!(r.skip_reason(pass::VIRTUAL_VOLUMES), Some(WHY), "{r:?}");
    assert!(r.ran(pass::REAL_VOLUMES) && r.ran(pass::VIRTUAL_SHADING), "{r:?}");
    let m = f.masks.unwrap();
    assert_eq!(m.iter().filter(|m| m[0] > 0).count(), 0, "no virtual shadow with its volumes off");
    assert!(m.iter().filter(|m| m[3] > 0).count() > 50, "the sphere is still drawn");

    // A second frame with the same switches reuses the stencil and still names the switch.
    let (_, r) = comp.render(&v, &l).unwrap();
    assert!(r.volumes.reused, "{r:?}");
    assert_eq!(r.skip_reason(pass::VIRTUAL_VOLUMES), Some(WHY), "{r:?}");

    // Real shadows off: the virtual shadow now covers the part inside the wall's shadow too.
    comp.set_switches(PassSwitches { real_volumes: false, ..Default::default() }, WHY);
    let (f, r) = comp.render(&v, &l).unwrap();
    assert_eq!(r.skip_reason(pass::REAL_VOLUMES), Some(WHY), "{r:?}");
    assert!(r.ran(pass::VIRTUAL_VOLUMES) && !r.volumes.reused, "a change of switches rebuilds: {r:?}");
    let without_real = f.masks.unwrap().iter().filter(|m| m[0] > 0).count();
    assert!(without_real > shadowed + 20, "{without_real} vs {shadowed} px");

    // The per-pixel transfer off: reported, and the objects' ambient comes from the probe grid
    // times occlusion instead, which changes the sphere (this test sets no probe grid, so its
    // ambient is then zero).
    comp.set_switches(PassSwitches { transfer: false, ..Default::default() }, WHY);
    let (f, r) = comp.render(&v, &l).unwrap();
    assert_eq!(r.skip_reason(pass::OBJECT_TRANSFER), Some(WHY), "{r:?}");
    let changed = f.image.data.iter().zip(&all.image.data).filter(|(a, b)| (0..3).any(|c| (a[c] - b[c]).abs() > 0.01 * b[c].max(1e-3))).count();
    assert!(changed > 50, "only {changed} pixels changed with the transfer off");

    // Virtual objects off: the footage passes through unchanged.
    comp.set_switches(PassSwitches { virtual_objects: false, ..Default::default() }, WHY);
    let (f, r) = comp.render(&v, &l).unwrap();
    for p in [pass::DEPTH_PREPASS, pass::VIRTUAL_SHADING, pass::VIRTUAL_VOLUMES, pass::SUN_TERM] {
        assert_eq!(r.skip_reason(p), Some(WHY), "{p}: {r:?}");
    }
    for (i, px) in f.image.data.iter().enumerate() {
        assert!((0..3).all(|c| (px[c] - v.rgba[i][c]).abs() <= f.precision * v.rgba[i][c]), "pixel {i} changed with the objects off");
    }

    // All on again: the same picture as the first frame.
    comp.set_switches(PassSwitches::default(), WHY);
    let (f, r) = comp.render(&v, &l).unwrap();
    assert!(r.skipped.iter().all(|s| s.reason != WHY), "{r:?}");
    assert_eq!(f.image.data, all.image.data);
}

#[test]
fn the_scissored_region_draws_the_same_picture_as_the_whole_canvas() {
    // The 3D passes cover only the canvas region the objects and their shadows can reach; the
    // picture must be the one the whole canvas gives, bit for bit, with and without sun.
    let s = setup(statue_near_wall());
    let v = video(160, 120);
    let mut plain = CompositorConfig::from_estimator_settings(&Default::default());
    plain.scissor = false;
    let mut full = s.compositor(plain.clone());
    let mut cut = s.compositor(CompositorConfig { scissor: true, ..plain });
    for l in [lighting(courtyard_sun(), 3.0), lighting(courtyard_sun(), 0.0), lighting(Vec3::new(0.7, 0.3, -0.2).normalize(), 3.0)] {
        let (a, ra) = full.render(&v, &l).unwrap();
        let (b, rb) = cut.render(&v, &l).unwrap();
        assert_eq!(ra.canvas_region, None);
        let r = rb.canvas_region.expect("a region smaller than the canvas");
        let canvas = cut.canvas();
        assert!((r.width * r.height) < canvas.intrinsics.width * canvas.intrinsics.height / 2, "{r:?} of {}×{}", canvas.intrinsics.width, canvas.intrinsics.height);
        let differ = a.image.data.iter().zip(&b.image.data).filter(|(x, y)| x != y).count();
        assert_eq!(differ, 0, "{differ} pixels differ with the scissor ({r:?})");
    }
}
