//! `heliar bench`: error-against-run-time sweeps of the quality knobs.

use crate::common::{frame_bar, load_scene};
use heliar::run::source::pick_sequence;
use anyhow::{Context, Result, bail};
use clap::{Args, Subcommand, ValueEnum};
use heliar::estimate::{EstimatorConfig, Estimator};
use heliar::io::frames::Frame;
use heliar::report::{Series, Table, line_plot_svg, lighting_error, median, percentile};
use std::path::PathBuf;

#[derive(Args)]
pub struct BenchArgs {
    #[command(subcommand)]
    what: BenchWhat,
}

#[derive(Subcommand)]
enum BenchWhat {
    /// The estimator on a sequence with known truth.
    Estimate(EstimateSweep),
    /// The irradiance volume against brute-force irradiance.
    Irradiance(crate::bench_irradiance::IrradianceSweep),
    /// VEM lights: irradiance error against time, temporal coherence and speed.
    Vem(crate::bench_vem::VemSweep),
    /// The compositor against the scene's reference frames: transfer paths and stride, MSAA,
    /// supersampling.
    Render(crate::bench_render::RenderSweep),
    /// Lamps (issue 16 §5): light-field grid, texels and storage format against the truth;
    /// shadow-map size against the references; frame time against frame size and lamp count.
    Lamps(crate::bench_lamps::LampsSweep),
    /// Visibility cuts (issue 15 §4): threshold, S and field sampling against a traced reference.
    Cuts(crate::bench_cuts::CutsSweep),
}

#[derive(Clone, Copy, ValueEnum)]
enum Knob {
    /// Pixels drawn per frame: 50 … 5000.
    Samples,
    /// Paths per pool entry for the weighted-ambient factor c.
    AmbientPaths,
    /// Paths per pool entry for the sun-bounce term (0 = term off).
    BouncePaths,
    /// Pool size.
    PoolSize,
    /// The sky in the model (`[estimator.sky]`): uniform without terrain (Jensen), uniform with
    /// terrain, Hošek–Wilkie at turbidity 2, 3, 4 (terrain 0.2), Hošek–Wilkie without terrain,
    /// and Hošek–Wilkie with the turbidity chosen per frame by residual (`turbidity = "fit"`).
    Sky,
    /// The terrain's albedo (Hošek–Wilkie, the scene's turbidity): the default 0.2, the winter
    /// scenes' true albedos 0.08 and 0.8, and `"map"` (measured on the environment map).
    Terrain,
    /// Quadrature directions of the sky and terrain terms: 32 … 1024.
    SkyDirections,
    /// Time per frame when the sun moves past `sun_rebuild_deg` every frame, with the bounce and
    /// sky re-trace whole and sliced (`--frames`, `--sun-step-s`), and the error of each.
    MovingSun,
}

#[derive(Args)]
struct EstimateSweep {
    /// Scene folder.
    #[arg(default_value = "scenes/courtyard")]
    scene: PathBuf,
    /// Sequence (needs a truth file).
    #[arg(long)]
    sequence: Option<String>,
    /// Which knob to sweep.
    #[arg(long, value_enum, default_value = "samples")]
    knob: Knob,
    /// Draws per frame and knob value (different seeds).
    #[arg(long, default_value_t = 10)]
    repeats: usize,
    /// CSV output.
    #[arg(long, default_value = "out/bench_estimate.csv")]
    csv: PathBuf,
    /// SVG plot of error against time per frame (log–log).
    #[arg(long)]
    plot: Option<PathBuf>,
    /// `moving-sun`: frames of the fast-sun sequence.
    #[arg(long, default_value_t = 48)]
    frames: usize,
    /// `moving-sun`: seconds between the fast-sun sequence's frame times.
    #[arg(long, default_value_t = 120.0)]
    sun_step_s: f64,
    /// Write the outputs even over a file of the scene.
    #[arg(long)]
    force: bool,
}

struct Row {
    value: String,
    errs_pd: Vec<f64>,
    errs_pa: Vec<f64>,
    missing: usize,
    ms: Vec<f64>,
    setup_ms: f64,
    rebuild_ms: Vec<f64>,
}

fn run_config(
    scene: &heliar::scene::Scene,
    ray: std::sync::Arc<heliar::geometry::raycast::RayScene>,
    seq: &heliar::scene::Sequence,
    frames: &[Frame],
    cfg: EstimatorConfig,
    repeats: usize,
    value: String,
) -> Result<Row> {
    let truth = seq.truth.as_ref().context("the sequence has no truth file")?;
    let t = std::time::Instant::now();
    let mut est = Estimator::with_camera(cfg, scene.observer, scene.geo, &scene.camera, ray)?;
    let setup_ms = t.elapsed().as_secs_f64() * 1e3;
    let lin = seq.photometry.linearizer();
    let mut row = Row { value, errs_pd: vec![], errs_pa: vec![], missing: 0, ms: vec![], setup_ms, rebuild_ms: vec![] };
    for (i, frame) in frames.iter().enumerate() {
        for r in 0..repeats {
            let e = est.estimate(i + 1_000_003 * r, &seq.times[i], frame, &lin)?;
            if e.sun_rebuilt {
                row.rebuild_ms.push(e.sun_rebuild_ms);
            }
            row.ms.push(e.estimate_ms);
            match (e.pd, e.pa) {
                (Some(pd), Some(pa)) => {
                    let (a, b) = lighting_error(&pd, &pa, &truth[i].pd, &truth[i].pa);
                    row.errs_pd.push(a);
                    row.errs_pa.push(b);
                }
                _ => row.missing += 1,
            }
        }
    }
    Ok(row)
}

