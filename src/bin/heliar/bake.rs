//! `heliar bake`, `heliar relight`, `heliar irradiance`: the offline maps, the relit map and
//! probe queries.

use crate::common::{build_estimator, load_scene};
use heliar::run::source::pick_sequence;
use anyhow::{Context, Result, bail};
use clap::Args;
use glam::Vec3;
use heliar::envmap::bake::{Baked, bake_cached, bake_dir};
use heliar::envmap::relight::Relighter;
use heliar::lighting::Lighting;
use heliar::geometry::raycast::RayScene;
use heliar::io::frames::Frame;
use heliar::io::image::ExrPrecision;
use heliar::irradiance::probe_transfer::{LinearBasis, ProbeTransfer};
use heliar::scene::Scene;
use indicatif::{MultiProgress, ProgressBar, ProgressStyle};
use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};

#[derive(Args)]
pub struct BakeArgs {
    /// Scene folder.
    scene: PathBuf,
    /// Bake even when the cache is up to date.
    #[arg(long)]
    force: bool,
}

/// Bakes with progress bars (or loads the cache).
pub fn bake_with_progress(scene: &Scene, ray: Arc<RayScene>, force: bool) -> Result<Baked> {
    let multi = MultiProgress::new();
    let bars: Mutex<HashMap<String, ProgressBar>> = Mutex::new(HashMap::new());
    let progress = |stage: &str, done: u64, total: u64| {
        let Ok(mut bars) = bars.lock() else { return };
        let bar = bars.entry(stage.to_owned()).or_insert_with(|| {
            let b = multi.add(ProgressBar::new(total));
            b.set_style(
                ProgressStyle::with_template("{prefix:>18} [{bar:30}] {pos}/{len} texels, {per_sec}, ETA {eta}")
                    .unwrap_or_else(|_| ProgressStyle::default_bar())
                    .progress_chars("=> "),
            );
            b.set_prefix(stage.to_owned());
            b
        });
        bar.set_position(done);
        if done >= total {
            bar.finish();
        }
    };
    let t = std::time::Instant::now();
    let (baked, cached) = bake_cached(scene, ray, force, &progress).with_context(|| format!("baking {}", scene.root.display()))?;
    let i = &baked.info;
    if let Some(o) = &i.orientation {
        match o.warning() {
            Some(w) => eprintln!("{w}"),
            None if !cached => eprintln!("environment map orientation: {:.1}% of the upper hemisphere agrees with the proxy (best turn {:.0}°)", 100.0 * o.agreement, o.best_yaw_deg),
            None => {}
        }
    }
    if cached {
        eprintln!("bake of {} is up to date ({} ms to load; `--force` to redo)", scene.root.display(), t.elapsed().as_millis());
    } else {
        eprintln!(
            "baked {}×{} maps in {:.1} s: {} surface and {} sky texels; {} input texels sanitised; albedo from {:?}: {} texels filled from neighbours, {} from base colour",
            i.width,
            i.height,
            t.elapsed().as_secs_f64(),
            i.surface_texels,
            i.sky_texels,
            i.sanitized_texels,
            i.albedo_source,
            i.filled_from_neighbours,
            i.filled_from_base_colour
        );
        if let Some(s) = i.capture_status {
            eprintln!("lighting at capture ({s:?}): Pd {:.3?}, Pa {:.3?}", i.capture_pd, i.capture_pa);
        }
        eprintln!("wrote {}", bake_dir(scene).display());
    }
    Ok(baked)
}

pub fn run_bake(a: BakeArgs) -> Result<()> {
    let (scene, ray) = load_scene(&a.scene)?;
    bake_with_progress(&scene, ray, a.force)?;
    Ok(())
}

fn parse3(s: &str, what: &str) -> Result<Vec3> {
    let v: Vec<f32> = s.split(',').map(|x| x.trim().parse::<f32>()).collect::<Result<_, _>>().with_context(|| format!("{what} '{s}': expected three comma-separated numbers"))?;
    if v.len() != 3 || v.iter().any(|x| !x.is_finite()) {
        bail!("{what} '{s}': expected three finite comma-separated numbers");
    }
    Ok(Vec3::new(v[0], v[1], v[2]))
}

/// An irradiance `R,G,B` given on the command line: three finite, non-negative numbers.
fn parse_intensity(s: &str, what: &str) -> Result<Vec3> {
    let v = parse3(s, what)?;
    if v.cmplt(Vec3::ZERO).any() {
        bail!("{what} '{s}': an irradiance cannot be negative (three finite numbers ≥ 0)");
    }
    Ok(v)
}

