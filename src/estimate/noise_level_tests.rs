//! Tests of [`super`]: synthetic frames of known read noise and gain.

use super::*;
use crate::io::frames::{FrameData, Response, code_from_linear};
use rand::{Rng, SeedableRng, rngs::SmallRng};

/// A standard normal draw (Box–Muller).
fn gauss(rng: &mut SmallRng) -> f64 {
    let u: f64 = rng.random_range(f64::EPSILON..1.0);
    let v: f64 = rng.random_range(0.0..1.0);
    (-2.0 * u.ln()).sqrt() * (2.0 * std::f64::consts::PI * v).cos()
}

/// A noiseless scene: a ramp in `x` from `lo` to `hi` (log-spaced, so that every level has
/// blocks), a slow texture of ±10%, and discs and turned squares at other levels whose edges
/// cut blocks at every angle.
fn clean(w: usize, h: usize, lo: f64, hi: f64, seed: u64) -> Vec<f64> {
    let mut rng = SmallRng::seed_from_u64(seed);
    let shapes: Vec<(f64, f64, f64, f64, f64, bool)> = (0..12)
        .map(|_| {
            let (cx, cy) = (rng.random_range(0.0..w as f64), rng.random_range(0.0..h as f64));
            (cx, cy, rng.random_range(6.0..30.0), rng.random_range(0.0..1.5), rng.random_range(0.3..2.0), rng.random_bool(0.5))
        })
        .collect();
    let mut out = Vec::with_capacity(w * h);
    for y in 0..h {
        for x in 0..w {
            let t = x as f64 / (w - 1) as f64;
            let mut v = lo * (hi / lo).powf(t) * (1.0 + 0.1 * (x as f64 / 9.0).sin() * (y as f64 / 13.0).cos());
            for &(cx, cy, r, turn, gain, disc) in &shapes {
                let (dx, dy) = (x as f64 - cx, y as f64 - cy);
                let (u, s) = (dx * turn.cos() + dy * turn.sin(), -dx * turn.sin() + dy * turn.cos());
                let inside = if disc { u * u + s * s < r * r } else { u.abs() < r && s.abs() < r };
                if inside {
                    v *= gain;
                }
            }
            out.push(v);
        }
    }
    out
}

/// `clean` with Poissonian–Gaussian noise of variance `σ_r² + g·μ` (and `(c·μ)²`), clipped at 0.
fn noisy(clean: &[f64], sigma_r: f64, gain: f64, rel: f64, seed: u64) -> Vec<f32> {
    let mut rng = SmallRng::seed_from_u64(seed);
    clean.iter().map(|&m| (m + (sigma_r * sigma_r + gain * m + (rel * m).powi(2)).sqrt() * gauss(&mut rng)).max(0.0) as f32).collect()
}

#[test]
fn it_recovers_the_read_noise_of_poissonian_gaussian_frames() {
    // (σ_r, g, c, levels lo..hi): dusk-like (the bundled frames' σ_r with 1% relative noise), a
    // shot-noise dominated frame, a frame at night with read noise only, a bright one.
    let cases = [
        (5e-4, 0.0, 0.01, 2e-3, 0.2),
        (1e-3, 1e-4, 0.0, 5e-3, 0.5),
        (2e-4, 0.0, 0.0, 1e-3, 1e-2),
        (2e-3, 5e-4, 0.005, 2e-2, 2.0),
    ];
    let (w, h) = (384, 384);
    for (k, &(sr, g, c, lo, hi)) in cases.iter().enumerate() {
        for seed in 0..3 {
            let plane = noisy(&clean(w, h, lo, hi, seed), sr, g, c, 100 + seed);
            let m = measure_plane(&plane, w, h, |_| 0.0).expect("a fit");
            eprintln!("case {k} seed {seed}: σ_r {:.4e} ± {:.1e} (truth {sr:.1e}), g {:.2e} (truth {g:.1e}), c {:.2e} (truth {:.1e}), {} blocks, {} bins", m.read_noise, m.read_noise_se, m.gain, m.relative, c * c, m.blocks, m.bins);
            // The reported standard error covers the error (3 standard errors), and is small
            // enough to say something: at most 8% of σ_r with ≈ 2000 blocks.
            assert!((m.read_noise - sr).abs() < 3.0 * m.read_noise_se, "case {k} seed {seed}: {m:?}");
            assert!(m.read_noise_se < 0.08 * sr, "case {k} seed {seed}: {m:?}");
        }
    }
}

