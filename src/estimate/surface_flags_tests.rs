use super::*;
use crate::estimate::noise::robust_fit_noise;
use crate::estimate::solve::HDR_NOISE_FLOOR_REL;
use rand::{Rng, SeedableRng, rngs::SmallRng};

/// A standard normal draw (Box–Muller).
fn gauss(rng: &mut SmallRng) -> f64 {
    let u: f64 = rng.random_range(f64::EPSILON..1.0);
    let v: f64 = rng.random_range(0.0..1.0);
    (-2.0 * u.ln()).sqrt() * (2.0 * std::f64::consts::PI * v).cos()
}

/// Read noise of the synthetic camera (the dusk scene's, radiance).
const SIGMA_R: f64 = 5e-4;
/// Entries of the synthetic pool, and the block the model does not know (all lit by the lamp,
/// as the dusk scene's wet patch under the street lamp).
const N: usize = 1000;
const BLOCK: std::ops::Range<usize> = 0..60;

/// A pool: a sky column `a` on every entry, a lamp column `g` on the block and on 40% of the
/// rest. `pool.2[i]` is the entry's true albedo factor against the model's.
fn pool(seed: u64) -> (Vec<f64>, Vec<f64>) {
    let mut rng = SmallRng::seed_from_u64(seed);
    let (mut a, mut g) = (Vec::with_capacity(N), Vec::with_capacity(N));
    for i in 0..N {
        let rho: f64 = rng.random_range(0.2..0.6);
        a.push(rho * rng.random_range(0.5..1.0) / std::f64::consts::PI);
        let lit = BLOCK.contains(&i) || rng.random_bool(0.4);
        g.push(if lit { rho * rng.random_range(0.5..2.0) } else { 0.0 });
    }
    (a, g)
}

/// A frame: `x = [Pa, k]`, the block's true light `factor` times the model's, independent noise
/// `σ_r` and 1% relative, clipped at zero.
fn frame(a: &[f64], g: &[f64], x: [f64; 2], factor: f64, seed: u64) -> Vec<f64> {
    let mut rng = SmallRng::seed_from_u64(seed);
    (0..N)
        .map(|i| {
            let mu = (a[i] * x[0] + g[i] * x[1]) * if BLOCK.contains(&i) { factor } else { 1.0 };
            (mu + SIGMA_R * gauss(&mut rng) + 0.01 * mu * gauss(&mut rng)).max(0.0)
        })
        .collect()
}

/// The robust fit (`super::noise`) on 500 entries drawn among those not excluded; returns `[Pa, k]`.
fn fit(a: &[f64], g: &[f64], y: &[f64], excluded: Option<&[bool]>, seed: u64) -> [f64; 2] {
    let mut rng = SmallRng::seed_from_u64(seed);
    let keep: Vec<usize> = (0..N).filter(|&i| !excluded.is_some_and(|x| x[i])).collect();
    let rows: Vec<usize> = rand::seq::index::sample(&mut rng, keep.len(), 500).into_iter().map(|k| keep[k]).collect();
    let cols = vec![rows.iter().map(|&i| a[i]).collect(), rows.iter().map(|&i| g[i]).collect()];
    let yy: Vec<f64> = rows.iter().map(|&i| y[i]).collect();
    let f = robust_fit_noise(&cols, &yy, HDR_NOISE_FLOOR_REL, SIGMA_R, &mut rng).unwrap();
    [f.x[0], f.x[1]]
}

/// The fitted model's observation of every entry (as `Estimator::flag_observations`).
fn observations(a: &[f64], g: &[f64], y: &[f64], x: [f64; 2]) -> Vec<Observation> {
    (0..N).map(|i| Observation { entry: i as u32, y: y[i], mu: a[i] * x[0] + g[i] * x[1], group: 0 }).collect()
}

/// The bright frames' light (sky and lamp 100× the night's: the lamp-lit entries at 40–240 σ_r)
/// and the night's (the lamp-lit entries at 0.8–4.8 σ_r, the sky at 0.03–0.4 σ_r).
const BRIGHT: [f64; 2] = [0.2, 0.2];
const NIGHT: [f64; 2] = [2e-3, 2e-3];

/// Two bright frames flag the block; on the night frames it is hidden in the noise.
fn learned(a: &[f64], g: &[f64]) -> SurfaceFlags {
    let mut flags = SurfaceFlags::new(N);
    for f in 0..2 {
        let y = frame(a, g, BRIGHT, 0.6, 100 + f);
        let x = fit(a, g, &y, None, 200 + f);
        // the robust fit rejects the block on a bright frame: Pa and k within 2% of the truth
        assert!((x[0] / BRIGHT[0] - 1.0).abs() < 0.02 && (x[1] / BRIGHT[1] - 1.0).abs() < 0.02, "bright fit {x:?}");
        let up = flags.observe(&observations(a, g, &y, x), SIGMA_R);
        assert_eq!(up.observed, N);
        // one observation is not a flag (a passer-by, a noise excursion)
        assert_eq!(flags.flagged(), if f == 0 { 0 } else { BLOCK.len() }, "frame {f}: {up:?}");
    }
    flags
}

