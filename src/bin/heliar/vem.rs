//! `heliar vem`: captured HDR video environment maps → directional lights, one JSON line per frame;
//! with `--scene`, the scene's virtual objects composited with those lights on the GPU
//! (`heliar::run::vem`).

use crate::common::BarObserver;
use anyhow::{Context, Result, bail};
use clap::{Args, ValueEnum};
use heliar::render::vem::{ObjectLight, VemRenderConfig};
use heliar::report::{JsonLines, Series, Table, line_plot_svg, median};
use heliar::run::vem::{VemScene, VemStage, run_vem};
use heliar::vem::VemConfig;
use heliar::vem::fir::Temporal;
use heliar::vem::sampling::SamplerKind;
use heliar::vem::sampling::pattern::Pattern;
use std::path::PathBuf;

/// The inverse transform, as named on the command line.
#[derive(Clone, Copy, ValueEnum)]
pub enum SamplerArg {
    /// Havran's continuous transform (progressive: adding lights moves none).
    Havran,
    /// Havran's transform interpolating between ring centres (the paper's description).
    HavranCentres,
    /// The standard marginal/conditional inversion (pbrt).
    Standard,
    /// Debevec's median cut (a baseline: lights of unequal power, not temporally filtered).
    MedianCut,
    /// The temporally coherent median cut (default): equal-energy leaves of a fixed kd-tree,
    /// stable indices, temporally filtered (not progressive: adding lights moves the others).
    CoherentCut,
}

impl From<SamplerArg> for SamplerKind {
    fn from(s: SamplerArg) -> Self {
        match s {
            SamplerArg::Havran => SamplerKind::Havran,
            SamplerArg::HavranCentres => SamplerKind::HavranCentres,
            SamplerArg::Standard => SamplerKind::Standard,
            SamplerArg::MedianCut => SamplerKind::MedianCut,
            SamplerArg::CoherentCut => SamplerKind::CoherentCut,
        }
    }
}

/// How the temporal filter runs, as named on the command line.
#[derive(Clone, Copy, ValueEnum)]
pub enum TemporalArg {
    /// Centred on the frame (default for files): frame t's lights describe frame t.
    ZeroPhase,
    /// The paper's causal FIR: frame t's lights describe frame t − 4 (at 21 Hz).
    Causal,
    /// The minimum-phase version (what `live` uses): causal with the least delay.
    MinPhase,
}

impl From<TemporalArg> for Temporal {
    fn from(t: TemporalArg) -> Self {
        match t {
            TemporalArg::ZeroPhase => Temporal::ZeroPhase,
            TemporalArg::Causal => Temporal::Causal,
            TemporalArg::MinPhase => Temporal::MinimumPhase,
        }
    }
}

/// Where the objects' light comes from, as named on the command line.
#[derive(Clone, Copy, ValueEnum)]
pub enum ObjectLightArg {
    /// The frame's directional lights with the shadow-map atlas (Havran §4; default).
    Lights,
    /// The visibility cuts under the VEM frame (cyberworlds §V): light and shadows per vertex,
    /// the receivers' contact shadows from the objects' fields.
    Cuts,
}

