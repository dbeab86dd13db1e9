//! End to end on the bundled courtyard: estimate → composite the statue into the footage, and
//! compare with the generator's reference frames, path traced with the statue physically present
//! (its own material, its shadow on the ground, the wall's shadow on it, interreflection).
//!
//! The metric is `heliar::render::reference`'s: the relative RMSE `√(Σ(out − ref)²/Σref²)` over
//! the pixels that show the statue or its shadow on real surfaces (from ray casts through the lens
//! model), all three channels. It is printed for the product path (the statue's per-pixel ambient
//! transfer, with the baked irradiance volume relit per frame where the transfer has no entry, and
//! the differential darkening), for the other two darkening models, and for two ablations: the
//! irradiance volume alone (transfer off: probes times ambient occlusion, the previous product
//! path) and a uniform sky alone (the stand-in for scenes without an environment map).
//! `cargo test --test suite render::courtyard -- --nocapture` shows the table, and `HELIAR_DUMP=dir`
//! writes footage / composite / reference / signed difference crops.
//!
//! What limits the agreement (measured, see DEVELOPERS.md): silhouette and shadow-edge pixels,
//! resampled through the lens warp from a 4×-multisampled canvas where the reference integrates
//! each pixel (the error away from 1-px edges is 1.4 points lower); the footage's own Monte Carlo
//! and sensor noise, which the shadow inherits (≈ 3% elsewhere in the crop on sunny frames, 5%
//! overcast); the estimated `Pd`, `Pa` (≤ 1.5% off); the proxy's mean albedo where the real
//! surfaces are textured; and the reference's own noise (≈ 1.5% at 4096 spp).

use super::support::*;
use glam::Vec3;
use heliar::io::frames::Frame;
use heliar::io::image::LinearImage;
use heliar::irradiance::{ProbeGrid, sh};
use heliar::render::reference::{Classes, Crop, composite_error};
use heliar::render::{Compositor, CompositorConfig, Darkening, VideoFrame};
use heliar::scene::Scene;
use std::path::Path;

/// The target for the relative RMSE over the statue and its shadow (issue 4, §6),
/// enforced on the product path (measured worst frame: see DEVELOPERS.md).
const TARGET_RELATIVE_RMSE: f64 = 0.06;

fn scene() -> Scene {
    Scene::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/courtyard")).expect("bundled scene")
}

