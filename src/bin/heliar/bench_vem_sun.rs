//! `heliar bench vem --what sun`: the samplers, median cut and the peak lights on the
//! sun-dominated Hošek–Wilkie sequence (`heliar::vem::eval::sunny`): irradiance error against
//! the brute-force integral at upper-hemisphere normals, time per frame, and excess flicker.
//!
//! All lights are per frame and unfiltered (the FIR's delay would be counted as error).
//! - **Error**: `|E − E_ref| / E_ref` per frame and normal (luminance); mean, p95 and max.
//! - **Excess flicker**: `((E_k − E_k−1) − (E_ref,k − E_ref,k−1)) / E_ref,k`, the frame-to-frame
//!   change of the lights' irradiance beyond that of the integral, rms over frames and normals.

use anyhow::{Context, Result};
use heliar::report::{Table, median, percentile};
use heliar::vem::eval::metrics::{random_normals, reference_irradiance};
use heliar::vem::eval::sunny;
use heliar::vem::eval::synth::Environment;
use heliar::vem::peaks::PeakTracker;
use heliar::vem::polar::{IrradianceReference, PolarMap};
use heliar::vem::sampling::SamplerKind;
use heliar::vem::sampling::coherent_cut::CoherentCut;
use heliar::vem::sampling::pattern::Pattern;
use heliar::vem::{Light, irradiance, lights_of_map, lights_with_peaks};
use std::path::Path;

/// (name, sampler, peaks).
const VARIANTS: [(&str, SamplerKind, bool); 8] = [
    ("havran", SamplerKind::Havran, false),
    ("havran_centres", SamplerKind::HavranCentres, false),
    ("standard", SamplerKind::Standard, false),
    ("median_cut", SamplerKind::MedianCut, false),
    ("coherent_cut", SamplerKind::CoherentCut, false),
    ("havran+peaks", SamplerKind::Havran, true),
    ("median_cut+peaks", SamplerKind::MedianCut, true),
    ("coherent_cut+peaks", SamplerKind::CoherentCut, true),
];
const COUNTS: [usize; 3] = [64, 128, 300];

fn lum(e: [f64; 3]) -> f64 {
    0.2126 * e[0] + 0.7152 * e[1] + 0.0722 * e[2]
}

/// Measures of one variant at one light count.
struct Row {
    mean: f64,
    p95: f64,
    max: f64,
    ms: f64,
    flicker: f64,
    /// Median and 95th percentile of the angle each light index moves from frame to frame, degrees.
    motion: (f64, f64),
}

/// One frame's unfiltered lights. The coherent cut keeps its state (its axes) from frame to
/// frame, as in the decomposer; the others are per frame.
fn frame_lights(cut: &mut CoherentCut, tracker: &mut PeakTracker, m: &PolarMap, kind: SamplerKind, peaks: bool, n: usize) -> Vec<Light> {
    if kind != SamplerKind::CoherentCut {
        return if peaks { lights_with_peaks(tracker, m, kind, Pattern::RelaxedHalton, n) } else { lights_of_map(m, kind, Pattern::RelaxedHalton, n) };
    }
    let mut out = Vec::with_capacity(n);
    if peaks {
        // As the decomposer does: the remainder as patches of the map, no copy.
        tracker.find(m, n - 1);
        cut.rebuild_patched(m, tracker.patches());
        cut.lights_of_tables(n - tracker.peaks().len(), &mut out);
        out.extend_from_slice(tracker.peaks());
    } else {
        cut.lights(m, n, &mut out);
    }
    out
}

/// Angles (degrees) each index of `b` moved from `a`.
fn index_motion(a: &[Light], b: &[Light], out: &mut Vec<f64>) {
    let by_index: std::collections::HashMap<u32, glam::Vec3> = a.iter().map(|l| (l.index, l.dir)).collect();
    for l in b {
        if let Some(d) = by_index.get(&l.index) {
            out.push(((d.dot(l.dir)).clamp(-1.0, 1.0) as f64).acos().to_degrees());
        }
    }
}

