//! The coherent median cut (`heliar::vem::sampling::coherent_cut`, issue 14) through the public
//! API: coherence under small map changes and a change of `N`, the temporal FIR following each
//! leaf on a static map, and clustering and peaks with its lights. (Closed forms: unit tests in
//! the module.)

use glam::Vec3;
use heliar::vem::eval::synth;
use heliar::vem::fir::Temporal;
use heliar::vem::polar::luminance;
use heliar::vem::sampling::SamplerKind;
use heliar::vem::sampling::coherent_cut::{CoherentCut, coherent_cut_lights};
use heliar::vem::{Decomposer, VemConfig};

fn angle(a: Vec3, b: Vec3) -> f64 {
    (a.dot(b).clamp(-1.0, 1.0) as f64).acos()
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
    Decomposer::new(VemConfig { lights: 64, sampler: SamplerKind::CoherentCut, temporal, clusters, peaks: Some(peaks), ..VemConfig::default() })
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
    let maps = heliar::vem::eval::sunny::polar_maps(360, 90, 2);
    let mut dec = decomposer(Temporal::Causal, Some(12), true);
    for m in &maps {
        let s = dec.process(m);
        let l = dec.lights();
        assert_eq!(l.len(), 64);
        assert_eq!(l.iter().filter(|x| x.index >= heliar::vem::peaks::PEAK_INDEX_BASE).count(), 1);
        let y: f64 = l.iter().map(|x| luminance(x.rgb) as f64).sum();
        assert!((y - s.power).abs() < 1e-3 * s.power, "{y} vs {}", s.power);
        let c = dec.clusters();
        assert!(!c.is_empty() && c.len() <= 12, "{}", c.len());
    }
}

#[test]
fn peaks_are_the_default_and_join_both_glossy_sets_at_their_own_power() {
    // Peaks are on by default with the coherent cut. With a glossy set (Havran §4.2) the sun's
    // light is in `L` and `H` alike, unscaled; the samples of the remainder fill the rest of each
    // set, so both sets hold the map's power (f32 sums over 256 lights: 1e-4).
    use heliar::vem::glossy::shade_glossy_all;
    use heliar::vem::peaks::PEAK_INDEX_BASE;
    use heliar::vem::regions::GpuLight;
    assert!(VemConfig::default().peaks_on());
    assert!(!VemConfig { sampler: SamplerKind::Havran, ..VemConfig::default() }.peaks_on());
    let bad = VemConfig { glossy_lights: Some(256), sampler: SamplerKind::MedianCut, ..VemConfig::default() };
    assert!(Decomposer::new(bad).is_err(), "median cut has no equal-power samples for a glossy set");
    let maps = heliar::vem::eval::sunny::polar_maps(360, 90, 2);
    let mut dec = Decomposer::new(VemConfig { lights: 64, glossy_lights: Some(256), temporal: Temporal::ZeroPhase, ..VemConfig::default() }).expect("glossy with peaks");
    for m in &maps {
        let s = dec.process(m);
        let (h, l) = (dec.lights().to_vec(), dec.glossy_lights().expect("a glossy set").to_vec());
        assert_eq!((h.len(), l.len()), (64, 256));
        let (sh, sl): (Vec<_>, Vec<_>) = (h.iter().filter(|x| x.index >= PEAK_INDEX_BASE).collect(), l.iter().filter(|x| x.index >= PEAK_INDEX_BASE).collect());
        assert_eq!(sh.len(), 1);
        assert_eq!(sh, sl, "the same sun light in both sets");
        // Measured at the map's resolution: the sun splatted over 2×2 texels of 1°.
        assert!(sh[0].radius > 0.0 && sh[0].radius < 2f32.to_radians(), "a sun of a few texels: {}", sh[0].radius);
        for set in [&h, &l] {
            let y: f64 = set.iter().map(|x| luminance(x.rgb) as f64).sum();
            assert!((y - s.power).abs() < 1e-4 * s.power, "{y} vs {}", s.power);
        }
        // The cone's energy from `L` only, the rest from `H` only: with a unit factor the two
        // strata give the map's power once. The sun holds 60% of it, so counting it in both sets
        // would give 1.6×; the stratification of the remainder costs at most a few percent.
        let (gl, gh): (Vec<GpuLight>, Vec<GpuLight>) = (l.iter().map(GpuLight::from_light).collect(), h.iter().map(GpuLight::from_light).collect());
        let cos_cone = 0.1f32.cos();
        for r in [sh[0].dir, Vec3::Y, Vec3::new(0.5, 0.5, -0.7).normalize()] {
            let e = luminance(shade_glossy_all(&gl, &gh, r, cos_cone, None, |_| 1.0)) as f64;
            assert!((e - s.power).abs() < 0.03 * s.power, "R = {r:?}: {e} vs {}", s.power);
        }
    }
}
