//! `heliar bench vem`: the light decomposition's irradiance error against run time, and its
//! temporal coherence, for Havran's transform and the standard inversion; with `--what sun`,
//! median cut and the peak lights on a sun-dominated sequence (`bench_vem_sun`).

use anyhow::{Context, Result};
use clap::{Args, ValueEnum};
use heliar::report::{Series, Table, line_plot_svg, median};
use heliar::vem::capture::input::VemInput;
use heliar::vem::eval::metrics::{irradiance_error, motion, random_normals, reference_irradiance};
use heliar::vem::sampling::pattern::Pattern;
use heliar::vem::polar::{IrradianceReference, PolarMap};
use heliar::vem::sampling::{PolarDistribution, SamplerKind};
use heliar::vem::cluster::{DEFAULT_CF, cluster_lights, cluster_radius};
use heliar::vem::regions::{RegionLists, RegionSet};
use heliar::vem::fir::{FirDesign, LightFilter};
use heliar::vem::eval::synth;
use heliar::vem::{Decomposer, VemConfig, lights_of_distribution, lights_of_map};
use std::path::{Path, PathBuf};

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
enum What {
    /// Irradiance error and time per frame against the light count.
    Error,
    /// Angular motion of the lights under small local changes of the map.
    Coherence,
    /// Time per frame of the whole pipeline and its parts, wall clock and CPU time of the thread.
    Speed,
    /// Samplers, median cut and peak lights on the sun-dominated Hošek–Wilkie sequence
    /// (error, time, excess flicker at N = 64, 128, 300).
    Sun,
    /// Error, coherence and speed (not `sun`).
    All,
}

#[derive(Args)]
pub struct VemSweep {
    /// What to measure.
    #[arg(long, value_enum, default_value = "all")]
    what: What,
    /// Frames to measure on (folder or file; default: the synthetic skies of `heliar::vem::eval::synth`).
    /// Coherence then compares consecutive frames.
    #[arg(long)]
    input: Option<PathBuf>,
    /// Fisheye calibration of `--input`.
    #[arg(long)]
    calib: Option<PathBuf>,
    /// Random normals the irradiance error is measured at.
    #[arg(long, default_value_t = 256)]
    normals: usize,
    /// Timed repetitions per light count (the median is reported).
    #[arg(long, default_value_t = 15)]
    repeats: usize,
    /// Output prefix: writes PREFIX_error.csv/.svg, PREFIX_coherence.csv/.svg and PREFIX_sun.csv.
    #[arg(long, default_value = "out/bench_vem")]
    out: PathBuf,
}

/// The sampler variants compared: (name, transform, samples).
const VARIANTS: [(&str, SamplerKind, Pattern); 7] = [
    ("havran", SamplerKind::Havran, Pattern::RelaxedHalton),
    ("standard", SamplerKind::Standard, Pattern::RelaxedHalton),
    ("havran_centres", SamplerKind::HavranCentres, Pattern::RelaxedHalton),
    ("havran_halton", SamplerKind::Havran, Pattern::Halton),
    ("standard_halton", SamplerKind::Standard, Pattern::Halton),
    ("median_cut", SamplerKind::MedianCut, Pattern::RelaxedHalton),
    ("coherent_cut", SamplerKind::CoherentCut, Pattern::RelaxedHalton),
];
const COUNTS: [usize; 9] = [4, 8, 16, 32, 64, 128, 256, 512, 1024];

fn with_suffix(prefix: &Path, suffix: &str) -> PathBuf {
    let mut s = prefix.as_os_str().to_owned();
    s.push(suffix);
    PathBuf::from(s)
}

fn load_maps(input: &Path, calib: Option<&Path>) -> Result<Vec<(String, PolarMap)>> {
    let mut inp = VemInput::open(input, calib, 360, 90)?;
    let mut maps = Vec::new();
    for i in 0..inp.len() {
        let mut m = PolarMap::new(360, 90);
        inp.load(i, &mut m)?;
        m.sanitize();
        maps.push((inp.files[i].file_name().map_or("frame".into(), |f| f.to_string_lossy().into_owned()), m));
    }
    Ok(maps)
}

