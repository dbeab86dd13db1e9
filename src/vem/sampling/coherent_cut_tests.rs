//! Unit tests of the coherent median cut (closed forms, coherence, the FIR on a static map).

use super::*;
use crate::vem::eval::synth;
use crate::vem::fir::Temporal;
use crate::vem::{Decomposer, VemConfig};
use glam::Vec3;

fn power(l: &[Light]) -> [f64; 3] {
    let mut p = [0.0; 3];
    for x in l {
        for c in 0..3 {
            p[c] += x.rgb[c] as f64;
        }
    }
    p
}

fn angle(a: Vec3, b: Vec3) -> f64 {
    (a.dot(b).clamp(-1.0, 1.0) as f64).acos()
}

#[test]
fn leaf_indices_are_a_bijection_and_a_new_light_takes_the_next_index() {
    for n in [1usize, 2, 3, 7, 64, 300, 1000] {
        let mut idx: Vec<u32> = (n..2 * n).map(leaf_index).collect();
        idx.sort_unstable();
        assert_eq!(idx, (0..n as u32).collect::<Vec<_>>(), "n={n}");
        // N → N + 1 splits leaf N into 2N (same index) and 2N + 1 (index N).
        assert_eq!(leaf_index(2 * n), leaf_index(n));
        assert_eq!(leaf_index(2 * n + 1), n as u32);
    }
}

#[test]
fn a_uniform_map_gives_exactly_n_leaves_of_equal_power_summing_to_the_map() {
    // Closed form: every leaf holds P/N of the solid-angle-weighted power P = Σ L·ΔΩ (2π·L for a
    // constant L; the texel sum is exact up to f32 solid angles, 1e-5).
    let map = PolarMap::from_fn(360, 90, |_| [2.0, 1.0, 0.5]);
    let want = map.total_power();
    assert!((want[0] - 2.0 * std::f64::consts::TAU).abs() < 1e-4 * want[0]);
    for n in [1usize, 7, 64, 128, 300] {
        let l = coherent_cut_lights(&map, n);
        assert_eq!(l.len(), n);
        assert!(l.iter().enumerate().all(|(k, x)| x.index == k as u32));
        let got = power(&l);
        for c in 0..3 {
            assert!((got[c] - want[c]).abs() < 1e-6 * want[c], "n={n} channel {c}: {} vs {}", got[c], want[c]);
        }
        for x in &l {
            // Cuts are continuous, so the leaves are equal to f64 rounding (f32 output: 1e-5).
            assert!((x.rgb[0] as f64 - want[0] / n as f64).abs() < 1e-5 * want[0] / n as f64, "n={n}: {:?}", x.rgb);
            assert!(x.dir.y >= 0.0 && (x.dir.length() - 1.0).abs() < 1e-5);
        }
    }
}

#[test]
fn a_single_bright_texel_holds_every_leaf_at_its_direction() {
    // All the energy is in one texel, so every equal-energy leaf lies inside it and its centroid
    // is the texel's direction; N = 1 is the one light at that texel.
    let mut map = PolarMap::new(360, 90);
    let (i, j) = (123u32, 40u32);
    map.data[(j * 360 + i) as usize] = [50.0, 40.0, 30.0];
    let dw = map.row_solid_angle(j) as f64;
    for n in [1usize, 7, 64] {
        let l = coherent_cut_lights(&map, n);
        assert_eq!(l.len(), n);
        for x in &l {
            assert!(angle(x.dir, map.texel_dir(i, j)) < 1e-3, "n={n}: {:?}", x.dir);
        }
        let p = power(&l);
        assert!((p[0] - 50.0 * dw).abs() < 1e-6 * 50.0 * dw, "n={n}: {p:?}");
    }
    assert!(coherent_cut_lights(&PolarMap::new(36, 9), 8).is_empty());
    assert!(coherent_cut_lights(&map, 0).is_empty());
}

#[test]
fn the_energy_of_a_fractional_rectangle_is_exact_for_a_piecewise_constant_map() {
    // Closed form: half of texel (5, 3) and all of texel (6, 3), each of its own value.
    let mut map = PolarMap::new(12, 6);
    map.data[3 * 12 + 5] = [1.0; 3];
    map.data[3 * 12 + 6] = [3.0; 3];
    let mut cut = CoherentCut::new();
    cut.rebuild(&map);
    let e = cut.energy(&Rect { x0: 5.5, y0: 3.0, x1: 7.0, y1: 4.0 });
    let dw = map.row_solid_angle(3) as f64;
    assert!((e - (0.5 + 3.0) * dw).abs() < 1e-9, "{e} vs {}", 3.5 * dw);
    let e = cut.energy(&Rect { x0: 5.0, y0: 3.25, x1: 6.0, y1: 3.75 });
    assert!((e - 0.5 * dw).abs() < 1e-9);
}

