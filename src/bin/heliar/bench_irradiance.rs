//! `heliar bench irradiance`: irradiance-volume error against brute force, next to run time, for
//! probe spacing, transfer directions, environment-map resolution and the bake's ray count.

use crate::common::{frame_bar, load_scene};
use anyhow::{Context, Result};
use clap::{Args, ValueEnum};
use glam::Vec3;
use heliar::envmap::bake::{Baked, bake_with_map};
use heliar::envmap::relight::{RelitMap, Relighter};
use heliar::lighting::Lighting;
use heliar::geometry::raycast::RayScene;
use heliar::geometry::sampling::sphere_fibonacci;
use heliar::io::image::LinearImage;
use heliar::irradiance::probe_transfer::{LinearBasis, ProbeTransfer, brute_force_irradiance};
use heliar::report::{Series, Table, line_plot_svg, median};
use heliar::scene::Scene;
use rand::{Rng, SeedableRng, rngs::SmallRng};
use std::path::PathBuf;
use std::sync::Arc;

#[derive(Clone, Copy, ValueEnum)]
pub enum Knob {
    /// Probe spacing, metres: 2, 1, 0.5, 0.25.
    ProbeSpacing,
    /// Directions per probe of the transfer: 64 … 4096.
    Directions,
    /// Environment-map resolution: 64×32 … 512×256 (resampled from the scene's map).
    EnvResolution,
    /// Paths per texel of the bake's weighted-ambient map: 16 … 1024.
    BakePaths,
}

#[derive(Args)]
pub struct IrradianceSweep {
    /// Scene folder.
    #[arg(default_value = "scenes/courtyard")]
    scene: PathBuf,
    /// Which knob to sweep.
    #[arg(long, value_enum, default_value = "probe-spacing")]
    knob: Knob,
    /// Test points (random, at least 0.5 m from every surface, random normals).
    #[arg(long, default_value_t = 120)]
    points: usize,
    /// Brute-force rays per point.
    #[arg(long, default_value_t = 4096)]
    rays: u32,
    /// CSV output.
    #[arg(long, default_value = "out/bench_irradiance.csv")]
    csv: PathBuf,
    /// SVG plot of error against time.
    #[arg(long)]
    plot: Option<PathBuf>,
    /// Write the outputs even over a file of the scene.
    #[arg(long)]
    force: bool,
}

fn v3(a: [f64; 3]) -> Vec3 {
    Vec3::new(a[0] as f32, a[1] as f32, a[2] as f32)
}