fn error_sweep(s: &VemSweep, maps: &[(String, PolarMap)]) -> Result<()> {
    let normals = random_normals(s.normals, 12345);
    let refs: Vec<Vec<f64>> = maps.iter().map(|(_, m)| reference_irradiance(&IrradianceReference::new(m, 2), &normals)).collect();
    let mut headers = vec!["lights".to_string()];
    for (name, _, _) in VARIANTS {
        headers.push(format!("{name}_err_pct"));
        headers.push(format!("{name}_err_max_pct"));
        headers.push(format!("{name}_ms"));
    }
    let mut table = Table::new(&headers.iter().map(String::as_str).collect::<Vec<_>>());
    let mut short_headers = vec!["lights".to_string()];
    short_headers.extend(VARIANTS.iter().map(|(n, _, _)| format!("{n} err% @ ms")));
    let mut short = Table::new(&short_headers.iter().map(String::as_str).collect::<Vec<_>>());
    let mut series: Vec<Series> = VARIANTS.iter().map(|(n, _, _)| Series { name: n.to_string(), points: vec![], reference: false }).collect();
    let mut dist = PolarDistribution::default();
    for &n in &COUNTS {
        let mut row = vec![n.to_string()];
        let mut short_row = vec![n.to_string()];
        for (v, &(_, kind, pattern)) in VARIANTS.iter().enumerate() {
            let errs: Vec<f64> = maps
                .iter()
                .zip(&refs)
                .map(|((_, m), r)| irradiance_error(&lights_of_map(m, kind, pattern, n), &normals, r).rel_rms)
                .collect();
            // Time per frame, one core: CDFs + N lights (with their colours).
            let mut ms = Vec::new();
            for rep in 0..s.repeats.max(1) {
                let m = &maps[rep % maps.len()].1;
                let t = std::time::Instant::now();
                dist.rebuild(m);
                let l = lights_of_distribution(&dist, m, kind, pattern, n);
                std::hint::black_box(&l);
                ms.push(t.elapsed().as_secs_f64() * 1e3);
            }
            let mean = errs.iter().sum::<f64>() / errs.len() as f64;
            let max = errs.iter().cloned().fold(0.0, f64::max);
            let t = median(&ms);
            row.extend([format!("{:.3}", 100.0 * mean), format!("{:.3}", 100.0 * max), format!("{t:.4}")]);
            short_row.push(format!("{:.2} @ {t:.3}", 100.0 * mean));
            series[v].points.push((t, 100.0 * mean));
        }
        table.push(row);
        short.push(short_row);
    }
    println!(
        "irradiance error (relative RMS over {} random normals, mean and max over {} maps: {}) and median time per frame (CDFs + lights, one core)",
        s.normals,
        maps.len(),
        maps.iter().map(|(n, _)| n.as_str()).collect::<Vec<_>>().join(", ")
    );
    print!("{short}");
    let csv = with_suffix(&s.out, "_error.csv");
    table.write_csv(&csv).with_context(|| format!("writing {}", csv.display()))?;
    println!("wrote {} (with the largest error over the maps)", csv.display());
    let svg = with_suffix(&s.out, "_error.svg");
    line_plot_svg(&svg, "VEM lights: irradiance error against time per frame (N = 4 … 1024)", "time per frame (ms)", "relative RMS irradiance error (%)", &series, true, true)
        .with_context(|| format!("writing {}", svg.display()))?;
    println!("wrote {}", svg.display());
    Ok(())
}

