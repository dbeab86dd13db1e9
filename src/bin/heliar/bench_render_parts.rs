//! `heliar bench render --parts DIR`: the virtual objects' radiance split by light (sky, sun,
//! lamps) against the generator's per-light crops of the same reference frames
//! (`gen-courtyard --dusk-parts DIR`), under the truth's `Pd` and `Pa` (and `--lamp-k` for the
//! lamps, 1 for the dusk scene's truth), so that a light the compositor renders too dark or too
//! bright shows by itself (issue 16, the missing light at dusk).
//!
//! Each reference frame is rendered four times by one compositor: all lights, then the sky alone
//! (`Pd` = 0, lamps dark), the sun alone (`Pa` = 0, lamps dark) and the lamps alone (`Pd` = `Pa` =
//! 0), and the estimate's lighting. The frame's sun direction and sky shape stay, so the
//! transfer traced for the frame serves all; the probe grid (the shading's fallback at
//! silhouettes) is relit for each. The table gives the mean radiance per channel over the interior object pixels
//! (not at a silhouette) of the reference classes, the compositor's and the generator's, and their ratio.

use crate::bench_render::RefFrame;
use anyhow::{Context, Result};
use heliar::io::image::LinearImage;
use heliar::lighting::{LampScales, Lighting};
use heliar::estimate::lamp_bounce::bounce_irradiance;
use heliar::geometry::ambient::TransportQuality;
use heliar::geometry::raycast::{Hit, RayScene};
use heliar::render::reference::{OBJECT, SHADOW};
use rayon::prelude::*;
use std::f32::consts::FRAC_1_PI;
use heliar::render::{Compositor, CompositorConfig};
use heliar::gpu::{Gpu, GpuOptions};
use glam::Vec3;
use std::path::Path;
use std::sync::Arc;

/// Mean radiance per channel of `img` over the interior object pixels of `f`'s classes; `crop_image`
/// says whether `img` is the crop (the generator's) or the whole frame (the compositor's).
fn object_mean(f: &RefFrame, img: &LinearImage, crop_image: bool) -> Vec3 {
    let c = f.classes.crop;
    let (mut sum, mut n) = (Vec3::ZERO, 0u32);
    for (i, class) in f.classes.class.iter().enumerate() {
        // Interior pixels only: at the silhouettes the composite blends in the footage, which
        // carries every light whatever the part.
        if *class != OBJECT || f.classes.edge[i] {
            continue;
        }
        let (x, y) = (i as u32 % c.width, i as u32 / c.width);
        let p = if crop_image { img.get(x, y) } else { img.get(c.x + x, c.y + y) };
        sum += Vec3::from(p);
        n += 1;
    }
    sum / n.max(1) as f32
}

/// Runs the split for every frame of `frames` (module docs) and prints the table.
pub fn run(scene: &heliar::scene::Scene, ray: &Arc<heliar::geometry::raycast::RayScene>, frames: &[RefFrame], truth: Option<&[heliar::scene::Truth]>, parts: &Path, options: heliar::render::lamps::LampOptions) -> Result<()> {
    let gpu = Arc::new(Gpu::new(GpuOptions { samples: 4 })?);
    let mut comp = Compositor::for_scene(gpu, scene, ray.clone(), CompositorConfig::for_scene(scene)).with_context(|| format!("setting up the compositor for {}", scene.root.display()))?;
    let lamps = heliar::lamps::Lamp::load_all(&scene.root.join(heliar::scene::MANIFEST_FILE), &scene.lights)?;
    if !lamps.is_empty() {
        comp.set_lamps(&lamps, options)?;
    }
    let truth = truth.context("the references' sequence has no truth file")?;
    // The probe grid (the shading's fallback where no transfer entry matches, at silhouettes)
    // relit for each part's lighting, so that no part borrows another's light.
    let mut probes = heliar::run::outdoor::probe_source(scene, ray.clone(), heliar::run::outdoor::Ambient::Auto, |s, r| crate::bake::bake_with_progress(s, r, false))?;
    println!("part | frame | compositor (R G B) | generator (R G B) | ratio (R G B)");
    for f in frames {
        let t = truth.get(f.index).context("the truth file is shorter than the sequence")?;
        let v = |a: [f64; 3]| Vec3::new(a[0] as f32, a[1] as f32, a[2] as f32);
        let all = Lighting { pd: v(t.pd), pa: v(t.pa), ..f.lighting };
        let dark = LampScales::from_slice(&vec![[0.0; 3]; all.lamps.as_slice().len()]);
        println!("frame {}: estimated Pd {:.4} Pa {:.4} sky {:?} lamps {:?}; truth Pd {:.4} Pa {:.4}", f.index, f.lighting.pd, f.lighting.pa, f.lighting.sky, f.lighting.lamps.as_slice(), all.pd, all.pa);
        let runs = [
            ("estimated", f.lighting, None),
            ("all", all, None),
            ("sky", Lighting { pd: Vec3::ZERO, lamps: dark, ..all }, Some("sky")),
            ("sun", Lighting { pa: Vec3::ZERO, lamps: dark, ..all }, Some("sun")),
            ("lamp", Lighting { pd: Vec3::ZERO, pa: Vec3::ZERO, ..all }, Some("lamp")),
        ];
        let mut all_image = None;
        for (name, lighting, file) in runs {
            comp.set_probes(probes.relight(&lighting));
            let (out, _) = comp.render(&f.video, &lighting)?;
            if name == "all" {
                all_image = Some(out.image.clone());
            }
            let ours = object_mean(f, &out.image, false);
            let theirs = match file {
                Some(part) => {
                    let path = parts.join(format!("frame_{:03}_{part}.exr", f.index));
                    let img = LinearImage::read_exr(&path).with_context(|| format!("reading {}", path.display()))?;
                    object_mean(f, &img, true)
                }
                None => object_mean(f, &f.reference, true),
            };
            let r = ours / theirs.max(Vec3::splat(1e-12));
            println!("{name} | {} | {:.5} {:.5} {:.5} | {:.5} {:.5} {:.5} | {:.3} {:.3} {:.3}", f.index, ours.x, ours.y, ours.z, theirs.x, theirs.y, theirs.z, r.x, r.y, r.z);
        }
        if let (Some(all_image), false) = (all_image, lamps.is_empty()) {
            shadow_split(scene, ray, f, &all_image, parts, &lamps, all.lamps)?;
        }
    }
    Ok(())
}