/// The estimator settings of a sweep over `knob`, with their labels.
fn knob_configs(knob: Knob, base: &EstimatorConfig) -> Vec<(String, EstimatorConfig)> {
    match knob {
        Knob::Samples => [50, 100, 200, 500, 1000, 2000, 5000]
            .iter()
            .map(|&n| (n.to_string(), EstimatorConfig { samples: n, pool_size: base.pool_size.max(n), ..base.clone() }))
            .collect(),
        Knob::AmbientPaths => [4, 16, 64, 256, 1024]
            .iter()
            .map(|&p| {
                let mut c = base.clone();
                c.ambient.paths = p;
                (p.to_string(), c)
            })
            .collect(),
        Knob::BouncePaths => [0, 4, 16, 64, 256]
            .iter()
            .map(|&p| {
                let mut c = base.clone();
                c.sun_bounce = p > 0;
                c.bounce.paths = p.max(1);
                (p.to_string(), c)
            })
            .collect(),
        Knob::PoolSize => [512, 1024, 2048, 4096, 8192, 16384]
            .iter()
            .map(|&p| (p.to_string(), EstimatorConfig { pool_size: p, samples: base.samples.min(p), ..base.clone() }))
            .collect(),
        Knob::Sky => {
            use heliar::scene::settings::{DEFAULT_TERRAIN_ALBEDO, SkyShape, SkyTermsConfig, TerrainAlbedo, Turbidity};
            // A fixed terrain, so the sweep compares sky shapes (`--knob terrain` measures the map's).
            let d = SkyTermsConfig { terrain_albedo: TerrainAlbedo::Rgb(DEFAULT_TERRAIN_ALBEDO), ..SkyTermsConfig::default() };
            let skies = [
                ("uniform", SkyTermsConfig::jensen()),
                ("uniform+terrain", SkyTermsConfig { shape: SkyShape::Uniform, ..d.clone() }),
                ("hosek_t2", SkyTermsConfig { turbidity: Turbidity::Value(2.0), ..d.clone() }),
                ("hosek_t3", d.clone()),
                ("hosek_t4", SkyTermsConfig { turbidity: Turbidity::Value(4.0), ..d.clone() }),
                ("hosek_t3_no_terrain", SkyTermsConfig { terrain_albedo: TerrainAlbedo::Rgb([0.0; 3]), ..d.clone() }),
                ("hosek_fit", SkyTermsConfig { turbidity: Turbidity::Fit, ..d.clone() }),
            ];
            skies.into_iter().map(|(name, sky)| (name.to_string(), EstimatorConfig { sky, ..base.clone() })).collect()
        }
        Knob::SkyDirections => [32, 64, 128, 256, 512, 1024]
            .iter()
            .map(|&n| {
                let mut c = base.clone();
                c.sky.directions = n;
                (n.to_string(), c)
            })
            .collect(),
        Knob::MovingSun | Knob::Terrain => Vec::new(),
    }
}

/// The configurations of `--knob terrain`: fixed albedos, and the map's (resolved here).
fn terrain_configs(scene: &heliar::scene::Scene, ray: &std::sync::Arc<heliar::geometry::raycast::RayScene>) -> Result<Vec<(String, EstimatorConfig)>> {
    use heliar::scene::settings::TerrainAlbedo;
    let mut out: Vec<(String, EstimatorConfig)> = [0.2f32, 0.08, 0.8]
        .iter()
        .map(|&v| {
            let mut c = scene.estimator.clone();
            c.sky.terrain_albedo = TerrainAlbedo::Rgb([v; 3]);
            (v.to_string(), c)
        })
        .collect();
    let mut with_map = scene.clone();
    with_map.estimator.sky.terrain_albedo = TerrainAlbedo::Map;
    with_map.estimator.sky.resolved_terrain = None;
    let t = heliar::envmap::bake::terrain::resolve_scene(&mut with_map, ray).with_context(|| format!("measuring the terrain albedo of {}", scene.root.display()))?;
    let label = t.map_or_else(|| "map".to_owned(), |t| format!("map ({:.3}, {:.3}, {:.3}; {:?})", t.albedo_rgb[0], t.albedo_rgb[1], t.albedo_rgb[2], t.source));
    out.push((label, with_map.estimator));
    Ok(out)
}