fn coherence_sweep(s: &VemSweep, pairs: &[(String, PolarMap, PolarMap)]) -> Result<()> {
    let mut table = Table::new(&["change", "sampler", "lights", "mean_deg", "p95_deg", "max_deg", "jumps_pct"]);
    let mut series: Vec<Series> = VARIANTS.iter().map(|(n, _, _)| Series { name: n.to_string(), points: vec![], reference: false }).collect();
    let counts = [16usize, 64, 300, 1024];
    let mut summary = Table::new(&["change", "havran_mean_deg", "standard_mean_deg", "standard / havran", "havran_max_deg", "standard_max_deg"]);
    let mut at300: Vec<Vec<f64>> = vec![vec![]; VARIANTS.len()];
    for &n in &counts {
        let mut sums = vec![0.0f64; VARIANTS.len()];
        for (name, a, b) in pairs {
            let mut row_means = vec![];
            for (v, &(vname, kind, pattern)) in VARIANTS.iter().enumerate() {
                let m = motion(&lights_of_map(a, kind, pattern, n), &lights_of_map(b, kind, pattern, n));
                sums[v] += m.mean_rad.to_degrees() / pairs.len() as f64;
                table.push(vec![
                    name.clone(),
                    vname.into(),
                    n.to_string(),
                    format!("{:.4}", m.mean_rad.to_degrees()),
                    format!("{:.4}", m.p95_rad.to_degrees()),
                    format!("{:.3}", m.max_rad.to_degrees()),
                    format!("{:.2}", 100.0 * m.jump_fraction),
                ]);
                row_means.push((m.mean_rad.to_degrees(), m.max_rad.to_degrees()));
                if n == 300 {
                    at300[v].push(m.mean_rad.to_degrees());
                }
            }
            if n == 300 {
                let (h, st) = (row_means[0], row_means[1]);
                summary.push(vec![
                    name.clone(),
                    format!("{:.4}", h.0),
                    format!("{:.4}", st.0),
                    format!("{:.2}", st.0 / h.0.max(1e-12)),
                    format!("{:.3}", h.1),
                    format!("{:.3}", st.1),
                ]);
            }
        }
        for (v, sm) in sums.iter().enumerate() {
            series[v].points.push((n as f64, *sm));
        }
    }
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len().max(1) as f64;
    summary.push(vec![
        "mean over changes".into(),
        format!("{:.4}", mean(&at300[0])),
        format!("{:.4}", mean(&at300[1])),
        format!("{:.2}", mean(&at300[1]) / mean(&at300[0]).max(1e-12)),
        String::new(),
        String::new(),
    ]);
    println!("temporal coherence: angular motion of index-matched lights between two maps (same samples), N = 300");
    print!("{summary}");
    let csv = with_suffix(&s.out, "_coherence.csv");
    table.write_csv(&csv).with_context(|| format!("writing {}", csv.display()))?;
    println!("wrote {} (every change, sampler and N = {counts:?})", csv.display());
    let svg = with_suffix(&s.out, "_coherence.svg");
    line_plot_svg(&svg, "VEM lights: mean angular motion under small local changes", "lights", "mean motion (degrees)", &series, true, true)
        .with_context(|| format!("writing {}", svg.display()))?;
    println!("wrote {}", svg.display());
    Ok(())
}

/// CPU time of this thread in nanoseconds (Linux `/proc/thread-self/schedstat`), `None` elsewhere.
fn thread_cpu_ns() -> Option<u64> {
    std::fs::read_to_string("/proc/thread-self/schedstat").ok()?.split_whitespace().next()?.parse().ok()
}

/// Runs `f` `n` times; returns (wall, CPU) microseconds per call (CPU `NaN` if unavailable).
fn time_per_call(n: usize, mut f: impl FnMut(usize)) -> (f64, f64) {
    for i in 0..n / 10 + 1 {
        f(i); // warm-up
    }
    let (t, c) = (std::time::Instant::now(), thread_cpu_ns());
    for i in 0..n {
        f(i);
    }
    let wall = t.elapsed().as_secs_f64() * 1e6 / n as f64;
    let cpu = match (c, thread_cpu_ns()) {
        (Some(a), Some(b)) => (b - a) as f64 / 1e3 / n as f64,
        _ => f64::NAN,
    };
    (wall, cpu)
}