#[test]
fn a_frame_mostly_at_zero_keeps_its_bright_part() {
    // 80% of the frame at 0–1σ (clipped at zero: a third of those pixels are 0), 20% a band
    // from 4σ to 100σ: the dark bins are left out (their σ shrunk by the clip, up to 40% at
    // μ = 0), and the intercept comes from the band.
    let (w, h, sr) = (384, 384, 5e-4);
    for seed in 0..3 {
        let x0 = w * 80 / 100;
        let band = clean(w - x0, h, 4.0 * sr, 100.0 * sr, seed);
        let dark_at = |x: usize, y: usize| 0.5 * sr * (1.0 + (x as f64 / 17.0).sin() * (y as f64 / 23.0).cos());
        let dark: Vec<f64> = (0..w * h).map(|i| if i % w < x0 { dark_at(i % w, i / w) } else { band[i / w * (w - x0) + i % w - x0] }).collect();
        let plane = noisy(&dark, sr, 0.0, 0.01, 200 + seed);
        let m = measure_plane(&plane, w, h, |_| 0.0).expect("a fit");
        eprintln!("mostly dark, seed {seed}: σ_r {:.4e} ± {:.1e}, {} blocks, {} bins", m.read_noise, m.read_noise_se, m.blocks, m.bins);
        assert!((m.read_noise - sr).abs() < 3.0 * m.read_noise_se, "seed {seed}: {m:?}");
        // ≈ 250 blocks in the band, against ≈ 2000 over the whole level range in the test above:
        // a standard error under 15%.
        assert!(m.read_noise_se < 0.15 * sr, "seed {seed}: {m:?}");
    }
    // Without the clip's test the dark bins would pull σ_r low: the dark part alone has too few
    // bins above 3σ for a fit.
    let dark: Vec<f64> = (0..w * h).map(|i| 0.5 * sr * (1.0 + (i as f64 / 17.0).sin())).collect();
    assert_eq!(measure_plane(&noisy(&dark, sr, 0.0, 0.0, 9), w, h, |_| 0.0), None);
}

#[test]
fn an_8_bit_srgb_frame_recovers_its_linear_read_noise() {
    // Noise added in linear units, then encoded to 8-bit sRGB: the code step in linear units is
    // 3.0·10⁻⁴ at black and 0.0036 at 0.3, whose Δ²/12 is taken off each bin.
    let (w, h, sr, g) = (320, 240, 2e-3, 2e-4);
    for seed in 0..3 {
        let planes: Vec<Vec<f32>> = (0..3).map(|c| noisy(&clean(w, h, 0.01, 0.3, seed), sr, g, 0.0, 300 + 3 * seed + c)).collect();
        let codes = (0..w * h).flat_map(|i| (0..3).map(move |c| i * 3 + c)).map(|k| (code_from_linear(&Response::Srgb, planes[k % 3][k / 3], 0) * 255.0).round() as u16).collect();
        let frame = Frame { width: w as u32, height: h as u32, data: FrameData::Ldr { bits: 8, codes } };
        let lin = Linearizer::new(&Response::Srgb, 1.0, 0.98, None);
        let m = measure(&frame, &lin).expect("a fit");
        eprintln!("8-bit, seed {seed}: σ_r {:.4e} ± {:.1e}, g {:.2e}, {} blocks, {} bins", m.read_noise, m.read_noise_se, m.gain, m.blocks, m.bins);
        assert!((m.read_noise - sr).abs() < 3.0 * m.read_noise_se, "seed {seed}: {m:?}");
        assert!(m.read_noise_se < 0.1 * sr, "seed {seed}: {m:?}");
    }
}

#[test]
fn a_textured_noiseless_frame_has_no_read_noise() {
    // Texture, discs and turned squares, no noise: the edges' blocks are left out and the
    // texture's high-pass is ≈ 10⁻⁴ of its amplitude, so σ_r is that small against the levels.
    let (w, h) = (384, 384);
    let plane: Vec<f32> = clean(w, h, 1e-2, 1.0, 4).into_iter().map(|v| v as f32).collect();
    let m = measure_plane(&plane, w, h, |_| 0.0).expect("a fit");
    eprintln!("noiseless: {m:?}");
    assert!(m.read_noise < 1e-5, "{m:?}");
}