pub fn run(a: BenchArgs) -> Result<()> {
    match a.what {
        BenchWhat::Estimate(s) => run_estimate(s),
        BenchWhat::Irradiance(s) => crate::bench_irradiance::run(s),
        BenchWhat::Vem(s) => crate::bench_vem::run(s),
        BenchWhat::Render(s) => crate::bench_render::run(s),
        BenchWhat::Lamps(s) => crate::bench_lamps::run(s),
        BenchWhat::Cuts(s) => crate::bench_cuts::run(s),
    }
}

/// `heliar bench estimate`.
fn run_estimate(s: EstimateSweep) -> Result<()> {
    let (scene, ray) = load_scene(&s.scene)?;
    let outputs: Vec<&std::path::Path> = std::iter::once(&s.csv).chain(&s.plot).map(PathBuf::as_path).collect();
    crate::common::guard_files(Some(&scene.root), &[], &outputs, s.force)?;
    let seq = pick_sequence(&scene, s.sequence.as_deref())?.clone();
    if seq.truth.is_none() {
        bail!("sequence '{}' of {} has no truth file: nothing to measure error against", seq.name, s.scene.display());
    }
    let k = &scene.camera.intrinsics;
    let frames: Vec<Frame> = seq.files.iter().map(|p| Frame::load_sized(p, k.width, k.height)).collect::<Result<_, _>>()?;
    if let Knob::MovingSun = s.knob {
        return crate::bench_estimate_sun::run(&scene, ray, &seq, &frames, s.frames.max(2), s.sun_step_s, &s.csv);
    }
    let configs = match s.knob {
        Knob::Terrain => terrain_configs(&scene, &ray)?,
        _ => knob_configs(s.knob, &scene.estimator),
    };
    let knob_name = match s.knob {
        Knob::Samples => "samples",
        Knob::AmbientPaths => "ambient_paths",
        Knob::BouncePaths => "bounce_paths",
        Knob::PoolSize => "pool_size",
        Knob::Sky => "sky",
        Knob::Terrain => "terrain_albedo",
        Knob::SkyDirections => "sky_directions",
        Knob::MovingSun => "moving_sun",
    };
    let pb = frame_bar(configs.len(), &format!("sweep {knob_name}"));
    let mut table = Table::new(&[
        knob_name,
        "pd_err_mean_pct",
        "pd_err_p95_pct",
        "pa_err_mean_pct",
        "pa_err_p95_pct",
        "no_estimate",
        "median_ms_per_frame",
        "setup_ms",
        "sun_rebuild_ms",
    ]);
    let (mut pd_pts, mut pa_pts) = (Vec::new(), Vec::new());
    for (value, cfg) in configs {
        let r = run_config(&scene, ray.clone(), &seq, &frames, cfg, s.repeats, value)?;
        let mean = |v: &[f64]| if v.is_empty() { f64::NAN } else { v.iter().sum::<f64>() / v.len() as f64 };
        // Time axis: per-frame time for the sample count; set-up time for the set-up knobs.
        let t = match s.knob {
            Knob::Samples => median(&r.ms),
            Knob::AmbientPaths | Knob::PoolSize | Knob::Sky | Knob::Terrain | Knob::SkyDirections => r.setup_ms,
            Knob::BouncePaths | Knob::MovingSun => median(&r.rebuild_ms),
        };
        pd_pts.push((t, 100.0 * mean(&r.errs_pd)));
        pa_pts.push((t, 100.0 * mean(&r.errs_pa)));
        table.push(vec![
            r.value,
            format!("{:.3}", 100.0 * mean(&r.errs_pd)),
            format!("{:.3}", 100.0 * percentile(&r.errs_pd, 0.95)),
            format!("{:.3}", 100.0 * mean(&r.errs_pa)),
            format!("{:.3}", 100.0 * percentile(&r.errs_pa, 0.95)),
            r.missing.to_string(),
            format!("{:.4}", median(&r.ms)),
            format!("{:.0}", r.setup_ms),
            format!("{:.0}", median(&r.rebuild_ms)),
        ]);
        pb.inc(1);
    }
    pb.finish_and_clear();
    println!("estimator sweep over '{}' of {} ({} frames × {} draws per value)", seq.name, s.scene.display(), frames.len(), s.repeats);
    print!("{table}");
    crate::common::write_output(&s.csv, |tmp| Ok(table.write_csv(tmp)?))?;
    println!("wrote {}", s.csv.display());
    if let Some(path) = &s.plot {
        let x_label = match s.knob {
            Knob::Samples => "median estimate time per frame (ms)",
            Knob::AmbientPaths | Knob::PoolSize | Knob::Sky | Knob::Terrain | Knob::SkyDirections => "estimator set-up time (ms)",
            Knob::BouncePaths | Knob::MovingSun => "sun-visibility rebuild time (ms)",
        };
        let series = vec![
            Series { name: "Pd mean error".into(), points: pd_pts, reference: false },
            Series { name: "Pa mean error".into(), points: pa_pts, reference: false },
        ];
        crate::common::write_output(path, |tmp| Ok(line_plot_svg(tmp, &format!("estimator error against run time ({knob_name})"), x_label, "mean relative error (%)", &series, true, true)?))?;
        println!("wrote {}", path.display());
    }
    Ok(())
}
