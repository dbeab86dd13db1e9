//! The per-frame pass report, entry by entry and in order, for every way a frame can go: no
//! objects (none in the scene, or switched off), no sun (below the horizon, `Pd ≈ 0`, no
//! direction) with and without reuse, sun with and without reuse, passes switched off, no real
//! part in reach, no transfer, no object on the canvas.
//!
//! The report is part of `augment`'s JSON lines, so its order is behaviour. The expected lines
//! were recorded from the compositor as it was before its passes became units (commit e556da0,
//! one `encode` function holding every decision); every frame here must still give them exactly.

use super::support::*;
use glam::Vec3;
use heliar::geometry::{Material, Mesh};
use heliar::lighting::Lighting;
use heliar::render::{CompositorConfig, Darkening, PassReport, PassSwitches, VideoFrame};

const WHY: &str = "turned off in the live view";

fn video() -> VideoFrame {
    VideoFrame { width: 160, height: 120, rgba: vec![[0.2, 0.25, 0.3, 1.0]; 160 * 120] }
}

fn setup(objects: Vec<(String, Mesh)>) -> Setup {
    Setup { camera: camera([1.5, 1.6, 5.0], [-1.2, 0.4, 0.2], 160, 120, [0.0; 5]), proxy: yard_proxy(), objects }
}

fn statue_near_wall() -> Vec<(String, Mesh)> {
    vec![("sphere".into(), icosphere(Vec3::new(-1.9, 0.85, 0.0), 0.35, 2, Material::diffuse("red", [0.6, 0.12, 0.08]), "sphere"))]
}

fn lit(sun: Vec3, pd: f32) -> Lighting {
    Lighting { sun_dir: sun, above_horizon: sun.y > 0.0, pd: Vec3::splat(pd), pa: Vec3::new(0.55, 0.62, 0.8), sky: heliar::lighting::FrameSky::Declared, lamps: heliar::lighting::LampScales::NONE }
}

fn below() -> Lighting {
    lit(Vec3::new(-0.5, -0.1, 0.4).normalize(), 3.0)
}

/// One report as a line: everything but the timings.
fn line(r: &PassReport) -> String {
    let skipped: Vec<String> = r.skipped.iter().map(|s| format!("{}: {}", s.pass, s.reason)).collect();
    format!(
        "sun={} volumes={:?} receivers={} traced={} region={:?} ran=[{}] skipped=[{}]",
        r.sun,
        r.volumes,
        r.receivers_computed,
        r.transfer_traced,
        r.canvas_region,
        r.ran.join(", "),
        skipped.join("; ")
    )
}