#[derive(Args)]
pub struct VemArgs {
    /// Folder of frames (.exr/.png, sorted by name) or one frame file.
    #[arg(long)]
    input: PathBuf,
    /// Fisheye calibration (a scene's calib/fisheye.toml). Without it, 2:1 frames are equirect
    /// and 4:1 frames polar maps, in the world frame.
    #[arg(long)]
    calib: Option<PathBuf>,
    /// Yaw of the input, degrees: the azimuth (clockwise from north) its north looks toward.
    /// Without a calibration a 2:1 frame is an equirect map with north (−Z) at the centre
    /// column and east (+X) to the right, a 4:1 frame a polar map laid out the same way; give
    /// the azimuth of a map's centre column here when it is not north. Lights are in the world
    /// frame either way.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    yaw: f64,
    /// Number of lights (the set H).
    #[arg(long, default_value_t = 300)]
    lights: usize,
    /// JSON-lines output file (default: stdout); with --scene, the output folder (frames,
    /// frames.jsonl, report.json, contact_sheet.png).
    #[arg(long, short)]
    output: Option<PathBuf>,
    /// Composite this scene's virtual objects (scene folder) with every frame's lights.
    #[arg(long)]
    scene: Option<PathBuf>,
    /// Also decompose into a denser glossy set L of this many lights (Havran §4.2).
    #[arg(long)]
    glossy_lights: Option<usize>,
    /// Shadow maps in the atlas (at most this many clustered lights cast shadows).
    #[arg(long, default_value_t = heliar::render::vem::shadow_atlas::DEFAULT_SLOTS)]
    shadow_maps: usize,
    /// Shadow-map tile size, texels.
    #[arg(long, default_value_t = heliar::render::vem::shadow_atlas::DEFAULT_TILE)]
    shadow_tile: u32,
    /// Visit every light in the shader instead of the region's list (the culling baseline).
    #[arg(long)]
    no_culling: bool,
    /// No shadow maps.
    #[arg(long)]
    no_shadows: bool,
    /// Where the objects' light comes from (with --scene): the frame's lights and shadow maps,
    /// or the visibility cuts under the VEM frame (read from SCENE/baked/cuts.bin, computed there
    /// for every object when missing, as `heliar precompute --draggable` does).
    #[arg(long, value_enum, default_value = "lights")]
    object_light: ObjectLightArg,
    /// Capture rate in Hz (designs the temporal filter; the paper's taps at 21).
    #[arg(long, default_value_t = 21.0)]
    rate_hz: f64,
    /// How the temporal filter runs: zero phase (footage: no lag), the paper's causal filter, or
    /// its minimum-phase version (low delay).
    #[arg(long, value_enum, default_value = "zero-phase")]
    temporal: TemporalArg,
    /// How the map becomes lights.
    #[arg(long, value_enum, default_value = "coherent-cut")]
    sampler: SamplerArg,
    /// Give concentrated peaks (the sun, a lamp) lights of their own, at their measured power
    /// and angular size, tracked from frame to frame, and sample the rest of the map with the
    /// other lights. The default with the coherent cut; this turns it on for the other samplers.
    #[arg(long, conflicts_with = "no_peaks")]
    peaks: bool,
    /// No peak lights: every light samples the map (the default of the samplers other than the
    /// coherent cut).
    #[arg(long)]
    no_peaks: bool,
    /// Use plain Halton samples instead of the relaxed ones.
    #[arg(long)]
    no_relax: bool,
    /// Also cluster the lights into at most this many (Havran §4.3).
    #[arg(long)]
    clusters: Option<usize>,
    /// Polar map size, WIDTHxHEIGHT.
    #[arg(long, default_value = "360x90")]
    polar: String,
    /// Largest fraction of NaN/Inf/negative pixels accepted in a frame.
    #[arg(long, default_value_t = heliar::vem::capture::input::DEFAULT_MAX_INVALID_FRACTION)]
    max_invalid_fraction: f64,
    /// Also write an SVG plot of the frame power, raw and filtered.
    #[arg(long)]
    plot: Option<PathBuf>,
    /// Write the outputs even over an input or a file of the scene.
    #[arg(long)]
    force: bool,
}

/// Refuses outputs over the input frames, the calibration or the scene (unless `--force`).
fn check_outputs(a: &VemArgs) -> Result<()> {
    let mut inputs: Vec<&std::path::Path> = vec![a.input.as_path()];
    inputs.extend(a.calib.as_deref());
    let guard = heliar::io::guard::OutputGuard::new(a.scene.as_deref(), &inputs, a.force);
    match (&a.scene, &a.output) {
        (Some(_), Some(dir)) => {
            guard.check_dir(dir)?;
            for f in ["frames.jsonl", "report.json", "contact_sheet.png"] {
                guard.check_file(&dir.join(f))?;
            }
        }
        (None, Some(file)) => guard.check_file(file)?,
        _ => {}
    }
    if let Some(p) = &a.plot {
        guard.check_file(p)?;
    }
    Ok(())
}

fn parse_size(s: &str) -> Result<(u32, u32)> {
    let (w, h) = s.split_once(['x', 'X']).with_context(|| format!("--polar {s}: expected WIDTHxHEIGHT, e.g. 360x90"))?;
    Ok((w.trim().parse().with_context(|| format!("--polar {s}: bad width"))?, h.trim().parse().with_context(|| format!("--polar {s}: bad height"))?))
}

