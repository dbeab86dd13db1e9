//! Which of the dusk frames' sample rows pull the lamp's fitted scale `k` down (issue 16 §4,
//! "`k_i` within 5%"): the estimator's rows against the generator's own per-pixel parts.
//!
//! `gen-courtyard --dusk-frame-parts DIR` renders every dusk frame's sky, sun and lamp light with
//! the frame's own seed and samples, so the parts add up to the frame before its sensor noise,
//! pixel for pixel. Each row `y = S + D + L + n` (the generator's sky, sun and lamp light at the
//! sample's pixel, and the noise) is set against the model `a·Pa + b·Pd + g·k` at the truth's
//! `Pa`, `Pd` and `k = 1`; the rows are classed by what the proxy leaves out at the sample (the
//! unmodelled person between the sample and the lamp, or in front of the sample; the wet patch),
//! and the frame is refitted with one mismatch taken off the rows at a time.
//!
//! Run with the parts' folder (2 min to render in a debug build; `HELIAR_DUSK_SEEDS=0,3` picks
//! the estimator seeds, 0–4 by default):
//! `HELIAR_DUSK_FRAME_PARTS=DIR cargo test --features opencv --test suite -- --ignored estimate_dusk_rows::`
//! `HELIAR_DUSK_FRAME_PARTS_ALT=DIR2` adds the refits with DIR2's sky part in place of DIR's (the
//! generator rendered with another twilight sky, `docs/measurements.md`).
//!
//! Found (2026-12-04, `docs/measurements.md`, "Why the dusk lamp's `k` came out low"): the
//! refit with the rows' sky and sun light made exact (`S + D` replaced by the model's at the
//! truth) lifts the mean `k` over seeds 0–4 and frames 1–3 from 0.834 to 0.969; the person's rows
//! made exact add ≈ 0.02, the wet patch's ≈ 0.02–0.05; the noise alone leaves 0.99–1.01. The
//! sky's mismatch is the generator's twilight sky (the Hošek–Wilkie shape of a sun 2° up while
//! the sun is below 2°) against the model's (the sun's own shape, lifted onto the horizon once
//! it has set): the walls get 2–11% more sky light than the model says, the paving 2–3% less.
//!
//! `the_surface_flags_are_the_person_and_the_wet_patch` (not ignored: it needs no parts) classes
//! the pool entries that `estimate::surface_flags` learns on frames 0–2 the same way. The other
//! test runs the estimator with its defaults, the flags on (its measurements before them were
//! taken without).

use heliar::estimate::noise::robust_fit_noise;
use heliar::estimate::sky_band::SkyBandStatus;
use heliar::estimate::solve::HDR_NOISE_FLOOR_REL;
use heliar::estimate::{Estimator, LampStatus, LUMA};
use heliar::geometry::raycast::RayScene;
use heliar::io::frames::Frame;
use heliar::io::image::LinearImage;
use heliar::scene::Scene;
use glam::Vec3;
use rand::{SeedableRng, rngs::SmallRng};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// The generator's unmodelled person (`gen-courtyard`'s `build_geometry`): an axis-aligned box.
const PERSON: [[f32; 3]; 2] = [[1.6, 0.0, 1.0], [2.1, 1.75, 1.35]];
/// The generator's wet patch on the ground: centre (x, z) and radius.
const WET: ([f32; 2], f32) = ([2.5, 4.2], 0.9);
/// The generator's lamp disc: centre and radius (it faces down).
const LAMP: ([f32; 3], f32) = ([0.0, 4.0, 2.0], 0.15);

/// Whether the segment `p → q` passes through the person's box (slab test).
fn through_person(p: Vec3, q: Vec3) -> bool {
    let (lo, hi) = (Vec3::from(PERSON[0]), Vec3::from(PERSON[1]));
    let d = q - p;
    let (mut t0, mut t1) = (0.0f32, 1.0f32);
    for a in 0..3 {
        if d[a].abs() < 1e-9 {
            if p[a] < lo[a] || p[a] > hi[a] {
                return false;
            }
            continue;
        }
        let (ta, tb) = ((lo[a] - p[a]) / d[a], (hi[a] - p[a]) / d[a]);
        t0 = t0.max(ta.min(tb));
        t1 = t1.min(ta.max(tb));
    }
    t0 <= t1
}