/// Lighting from explicit values, or from the estimator on one frame, or the capture's.
#[derive(Args)]
pub struct LightingArgs {
    /// Estimate the lighting on this frame of the sequence.
    #[arg(long, conflicts_with_all = ["pd", "pa"])]
    frame: Option<usize>,
    /// Sequence for `--frame`.
    #[arg(long)]
    sequence: Option<String>,
    /// Sun irradiance R,G,B.
    #[arg(long, requires = "pa")]
    pd: Option<String>,
    /// Sky irradiance R,G,B.
    #[arg(long, requires = "pd")]
    pa: Option<String>,
    /// Time for the sun direction (RFC 3339; default: the capture time).
    #[arg(long)]
    time: Option<String>,
}

impl LightingArgs {
    /// Checks the explicit values before anything is loaded or baked.
    fn check(&self) -> Result<()> {
        if let (Some(pd), Some(pa)) = (&self.pd, &self.pa) {
            parse_intensity(pd, "--pd")?;
            parse_intensity(pa, "--pa")?;
        }
        if let Some(t) = &self.time {
            chrono::DateTime::parse_from_rfc3339(t).with_context(|| format!("--time '{t}' is not RFC 3339"))?;
        }
        Ok(())
    }
}

fn resolve_lighting(scene: &Scene, ray: Arc<RayScene>, baked: &Baked, a: &LightingArgs) -> Result<(Lighting, String)> {
    let sun_at = |t: &chrono::DateTime<chrono::FixedOffset>| -> Result<(Vec3, bool)> {
        let pos = heliar::sun::sun_position(&scene.observer, t)?;
        Ok((scene.geo.sun_dir_in_world(&pos), pos.above_horizon()))
    };
    if let Some(i) = a.frame {
        let seq = pick_sequence(scene, a.sequence.as_deref())?;
        let path = seq.files.get(i).with_context(|| format!("frame {i}: the sequence '{}' has {} frames", seq.name, seq.files.len()))?;
        let mut est = build_estimator(scene, ray)?;
        let k = &scene.camera.intrinsics;
        let frame = Frame::load_sized(path, k.width, k.height)?;
        let e = est.estimate(i, &seq.times[i], &frame, &seq.photometry.linearizer())?;
        let (Some(pd), Some(pa)) = (e.pd, e.pa) else {
            bail!("{}: the estimator gave no Pd/Pa (status {:?}); give --pd and --pa instead", path.display(), e.status);
        };
        let f = |v: [f64; 3]| Vec3::new(v[0] as f32, v[1] as f32, v[2] as f32);
        return Ok((
            Lighting { sun_dir: Vec3::from(e.sun.dir_world), above_horizon: e.sun.above_horizon, pd: f(pd), pa: f(pa), sky: heliar::lighting::FrameSky::Declared, lamps: heliar::lighting::LampScales::NONE },
            format!("estimated on {} ({:?})", path.display(), e.status),
        ));
    }
    let time = match &a.time {
        Some(t) => chrono::DateTime::parse_from_rfc3339(t).with_context(|| format!("--time '{t}' is not RFC 3339"))?,
        None => {
            let env = scene.manifest.envmap.as_ref().context("the scene has no [envmap]")?;
            chrono::DateTime::parse_from_rfc3339(&env.capture_time.to_string())?
        }
    };
    let (dir, up) = sun_at(&time)?;
    match (&a.pd, &a.pa) {
        (Some(pd), Some(pa)) => Ok((Lighting { sun_dir: dir, above_horizon: up, pd: parse_intensity(pd, "--pd")?, pa: parse_intensity(pa, "--pa")?, sky: heliar::lighting::FrameSky::Declared, lamps: heliar::lighting::LampScales::NONE }, "given".into())),
        _ => {
            let i = &baked.info;
            if i.albedo_source == heliar::scene::AlbedoSource::Gltf {
                bail!("no lighting given and the bake has none at capture (albedo from glTF): pass --frame N or --pd/--pa");
            }
            let f = |v: [f64; 3]| Vec3::new(v[0] as f32, v[1] as f32, v[2] as f32);
            Ok((Lighting { sun_dir: dir, above_horizon: up, pd: f(i.capture_pd), pa: f(i.capture_pa), sky: heliar::lighting::FrameSky::Declared, lamps: heliar::lighting::LampScales::NONE }, "estimated on the environment map at capture".into()))
        }
    }
}

#[derive(Args)]
pub struct RelightArgs {
    /// Scene folder.
    scene: PathBuf,
    #[command(flatten)]
    lighting: LightingArgs,
    /// Output EXR (a PNG preview is written beside it).
    #[arg(long, short, default_value = "out/relit.exr")]
    output: PathBuf,
    /// Write the outputs even over an input or a file of the scene.
    #[arg(long)]
    force: bool,
}

