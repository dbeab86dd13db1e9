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
use heliar::render::reference::OBJECT;
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
    if !scene.lights.is_empty() {
        let lamps = heliar::lamps::Lamp::load_all(&scene.root.join(heliar::scene::MANIFEST_FILE), &scene.lights)?;
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
        for (name, lighting, file) in runs {
            comp.set_probes(probes.relight(&lighting));
            let (out, _) = comp.render(&f.video, &lighting)?;
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
    }
    Ok(())
}