fn measure(maps: &[PolarMap], normals: &[glam::Vec3], refs: &[Vec<f64>], kind: SamplerKind, peaks: bool, n: usize) -> Row {
    let (mut tracker, mut cut) = (PeakTracker::new(), CoherentCut::new());
    let (mut rel, mut ms, mut flick, mut moved) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let mut prev: Option<Vec<f64>> = None;
    let mut prev_lights: Vec<Light> = Vec::new();
    for (k, m) in maps.iter().enumerate() {
        let t = std::time::Instant::now();
        let lights = frame_lights(&mut cut, &mut tracker, m, kind, peaks, n);
        ms.push(t.elapsed().as_secs_f64() * 1e3);
        if k > 0 {
            index_motion(&prev_lights, &lights, &mut moved);
        }
        let est: Vec<f64> = normals.iter().map(|&nrm| lum(irradiance(&lights, nrm))).collect();
        for (a, b) in est.iter().zip(&refs[k]) {
            rel.push((a - b).abs() / b.max(1e-300));
        }
        if let Some(p) = &prev {
            for i in 0..normals.len() {
                let d = (est[i] - p[i]) - (refs[k][i] - refs[k - 1][i]);
                flick.push(d / refs[k][i].max(1e-300));
            }
        }
        prev = Some(est);
        prev_lights = lights;
    }
    Row {
        mean: rel.iter().sum::<f64>() / rel.len().max(1) as f64,
        p95: percentile(&rel, 0.95),
        max: rel.iter().cloned().fold(0.0, f64::max),
        ms: median(&ms),
        flicker: (flick.iter().map(|d| d * d).sum::<f64>() / flick.len().max(1) as f64).sqrt(),
        motion: (median(&moved), percentile(&moved, 0.95)),
    }
}

/// How well the peak detector finds the sun: frames with one peak, its power and direction
/// against the sequence's sun.
fn print_peaks(maps: &[PolarMap]) {
    let base = sunny::clear_sky();
    let mut tracker = PeakTracker::new();
    let (mut found, mut ids, mut worst_rel, mut worst_deg) = (0, std::collections::BTreeSet::new(), 0.0f64, 0.0f64);
    for (k, m) in maps.iter().enumerate() {
        tracker.split(m, 4);
        let truth = sunny::frame(&base, k).suns().first().map_or(0.0, |s| heliar::vem::polar::luminance(s.1) as f64);
        if let Some(p) = tracker.peaks().first() {
            found += 1;
            ids.insert(p.index);
            worst_rel = worst_rel.max((heliar::vem::polar::luminance(p.rgb) as f64 - truth).abs() / truth.max(1e-300));
            worst_deg = worst_deg.max(p.dir.dot(base.sun_dir).clamp(-1.0, 1.0).acos().to_degrees() as f64);
        }
    }
    println!(
        "peaks: the sun found in {found} of {} frames under {} index(es); worst power error {:.2}%, worst direction error {worst_deg:.3}°",
        maps.len(),
        ids.len(),
        100.0 * worst_rel
    );
}

/// The temporal filters on the same sequence (N = 300): each output frame's lights against its
/// own frame's map (`heliar::vem::eval::lag`), for Havran's samples and the coherent cut (with
/// and without peaks).
fn print_lag(maps: &[PolarMap], normals: &[glam::Vec3], refs: &[Vec<f64>]) -> Result<()> {
    use heliar::vem::eval::lag::{lag_error, unfiltered_error};
    use heliar::vem::fir::Temporal;
    let mut t = Table::new(&["sampler", "filter", "delay_frames", "err_mean_pct", "err_p95_pct", "err_max_pct"]);
    for (sname, sampler, peaks) in [("havran", SamplerKind::Havran, false), ("coherent_cut", SamplerKind::CoherentCut, false), ("coherent_cut+peaks", SamplerKind::CoherentCut, true)] {
        let cfg = |temporal| heliar::vem::VemConfig { lights: 300, temporal, sampler, peaks: Some(peaks), ..Default::default() };
        let mut rows = vec![
            ("zero phase (files)", lag_error(maps, cfg(Temporal::ZeroPhase), normals, refs)?),
            ("minimum phase (live)", lag_error(maps, cfg(Temporal::MinimumPhase), normals, refs)?),
            ("causal, the paper's", lag_error(maps, cfg(Temporal::Causal), normals, refs)?),
        ];
        if !peaks {
            rows.insert(0, ("none (unfiltered)", unfiltered_error(maps, &cfg(Temporal::Causal), normals, refs)));
        }
        for (name, e) in rows {
            t.push(vec![sname.into(), name.into(), format!("{:.2}", e.delay_frames), format!("{:.3}", 100.0 * e.mean), format!("{:.3}", 100.0 * e.p95), format!("{:.3}", 100.0 * e.max)]);
        }
    }
    println!("temporal filter: each output frame's lights (N = 300) against the integral of its own frame's map");
    print!("{t}");
    Ok(())
}