fn ms(t: std::time::Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

struct Setup {
    scene: Scene,
    /// The scene's `[irradiance]` grid (required by `run`).
    grid: heliar::scene::GridSpec,
    ray: Arc<RayScene>,
    lighting: Lighting,
    points: Vec<(Vec3, Vec3)>,
}

fn lighting_of(b: &Baked) -> Lighting {
    Lighting { sun_dir: Vec3::from(b.info.capture_sun_dir), above_horizon: true, pd: v3(b.info.capture_pd), pa: v3(b.info.capture_pa), sky: heliar::lighting::FrameSky::Declared, lamps: heliar::lighting::LampScales::NONE }
}

/// Brute-force irradiance of every test point under a relit map.
fn reference(s: &Setup, centre: Vec3, relit: &RelitMap, rays: u32) -> Vec<Vec3> {
    use rayon::prelude::*;
    s.points.par_iter().enumerate().map(|(k, (p, n))| brute_force_irradiance(&s.ray, centre, relit, s.lighting.pa, *p, *n, rays, k as u64)).collect()
}

struct Measure {
    err_mean: f64,
    err_p95: f64,
    bake_ms: f64,
    transfer_ms: f64,
    linear_ms: f64,
    full_ms: f64,
    relight_ms: f64,
    probes: usize,
}

fn measure(s: &Setup, baked: &Baked, spacing: f32, directions: usize, reference: &[Vec3], bake_ms: f64) -> Measure {
    let g = &s.grid;
    let t = std::time::Instant::now();
    let transfer = ProbeTransfer::build(v3(g.min), v3(g.max), spacing, baked, &s.ray, directions);
    let transfer_ms = ms(t);
    let mut r = Relighter::new(baked, s.ray.clone(), s.scene.bake.relight.clone());
    r.update_sun(s.lighting.sun_dir);
    let mut relit = RelitMap::new(baked.width, baked.height);
    let mut relight_t = Vec::new();
    for _ in 0..20 {
        let t = std::time::Instant::now();
        r.relight_into(&s.lighting, &mut relit);
        relight_t.push(ms(t));
    }
    let basis = LinearBasis { ambient: transfer.ambient_response(&r), direct: transfer.direct_response(&r) };
    let mut grid = transfer.grid();
    let mut lin_t = Vec::new();
    for _ in 0..50 {
        let t = std::time::Instant::now();
        transfer.linear_into(&basis, s.lighting.pd, s.lighting.pa, &mut grid);
        lin_t.push(ms(t));
    }
    let mut full_grid = transfer.grid();
    let mut full_t = Vec::new();
    for _ in 0..5 {
        let t = std::time::Instant::now();
        transfer.full_into(&relit, s.lighting.pa, &mut full_grid);
        full_t.push(ms(t));
    }
    let errs: Vec<f64> = s
        .points
        .iter()
        .zip(reference)
        .map(|((p, n), want)| {
            let got = grid.irradiance(*p, *n).unwrap_or(Vec3::ZERO);
            let scale = want.max_element().max(0.05 * s.lighting.pa.max_element());
            ((got - *want).abs().max_element() / scale) as f64
        })
        .collect();
    Measure {
        err_mean: errs.iter().sum::<f64>() / errs.len() as f64,
        err_p95: heliar::report::percentile(&errs, 0.95),
        bake_ms,
        transfer_ms,
        linear_ms: median(&lin_t),
        full_ms: median(&full_t),
        relight_ms: median(&relight_t),
        probes: transfer.probes(),
    }
}

pub fn run(a: IrradianceSweep) -> Result<()> {
    let (scene, ray) = load_scene(&a.scene)?;
    let outputs: Vec<&std::path::Path> = std::iter::once(&a.csv).chain(&a.plot).map(PathBuf::as_path).collect();
    crate::common::guard_files(Some(&scene.root), &[], &outputs, a.force)?;
    let g = scene.manifest.irradiance.clone().context("the scene has no [irradiance] grid")?;
    let env_file = scene.manifest.envmap.as_ref().and_then(|e| e.file.clone()).context("the scene has no environment map file")?;
    let env = LinearImage::read_exr(&scene.root.join(&env_file))?;
    let quiet = |_: &str, _: u64, _: u64| {};
    eprintln!("baking ({}×{}) and a reference with 1024 paths per texel…", env.width, env.height);
    let t = std::time::Instant::now();
    let default_bake = bake_with_map(&scene, ray.clone(), Some(env.clone()), &quiet)?;
    let default_bake_ms = ms(t);
    // Every sweep bake uses the lighting at capture found here (at low map resolutions the
    // estimator may not separate it), so the sweep measures the maps, not the estimator.
    let (cpd, cpa) = (default_bake.info.capture_pd, default_bake.info.capture_pa);
    let mut scene = scene;
    if let Some(e) = scene.manifest.envmap.as_mut() {
        e.capture_pd = Some(cpd);
        e.capture_pa = Some(cpa);
    }
    // Relit for a moment other than the capture (a thin cloud: 30% of the sun, 20% more sky):
    // at the capture's own lighting the weighted-ambient map cancels out of the relit map.
    let capture = lighting_of(&default_bake);
    let lighting = Lighting { pd: capture.pd * 0.3, pa: capture.pa * 1.2, ..capture };

    let points = test_points(&ray, &g, a.points);
    let setup = Setup { scene: scene.clone(), grid: g.clone(), ray: ray.clone(), lighting, points };
    let mut ref_scene = scene.clone();
    ref_scene.bake.ambient.paths = 1024;
    let reference_bake = bake_with_map(&ref_scene, ray.clone(), Some(env.clone()), &quiet)?;
    let relit_of = |b: &Baked| {
        let mut r = Relighter::new(b, ray.clone(), scene.bake.relight.clone());
        r.update_sun(lighting.sun_dir);
        r.relight(&lighting)
    };
    let spacing = g.spacing_m as f32;
    let dirs_default = scene.bake.probe_directions;

    let (name, rows): (&str, Vec<(String, Measure)>) = match a.knob {
        Knob::ProbeSpacing | Knob::Directions => {
            let refv = reference(&setup, default_bake.centre, &relit_of(&default_bake), a.rays);
            let values: Vec<(String, f32, usize)> = match a.knob {
                Knob::ProbeSpacing => [2.0f32, 1.0, 0.5, 0.25].iter().map(|&s| (format!("{s}"), s, dirs_default)).collect(),
                _ => [64usize, 256, 1024, 4096].iter().map(|&d| (d.to_string(), spacing, d)).collect(),
            };
            let pb = frame_bar(values.len(), "sweep");
            let rows = values
                .into_iter()
                .map(|(label, sp, d)| {
                    let m = measure(&setup, &default_bake, sp, d, &refv, default_bake_ms);
                    pb.inc(1);
                    (label, m)
                })
                .collect();
            pb.finish_and_clear();
            (if matches!(a.knob, Knob::ProbeSpacing) { "probe_spacing_m" } else { "directions" }, rows)
        }
        Knob::EnvResolution | Knob::BakePaths => {
            // The reference uses the map at its own resolution with the 1024-path bake.
            let refv = reference(&setup, reference_bake.centre, &relit_of(&reference_bake), a.rays);
            let values: Vec<(String, u32, u32)> = match a.knob {
                Knob::EnvResolution => [(64u32, 32u32), (128, 64), (256, 128), (512, 256)]
                    .iter()
                    .map(|&(w, h)| (format!("{w}x{h}"), w, h))
                    .collect(),
                _ => [16u32, 64, 256, 1024].iter().map(|&p| (p.to_string(), p, 0)).collect(),
            };
            let pb = frame_bar(values.len(), "sweep");
            let mut rows = Vec::new();
            for (label, x, y) in values {
                let mut sc = scene.clone();
                let map = if matches!(a.knob, Knob::EnvResolution) {
                    env.resized(x, y)
                } else {
                    sc.bake.ambient.paths = x;
                    env.clone()
                };
                let t = std::time::Instant::now();
                let b = bake_with_map(&sc, ray.clone(), Some(map), &quiet)?;
                let bake_ms = ms(t);
                rows.push((label, measure(&setup, &b, spacing, dirs_default, &refv, bake_ms)));
                pb.inc(1);
            }
            pb.finish_and_clear();
            (if matches!(a.knob, Knob::EnvResolution) { "env_resolution" } else { "bake_paths" }, rows)
        }
    };

    report(&a, name, &rows, setup.points.len())
}

/// `n` random test points at least 0.5 m from every surface and outside closed geometry, with
/// random normals.
fn test_points(ray: &RayScene, g: &heliar::scene::GridSpec, n: usize) -> Vec<(Vec3, Vec3)> {
    let dirs = sphere_fibonacci(64);
    let mut rng = SmallRng::seed_from_u64(7);
    let (lo, hi) = (v3(g.min), v3(g.max));
    let mut points = Vec::new();
    while points.len() < n {
        let p = lo + (hi - lo) * Vec3::new(rng.random(), rng.random(), rng.random());
        if dirs.iter().any(|&d| ray.intersect(p, d, 0.5).is_some()) || ray.back_face_fraction(p, &dirs).is_some_and(|f| f >= 0.5) {
            continue;
        }
        let n = Vec3::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0)).normalize_or(Vec3::Y);
        points.push((p, n));
    }
    points
}