/// Fraction of the lamp disc (a 7 × 7 grid inside it) that the person hides from `p`.
fn person_shadow(p: Vec3) -> f32 {
    let (c, r) = (Vec3::from(LAMP.0), LAMP.1);
    let (mut hit, mut all) = (0, 0);
    for i in 0..7 {
        for j in 0..7 {
            let (u, v) = ((i as f32 - 3.0) / 3.0, (j as f32 - 3.0) / 3.0);
            if u * u + v * v > 1.0 {
                continue;
            }
            all += 1;
            hit += through_person(p, c + Vec3::new(u * r, 0.0, v * r)) as u32;
        }
    }
    hit as f32 / all as f32
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Class {
    /// The camera sees the person, not the proxy surface.
    PersonSeen,
    /// The person hides some of the lamp from the sample.
    PersonShadow,
    Wet,
    Rest,
}

/// One usable row of a frame: per channel the observation, the model's columns and the
/// generator's parts at the pixel.
struct Row {
    class: Class,
    y: [f64; 3],
    a: [f64; 3],
    b: [f64; 3],
    g: [f64; 3],
    /// The twilight band's coefficient (0 when the band was not a column).
    h: [f64; 3],
    sky: [f64; 3],
    sun: [f64; 3],
    lamp: [f64; 3],
    /// The sky part of the alternative parts (`HELIAR_DUSK_FRAME_PARTS_ALT`), else `sky`.
    sky_alt: [f64; 3],
    dist: f32,
    node: u32,
    /// The sample faces up (the paving).
    up: bool,
}

fn luma(v: &[f64; 3]) -> f64 {
    (0..3).map(|c| LUMA[c] * v[c]).sum()
}

/// The twilight band in a refit.
#[derive(Clone, Copy)]
enum Band {
    Off,
    /// A free non-negative column.
    Free,
    /// Fixed at this ratio to the sky shape per channel (the sky column is `a + β·h`).
    Fixed([f64; 3]),
}

/// `k` (luma) of a refit of `rows` with `y` replaced by `y(row)` (`two`: with the sun column) and
/// the twilight band as `band`.
fn refit_band(rows: &[Row], two: bool, read_noise: f64, band: Band, y: &dyn Fn(&Row, usize) -> f64) -> f64 {
    let mut k = [0.0; 3];
    for c in 0..3 {
        let beta = if let Band::Fixed(b) = band { b[c] } else { 0.0 };
        let mut cols = vec![rows.iter().map(|r| r.a[c] + beta * r.h[c]).collect::<Vec<_>>()];
        if two {
            cols.push(rows.iter().map(|r| r.b[c]).collect());
        }
        cols.push(rows.iter().map(|r| r.g[c]).collect());
        if let Band::Free = band {
            cols.push(rows.iter().map(|r| r.h[c]).collect());
        }
        let ys: Vec<f64> = rows.iter().map(|r| y(r, c)).collect();
        let f = robust_fit_noise(&cols, &ys, HDR_NOISE_FLOOR_REL, read_noise, &mut SmallRng::seed_from_u64(17)).expect("fit");
        k[c] = f.x[1 + two as usize];
    }
    luma(&k)
}

/// Per channel, the band ratio `β` at which `a·Pa + β·h·Pa` best fits the generator's sky light
/// `S` on `rows` (least squares on `S/Pa`, two columns).
fn true_band_ratio(rows: &[&Row], pa: [f64; 3]) -> [f64; 3] {
    std::array::from_fn(|c| {
        let (mut aa, mut ah, mut hh, mut as_, mut hs) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for r in rows {
            let s = r.sky[c] / pa[c];
            aa += r.a[c] * r.a[c];
            ah += r.a[c] * r.h[c];
            hh += r.h[c] * r.h[c];
            as_ += r.a[c] * s;
            hs += r.h[c] * s;
        }
        let det = aa * hh - ah * ah;
        let alpha = (as_ * hh - hs * ah) / det;
        let beta = (aa * hs - ah * as_) / det;
        beta / alpha
    })
}

/// `k` (luma) of a refit whose sky column is split in two, the paving's and the rest's (each
/// surface class with its own `Pa`).
fn refit_split(rows: &[Row], two: bool, read_noise: f64) -> f64 {
    let mut k = [0.0; 3];
    for c in 0..3 {
        let mut cols = vec![rows.iter().map(|r| if r.up { r.a[c] } else { 0.0 }).collect::<Vec<_>>(), rows.iter().map(|r| if r.up { 0.0 } else { r.a[c] }).collect()];
        if two {
            cols.push(rows.iter().map(|r| r.b[c]).collect());
        }
        cols.push(rows.iter().map(|r| r.g[c]).collect());
        let ys: Vec<f64> = rows.iter().map(|r| r.y[c]).collect();
        let f = robust_fit_noise(&cols, &ys, HDR_NOISE_FLOOR_REL, read_noise, &mut SmallRng::seed_from_u64(17)).expect("fit");
        k[c] = *f.x.last().unwrap();
    }
    luma(&k)
}

fn parts_dir() -> Option<PathBuf> {
    std::env::var_os("HELIAR_DUSK_FRAME_PARTS").map(PathBuf::from)
}

#[test]
#[ignore = "needs HELIAR_DUSK_FRAME_PARTS (gen-courtyard --dusk-frame-parts DIR); a diagnostic"]
fn the_rows_that_pull_the_dusk_lamps_k_down() {
    let parts = parts_dir().expect("HELIAR_DUSK_FRAME_PARTS=DIR (gen-courtyard --dusk-frame-parts DIR)");
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/dusk");
    let seeds: Vec<u64> = std::env::var("HELIAR_DUSK_SEEDS").ok().map_or(vec![0, 1, 2, 3, 4], |s| s.split(',').map(|v| v.parse().unwrap()).collect());
    let base = Scene::load(&root).unwrap();
    let seq = base.sequences[0].clone();
    let truth = seq.truth.clone().expect("truth file");
    let lin = seq.photometry.linearizer();
    let read_noise = lin.read_noise();
    let cam = base.camera.pose.translation.as_vec3();
    let load = |i: usize, name: &str| LinearImage::read_exr(&parts.join(format!("frame_{i:03}_{name}.exr"))).unwrap();
    let alt_given = std::env::var_os("HELIAR_DUSK_FRAME_PARTS_ALT").is_some();
    let alt = std::env::var_os("HELIAR_DUSK_FRAME_PARTS_ALT").map(PathBuf::from).unwrap_or(parts.clone());
    let frames: Vec<(Frame, [LinearImage; 4])> = (0..seq.files.len())
        .map(|i| (Frame::load(&seq.files[i]).unwrap(), [load(i, "sky"), load(i, "sun"), load(i, "lamp"), LinearImage::read_exr(&alt.join(format!("frame_{i:03}_sky.exr"))).unwrap()]))
        .collect();
    // Per frame 1–3 of every seed: k as estimated, with the sky and sun exact, with the noise alone.
    let (mut k_as_is, mut k_sky_exact) = (Vec::new(), Vec::new());
    // Frames 3–4: k with the band fixed at the generator's own ratio, and with the person's and
    // wet patch's rows made exact on top.
    let mut k_night: Vec<(f64, f64)> = Vec::new();
    // Frames 3–4: k as estimated with the person's and wet patch's rows left out.
    let mut k_left_out: Vec<f64> = Vec::new();
    for seed in seeds {
        let mut scene = base.clone();
        scene.estimator.seed = seed;
        let mut est = Estimator::new(&scene, Arc::new(RayScene::new(scene.proxy.clone()))).unwrap();
        for (i, (frame, [sky, sun, lamp, sky_alt])) in frames.iter().enumerate() {
            let e = est.estimate(i, &seq.times[i], frame, &lin).unwrap();
            if e.lamps[0].status != LampStatus::Fitted {
                continue;
            }
            // Two columns when Pd was fitted, or (frame 1) when the sun's bounce separated it.
            let two = (e.fallback.is_none() && e.pd.is_some_and(|pd| pd.iter().any(|&v| v > 0.0))) || e.condition_number.is_some_and(|c| c != 1.0);
            let (entries, chan) = est.frame_rows();
            let hrows = est.frame_band_rows().to_vec();
            let pool = est.pool();
            let lc = est.lamp_columns().unwrap();
            let w = sky.width;
            let (tpa, tpd) = (truth[i].pa, truth[i].pd);
            let rows: Vec<Row> = entries
                .iter()
                .enumerate()
                .map(|(r, &ent)| {
                    let ent = ent as usize;
                    let px = pool.pixel[ent];
                    let (x, y) = (px % w, px / w);
                    let p = pool.point[ent];
                    let ground = p.y.abs() < 1e-3 && pool.normal[ent].y > 0.9;
                    let class = if through_person(cam, p) {
                        Class::PersonSeen
                    } else if person_shadow(p) > 0.0 {
                        Class::PersonShadow
                    } else if ground && (glam::Vec2::new(p.x, p.z) - glam::Vec2::from(WET.0)).length() < WET.1 + 0.05 {
                        Class::Wet
                    } else {
                        Class::Rest
                    };
                    let f = |img: &LinearImage| -> [f64; 3] { img.get(x, y).map(f64::from) };
                    Row {
                        class,
                        y: std::array::from_fn(|c| chan[c].y[r]),
                        a: std::array::from_fn(|c| chan[c].a[r]),
                        b: std::array::from_fn(|c| chan[c].b[r]),
                        g: lc.g(0, ent),
                        h: hrows.get(r).copied().unwrap_or([0.0; 3]),
                        sky: f(sky),
                        sun: f(sun),
                        lamp: f(lamp),
                        sky_alt: f(sky_alt),
                        dist: glam::Vec2::new(p.x - LAMP.0[0], p.z - LAMP.0[2]).length(),
                        node: pool.node[ent],
                        up: ground,
                    }
                })
                .collect();
            let k_est = luma(&e.lamps[0].k);
            // The model at the truth (k = 1) against the generator, per class.
            let mut line = format!("seed {seed} frame {i} ({:?}, two {two}): k {k_est:.3}, {} rows", e.status, rows.len());
            for class in [Class::PersonSeen, Class::PersonShadow, Class::Wet, Class::Rest] {
                let cl: Vec<&Row> = rows.iter().filter(|r| r.class == class).collect();
                let lit: Vec<&&Row> = cl.iter().filter(|r| luma(&r.g) > 0.0).collect();
                let sum = |f: &dyn Fn(&Row) -> f64| lit.iter().map(|r| f(r)).sum::<f64>();
                let ratio = sum(&|r| luma(&r.lamp)) / sum(&|r| luma(&r.g)).max(1e-300);
                let model_sky = cl.iter().map(|r| luma(&std::array::from_fn(|c| r.a[c] * tpa[c] + r.b[c] * tpd[c]))).sum::<f64>();
                let gen_sky = cl.iter().map(|r| luma(&r.sky) + luma(&r.sun)).sum::<f64>();
                line += &format!(" | {class:?} {} (L/g {ratio:.3}, (S+D)/model {:.3})", cl.len(), gen_sky / model_sky.max(1e-300));
            }
            eprintln!("{line}");
            // Refits with one mismatch taken off the rows at a time.
            let model_sd = |r: &Row, c: usize| r.a[c] * tpa[c] + if two { r.b[c] * tpd[c] } else { 0.0 };
            // The estimator's sky columns: the band free, fixed at its carried ratio, or none.
            let est_band = match e.sky_band.as_ref() {
                Some(b) if b.status == SkyBandStatus::Prior => Band::Fixed(b.prior.as_ref().expect("prior").used.ratio),
                Some(b) if b.status == SkyBandStatus::Fitted => Band::Free,
                _ => Band::Off,
            };
            let refit = |rows: &[Row], two: bool, read_noise: f64, y: &dyn Fn(&Row, usize) -> f64| refit_band(rows, two, read_noise, est_band, y);
            let as_is = refit(&rows, two, read_noise, &|r, c| r.y[c]);
            let fix_class = |classes: &[Class]| refit(&rows, two, read_noise, &|r, c| if classes.contains(&r.class) { r.y[c] - r.lamp[c] - r.sky[c] - r.sun[c] + r.g[c] + model_sd(r, c) } else { r.y[c] });
            let lamp_exact = refit(&rows, two, read_noise, &|r, c| r.y[c] - r.lamp[c] + r.g[c]);
            let sky_exact = refit_band(&rows, two, read_noise, Band::Off, &|r, c| r.y[c] - r.sky[c] - r.sun[c] + model_sd(r, c));
            let noise_only = refit_band(&rows, two, read_noise, Band::Off, &|r, c| r.y[c] - r.lamp[c] - r.sky[c] - r.sun[c] + r.g[c] + model_sd(r, c));
            let dropped: Vec<Row> = rows.iter().filter(|r| r.class != Class::PersonShadow && r.class != Class::PersonSeen).map(|r| Row { ..*r }).collect();
            let drop_person = refit(&dropped, two, read_noise, &|r, c| r.y[c]);
            // The same rows and columns as the estimator's fit; only the LMedS start's random draws
            // differ (up to 0.004 measured, seed 3 frame 4, against k_se 0.03).
            assert!((as_is - k_est).abs() < 6e-3, "frame {i}: the refit repeats the estimator's fit ({as_is} against {k_est})");
            // With every row's light made the model's at the truth, only the sensor noise is left:
            // measured 0.948–1.042 over seeds 0–4 and frames 1–5 (k_se 0.03–0.1).
            assert!((noise_only - 1.0).abs() < 0.07, "seed {seed} frame {i}: k {noise_only} from the noise alone");
            if i <= 3 {
                k_as_is.push(as_is);
                k_sky_exact.push(sky_exact);
            }
            eprintln!(
                "    refit k: as is {as_is:.3}; person rows exact {:.3}; person dropped {drop_person:.3}; wet exact {:.3}; lamp exact everywhere {lamp_exact:.3}; sky+sun exact everywhere {sky_exact:.3}; noise only {noise_only:.3}",
                fix_class(&[Class::PersonSeen, Class::PersonShadow]),
                fix_class(&[Class::Wet]),
            );
            // The lamp's ratio L/g by distance from the lamp's foot over the rest's lit rows.
            let mut bins = String::new();
            for (lo, hi) in [(0.0, 2.0), (2.0, 4.0), (4.0, 6.0), (6.0, 9.0), (9.0, 30.0)] {
                let sel: Vec<&Row> = rows.iter().filter(|r| r.class == Class::Rest && r.dist >= lo && r.dist < hi && luma(&r.g) > 0.0).collect();
                let l: f64 = sel.iter().map(|r| luma(&r.lamp)).sum();
                let g: f64 = sel.iter().map(|r| luma(&r.g)).sum();
                bins += &format!(" [{lo}-{hi} m: {} rows, L/g {:.3}]", sel.len(), l / g.max(1e-300));
            }
            eprintln!("    rest by distance:{bins}");
            // The sky's mismatch S/(a·Pa) over the rest, by proxy node and by which light dominates.
            let mut sky_line = String::new();
            let groups: [(&str, Box<dyn Fn(&Row) -> bool>); 5] = [
                ("paving", Box::new(|r: &Row| r.up)),
                ("north", Box::new(|r: &Row| !r.up && scene.proxy.nodes[r.node as usize].name.contains("north"))),
                ("west", Box::new(|r: &Row| !r.up && scene.proxy.nodes[r.node as usize].name.contains("west"))),
                ("lamp > sky", Box::new(|r: &Row| luma(&r.g) > luma(&std::array::from_fn(|c| r.a[c] * tpa[c])))),
                ("sky > lamp", Box::new(|r: &Row| luma(&r.g) <= luma(&std::array::from_fn(|c| r.a[c] * tpa[c])))),
            ];
            for (name, sel) in &groups {
                let rs: Vec<&Row> = rows.iter().filter(|r| r.class == Class::Rest && sel(r)).collect();
                let gen_sd: f64 = rs.iter().map(|r| luma(&r.sky) + luma(&r.sun)).sum();
                let model: f64 = rs.iter().map(|r| luma(&std::array::from_fn(|c| model_sd(r, c)))).sum();
                let lamp: f64 = rs.iter().map(|r| luma(&r.lamp)).sum();
                let alt_sd: f64 = rs.iter().map(|r| luma(&r.sky_alt) + luma(&r.sun)).sum();
                let g: f64 = rs.iter().map(|r| luma(&r.g)).sum();
                sky_line += &format!(" [{name}: {} rows, S/model {:.3} (alt {:.3}), L/g {:.3}, lamp share {:.2}]", rs.len(), gen_sd / model.max(1e-300), alt_sd / model.max(1e-300), lamp / g.max(1e-300), lamp / (lamp + gen_sd).max(1e-300));
            }
            eprintln!("    rest's sky:{sky_line}");
            if rows.iter().any(|r| r.h != [0.0; 3]) {
                let rest: Vec<&Row> = rows.iter().filter(|r| r.class == Class::Rest).collect();
                let beta = true_band_ratio(&rest, tpa);
                let band = e.sky_band.as_ref().expect("band report");
                let est_beta: [f64; 3] = std::array::from_fn(|c| band.scale[c] / band.shape_pa[c].max(1e-300));
                let fixed = refit_band(&rows, two, read_noise, Band::Fixed(beta), &|r, c| r.y[c]);
                let no_band = refit_band(&rows, two, read_noise, Band::Off, &|r, c| r.y[c]);
                let fixed_sky_exact = refit_band(&rows, two, read_noise, Band::Off, &|r, c| r.y[c] - r.sky[c] - r.sun[c] + model_sd(r, c));
                let fixed_exact_but_lamp = refit_band(&rows, two, read_noise, Band::Fixed(beta), &|r, c| if r.class == Class::Rest { r.y[c] } else { r.y[c] - r.lamp[c] - r.sky[c] - r.sun[c] + r.g[c] + model_sd(r, c) });
                // The person's and wet patch's rows left out (what a flag carried from the bright
                // frames, where they are far outside the noise, would do), at the estimator's band.
                let kept: Vec<Row> = rows.iter().filter(|r| r.class == Class::Rest).map(|r| Row { ..*r }).collect();
                let unmodelled_dropped = refit(&kept, two, read_noise, &|r, c| r.y[c]);
                eprintln!("    person and wet patch rows left out: k {unmodelled_dropped:.3}");
                if i == 3 || i == 4 {
                    k_left_out.push(unmodelled_dropped);
                }
                let fixed_lamp_exact = refit_band(&rows, two, read_noise, Band::Fixed(beta), &|r, c| r.y[c] - r.lamp[c] + r.g[c]);
                if i == 3 || i == 4 {
                    k_night.push((fixed, fixed_exact_but_lamp));
                }
                eprintln!(
                    "    band: β fitted {:.3} {:.3} {:.3}, β of the generator's sky {:.3} {:.3} {:.3}; k without band {no_band:.3}, band fixed at the generator's β {fixed:.3}, and person+wet exact {fixed_exact_but_lamp:.3}, and lamp exact {fixed_lamp_exact:.3}; sky exact {fixed_sky_exact:.3}",
                    est_beta[0], est_beta[1], est_beta[2], beta[0], beta[1], beta[2]
                );
            }
            if !alt_given {
                continue;
            }
            let alt_k = refit(&rows, two, read_noise, &|r, c| r.y[c] - r.sky[c] + r.sky_alt[c]);
            let alt_clean = refit(&rows, two, read_noise, &|r, c| if r.class == Class::Rest { r.y[c] - r.sky[c] + r.sky_alt[c] } else { r.y[c] - r.lamp[c] - r.sky[c] - r.sun[c] + r.g[c] + model_sd(r, c) });
            eprintln!("    refit k with the alternative sky: {alt_k:.3}; and the person and wet rows exact: {alt_clean:.3}; split sky column: {:.3}", refit_split(&rows, two, read_noise));
        }
    }
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    let (as_is, sky_exact) = (mean(&k_as_is), mean(&k_sky_exact));
    eprintln!("frames 1–3: mean k {as_is:.3} as estimated, {sky_exact:.3} with the sky and sun exact");
    // Measured over seeds 0–4 (before the twilight band): 0.834 and 0.969. With the band (its
    // ratio carried from frame to frame) the estimate is 0.944 / 0.967 / 0.920 on frames 1–3 and
    // the sky's mismatch is mostly gone: within 0.03 of the sky made exact.
    assert!((sky_exact - as_is).abs() < 0.05 && (sky_exact - 1.0).abs() < 0.05, "{as_is} → {sky_exact}");
    // Frames 3–4 (2026-12-05): the band at the generator's ratio gives 0.925 on the mean, the
    // person's and wet patch's rows made exact 0.982: the rest of the low k at night is the
    // light the proxy does not model (the sky's shape is fitted).
    let (fixed, clean) = (mean(&k_night.iter().map(|k| k.0).collect::<Vec<_>>()), mean(&k_night.iter().map(|k| k.1).collect::<Vec<_>>()));
    eprintln!("frames 3–4: mean k {fixed:.3} with the band at the generator's ratio, {clean:.3} with the person and wet patch exact");
    assert!(clean - fixed > 0.03 && (clean - 1.0).abs() < 0.05, "{fixed} → {clean}");
    // Leaving those rows out (what a per-surface flag carried from the bright frames would do):
    // measured 0.975 on the mean of frames 3–4 over seeds 0–4 (0.984, 0.967).
    let left_out = mean(&k_left_out);
    eprintln!("frames 3–4: mean k {left_out:.3} with the person's and wet patch's rows left out");
    assert!((left_out - 1.0).abs() < 0.05 && left_out - fixed > 0.03, "{left_out}");
}

/// What the surface flags (`estimate::surface_flags`) learn on the dusk frames 0–2 (seed 0): the
/// flagged pool entries classed as the rows above (the camera sees the person, the person hides
/// the lamp, the wet patch, the rest), against the classes' share of the whole pool.
#[test]
fn the_surface_flags_are_the_person_and_the_wet_patch() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/dusk");
    let scene = Scene::load(&root).unwrap();
    let seq = scene.sequences[0].clone();
    let lin = seq.photometry.linearizer();
    let cam = scene.camera.pose.translation.as_vec3();
    let mut est = Estimator::new(&scene, Arc::new(RayScene::new(scene.proxy.clone()))).unwrap();
    for i in 0..3 {
        est.estimate(i, &seq.times[i], &Frame::load(&seq.files[i]).unwrap(), &lin).unwrap();
    }
    let pool = est.pool();
    let class = |e: usize| {
        let p = pool.point[e];
        let ground = p.y.abs() < 1e-3 && pool.normal[e].y > 0.9;
        if through_person(cam, p) {
            Class::PersonSeen
        } else if person_shadow(p) > 0.0 {
            Class::PersonShadow
        } else if ground && (glam::Vec2::new(p.x, p.z) - glam::Vec2::from(WET.0)).length() < WET.1 + 0.05 {
            Class::Wet
        } else {
            Class::Rest
        }
    };
    let flagged: Vec<usize> = est.flagged_pixels().iter().map(|px| pool.pixel.binary_search(px).unwrap()).collect();
    let count = |v: &mut dyn Iterator<Item = usize>| {
        let mut c = [0usize; 4];
        for e in v {
            c[class(e) as usize] += 1;
        }
        c
    };
    let (f, all) = (count(&mut flagged.iter().copied()), count(&mut (0..pool.len())));
    eprintln!("flagged {} of {}: person seen / shadow / wet / rest {f:?}; in the pool {all:?}", flagged.len(), pool.len());
    let unmodelled = (f[0] + f[1] + f[2]) as f64 / flagged.len().max(1) as f64;
    eprintln!("share of the flags on the person and the wet patch: {unmodelled:.3}");
    // Measured (2026-12-05): 161 flagged, [36, 3, 121, 1] against the pool's [57, 24, 137, 3878]:
    // 99.4% of the flags on what the proxy leaves out; 88% of the wet patch's entries and 63% of
    // those that see the person (the rest of them are within the band: the person's clothes at
    // the paving's level), few of those in its shadow (the lamp is 2–5% of their light on frames
    // 1–2); one of 3878 elsewhere.
    assert!(unmodelled > 0.95, "{f:?}");
    assert!(f[2] as f64 > 0.75 * all[2] as f64 && f[0] as f64 > 0.4 * all[0] as f64, "{f:?} of {all:?}");
    assert!(f[3] as f64 <= 0.002 * all[3] as f64, "{f:?} of {all:?}");
}