#[test]
fn composite_matches_the_generators_reference_frames() {
    let scene = scene();
    let ReferenceRun { refs, seq, lin, ray, statue, mut est } = ReferenceRun::new(&scene);
    let config = CompositorConfig::for_scene(&scene);
    let mut product = Compositor::for_scene(gpu(), &scene, ray.clone(), config.clone()).expect("compositor");
    let mut probes_only = Compositor::for_scene(gpu(), &scene, ray.clone(), CompositorConfig { transfer_paths: 0, ..config }).expect("compositor");
    // The product's ambient: the scene's bake (in memory, so the test never writes into the
    // bundled scene) relit per frame into the irradiance volume.
    let baked = heliar::envmap::bake::bake(&scene, ray.clone(), &|_: &str, _: u64, _: u64| {}).expect("bake");
    let mut volume = heliar::irradiance::sources::VolumeProbes::new(&scene, ray.clone(), &baked);
    let last = *refs.frames.iter().max().unwrap();
    let mut worst: f64 = 0.0;
    for i in 0..=last {
        let frame = Frame::load(&seq.files[i]).unwrap();
        let e = est.estimate(i, &seq.times[i], &frame, &lin).unwrap();
        let Some(k) = refs.frames.iter().position(|&f| f == i) else { continue };
        assert!(e.smoothed.is_some(), "frame {i}: smoothed lighting");
        let lighting = heliar::run::outdoor::lighting_of(&e);
        let reference = refs.image(k).unwrap();
        if let Some(t) = seq.truth.as_ref().map(|t| t[i]) {
            eprintln!("frame {i}: Pd {:?} (true {:?}), Pa {:?} (true {:?})", lighting.pd, t.pd, lighting.pa, t.pa);
        }
        let classes = Classes::new(&scene, &statue, &ray, refs.crop, lighting.sun_dir);
        let video = VideoFrame::from_frame(&frame, &lin);
        let volume_grid = volume.update(lighting.sun_dir, lighting.above_horizon, lighting.pd, lighting.pa).clone();
        let uniform = ProbeGrid::filled(Vec3::new(-6.0, 0.1, -6.0), Vec3::new(6.0, 3.0, 6.0), 1.0, sh::uniform_upper_sky(lighting.pa));
        let mut frame_errors = Vec::new();
        for (name, with_transfer, grid, models) in [
            ("transfer + irradiance volume", true, &volume_grid, &[Darkening::Differential, Darkening::Normal, Darkening::Constant][..]),
            ("irradiance volume alone", false, &volume_grid, &[Darkening::Differential][..]),
            ("uniform sky alone", false, &uniform, &[Darkening::Differential][..]),
        ] {
            let comp = if with_transfer { &mut product } else { &mut probes_only };
            comp.set_probes(grid);
            for &model in models {
                comp.set_darkening(model);
                let (out, report) = comp.render(&video, &lighting).unwrap();
                if report.transfer_traced > 0 || report.receivers_computed > 0 {
                    eprintln!(
                        "transfer: {} pixels in {:.0} ms; receivers: {} pixels in {:.0} ms",
                        report.transfer_traced, report.timings.transfer_ms, report.receivers_computed, report.timings.receivers_ms
                    );
                }
                let err = composite_error(&classes, &out.image, &reference);
                eprintln!(
                    "frame {i} ({:?}, sun term {}), {name}, {model:?}: relative RMSE object+shadow {:.2}% (object {:.2}%, shadow {:.2}%) over {} px; away from 1-px edges {:.2}% over {} px; elsewhere in the crop {:.2}%; object mean {:.4}/{:.4}",
                    e.status,
                    report.sun,
                    100.0 * err.object_and_shadow,
                    100.0 * err.object,
                    100.0 * err.shadow,
                    err.pixels,
                    100.0 * err.interior,
                    err.interior_pixels,
                    100.0 * err.elsewhere,
                    err.object_mean,
                    err.object_mean_reference,
                );
                if let Some(dump) = std::env::var_os("HELIAR_DUMP") {
                    dump_crops(Path::new(&dump), &format!("f{i}_{}_{model:?}", name.replace([' ', '+'], "_")), &video, &out.image, &reference, &refs.crop);
                }
                if model == Darkening::Differential {
                    frame_errors.push(err.object_and_shadow);
                }
            }
        }
        // The product path beats the irradiance volume alone on every frame, which beats a
        // uniform sky (no occlusion by the wall, no ground bounce).
        assert!(frame_errors[0] < frame_errors[1] && frame_errors[1] < frame_errors[2], "frame {i}: {frame_errors:?}");
        worst = worst.max(frame_errors[0]);
    }
    eprintln!("worst relative RMSE (transfer + irradiance volume, differential): {:.2}% (target {:.0}%)", 100.0 * worst, 100.0 * TARGET_RELATIVE_RMSE);
    assert!(worst <= TARGET_RELATIVE_RMSE, "relative RMSE {:.2}% > {:.1}%", 100.0 * worst, 100.0 * TARGET_RELATIVE_RMSE);
}

/// Debugging aid (`HELIAR_DUMP=dir`): the crop of the footage, the composite and the reference
/// side by side, 4× enlarged, sRGB.
fn dump_crops(dir: &Path, name: &str, video: &VideoFrame, out: &LinearImage, reference: &LinearImage, crop: &Crop) {
    std::fs::create_dir_all(dir).unwrap();
    let z = 4;
    let (w, h) = (crop.width, crop.height);
    let img = LinearImage::from_fn(4 * w * z + 12, h * z, |x, y| {
        let (k, xi) = (x / (w * z + 4), x % (w * z + 4));
        if xi >= w * z {
            return [1.0; 3];
        }
        let (cx, cy) = (xi / z, y / z);
        match k {
            0 => {
                let v = video.rgba[((crop.y + cy) * video.width + crop.x + cx) as usize];
                [v[0], v[1], v[2]]
            }
            1 => out.get(crop.x + cx, crop.y + cy),
            2 => reference.get(cx, cy),
            _ => {
                // Signed difference: red where the composite is brighter, blue where darker.
                let (a, b) = (out.get(crop.x + cx, crop.y + cy), reference.get(cx, cy));
                let d = (a[0] + a[1] + a[2] - b[0] - b[1] - b[2]) / (b[0] + b[1] + b[2]).max(1e-3);
                [(d * 2.0).max(0.0), 0.0, (-d * 2.0).max(0.0)]
            }
        }
    });
    img.write_png_srgb(&dir.join(format!("{name}.png")), 1.0).unwrap();
}