#[test]
fn a_darker_block_is_flagged_on_bright_frames_and_the_night_fit_is_unbiased() {
    let (a, g) = pool(1);
    let flags = learned(&a, &g);
    // exactly the block: the others are 1% relative noise, 4.685 scales away twice in a row never
    assert!(BLOCK.clone().all(|i| flags.is_flagged(i)) && flags.flagged() == BLOCK.len());
    let (mask, flagged, cap) = flags.exclusion(0..N as u32);
    let mask = mask.expect("the block is left out");
    assert_eq!((flagged, cap, mask.iter().filter(|&&m| m).count()), (BLOCK.len(), N / 10, BLOCK.len()));
    // Night frames: the block's −40% is 0.3–1.9 σ_r per entry, inside Tukey's band. The mean k
    // over 12 frames, each fitted on 500 of the entries: without the flags the block (60 of the
    // ≈ 420 lamp-lit entries, half of them drawn) at 0.6 pulls k down by ≈ 0.4·60/420 = 5.7%
    // (measured −4.7%); with them left out it is within its noise (measured +1.1%). Each frame's k
    // has a standard error of ≈ 3% (`super::noise`'s test), so the mean of 12 has ≈ 0.9%.
    let (mut with, mut without) = (0.0, 0.0);
    let mut carried = flags.clone();
    let frames = 12;
    for f in 0..frames {
        let y = frame(&a, &g, NIGHT, 0.6, 300 + f);
        let x_with = fit(&a, &g, &y, Some(&mask), 400 + f);
        let x_without = fit(&a, &g, &y, None, 400 + f);
        with += x_with[1] / NIGHT[1] / frames as f64;
        without += x_without[1] / NIGHT[1] / frames as f64;
        // the night neither flags nor releases: its noise (≥ σ_r) hides the departure
        let up = carried.observe(&observations(&a, &g, &y, x_with), SIGMA_R);
        assert_eq!(up.released, 0, "night frame {f}");
        assert!((0..N).all(|i| carried.is_flagged(i) == flags.is_flagged(i)), "night frame {f}");
    }
    eprintln!("night k: with flags {with:.4}, without {without:.4}");
    // 2.5 standard errors of the mean of 12 (0.9%) around the truth, and around the bias
    assert!((with - 1.0).abs() < 0.025, "with the flags, mean k {with:.4}");
    assert!(without < 0.975, "without the flags, mean k {without:.4}");
}

#[test]
fn flags_are_released_when_the_surface_is_consistent_again() {
    let (a, g) = pool(2);
    let mut flags = learned(&a, &g);
    // a night frame where the block is consistent: its noise hides a 40% departure, no release
    let y = frame(&a, &g, NIGHT, 1.0, 500);
    flags.observe(&observations(&a, &g, &y, NIGHT), SIGMA_R);
    assert_eq!(flags.flagged(), BLOCK.len());
    // a bright frame where it is consistent (the parked car drove off): the departure from the
    // entries' mean is far beyond their noise, so they start afresh, released at once
    let y = frame(&a, &g, BRIGHT, 1.0, 501);
    let x = fit(&a, &g, &y, flags.exclusion(0..N as u32).0.as_deref(), 502);
    let up = flags.observe(&observations(&a, &g, &y, x), SIGMA_R);
    assert_eq!((up.released, flags.flagged()), (BLOCK.len(), 0), "{up:?}");
    assert_eq!(flags.exclusion(0..N as u32), (None, 0, N / 10));
    // and it takes two bright frames again to flag it
    let y = frame(&a, &g, BRIGHT, 0.6, 503);
    flags.observe(&observations(&a, &g, &y, BRIGHT), SIGMA_R);
    assert_eq!(flags.flagged(), 0);
}

#[test]
fn the_cap_leaves_out_the_largest_departures() {
    // 300 of 1000 entries darker than the model by 20–50% (the model wrong over a third of the
    // view), the rest within 1% relative noise: all 300 flagged, at most 100 left out, the
    // 100 darkest.
    let mut rng = SmallRng::seed_from_u64(9);
    let departure = |i: usize| if i < 300 { 0.2 + 0.3 * i as f64 / 300.0 } else { 0.0 };
    let mut flags = SurfaceFlags::new(N);
    for _ in 0..2 {
        let obs: Vec<Observation> = (0..N).map(|i| Observation { entry: i as u32, y: 1.0 - departure(i) + 0.01 * gauss(&mut rng), mu: 1.0, group: 0 }).collect();
        flags.observe(&obs, SIGMA_R);
    }
    assert_eq!(flags.flagged(), 300);
    let (mask, flagged, cap) = flags.exclusion(0..N as u32);
    let mask = mask.unwrap();
    assert_eq!((flagged, cap), (300, 100));
    let left_out: Vec<usize> = (0..N).filter(|&i| mask[i]).collect();
    assert_eq!(left_out.len(), 100);
    // the darkest 100 are entries 200–299 (departure 0.40–0.50); the noise of 0.01 is 10 entries'
    // steps of departure, so the edge may move by up to 3 of its σ: 30 entries
    assert!(left_out.iter().all(|&i| (170..300).contains(&i)), "{left_out:?}");
    assert!(left_out.iter().filter(|&&i| i >= 200).count() >= 85, "{left_out:?}");
    // a pool of which only 5 entries are valid this frame caps at 0: nothing left out
    assert_eq!(flags.exclusion(0..5).0, None);
}
