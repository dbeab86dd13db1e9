//! `heliar precompute`: the visibility cuts of a scene's moving (or, `--draggable`, draggable) objects, cached beside the bake
//! (`heliar::run::precompute`), with a progress bar and a JSON summary line on stdout.

use crate::common::load_scene;
use anyhow::{Result, bail};
use clap::Args;
use heliar::cuts::svc::SvcSettings;
use heliar::cuts::vcf::VcfSampling;
use heliar::run::precompute::{PrecomputeOptions, precompute};
use indicatif::{ProgressBar, ProgressStyle};
use std::path::PathBuf;

#[derive(Args)]
pub struct PrecomputeArgs {
    /// Scene folder.
    scene: PathBuf,
    /// Compute even when the cached cuts are up to date.
    #[arg(long)]
    force: bool,
    /// Tree depth: S = 2^levels directions (1..=15; the paper's 15).
    #[arg(long, default_value_t = heliar::cuts::PAPER_LEVELS)]
    levels: u32,
    /// Self-visibility cut threshold.
    #[arg(long, default_value_t = SvcSettings::default().threshold)]
    svc_threshold: f32,
    /// Visibility-cut-field sampling, spheres×rows×cols (the paper's 32x32x32).
    #[arg(long, default_value = "32x32x32")]
    vcf: String,
    /// Proxy-field grid spacing, m (default: the scene's `[irradiance]` spacing).
    #[arg(long)]
    proxy_spacing: Option<f32>,
    /// Also for a scene whose objects have no motion: `heliar live` lets a person drag and turn
    /// them, and the cuts make such a move cost no re-trace.
    #[arg(long)]
    draggable: bool,
}

fn parse_vcf(s: &str) -> Result<VcfSampling> {
    let n: Vec<u32> = s.split(['x', 'X', '×']).map(|p| p.trim().parse::<u32>()).collect::<Result<_, _>>().map_err(|_| anyhow::anyhow!("--vcf '{s}': expected spheres×rows×cols, e.g. 32x32x32"))?;
    let [spheres, rows, cols] = n[..] else { bail!("--vcf '{s}': expected three counts, spheres×rows×cols") };
    let v = VcfSampling { spheres, rows, cols, ..VcfSampling::default() };
    v.check()?;
    Ok(v)
}

pub fn run(a: PrecomputeArgs) -> Result<()> {
    heliar::cuts::tree::check_levels(a.levels)?;
    heliar::cuts::cut::check_threshold("--svc-threshold", a.svc_threshold)?;
    if a.proxy_spacing.is_some_and(|s| !(s.is_finite() && s > 0.0)) {
        bail!("--proxy-spacing must be a positive number of metres");
    }
    let opts = PrecomputeOptions {
        levels: a.levels,
        svc: SvcSettings { threshold: a.svc_threshold, ..SvcSettings::default() },
        vcf: parse_vcf(&a.vcf)?,
        proxy_spacing_m: a.proxy_spacing,
        force: a.force,
        draggable: a.draggable,
    };
    let (scene, ray) = load_scene(&a.scene)?;
    let bar = ProgressBar::new(0);
    bar.set_style(
        ProgressStyle::with_template("{prefix:>18} [{bar:30}] {pos}/{len} points, {per_sec}, ETA {eta}")
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    bar.set_prefix("visibility cuts");
    let progress = |done: u64, total: u64| {
        bar.set_length(total);
        bar.set_position(done);
    };
    let summary = precompute(&scene, &ray, &opts, &progress)?;
    bar.finish_and_clear();
    match (&summary.skipped, summary.cached) {
        (Some(why), _) => eprintln!("precompute skipped: {why}"),
        (None, true) => eprintln!("cuts of {} are up to date ({:.2} s to load; `--force` to redo)", scene.root.display(), summary.seconds),
        (None, false) => eprintln!(
            "precomputed the cuts of {} objects ({} moving) in {:.1} s: {} vertices, mean SVC {:.0} nodes, mean VCF {:.0} nodes, {} proxy points, {} bytes",
            summary.objects, summary.moving, summary.seconds, summary.vertices, summary.svc_mean_nodes, summary.vcf_mean_nodes, summary.proxy_points, summary.bytes
        ),
    }
    println!("{}", serde_json::to_string(&summary)?);
    Ok(())
}