/// Runs the comparison and writes `csv`.
pub fn sun_sweep(normals_wanted: usize, csv: &Path) -> Result<()> {
    let maps = sunny::polar_maps(360, 90, sunny::FRAMES);
    // Upper hemisphere: fold the uniform sphere normals up.
    let normals: Vec<glam::Vec3> = random_normals(normals_wanted.max(64), 777).into_iter().map(|n| glam::Vec3::new(n.x, n.y.abs().max(1e-3), n.z).normalize()).collect();
    let refs: Vec<Vec<f64>> = maps.iter().map(|m| reference_irradiance(&IrradianceReference::new(m, 2), &normals)).collect();
    let table = variant_table(&maps, &normals, &refs, &VARIANTS);
    println!(
        "sun-dominated sequence ({} frames, Hošek–Wilkie T = {}, sun {:.0}% of the power, a cloud crossing it): unfiltered lights per frame, error against the brute-force integral at {} upper-hemisphere normals, median time per frame (one core), excess flicker",
        maps.len(),
        sunny::TURBIDITY,
        100.0 * sunny::SUN_SHARE,
        normals.len()
    );
    print!("{table}");
    print_peaks(&maps);
    print_lag(&maps, &normals, &refs)?;
    table.write_csv(csv).with_context(|| format!("writing {}", csv.display()))?;
    println!("wrote {}", csv.display());
    other_sequences(&normals)
}

/// The error, time, flicker and motion table of `variants` on one sequence.
fn variant_table(maps: &[PolarMap], normals: &[glam::Vec3], refs: &[Vec<f64>], variants: &[(&str, SamplerKind, bool)]) -> Table {
    let mut table = Table::new(&["lights", "variant", "err_mean_pct", "err_p95_pct", "err_max_pct", "ms_per_frame", "excess_flicker_rms_pct", "motion_median_deg", "motion_p95_deg"]);
    for &n in &COUNTS {
        for &(name, kind, peaks) in variants {
            let r = measure(maps, normals, refs, kind, peaks, n);
            table.push(vec![
                n.to_string(),
                name.into(),
                format!("{:.3}", 100.0 * r.mean),
                format!("{:.3}", 100.0 * r.p95),
                format!("{:.3}", 100.0 * r.max),
                format!("{:.4}", r.ms),
                format!("{:.3}", 100.0 * r.flicker),
                format!("{:.4}", r.motion.0),
                format!("{:.3}", r.motion.1),
            ]);
        }
    }
    table
}

/// The same measures on the sequences of the plain `bench vem` (`heliar::vem::eval::synth`):
/// outdoor (a sun crossed by a cloud, drifting clouds), overcast (the same without the sun) and
/// indoor (a lamp flickering at 115 Hz and a window), [`OTHER_FRAMES`] frames each.
fn other_sequences(normals: &[glam::Vec3]) -> Result<()> {
    use heliar::vem::eval::synth::{self, OutdoorSky};
    const OTHER: [(&str, SamplerKind, bool); 5] = [
        ("havran", SamplerKind::Havran, false),
        ("median_cut", SamplerKind::MedianCut, false),
        ("coherent_cut", SamplerKind::CoherentCut, false),
        ("median_cut+peaks", SamplerKind::MedianCut, true),
        ("coherent_cut+peaks", SamplerKind::CoherentCut, true),
    ];
    let render = |env: &dyn Environment| synth::render_polar(env, 360, 90, 2);
    let sequences: [(&str, Vec<PolarMap>); 3] = [
        ("outdoor", (0..OTHER_FRAMES).map(|k| render(&synth::outdoor(k, synth::RATE_HZ))).collect()),
        ("overcast", (0..OTHER_FRAMES).map(|k| render(&OutdoorSky { sun_irradiance: [0.0; 3], ..synth::outdoor(k, synth::RATE_HZ) })).collect()),
        ("indoor", (0..OTHER_FRAMES).map(|k| render(&synth::indoor_lamp(k, synth::RATE_HZ))).collect()),
    ];
    for (name, maps) in &sequences {
        let refs: Vec<Vec<f64>> = maps.iter().map(|m| reference_irradiance(&IrradianceReference::new(m, 2), normals)).collect();
        println!("{name} sequence ({} frames, `heliar::vem::eval::synth`): the same measures", maps.len());
        print!("{}", variant_table(maps, normals, &refs, &OTHER));
    }
    Ok(())
}

/// Frames of each of [`other_sequences`]' sequences.
const OTHER_FRAMES: usize = 24;