#[test]
fn a_small_local_change_moves_every_index_little() {
    // A 10% brighter 6° patch of sky (the coherence case of `heliar bench vem`): every cut moves
    // continuously, so no light jumps (2°) and the median motion is a small fraction of a texel.
    for (name, a, b) in synth::local_changes(360, 90) {
        let mut cut = CoherentCut::new();
        let mut la = Vec::new();
        let mut lb = Vec::new();
        cut.lights(&a, 300, &mut la);
        cut.lights(&b, 300, &mut lb);
        let mut m: Vec<f64> = la.iter().zip(&lb).map(|(x, y)| angle(x.dir, y.dir).to_degrees()).collect();
        m.sort_by(f64::total_cmp);
        let (median, max) = (m[m.len() / 2], m[m.len() - 1]);
        if name != "next_frame" {
            assert!(median < 0.1 && max < 2.0, "{name}: median {median}°, max {max}°");
        }
    }
}

#[test]
fn one_more_light_keeps_the_indices_near_their_places() {
    // N → N + 1 splits one leaf; the other leaves move only by their ancestors' energy fractions.
    let map = synth::render_polar(&synth::outdoor(0, synth::RATE_HZ), 360, 90, 2);
    let (a, b) = (coherent_cut_lights(&map, 300), coherent_cut_lights(&map, 301));
    assert_eq!((a.len(), b.len()), (300, 301));
    let mut m: Vec<f64> = a.iter().zip(&b).map(|(x, y)| angle(x.dir, y.dir).to_degrees()).collect();
    m.sort_by(f64::total_cmp);
    assert!(m[150] < 1.0, "median motion {}°", m[150]);
}

fn decomposer(temporal: Temporal, clusters: Option<usize>, peaks: bool) -> Decomposer {
    Decomposer::new(VemConfig { lights: 64, sampler: crate::vem::sampling::SamplerKind::CoherentCut, temporal, clusters, peaks, ..VemConfig::default() })
        .expect("a valid configuration")
}

#[test]
fn the_filtered_lights_of_a_static_map_are_the_unfiltered_ones() {
    // The FIR has unit gain and follows each leaf index, so a constant input passes unchanged
    // (f32 taps: directions to 1e-5, power to 1e-4 relative).
    let map = synth::render_polar(&synth::outdoor(0, synth::RATE_HZ), 360, 90, 2);
    let want = coherent_cut_lights(&map, 64);
    for temporal in [Temporal::Causal, Temporal::MinimumPhase, Temporal::ZeroPhase] {
        let mut dec = decomposer(temporal, None, false);
        for t in 0..14 {
            dec.process(&map);
            let got = dec.lights();
            assert_eq!(got.len(), 64);
            for (g, w) in got.iter().zip(&want) {
                assert_eq!(g.index, w.index);
                assert!((g.dir - w.dir).length() < 1e-5, "{temporal:?} frame {t} light {}: {:?} vs {:?}", g.index, g.dir, w.dir);
                for c in 0..3 {
                    assert!((g.rgb[c] - w.rgb[c]).abs() < 1e-4 * w.rgb[c].max(1e-3), "{temporal:?} frame {t}: {:?} vs {:?}", g.rgb, w.rgb);
                }
            }
        }
    }
}

#[test]
fn clustering_and_peaks_work_with_the_cut_lights() {
    let maps = crate::vem::eval::sunny::polar_maps(360, 90, 2);
    let mut dec = decomposer(Temporal::Causal, Some(12), true);
    for m in &maps {
        let s = dec.process(m);
        let l = dec.lights();
        assert_eq!(l.len(), 64);
        assert_eq!(l.iter().filter(|x| x.index >= crate::vem::peaks::PEAK_INDEX_BASE).count(), 1);
        let y: f64 = l.iter().map(|x| luminance(x.rgb) as f64).sum();
        assert!((y - s.power).abs() < 1e-3 * s.power, "{y} vs {}", s.power);
        let c = dec.clusters();
        assert!(!c.is_empty() && c.len() <= 12, "{}", c.len());
    }
}
