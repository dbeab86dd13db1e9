//! `gen-courtyard --dusk-parts DIR`: the dusk scene's reference frames split by light, for
//! telling which light a renderer gets wrong on the statue (issue 16, the missing light at dusk).
//!
//! The generator's radiance is linear in `Pa` (per channel), `Pd` and the lamp's scale, and its
//! tracer returns the three bases separately (`sky_render::trace_split`). This renders the
//! same crop, camera, world, statue and lights as `reference/` (`dusk::write_references`) and
//! writes, for every reference frame `i`, `frame_{i:03}_sky.exr` (the sky basis times the
//! frame's `Pa`), `_sun.exr` (times `Pd`) and `_lamp.exr` (times `k`): they add up to the
//! reference frame, up to Monte Carlo noise. `_lamp_direct.exr` is the part of `_lamp.exr` that
//! the lamp gives the first surface seen directly (the disc's penumbrae included); the rest is
//! the lamp's light after one or more bounces. `--spp` sets the samples per pixel (the references
//! have 1024). Nothing in the scene folder is written.
//!
//! `gen-courtyard --dusk-frame-parts DIR` ([`run_frames`]) does the same for the frames
//! themselves (`frames/hdr`, the whole view, the world without the statue) with each frame's own
//! seed and samples: the random numbers are the frame's, so `sky + sun + lamp` is the frame
//! before its sensor noise, pixel for pixel. It is the per-sample truth of the estimator's rows
//! (issue 16, the dusk lamp's low `k`: `tests/suite/estimate_dusk_rows.rs`).

use super::dusk::{FRAME_SEED, FRAME_SPP, FRAMES, LAMP_CENTRE, LAMP_ON_FRAME, REFERENCE_FRAMES, START, INTERVAL_S, TERRAIN_ALBEDO, lamp, moment_at};
use super::sky_render::{Lighting, render_region_split};
use super::statue::WithStatue;
use super::{Args, Courtyard, STATUE_ROTATION_Y_DEG, STATUE_TRANSLATION};
use anyhow::{Context, Result};
use glam::{DVec3, Vec3};
use heliar::geometry::raycast::RayScene;
use heliar::io::image::{ExrPrecision, LinearImage};
use heliar::sun::{GeoFrame, Observer};
use std::path::Path;

/// Writes the per-light crops of the reference frames into `out` (module docs).
pub fn run(args: &Args, out: &Path) -> Result<()> {
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let (proxy, extra) = super::build_geometry();
    let placement = glam::Mat4::from_scale_rotation_translation(Vec3::ONE, glam::Quat::from_rotation_y((STATUE_ROTATION_Y_DEG as f32).to_radians()), DVec3::from(STATUE_TRANSLATION).as_vec3());
    // Placed as the references place it: through the glTF file, as the scene loads it.
    let statue_path = out.join("statue.glb");
    heliar::scene::gltf::save_glb(&super::statue_local(), &statue_path)?;
    let (statue, _) = heliar::scene::gltf::load_gltf(&statue_path, placement, &[])?;
    let mut world = proxy.clone();
    world.append(&extra);
    let real_tris = world.triangles.len();
    world.append(&statue);
    let scene = RayScene::new(world);
    let real = Courtyard { ground_tris: 2 };
    let surfaces = WithStatue { real: &real, real_tris, statue: &statue };
    let cam = super::camera_sized(args.width, args.height);
    let (lo, hi) = statue.bounds().context("the statue has no triangles")?;
    let toward_lamp = (Vec3::from(LAMP_CENTRE) - (lo + hi) * 0.5).normalize();
    let region = super::statue::reference_crop(&cam, &statue, &[toward_lamp])?;
    let observer = Observer::new(super::LAT, super::LON, super::ELEV);
    let geo = GeoFrame::default();
    let t0 = chrono::DateTime::parse_from_rfc3339(START)?;
    for &i in &REFERENCE_FRAMES {
        let time = t0 + chrono::Duration::seconds((i as f64 * INTERVAL_S) as i64);
        let f = moment_at(time, &observer, &geo, if i >= LAMP_ON_FRAME { 1.0 } else { 0.0 })?;
        let light = Lighting { sun: f.sun, sky: &f.sky, terrain_albedo: Vec3::splat(TERRAIN_ALBEDO), lamp: Some(lamp()) };
        let px = render_region_split(&scene, &surfaces, &cam, &light, args.spp, 9100 + i as u64, region);
        let image = |part: &dyn Fn(&[Vec3; 4]) -> Vec3| LinearImage { width: region.2, height: region.3, data: px.iter().map(|p| part(p).to_array()).collect() };
        let parts = [("sky", image(&|p| p[0] * f.pa)), ("sun", image(&|p| p[1] * f.pd)), ("lamp", image(&|p| p[2] * f.lamp_k)), ("lamp_direct", image(&|p| p[3] * f.lamp_k))];
        for (name, img) in parts {
            let path = out.join(format!("frame_{i:03}_{name}.exr"));
            img.write_exr(&path, ExrPrecision::Float).with_context(|| format!("writing {}", path.display()))?;
        }
        eprintln!("dusk parts: frame {i} (crop {region:?}, {} spp)", args.spp);
    }
    Ok(())
}

/// Writes `frame_{i:03}_{sky,sun,lamp}.exr` for every dusk frame into `out` (module docs): the
/// frame's parts at its own lighting, full view, before the sensor noise.
pub fn run_frames(args: &Args, out: &Path) -> Result<()> {
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let (proxy, extra) = super::build_geometry();
    let mut world = proxy;
    world.append(&extra);
    let scene = RayScene::new(world);
    let real = Courtyard { ground_tris: 2 };
    let cam = super::camera_sized(args.width, args.height);
    let (w, h) = (args.width, args.height);
    let observer = Observer::new(super::LAT, super::LON, super::ELEV);
    let geo = GeoFrame::default();
    let t0 = chrono::DateTime::parse_from_rfc3339(START)?;
    for i in 0..FRAMES {
        let time = t0 + chrono::Duration::seconds((i as f64 * INTERVAL_S) as i64);
        let f = moment_at(time, &observer, &geo, if i >= LAMP_ON_FRAME { 1.0 } else { 0.0 })?;
        let light = Lighting { sun: f.sun, sky: &f.sky, terrain_albedo: Vec3::splat(TERRAIN_ALBEDO), lamp: Some(lamp()) };
        let px = render_region_split(&scene, &real, &cam, &light, FRAME_SPP, FRAME_SEED + i as u64, (0, 0, w, h));
        let image = |part: &dyn Fn(&[Vec3; 4]) -> Vec3| LinearImage { width: w, height: h, data: px.iter().map(|p| part(p).to_array()).collect() };
        let parts = [("sky", image(&|p| p[0] * f.pa)), ("sun", image(&|p| p[1] * f.pd)), ("lamp", image(&|p| p[2] * f.lamp_k))];
        for (name, img) in parts {
            let path = out.join(format!("frame_{i:03}_{name}.exr"));
            img.write_exr(&path, ExrPrecision::Float).with_context(|| format!("writing {}", path.display()))?;
        }
        eprintln!("dusk frame parts: frame {i} ({w}×{h}, {FRAME_SPP} spp)");
    }
    Ok(())
}
