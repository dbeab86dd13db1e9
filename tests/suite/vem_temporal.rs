//! The temporal filter on footage and live (issue 14, part 4): zero phase for recorded input (no
//! lag), minimum phase live (low lag), against the paper's causal FIR (4 frames of lag at 21 Hz).

use heliar::vem::eval::lag::{lag_error, references, unfiltered_error, upper_normals};
use heliar::vem::eval::sunny;
use heliar::vem::fir::Temporal;
use heliar::vem::polar::PolarMap;
use heliar::vem::sampling::pattern::Pattern;
use heliar::vem::sampling::SamplerKind;
use heliar::vem::{Decomposer, VemConfig, lights_of_map};

/// Havran's samples (the sampler these tests were written for; the coherent cut has its own).
fn cfg(temporal: Temporal) -> VemConfig {
    VemConfig { polar_width: 180, polar_height: 45, lights: 128, temporal, sampler: SamplerKind::Havran, ..VemConfig::default() }
}

#[test]
fn the_coherent_cut_with_peaks_is_followed_by_the_filter_without_adding_error() {
    // The FIR follows each leaf index; with the sun as its own light the leaves barely move as
    // the cloud crosses it, so filtered lights (zero phase on files, minimum phase live) stay
    // within 1.5× the unfiltered error. (Without peaks the sun's leaves move tens of degrees as
    // it dims, and filtering them costs ~15× the unfiltered error: `heliar bench vem --what sun`.)
    let maps = sunny::polar_maps(180, 45, sunny::FRAMES);
    let normals = upper_normals(64, 777);
    let refs = references(&maps, &normals);
    let c = |temporal| VemConfig { polar_width: 180, polar_height: 45, lights: 128, temporal, sampler: SamplerKind::CoherentCut, peaks: Some(true), ..VemConfig::default() };
    let floor = lag_error(&maps, c(Temporal::ZeroPhase), &normals, &refs).unwrap();
    let mut rel = Vec::new();
    for (m, r) in maps.iter().zip(&refs) {
        // Unfiltered: a fresh decomposer's first frame is its own map's lights.
        let mut one = Decomposer::new(c(Temporal::Causal)).unwrap();
        one.process(m);
        for (n, e) in normals.iter().zip(r) {
            let got = heliar::vem::irradiance(one.lights(), *n);
            rel.push(((0.2126 * got[0] + 0.7152 * got[1] + 0.0722 * got[2]) - e).abs() / e);
        }
    }
    let unfiltered = rel.iter().sum::<f64>() / rel.len() as f64;
    let min = lag_error(&maps, c(Temporal::MinimumPhase), &normals, &refs).unwrap();
    println!("coherent cut + peaks: unfiltered {:.3}%, zero phase {:.3}%, minimum phase {:.3}%", 100.0 * unfiltered, 100.0 * floor.mean, 100.0 * min.mean);
    assert!(floor.mean < 1.5 * unfiltered && min.mean < 1.5 * unfiltered, "{floor:?} {min:?} vs {unfiltered}");
    assert!(unfiltered < 0.01, "{unfiltered}");
}