pub fn run_relight(a: RelightArgs) -> Result<()> {
    a.lighting.check()?;
    let (scene, ray) = load_scene(&a.scene)?;
    let png = a.output.with_extension("png");
    // Before the bake: the map and its preview may not overwrite the scene's files (env.exr).
    crate::common::guard_files(Some(&scene.root), &[], &[a.output.as_path(), png.as_path()], a.force)?;
    let baked = bake_with_progress(&scene, ray.clone(), false)?;
    let (lighting, source) = resolve_lighting(&scene, ray.clone(), &baked, &a.lighting)?;
    let mut relighter = Relighter::new(&baked, ray, scene.bake.relight.clone()).with_sky(scene.estimator.sky.sky_model());
    let up = relighter.update_sun(lighting.sun_dir);
    let t = std::time::Instant::now();
    let relit = relighter.relight(&lighting);
    let relight_ms = t.elapsed().as_secs_f64() * 1e3;
    let img = relit.to_image();
    crate::common::write_output(&a.output, |tmp| Ok(img.write_exr(tmp, ExrPrecision::Float)?))?;
    crate::common::write_output(&png, |tmp| Ok(img.write_png_srgb(tmp, 1.0)?))?;
    let v = serde_json::json!({
        "output": a.output, "preview": png, "lighting_source": source,
        "sun_dir": lighting.sun_dir.to_array(), "sun_up": lighting.above_horizon, "pd": lighting.pd.to_array(), "pa": lighting.pa.to_array(),
        "sun_visibility_build_ms": up.build_ms, "sunlit_texels": up.lit_texels, "relight_ms": relight_ms,
    });
    println!("{}", serde_json::to_string_pretty(&v)?);
    Ok(())
}

#[derive(Args)]
pub struct IrradianceArgs {
    /// Scene folder.
    scene: PathBuf,
    /// World point X,Y,Z (metres).
    #[arg(long, allow_hyphen_values = true)]
    at: String,
    /// Surface normal NX,NY,NZ (normalised here).
    #[arg(long, allow_hyphen_values = true)]
    normal: String,
    #[command(flatten)]
    lighting: LightingArgs,
    /// Use the full transfer path instead of the linear one.
    #[arg(long)]
    full: bool,
}

pub fn run_irradiance(a: IrradianceArgs) -> Result<()> {
    a.lighting.check()?;
    let (scene, ray) = load_scene(&a.scene)?;
    let grid = scene.manifest.irradiance.as_ref().context("the scene has no [irradiance] grid")?;
    let p = parse3(&a.at, "--at")?;
    let n = parse3(&a.normal, "--normal")?.try_normalize().context("--normal must not be zero")?;
    let baked = bake_with_progress(&scene, ray.clone(), false)?;
    let (lighting, source) = resolve_lighting(&scene, ray.clone(), &baked, &a.lighting)?;
    let mut relighter = Relighter::new(&baked, ray.clone(), scene.bake.relight.clone()).with_sky(scene.estimator.sky.sky_model());
    relighter.update_sun(lighting.sun_dir);
    let f = |v: [f64; 3]| Vec3::new(v[0] as f32, v[1] as f32, v[2] as f32);
    let transfer = ProbeTransfer::build(f(grid.min), f(grid.max), grid.spacing_m as f32, &baked, &ray, scene.bake.probe_directions);
    let mut probes = transfer.grid();
    if a.full {
        let relit = relighter.relight(&lighting);
        transfer.full_into(&relit, lighting.pa, &mut probes);
    } else {
        let basis = LinearBasis { ambient: transfer.ambient_response(&relighter), direct: transfer.direct_response(&relighter) };
        let pd = if lighting.above_horizon { lighting.pd } else { Vec3::ZERO };
        transfer.linear_into(&basis, pd, lighting.pa, &mut probes);
    }
    let e = probes.irradiance(p, n);
    let v = serde_json::json!({
        "at": p.to_array(), "normal": n.to_array(),
        "irradiance": e.map(|e| e.to_array()),
        "inside_grid": ((p - probes.min).cmpge(Vec3::ZERO).all() && (p - probes.min).cmple((probes.dims.as_vec3() - Vec3::ONE) * probes.spacing).all()),
        "path": if a.full { "full" } else { "linear" },
        "lighting": {"source": source, "sun_dir": lighting.sun_dir.to_array(), "sun_up": lighting.above_horizon, "pd": lighting.pd.to_array(), "pa": lighting.pa.to_array()},
        "grid": {"dims": probes.dims.to_array(), "spacing_m": probes.spacing, "invalid_probes": transfer.stats.invalid_probes, "directions": transfer.stats.directions},
    });
    println!("{}", serde_json::to_string_pretty(&v)?);
    Ok(())
}