/// Prints the table, writes the CSV and the plot.
fn report(a: &IrradianceSweep, name: &str, rows: &[(String, Measure)], points: usize) -> Result<()> {
    let mut table = Table::new(&[name, "probes", "err_mean_pct", "err_p95_pct", "bake_ms", "transfer_ms", "relight_ms", "update_linear_ms", "update_full_ms"]);
    let mut pts = Vec::new();
    for (label, m) in rows {
        table.push(vec![
            label.clone(),
            m.probes.to_string(),
            format!("{:.3}", 100.0 * m.err_mean),
            format!("{:.3}", 100.0 * m.err_p95),
            format!("{:.0}", m.bake_ms),
            format!("{:.0}", m.transfer_ms),
            format!("{:.3}", m.relight_ms),
            format!("{:.4}", m.linear_ms),
            format!("{:.3}", m.full_ms),
        ]);
        let cost = match a.knob {
            Knob::ProbeSpacing | Knob::Directions => m.transfer_ms,
            _ => m.bake_ms,
        };
        pts.push((cost, 100.0 * m.err_mean));
    }
    println!(
        "irradiance-volume sweep on {} ({} points ≥ 0.5 m from surfaces, {} brute-force rays each; lighting 0.3·Pd, 1.2·Pa of the capture; error = max over RGB of |E − E_ref| / max(E_ref, 5% of Pa))",
        a.scene.display(),
        points,
        a.rays
    );
    print!("{table}");
    crate::common::write_output(&a.csv, |tmp| Ok(table.write_csv(tmp)?))?;
    println!("wrote {}", a.csv.display());
    if let Some(path) = &a.plot {
        let x = match a.knob {
            Knob::ProbeSpacing | Knob::Directions => "transfer build time (ms)",
            _ => "bake time (ms)",
        };
        crate::common::write_output(path, |tmp| Ok(line_plot_svg(tmp, &format!("irradiance error against run time ({name})"), x, "mean relative error (%)", &[Series { name: "mean error".into(), points: pts, reference: false }], true, true)?))?;
        println!("wrote {}", path.display());
    }
    Ok(())
}