#[test]
fn zero_phase_lights_describe_their_own_frame_on_the_cloud_crossing_the_sun() {
    // The sun-dominated Hošek–Wilkie sequence (`vem::eval::sunny`): a cloud crosses the sun, which
    // holds 60% of the power, and takes it down to 3% and back over about 20 frames.
    let maps = sunny::polar_maps(180, 45, sunny::FRAMES);
    let normals = upper_normals(64, 777);
    let refs = references(&maps, &normals);
    let floor = unfiltered_error(&maps, &cfg(Temporal::Causal), &normals, &refs);
    let zero = lag_error(&maps, cfg(Temporal::ZeroPhase), &normals, &refs).unwrap();
    let causal = lag_error(&maps, cfg(Temporal::Causal), &normals, &refs).unwrap();
    let min = lag_error(&maps, cfg(Temporal::MinimumPhase), &normals, &refs).unwrap();
    for (name, e) in [("unfiltered", floor), ("zero phase", zero), ("minimum phase", min), ("causal (paper)", causal)] {
        println!(
            "{name:15} delay {:.2} frames: error mean {:.2}%, p95 {:.2}%, max {:.2}%",
            e.delay_frames,
            100.0 * e.mean,
            100.0 * e.p95,
            100.0 * e.max
        );
    }
    assert_eq!(causal.delay_frames, 4.0);
    // The lag costs the causal filter several times the zero-phase error, which stays close to
    // the sampling error of the unfiltered lights; live, the minimum-phase filter is in between.
    assert!(zero.mean < 0.5 * causal.mean && zero.p95 < 0.5 * causal.p95, "{zero:?} vs {causal:?}");
    assert!(zero.mean < 1.5 * floor.mean, "{zero:?} vs unfiltered {floor:?}");
    assert!(min.delay_frames < 2.0 && min.mean < causal.mean, "{min:?} vs {causal:?}");
}

#[test]
fn zero_phase_leaves_a_constant_sequence_unchanged_from_first_to_last_frame() {
    // Closed form: every (shortened, renormalised) window sums to 1, so with the same map in
    // every frame each frame's lights are that map's unfiltered lights, the ends included.
    let map = PolarMap::from_fn(180, 45, |d| [1.0 + 2.0 * d.y.max(0.0) + d.x.max(0.0), 1.0 + d.y.max(0.0), 0.5 + 0.5 * d.z.abs()]);
    let want = lights_of_map(&map, SamplerKind::Havran, Pattern::RelaxedHalton, 128);
    let mut dec = Decomposer::new(cfg(Temporal::ZeroPhase)).unwrap();
    let mut seen = Vec::new();
    let check = |dec: &Decomposer, s: heliar::vem::FrameSummary| {
        assert_eq!(s.describes_frame, s.frame);
        assert!((s.filtered_power - s.power).abs() < 1e-5 * s.power, "{s:?}");
        assert_eq!(dec.lights().len(), want.len());
        for (a, b) in dec.lights().iter().zip(&want) {
            assert_eq!(a.index, b.index);
            assert!(a.dir.angle_between(b.dir) < 1e-3, "frame {}: {:?} vs {:?}", s.frame, a.dir, b.dir);
            for c in 0..3 {
                assert!((a.rgb[c] - b.rgb[c]).abs() < 1e-4 * b.rgb[c].max(1e-3), "frame {}: {:?} vs {:?}", s.frame, a.rgb, b.rgb);
            }
        }
        s.frame
    };
    for _ in 0..12 {
        if let Some(s) = dec.push(&map) {
            seen.push(check(&dec, s));
        }
    }
    assert_eq!(seen, (0..8).collect::<Vec<u64>>(), "frame t is out once frame t + 4 is in");
    while let Some(s) = dec.flush() {
        seen.push(check(&dec, s));
    }
    assert_eq!(seen, (0..12).collect::<Vec<u64>>());
}

#[test]
fn causal_filters_say_which_earlier_frame_they_describe() {
    let maps = sunny::polar_maps(90, 23, 8);
    for (temporal, delay) in [(Temporal::Causal, 4), (Temporal::MinimumPhase, 1)] {
        let mut dec = Decomposer::new(VemConfig { polar_width: 90, polar_height: 23, lights: 32, temporal, ..VemConfig::default() }).unwrap();
        assert_eq!(dec.delay_frames(), delay, "{temporal:?}: {:?}", dec.filter_design());
        for (t, m) in maps.iter().enumerate() {
            let s = dec.push(m).expect("a causal filter gives every frame out at once");
            assert_eq!((s.frame, s.describes_frame), (t as u64, (t as u64).saturating_sub(delay as u64)));
        }
        assert!(dec.flush().is_none());
    }
}