/// The frames of every case, one line each, in order.
fn frames() -> Vec<String> {
    let v = video();
    let sun = courtyard_sun();
    let mut out = Vec::new();
    let run = |comp: &mut heliar::render::Compositor, l: &Lighting, out: &mut Vec<String>| {
        let (_, r) = comp.render(&v, l).expect("frame");
        out.push(line(&r));
    };
    // Whole re-traces after a sun move (the recorded lines predate the sliced re-trace of issue
    // 13 part 4, whose frame-by-frame work the unit tests of both `retrace` modules check).
    let config = || CompositorConfig { trace_paths_per_frame: 0, ..CompositorConfig::from_estimator_settings(&Default::default()) };

    // One compositor through sun, reuse, no sun, moves and switches (state carries over).
    let s = setup(statue_near_wall());
    let mut c = s.compositor(config());
    run(&mut c, &lit(sun, 3.0), &mut out);
    run(&mut c, &lit(sun, 1.5), &mut out);
    run(&mut c, &below(), &mut out);
    run(&mut c, &below(), &mut out);
    run(&mut c, &lit(sun, 0.01), &mut out);
    run(&mut c, &lit((sun + Vec3::new(0.01, 0.0, 0.0)).normalize(), 3.0), &mut out);
    for sw in [
        PassSwitches { virtual_volumes: false, ..Default::default() },
        PassSwitches { real_volumes: false, ..Default::default() },
        PassSwitches { virtual_volumes: false, real_volumes: false, ..Default::default() },
        PassSwitches { transfer: false, ..Default::default() },
    ] {
        c.set_switches(sw, WHY);
        run(&mut c, &lit(sun, 3.0), &mut out);
        run(&mut c, &lit(sun, 3.0), &mut out);
        run(&mut c, &below(), &mut out);
    }
    c.set_switches(PassSwitches { virtual_objects: false, ..Default::default() }, WHY);
    run(&mut c, &lit(sun, 3.0), &mut out);
    run(&mut c, &below(), &mut out);
    c.set_switches(PassSwitches::default(), "");
    run(&mut c, &below(), &mut out);
    run(&mut c, &lit(sun, 3.0), &mut out);
    c.set_darkening(Darkening::Normal);
    run(&mut c, &lit(sun, 3.0), &mut out);
    run(&mut c, &below(), &mut out);

    // Debug masks: the whole canvas, and the stencil is kept for the same masks only.
    let mut c = s.compositor(CompositorConfig { debug_masks: true, ..config() });
    run(&mut c, &lit(sun, 3.0), &mut out);
    run(&mut c, &lit(sun, 3.0), &mut out);

    // No objects in the scene.
    let mut c = setup(Vec::new()).compositor(config());
    run(&mut c, &lit(sun, 3.0), &mut out);
    run(&mut c, &below(), &mut out);

    // A ball in the open: no real part in reach; then odd lighting.
    let mut c = setup(vec![("ball".into(), icosphere(Vec3::new(1.0, 0.4, 2.5), 0.4, 2, Material::diffuse("b", [0.5; 3]), "ball"))]).compositor(config());
    run(&mut c, &lit(sun, 3.0), &mut out);
    run(&mut c, &lit(sun, 3.0), &mut out);
    run(&mut c, &Lighting { sun_dir: Vec3::ZERO, above_horizon: true, pd: Vec3::splat(3.0), pa: Vec3::splat(0.5), sky: heliar::lighting::FrameSky::Declared, lamps: heliar::lighting::LampScales::NONE }, &mut out);
    run(&mut c, &lit(sun, f32::NAN), &mut out);

    // The transfer off by configuration, and the compute builder.
    let mut c = s.compositor(CompositorConfig { transfer_paths: 0, builder: heliar::render::Builder::Compute, ..config() });
    run(&mut c, &lit(sun, 3.0), &mut out);
    run(&mut c, &lit(sun, 3.0), &mut out);

    // An object behind the camera: drawn, but no canvas pixel shows it.
    let mut c = setup(vec![("hidden".into(), cube(Vec3::new(2.0, 1.0, 8.0), Vec3::new(2.5, 1.5, 8.5), Material::diffuse("h", [0.5; 3]), "hidden"))]).compositor(config());
    run(&mut c, &lit(sun, 3.0), &mut out);
    run(&mut c, &lit(sun, 3.0), &mut out);
    out
}

#[test]
fn every_case_gives_the_recorded_report() {
    let got = frames();
    let want: Vec<&str> = EXPECTED.lines().map(str::trim).filter(|l| !l.is_empty()).collect();
    if got.len() != want.len() {
        // Shows every line, for recording them anew when the report is changed on purpose.
        eprintln!("{}", got.join("\n"));
    }
    let mut diff = Vec::new();
    for (i, g) in got.iter().enumerate() {
        if want.get(i) != Some(&g.as_str()) {
            diff.push(format!("frame {i}:\n  got  {g}\n  want {}", want.get(i).unwrap_or(&"(none)")));
        }
    }
    assert!(diff.is_empty() && got.len() == want.len(), "{} frames, {} expected; differences:\n{}", got.len(), want.len(), diff.join("\n"));
}