pub fn run(a: VemArgs) -> Result<()> {
    let (pw, ph) = parse_size(&a.polar)?;
    let cfg = VemConfig {
        polar_width: pw,
        polar_height: ph,
        lights: a.lights,
        sampler: a.sampler.into(),
        pattern: if a.no_relax { Pattern::Halton } else { Pattern::RelaxedHalton },
        rate_hz: a.rate_hz,
        clusters: a.clusters,
        glossy_lights: a.glossy_lights,
        peaks: if a.peaks { Some(true) } else if a.no_peaks { Some(false) } else { None },
        temporal: a.temporal.into(),
        ..VemConfig::default()
    };
    check_options(&a)?;
    let mut stage = VemStage::open(&a.input, a.calib.as_deref(), cfg)?;
    stage.input.max_invalid_fraction = a.max_invalid_fraction;
    stage.input.set_yaw_deg(a.yaw).context("--yaw")?;
    eprintln!("layout: {}", stage.input.layout()?);
    print_response(&stage);
    let delay = stage.dec.delay_frames();
    let group_delay = match stage.dec.config().temporal {
        Temporal::ZeroPhase => 0.0,
        _ => stage.dec.filter_design().group_delay_frames(),
    };
    let mut scene = match (&a.scene, &a.output) {
        (Some(scene), Some(dir)) => {
            let rcfg = render_config(&a);
            let s = VemScene::from_scene(crate::common::read_scene(scene)?, dir, rcfg, a.rate_hz)?;
            eprintln!("GPU: {}", s.adapter());
            Some(s)
        }
        _ => None,
    };
    let jsonl = match (&a.scene, &a.output) {
        (Some(_), Some(dir)) => Some(dir.join("frames.jsonl")),
        (None, p) => p.clone(),
        _ => None,
    };
    let (clustered, rate_hz) = (a.clusters.is_some(), a.rate_hz);
    let stats = match &jsonl {
        Some(p) => {
            let mut stats = None;
            crate::common::write_output(p, |tmp| {
                let mut out = JsonLines::create(tmp).with_context(|| format!("creating {}", tmp.display()))?;
                stats = Some(run_vem(&mut stage, scene.as_mut(), &mut out, rate_hz, clustered, &mut BarObserver::default())?);
                Ok(())
            })?;
            stats.context("the frame loop gave no statistics")?
        }
        None => run_vem(&mut stage, scene.as_mut(), &mut JsonLines::stdout(), rate_hz, clustered, &mut BarObserver::default())?,
    };
    let mut t = Table::new(&["quantity", "value"]);
    t.push(vec!["frames".into(), stage.len().to_string()]);
    for (s, n) in &stats.statuses {
        t.push(vec![format!("status {}", serde_json::to_value(s)?.as_str().unwrap_or("?")), n.to_string()]);
    }
    t.push(vec!["lights".into(), a.lights.to_string()]);
    let kind = match stage.dec.config().temporal {
        Temporal::ZeroPhase => "zero phase: each frame's lights describe that frame",
        Temporal::Causal => "causal (the paper's)",
        Temporal::MinimumPhase => "causal, minimum phase",
    };
    t.push(vec!["filter delay".into(), format!("{group_delay:.2} frames ({:.3} s; {kind})", group_delay / a.rate_hz)]);
    t.push(vec!["median decode + resample per frame".into(), format!("{:.3} ms", median(&stats.decode_ms))]);
    t.push(vec!["median decomposition per frame".into(), format!("{:.3} ms", median(&stats.decompose_ms))]);
    eprint!("{t}");
    if let Some(p) = &jsonl {
        eprintln!("wrote {}", p.display());
    }
    if let Some(s) = scene {
        eprintln!("wrote {}", s.finish()?.display());
    }
    if let Some(path) = &a.plot {
        let series = vec![
            Series { name: "frame power".into(), points: stats.power.iter().map(|p| (p.0, p.1)).collect(), reference: true },
            Series { name: format!("filtered ({delay}-frame delay)"), points: stats.power.iter().map(|p| (p.0, p.2)).collect(), reference: false },
        ];
        crate::common::write_output(path, |tmp| {
            Ok(line_plot_svg(tmp, "VEM power (luminance), raw and FIR-filtered", "time (s)", "power (scaled radiance × sr)", &series, false, false)?)
        })?;
        eprintln!("wrote {}", path.display());
    }
    Ok(())
}

/// The renderer's settings from the options.
fn render_config(a: &VemArgs) -> VemRenderConfig {
    VemRenderConfig {
        shadow_slots: a.shadow_maps,
        tile: a.shadow_tile,
        culling: !a.no_culling,
        shadows: !a.no_shadows,
        object_light: match a.object_light {
            ObjectLightArg::Lights => ObjectLight::Lights,
            ObjectLightArg::Cuts => ObjectLight::Cuts,
        },
        ..Default::default()
    }
}

/// The options' own consistency and the outputs' guards, before anything is read.
fn check_options(a: &VemArgs) -> Result<()> {
    if a.scene.is_some() && a.output.is_none() {
        bail!("--scene needs --output OUT_DIR (the folder for frames, report and contact sheet)");
    }
    if a.shadow_maps == 0 || a.shadow_tile == 0 {
        bail!("--shadow-maps and --shadow-tile must be positive");
    }
    if !a.yaw.is_finite() {
        bail!("--yaw {} must be a finite angle in degrees", a.yaw);
    }
    if !(0.0..=1.0).contains(&a.max_invalid_fraction) {
        bail!("--max-invalid-fraction {} must be in [0, 1]", a.max_invalid_fraction);
    }
    check_outputs(a)
}

/// Prints the calibrated log response and its errors, when the lens file has one.
fn print_response(stage: &VemStage) {
    if let Some(c) = &stage.input.calib
        && let Some((lr, Some(rep))) = &c.log_response
    {
        eprintln!(
            "log response c = {:.4} + {:.4}·ln Y from {} patches: max error {:.1}% (check patches: {})",
            lr.a,
            lr.b,
            rep.fit_patches,
            100.0 * rep.fit_max_rel_error,
            rep.check_max_rel_error.map_or("none".into(), |e| format!("{:.1}%", 100.0 * e))
        );
    }
}