/// Interior pixels of the objects' shadow class in `f`'s crop: `(crop index, proxy hit)`.
fn shadow_pixels(scene: &heliar::scene::Scene, ray: &RayScene, f: &RefFrame) -> Vec<(usize, Hit)> {
    let c = f.classes.crop;
    f.classes
        .class
        .iter()
        .enumerate()
        .filter(|(i, class)| **class == SHADOW && !f.classes.edge[*i])
        .filter_map(|(i, _)| {
            let (x, y) = (c.x + i as u32 % c.width, c.y + i as u32 / c.width);
            let (o, d) = scene.camera.pixel_ray(x, y)?;
            Some((i, ray.intersect(o.as_vec3(), d.as_vec3(), f32::MAX)?))
        })
        .collect()
}

/// The objects' shadow on the real ground split by light (issue 16, the lamp shadow at night):
/// mean radiance over its interior pixels of the composite under the truth's lighting, the
/// reference, the generator's sky, lamp and lamp-direct parts (`lamp − lamp_direct` is the
/// lamp's light after a bounce), and the model's `ρ/π·Σk_i·B_i` with and without the objects
/// (`estimate::lamp_bounce::bounce_irradiance`, against the proxy and the objects or the proxy
/// alone): what the composite's `L₁/L₀` leaves out where the objects block the lamp.
fn shadow_split(scene: &heliar::scene::Scene, ray: &Arc<RayScene>, f: &RefFrame, composite: &LinearImage, parts: &Path, lamps: &[heliar::lamps::Lamp], k: LampScales) -> Result<()> {
    let pixels = shadow_pixels(scene, ray, f);
    if pixels.is_empty() {
        return Ok(());
    }
    let c = f.classes.crop;
    let mean_of = |img: &LinearImage, crop_image: bool| {
        let sum: Vec3 = pixels
            .iter()
            .map(|(i, _)| {
                let (x, y) = (*i as u32 % c.width, *i as u32 / c.width);
                Vec3::from(if crop_image { img.get(x, y) } else { img.get(c.x + x, c.y + y) })
            })
            .sum();
        sum / pixels.len() as f32
    };
    let part = |name: &str| -> Result<Option<Vec3>> {
        let path = parts.join(format!("frame_{:03}_{name}.exr", f.index));
        if !path.exists() {
            return Ok(None);
        }
        let img = LinearImage::read_exr(&path).with_context(|| format!("reading {}", path.display()))?;
        Ok(Some(mean_of(&img, true)))
    };
    let mut objects = heliar::geometry::Mesh::default();
    for o in &scene.virtual_objects {
        objects.append(&o.mesh);
    }
    let meshes = [&objects];
    let with = heliar::render::object_transfer::TransferScene::new(ray.mesh(), &meshes);
    let quality = TransportQuality { paths: 1024, max_bounces: 4 };
    let model = |scene: &RayScene| -> Vec3 {
        let sum: Vec3 = pixels
            .par_iter()
            .map(|(i, hit)| {
                let rho = ray.albedo(hit);
                let mut b = Vec3::ZERO;
                for (j, lamp) in lamps.iter().enumerate() {
                    let e = bounce_irradiance(lamp, scene, hit.point, hit.normal, quality, 77 ^ *i as u64);
                    b += Vec3::from(k.get(j)) * Vec3::new(e[0] as f32, e[1] as f32, e[2] as f32);
                }
                rho * FRAC_1_PI * b
            })
            .sum();
        sum / pixels.len() as f32
    };
    let fmt = |v: Option<Vec3>| v.map_or("—".to_owned(), |v| format!("{:.6} {:.6} {:.6}", v.x, v.y, v.z));
    let lamp = part("lamp")?;
    let direct = part("lamp_direct")?;
    println!("shadow | frame {} | {} interior px", f.index, pixels.len());
    println!("shadow | composite (truth) | {}", fmt(Some(mean_of(composite, false))));
    println!("shadow | reference | {}", fmt(Some(mean_of(&f.reference, true))));
    println!("shadow | generator sky | {}", fmt(part("sky")?));
    println!("shadow | generator lamp | {}", fmt(lamp));
    println!("shadow | generator lamp direct | {}", fmt(direct));
    println!("shadow | generator lamp bounce | {}", fmt(lamp.zip(direct).map(|(a, b)| a - b)));
    println!("shadow | model lamp bounce with the objects | {}", fmt(Some(model(&with.world))));
    println!("shadow | model lamp bounce, proxy alone | {}", fmt(Some(model(ray))));
    Ok(())
}