fn speed(s: &VemSweep, maps: &[(String, PolarMap)]) -> Result<()> {
    let n = s.repeats.max(1) * 100;
    let mut t = Table::new(&["stage (360×90, one core)", "wall_us", "cpu_us"]);
    let mut row = |name: &str, (w, c): (f64, f64)| t.push(vec![name.into(), format!("{w:.1}"), format!("{c:.1}")]);
    for kind in [SamplerKind::Havran, SamplerKind::Standard, SamplerKind::MedianCut, SamplerKind::CoherentCut] {
        for peaks in [false, true] {
            let mut dec = Decomposer::new(VemConfig { lights: 300, sampler: kind, clusters: Some(72), peaks: Some(peaks), ..VemConfig::default() })?;
            let what = if peaks { "peaks + " } else { "" };
            row(&format!("whole frame, {}: {what}CDFs + 300 lights + FIR + clustering (Q = 72) + 200 region lists", kind.name()), time_per_call(n, |i| {
                std::hint::black_box(dec.process(&maps[i % maps.len()].1));
            }));
        }
    }
    let mut cut = heliar::vem::sampling::coherent_cut::CoherentCut::new();
    let mut cut_out = Vec::new();
    row("coherent cut: summed-area tables", time_per_call(n, |i| cut.rebuild(&maps[i % maps.len()].1)));
    row("coherent cut: 300 leaves from the tables", time_per_call(n, |_| cut.lights_of_tables(300, &mut cut_out)));
    let mut tracker = heliar::vem::peaks::PeakTracker::new();
    row("peak detector (peaks and the remainder's patches)", time_per_call(n, |i| tracker.find(&maps[i % maps.len()].1, 299)));
    let m = &maps[0].1;
    let mut dist = PolarDistribution::default();
    row("CDFs", time_per_call(n, |_| {
        std::hint::black_box(dist.rebuild(m));
    }));
    dist.rebuild(m);
    let mut samples_per_ms = vec![];
    for kind in [SamplerKind::Havran, SamplerKind::Standard] {
        let r = time_per_call(n, |_| {
            std::hint::black_box(lights_of_distribution(&dist, m, kind, Pattern::RelaxedHalton, 1024));
        });
        samples_per_ms.push((kind, 1024.0 / (r.1 / 1e3), 1024.0 / (r.0 / 1e3)));
        row(&format!("1024 lights, {}", kind.name()), r);
    }
    let lights = lights_of_map(m, SamplerKind::Havran, Pattern::RelaxedHalton, 300);
    let raw: Vec<_> = lights.iter().map(|l| (l.dir, [1.0f32; 3])).collect();
    let mut filter = LightFilter::new(&FirDesign::paper());
    let mut out = Vec::new();
    row("FIR, 300 lights", time_per_call(n, |_| {
        std::hint::black_box(filter.step(10.0, &raw, &mut out));
    }));
    let mut clusters = Vec::new();
    row("clustering 300 → at most 72", time_per_call(n, |_| cluster_lights(&lights, 72, cluster_radius(72, DEFAULT_CF), &mut clusters)));
    let regions = RegionSet::lambertian(200, 32);
    let mut lists = RegionLists::default();
    row("region lists, 300 lights × 200 regions", time_per_call(n, |_| regions.build_lists(&lights, &mut lists)));
    let cam = heliar::camera::Camera::equidistant_up(512, 180.0);
    let img = synth::render_fisheye(&synth::outdoor(0, synth::RATE_HZ), &cam, 1);
    let frame = heliar::io::frames::Frame { width: 512, height: 512, data: heliar::io::frames::FrameData::Hdr(img) };
    let lin = heliar::io::frames::Linearizer::new(&heliar::io::frames::Response::Linear, 1.0, 1.0, None);
    let mut rs = heliar::vem::capture::resample::Resampler::new(&heliar::vem::capture::resample::Projection::Fisheye(cam), 512, 512, 360, 90);
    let mut polar = PolarMap::new(360, 90);
    row(&format!("fisheye 512² → polar map ({} weights)", rs.entries()), time_per_call(n / 10 + 1, |_| {
        std::hint::black_box(rs.resample(&frame, &lin, &mut polar));
    }));
    println!("time per call, mean over {n} calls (resampling: {}): wall clock and CPU time of the thread (the CPU time is what one idle core would take)", n / 10 + 1);
    print!("{t}");
    for (kind, cpu, wall) in samples_per_ms {
        println!("sample rate, {}: {cpu:.0} samples/ms of CPU time ({wall:.0} per wall-clock ms)", kind.name());
    }
    Ok(())
}

pub fn run(s: VemSweep) -> Result<()> {
    let maps: Vec<(String, PolarMap)> = match &s.input {
        Some(p) => load_maps(p, s.calib.as_deref())?,
        None => synth::error_maps(360, 90).into_iter().map(|(n, m)| (n.to_string(), m)).collect(),
    };
    if matches!(s.what, What::Error | What::All) {
        error_sweep(&s, &maps)?;
    }
    if matches!(s.what, What::Speed | What::All) {
        speed(&s, &maps)?;
    }
    if s.what == What::Sun {
        crate::bench_vem_sun::sun_sweep(s.normals, &with_suffix(&s.out, "_sun.csv"))?;
    }
    if matches!(s.what, What::Coherence | What::All) {
        let pairs: Vec<(String, PolarMap, PolarMap)> = match &s.input {
            Some(_) => maps.windows(2).map(|w| (format!("{} -> {}", w[0].0, w[1].0), w[0].1.clone(), w[1].1.clone())).collect(),
            None => synth::local_changes(360, 90).into_iter().map(|(n, a, b)| (n.to_string(), a, b)).collect(),
        };
        if pairs.is_empty() {
            eprintln!("coherence needs at least two frames");
        } else {
            coherence_sweep(&s, &pairs)?;
        }
    }
    Ok(())
}