/// Recorded from the compositor of commit e556da0 (see the module docs).
const EXPECTED: &str = r#"
sun=true volumes=VolumeStats { virtual_triangles: Some(188), real_triangles: 40, real_parts: 1, compute: false, reused: false } receivers=3509 traced=176 region=Some(Rect { x: 57, y: 37, width: 48, height: 37 }) ran=[volume_build, object_transfer, depth_prepass, real_volumes, virtual_volumes, shadow_mask, virtual_shading, sun_term, composite, readback] skipped=[]
sun=true volumes=VolumeStats { virtual_triangles: None, real_triangles: 0, real_parts: 0, compute: false, reused: true } receivers=0 traced=0 region=Some(Rect { x: 57, y: 37, width: 48, height: 37 }) ran=[virtual_shading, sun_term, composite, readback] skipped=[volume_build: sun moved 0.0000° ≤ 0.05° since frame 0 and the objects are static: its volumes and stencil are reused; object_transfer: the sun moved 0.000° ≤ 0.25° since it was traced and the camera and objects are static: the transfer is reused; depth_prepass: sun moved 0.0000° ≤ 0.05° since frame 0 and the objects are static: its volumes and stencil are reused; real_volumes: sun moved 0.0000° ≤ 0.05° since frame 0 and the objects are static: its volumes and stencil are reused; virtual_volumes: sun moved 0.0000° ≤ 0.05° since frame 0 and the objects are static: its volumes and stencil are reused; shadow_mask: sun moved 0.0000° ≤ 0.05° since frame 0 and the objects are static: its volumes and stencil are reused]
sun=false volumes=VolumeStats { virtual_triangles: None, real_triangles: 0, real_parts: 0, compute: false, reused: false } receivers=0 traced=0 region=Some(Rect { x: 57, y: 37, width: 30, height: 28 }) ran=[depth_prepass, shadow_mask, virtual_shading, composite, readback] skipped=[volume_build: the sun is below the horizon; real_volumes: the sun is below the horizon; virtual_volumes: the sun is below the horizon; sun_term: the sun is below the horizon; object_transfer: no sun: the traced sky transfer is reused (camera and objects are static)]
sun=false volumes=VolumeStats { virtual_triangles: None, real_triangles: 0, real_parts: 0, compute: false, reused: true } receivers=0 traced=0 region=Some(Rect { x: 57, y: 37, width: 30, height: 28 }) ran=[virtual_shading, composite, readback] skipped=[volume_build: the sun is below the horizon; real_volumes: the sun is below the horizon; virtual_volumes: the sun is below the horizon; sun_term: the sun is below the horizon; object_transfer: no sun: the traced sky transfer is reused (camera and objects are static); depth_prepass: no sun now or at frame 2 and the objects are static: its depth and stencil are reused; shadow_mask: no sun now or at frame 2 and the objects are static: its depth and stencil are reused]
sun=false volumes=VolumeStats { virtual_triangles: None, real_triangles: 0, real_parts: 0, compute: false, reused: true } receivers=0 traced=0 region=Some(Rect { x: 57, y: 37, width: 30, height: 28 }) ran=[virtual_shading, composite, readback] skipped=[volume_build: Pd ≈ 0 (Pd/Pa = 0.016 < 0.05); real_volumes: Pd ≈ 0 (Pd/Pa = 0.016 < 0.05); virtual_volumes: Pd ≈ 0 (Pd/Pa = 0.016 < 0.05); sun_term: Pd ≈ 0 (Pd/Pa = 0.016 < 0.05); object_transfer: no sun: the traced sky transfer is reused (camera and objects are static); depth_prepass: no sun now or at frame 2 and the objects are static: its depth and stencil are reused; shadow_mask: no sun now or at frame 2 and the objects are static: its depth and stencil are reused]
sun=true volumes=VolumeStats { virtual_triangles: Some(190), real_triangles: 40, real_parts: 1, compute: false, reused: false } receivers=3509 traced=176 region=Some(Rect { x: 57, y: 37, width: 48, height: 37 }) ran=[volume_build, object_transfer, depth_prepass, real_volumes, virtual_volumes, shadow_mask, virtual_shading, sun_term, composite, readback] skipped=[]
sun=true volumes=VolumeStats { virtual_triangles: Some(188), real_triangles: 40, real_parts: 1, compute: false, reused: false } receivers=3509 traced=176 region=Some(Rect { x: 57, y: 37, width: 48, height: 37 }) ran=[volume_build, object_transfer, depth_prepass, real_volumes, shadow_mask, virtual_shading, sun_term, composite, readback] skipped=[virtual_volumes: turned off in the live view]
sun=true volumes=VolumeStats { virtual_triangles: None, real_triangles: 0, real_parts: 0, compute: false, reused: true } receivers=0 traced=0 region=Some(Rect { x: 57, y: 37, width: 48, height: 37 }) ran=[virtual_shading, sun_term, composite, readback] skipped=[volume_build: sun moved 0.0000° ≤ 0.05° since frame 6 and the objects are static: its volumes and stencil are reused; object_transfer: the sun moved 0.000° ≤ 0.25° since it was traced and the camera and objects are static: the transfer is reused; depth_prepass: sun moved 0.0000° ≤ 0.05° since frame 6 and the objects are static: its volumes and stencil are reused; real_volumes: sun moved 0.0000° ≤ 0.05° since frame 6 and the objects are static: its volumes and stencil are reused; virtual_volumes: turned off in the live view; shadow_mask: sun moved 0.0000° ≤ 0.05° since frame 6 and the objects are static: its volumes and stencil are reused]
sun=false volumes=VolumeStats { virtual_triangles: None, real_triangles: 0, real_parts: 0, compute: false, reused: false } receivers=0 traced=0 region=Some(Rect { x: 57, y: 37, width: 30, height: 28 }) ran=[depth_prepass, shadow_mask, virtual_shading, composite, readback] skipped=[volume_build: the sun is below the horizon; real_volumes: the sun is below the horizon; virtual_volumes: the sun is below the horizon; sun_term: the sun is below the horizon; object_transfer: no sun: the traced sky transfer is reused (camera and objects are static)]
sun=true volumes=VolumeStats { virtual_triangles: Some(188), real_triangles: 40, real_parts: 1, compute: false, reused: false } receivers=0 traced=0 region=Some(Rect { x: 57, y: 37, width: 48, height: 37 }) ran=[volume_build, depth_prepass, virtual_volumes, shadow_mask, virtual_shading, sun_term, composite, readback] skipped=[object_transfer: the sun moved 0.000° ≤ 0.25° since it was traced and the camera and objects are static: the transfer is reused; real_volumes: turned off in the live view]
sun=true volumes=VolumeStats { virtual_triangles: None, real_triangles: 0, real_parts: 0, compute: false, reused: true } receivers=0 traced=0 region=Some(Rect { x: 57, y: 37, width: 48, height: 37 }) ran=[virtual_shading, sun_term, composite, readback] skipped=[volume_build: sun moved 0.0000° ≤ 0.05° since frame 9 and the objects are static: its volumes and stencil are reused; object_transfer: the sun moved 0.000° ≤ 0.25° since it was traced and the camera and objects are static: the transfer is reused; depth_prepass: sun moved 0.0000° ≤ 0.05° since frame 9 and the objects are static: its volumes and stencil are reused; real_volumes: turned off in the live view; virtual_volumes: sun moved 0.0000° ≤ 0.05° since frame 9 and the objects are static: its volumes and stencil are reused; shadow_mask: sun moved 0.0000° ≤ 0.05° since frame 9 and the objects are static: its volumes and stencil are reused]
sun=false volumes=VolumeStats { virtual_triangles: None, real_triangles: 0, real_parts: 0, compute: false, reused: false } receivers=0 traced=0 region=Some(Rect { x: 57, y: 37, width: 30, height: 28 }) ran=[depth_prepass, shadow_mask, virtual_shading, composite, readback] skipped=[volume_build: the sun is below the horizon; real_volumes: the sun is below the horizon; virtual_volumes: the sun is below the horizon; sun_term: the sun is below the horizon; object_transfer: no sun: the traced sky transfer is reused (camera and objects are static)]
sun=true volumes=VolumeStats { virtual_triangles: None, real_triangles: 0, real_parts: 0, compute: false, reused: false } receivers=0 traced=0 region=Some(Rect { x: 57, y: 37, width: 48, height: 37 }) ran=[depth_prepass, shadow_mask, virtual_shading, sun_term, composite, readback] skipped=[volume_build: turned off in the live view; object_transfer: the sun moved 0.000° ≤ 0.25° since it was traced and the camera and objects are static: the transfer is reused; real_volumes: turned off in the live view; virtual_volumes: turned off in the live view]
sun=true volumes=VolumeStats { virtual_triangles: None, real_triangles: 0, real_parts: 0, compute: false, reused: true } receivers=0 traced=0 region=Some(Rect { x: 57, y: 37, width: 48, height: 37 }) ran=[virtual_shading, sun_term, composite, readback] skipped=[volume_build: sun moved 0.0000° ≤ 0.05° since frame 12 and the objects are static: its volumes and stencil are reused; object_transfer: the sun moved 0.000° ≤ 0.25° since it was traced and the camera and objects are static: the transfer is reused; depth_prepass: sun moved 0.0000° ≤ 0.05° since frame 12 and the objects are static: its volumes and stencil are reused; real_volumes: turned off in the live view; virtual_volumes: turned off in the live view; shadow_mask: sun moved 0.0000° ≤ 0.05° since frame 12 and the objects are static: its volumes and stencil are reused]
sun=false volumes=VolumeStats { virtual_triangles: None, real_triangles: 0, real_parts: 0, compute: false, reused: false } receivers=0 traced=0 region=Some(Rect { x: 57, y: 37, width: 30, height: 28 }) ran=[depth_prepass, shadow_mask, virtual_shading, composite, readback] skipped=[volume_build: the sun is below the horizon; real_volumes: the sun is below the horizon; virtual_volumes: the sun is below the horizon; sun_term: the sun is below the horizon; object_transfer: no sun: the traced sky transfer is reused (camera and objects are static)]
sun=true volumes=VolumeStats { virtual_triangles: Some(188), real_triangles: 40, real_parts: 1, compute: false, reused: false } receivers=0 traced=0 region=Some(Rect { x: 57, y: 37, width: 48, height: 37 }) ran=[volume_build, depth_prepass, real_volumes, virtual_volumes, shadow_mask, virtual_shading, sun_term, composite, readback] skipped=[object_transfer: turned off in the live view]
sun=true volumes=VolumeStats { virtual_triangles: None, real_triangles: 0, real_parts: 0, compute: false, reused: true } receivers=0 traced=0 region=Some(Rect { x: 57, y: 37, width: 48, height: 37 }) ran=[virtual_shading, sun_term, composite, readback] skipped=[volume_build: sun moved 0.0000° ≤ 0.05° since frame 15 and the objects are static: its volumes and stencil are reused; object_transfer: turned off in the live view; depth_prepass: sun moved 0.0000° ≤ 0.05° since frame 15 and the objects are static: its volumes and stencil are reused; real_volumes: sun moved 0.0000° ≤ 0.05° since frame 15 and the objects are static: its volumes and stencil are reused; virtual_volumes: sun moved 0.0000° ≤ 0.05° since frame 15 and the objects are static: its volumes and stencil are reused; shadow_mask: sun moved 0.0000° ≤ 0.05° since frame 15 and the objects are static: its volumes and stencil are reused]
sun=false volumes=VolumeStats { virtual_triangles: None, real_triangles: 0, real_parts: 0, compute: false, reused: false } receivers=0 traced=0 region=Some(Rect { x: 57, y: 37, width: 30, height: 28 }) ran=[depth_prepass, shadow_mask, virtual_shading, composite, readback] skipped=[volume_build: the sun is below the horizon; real_volumes: the sun is below the horizon; virtual_volumes: the sun is below the horizon; sun_term: the sun is below the horizon; object_transfer: turned off in the live view]
sun=false volumes=VolumeStats { virtual_triangles: None, real_triangles: 0, real_parts: 0, compute: false, reused: false } receivers=0 traced=0 region=None ran=[composite, readback] skipped=[volume_build: turned off in the live view; depth_prepass: turned off in the live view; real_volumes: turned off in the live view; virtual_volumes: turned off in the live view; virtual_shading: turned off in the live view; shadow_mask: turned off in the live view; sun_term: turned off in the live view; object_transfer: turned off in the live view]
sun=false volumes=VolumeStats { virtual_triangles: None, real_triangles: 0, real_parts: 0, compute: false, reused: false } receivers=0 traced=0 region=None ran=[composite, readback] skipped=[volume_build: turned off in the live view; depth_prepass: turned off in the live view; real_volumes: turned off in the live view; virtual_volumes: turned off in the live view; virtual_shading: turned off in the live view; shadow_mask: turned off in the live view; sun_term: turned off in the live view; object_transfer: turned off in the live view]
sun=false volumes=VolumeStats { virtual_triangles: None, real_triangles: 0, real_parts: 0, compute: false, reused: false } receivers=0 traced=0 region=Some(Rect { x: 57, y: 37, width: 30, height: 28 }) ran=[depth_prepass, shadow_mask, virtual_shading, composite, readback] skipped=[volume_build: the sun is below the horizon; real_volumes: the sun is below the horizon; virtual_volumes: the sun is below the horizon; sun_term: the sun is below the horizon; object_transfer: no sun: the traced sky transfer is reused (camera and objects are static)]
sun=true volumes=VolumeStats { virtual_triangles: Some(188), real_triangles: 40, real_parts: 1, compute: false, reused: false } receivers=0 traced=0 region=Some(Rect { x: 57, y: 37, width: 48, height: 37 }) ran=[volume_build, depth_prepass, real_volumes, virtual_volumes, shadow_mask, virtual_shading, sun_term, composite, readback] skipped=[object_transfer: the sun moved 0.000° ≤ 0.25° since it was traced and the camera and objects are static: the transfer is reused]
sun=true volumes=VolumeStats { virtual_triangles: Some(188), real_triangles: 40, real_parts: 1, compute: false, reused: false } receivers=0 traced=0 region=Some(Rect { x: 57, y: 37, width: 48, height: 37 }) ran=[volume_build, depth_prepass, real_volumes, virtual_volumes, shadow_mask, virtual_shading, sun_term, composite, readback] skipped=[object_transfer: the sun moved 0.000° ≤ 0.25° since it was traced and the camera and objects are static: the transfer is reused]
sun=false volumes=VolumeStats { virtual_triangles: None, real_triangles: 0, real_parts: 0, compute: false, reused: false } receivers=0 traced=0 region=Some(Rect { x: 57, y: 37, width: 30, height: 28 }) ran=[depth_prepass, shadow_mask, virtual_shading, composite, readback] skipped=[volume_build: the sun is below the horizon; real_volumes: the sun is below the horizon; virtual_volumes: the sun is below the horizon; sun_term: the sun is below the horizon; object_transfer: no sun: the traced sky transfer is reused (camera and objects are static)]
sun=true volumes=VolumeStats { virtual_triangles: Some(188), real_triangles: 40, real_parts: 1, compute: false, reused: false } receivers=3509 traced=176 region=None ran=[volume_build, object_transfer, depth_prepass, real_volumes, virtual_volumes, shadow_mask, virtual_shading, sun_term, composite, readback] skipped=[]
sun=true volumes=VolumeStats { virtual_triangles: None, real_triangles: 0, real_parts: 0, compute: false, reused: true } receivers=0 traced=0 region=None ran=[virtual_shading, sun_term, composite, readback] skipped=[volume_build: sun moved 0.0000° ≤ 0.05° since frame 0 and the objects are static: its volumes and stencil are reused; object_transfer: the sun moved 0.000° ≤ 0.25° since it was traced and the camera and objects are static: the transfer is reused; depth_prepass: sun moved 0.0000° ≤ 0.05° since frame 0 and the objects are static: its volumes and stencil are reused; real_volumes: sun moved 0.0000° ≤ 0.05° since frame 0 and the objects are static: its volumes and stencil are reused; virtual_volumes: sun moved 0.0000° ≤ 0.05° since frame 0 and the objects are static: its volumes and stencil are reused; shadow_mask: sun moved 0.0000° ≤ 0.05° since frame 0 and the objects are static: its volumes and stencil are reused]
sun=false volumes=VolumeStats { virtual_triangles: None, real_triangles: 0, real_parts: 0, compute: false, reused: false } receivers=0 traced=0 region=None ran=[composite, readback] skipped=[volume_build: the scene has no virtual objects; depth_prepass: the scene has no virtual objects; real_volumes: the scene has no virtual objects; virtual_volumes: the scene has no virtual objects; virtual_shading: the scene has no virtual objects; shadow_mask: the scene has no virtual objects; sun_term: the scene has no virtual objects; object_transfer: the scene has no virtual objects]
sun=false volumes=VolumeStats { virtual_triangles: None, real_triangles: 0, real_parts: 0, compute: false, reused: false } receivers=0 traced=0 region=None ran=[composite, readback] skipped=[volume_build: the scene has no virtual objects; depth_prepass: the scene has no virtual objects; real_volumes: the scene has no virtual objects; virtual_volumes: the scene has no virtual objects; virtual_shading: the scene has no virtual objects; shadow_mask: the scene has no virtual objects; sun_term: the scene has no virtual objects; object_transfer: the scene has no virtual objects]
sun=true volumes=VolumeStats { virtual_triangles: Some(188), real_triangles: 0, real_parts: 0, compute: false, reused: false } receivers=5577 traced=1297 region=Some(Rect { x: 90, y: 63, width: 73, height: 60 }) ran=[volume_build, object_transfer, depth_prepass, virtual_volumes, shadow_mask, virtual_shading, sun_term, composite, readback] skipped=[real_volumes: no part of the real proxy can shadow the virtual objects or the surfaces their shadows fall on]
sun=true volumes=VolumeStats { virtual_triangles: None, real_triangles: 0, real_parts: 0, compute: false, reused: true } receivers=0 traced=0 region=Some(Rect { x: 90, y: 63, width: 73, height: 60 }) ran=[virtual_shading, sun_term, composite, readback] skipped=[volume_build: sun moved 0.0000° ≤ 0.05° since frame 0 and the objects are static: its volumes and stencil are reused; object_transfer: the sun moved 0.000° ≤ 0.25° since it was traced and the camera and objects are static: the transfer is reused; depth_prepass: sun moved 0.0000° ≤ 0.05° since frame 0 and the objects are static: its volumes and stencil are reused; real_volumes: sun moved 0.0000° ≤ 0.05° since frame 0 and the objects are static: its volumes and stencil are reused; virtual_volumes: sun moved 0.0000° ≤ 0.05° since frame 0 and the objects are static: its volumes and stencil are reused; shadow_mask: sun moved 0.0000° ≤ 0.05° since frame 0 and the objects are static: its volumes and stencil are reused]
sun=false volumes=VolumeStats { virtual_triangles: None, real_triangles: 0, real_parts: 0, compute: false, reused: false } receivers=0 traced=0 region=Some(Rect { x: 90, y: 63, width: 62, height: 60 }) ran=[depth_prepass, shadow_mask, virtual_shading, composite, readback] skipped=[volume_build: no sun direction; real_volumes: no sun direction; virtual_volumes: no sun direction; sun_term: no sun direction; object_transfer: no sun: the traced sky transfer is reused (camera and objects are static)]
sun=false volumes=VolumeStats { virtual_triangles: None, real_triangles: 0, real_parts: 0, compute: false, reused: true } receivers=0 traced=0 region=Some(Rect { x: 90, y: 63, width: 62, height: 60 }) ran=[virtual_shading, composite, readback] skipped=[volume_build: Pd ≈ 0 (Pd/Pa = NaN < 0.05); real_volumes: Pd ≈ 0 (Pd/Pa = NaN < 0.05); virtual_volumes: Pd ≈ 0 (Pd/Pa = NaN < 0.05); sun_term: Pd ≈ 0 (Pd/Pa = NaN < 0.05); object_transfer: no sun: the traced sky transfer is reused (camera and objects are static); depth_prepass: no sun now or at frame 2 and the objects are static: its depth and stencil are reused; shadow_mask: no sun now or at frame 2 and the objects are static: its depth and stencil are reused]
sun=true volumes=VolumeStats { virtual_triangles: None, real_triangles: 40, real_parts: 1, compute: true, reused: false } receivers=3509 traced=0 region=Some(Rect { x: 57, y: 37, width: 48, height: 37 }) ran=[volume_build, depth_prepass, real_volumes, virtual_volumes, shadow_mask, virtual_shading, sun_term, composite, readback] skipped=[object_transfer: transfer_paths = 0: ambient from the probe grid times ambient occlusion]
sun=true volumes=VolumeStats { virtual_triangles: None, real_triangles: 0, real_parts: 0, compute: true, reused: true } receivers=0 traced=0 region=Some(Rect { x: 57, y: 37, width: 48, height: 37 }) ran=[virtual_shading, sun_term, composite, readback] skipped=[volume_build: sun moved 0.0000° ≤ 0.05° since frame 0 and the objects are static: its volumes and stencil are reused; object_transfer: transfer_paths = 0: ambient from the probe grid times ambient occlusion; depth_prepass: sun moved 0.0000° ≤ 0.05° since frame 0 and the objects are static: its volumes and stencil are reused; real_volumes: sun moved 0.0000° ≤ 0.05° since frame 0 and the objects are static: its volumes and stencil are reused; virtual_volumes: sun moved 0.0000° ≤ 0.05° since frame 0 and the objects are static: its volumes and stencil are reused; shadow_mask: sun moved 0.0000° ≤ 0.05° since frame 0 and the objects are static: its volumes and stencil are reused]
sun=true volumes=VolumeStats { virtual_triangles: Some(12), real_triangles: 0, real_parts: 0, compute: false, reused: false } receivers=0 traced=0 region=None ran=[volume_build, depth_prepass, virtual_volumes, shadow_mask, virtual_shading, sun_term, composite, readback] skipped=[object_transfer: no canvas pixel shows a virtual object; real_volumes: no part of the real proxy can shadow the virtual objects or the surfaces their shadows fall on]
sun=true volumes=VolumeStats { virtual_triangles: None, real_triangles: 0, real_parts: 0, compute: false, reused: true } receivers=0 traced=0 region=None ran=[virtual_shading, sun_term, composite, readback] skipped=[volume_build: sun moved 0.0000° ≤ 0.05° since frame 0 and the objects are static: its volumes and stencil are reused; object_transfer: no canvas pixel shows a virtual object; depth_prepass: sun moved 0.0000° ≤ 0.05° since frame 0 and the objects are static: its volumes and stencil are reused; real_volumes: sun moved 0.0000° ≤ 0.05° since frame 0 and the objects are static: its volumes and stencil are reused; virtual_volumes: sun moved 0.0000° ≤ 0.05° since frame 0 and the objects are static: its volumes and stencil are reused; shadow_mask: sun moved 0.0000° ≤ 0.05° since frame 0 and the objects are static: its volumes and stencil are reused]
"#;
