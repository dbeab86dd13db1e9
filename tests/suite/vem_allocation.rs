//! Allocation by accuracy (issue 14, part 2), first step: lights with density `∝ √L`
//! (`vem::sampling::tempered`) against equal-power lights (`γ = 1`, Havran), measured as
//! irradiance error against the brute-force integral at 64 upper-hemisphere normals.

use heliar::vem::eval::lag::{references, upper_normals};
use heliar::vem::eval::synth::{self, RATE_HZ, indoor_lamp, render_polar};
use heliar::vem::eval::sunny;
use heliar::vem::peaks::PeakTracker;
use heliar::vem::polar::PolarMap;
use heliar::vem::sampling::SamplerKind;
use heliar::vem::sampling::pattern::Pattern;
use heliar::vem::sampling::tempered::tempered_lights;
use heliar::vem::{Light, irradiance};

fn lum(e: [f64; 3]) -> f64 {
    0.2126 * e[0] + 0.7152 * e[1] + 0.0722 * e[2]
}

/// Mean and 95th percentile of `|ΔE| / E_ref` over the maps and normals, with `n` lights of
/// exponent `gamma` (peaks as their own lights when `peaks`).
fn error(maps: &[PolarMap], gamma: f32, n: usize, peaks: bool) -> (f64, f64) {
    let normals = upper_normals(64, 777);
    let refs = references(maps, &normals);
    let mut tracker = PeakTracker::new();
    let mut rel = Vec::new();
    for (m, r) in maps.iter().zip(&refs) {
        let lights: Vec<Light> = if peaks {
            tracker.split(m, n - 1);
            let mut l = tempered_lights(tracker.remainder(), SamplerKind::Havran, Pattern::RelaxedHalton, n - tracker.peaks().len(), gamma);
            l.extend_from_slice(tracker.peaks());
            l
        } else {
            tempered_lights(m, SamplerKind::Havran, Pattern::RelaxedHalton, n, gamma)
        };
        for (nrm, e) in normals.iter().zip(r) {
            rel.push((lum(irradiance(&lights, *nrm)) - e).abs() / e.max(1e-300));
        }
    }
    (rel.iter().sum::<f64>() / rel.len() as f64, heliar::report::percentile(&rel, 0.95))
}

#[test]
fn square_root_density_against_equal_power() {
    let sunny: Vec<PolarMap> = sunny::polar_maps(180, 45, sunny::FRAMES).into_iter().step_by(4).collect();
    let outdoor: Vec<PolarMap> = (0..20).step_by(4).map(|k| render_polar(&synth::outdoor(k, RATE_HZ), 180, 45, 2)).collect();
    let indoor: Vec<PolarMap> = (0..20).step_by(4).map(|k| render_polar(&indoor_lamp(k, RATE_HZ), 180, 45, 2)).collect();
    let overcast = vec![PolarMap::from_fn(180, 45, |d| [(1.0 + 2.0 * d.y.max(0.0)) / 3.0; 3])];
    let mut rows = Vec::new();
    for (name, maps) in [("sunny", &sunny), ("outdoor", &outdoor), ("indoor", &indoor), ("overcast", &overcast)] {
        for peaks in [false, true] {
            for n in [64, 128, 300] {
                let (eq, half) = (error(maps, 1.0, n, peaks), error(maps, 0.5, n, peaks));
                println!(
                    "{name:9} peaks {peaks:5} N {n:3}: equal power mean {:.2}% p95 {:.2}% | √L mean {:.2}% p95 {:.2}%",
                    100.0 * eq.0,
                    100.0 * eq.1,
                    100.0 * half.0,
                    100.0 * half.1
                );
                rows.push((name, peaks, n, eq, half));
            }
        }
    }
    // The finding (module docs of `tempered`): √L density wins only on smooth maps (the
    // overcast sky, and the lamp room once its lamp is a peak and the remainder is smooth) and
    // loses where the sun is, even with peaks as their own lights.
    let at = |name: &str, peaks: bool, n: usize| rows.iter().find(|r| r.0 == name && r.1 == peaks && r.2 == n).map(|r| (r.3.0, r.4.0)).unwrap();
    for (name, peaks) in [("overcast", false), ("indoor", true)] {
        let (eq, half) = at(name, peaks, 300);
        assert!(half < 0.85 * eq, "{name}: √L {half} vs equal power {eq}");
    }
    for name in ["sunny", "outdoor"] {
        let (eq, half) = at(name, true, 300);
        assert!(half > eq, "{name}: √L {half} vs equal power {eq}");
    }
}

#[test]
fn gamma_one_samples_where_equal_power_does_progressively_and_holds_the_power() {
    use heliar::vem::polar::luminance;
    use heliar::vem::sampling::PolarDistribution;
    let map = PolarMap::from_fn(90, 23, |d| [1.0 + 3.0 * d.x.max(0.0), 1.0 + d.y, 0.5]);
    let a = tempered_lights(&map, SamplerKind::Standard, Pattern::Halton, 40, 1.0);
    let b = heliar::vem::lights_of_map(&map, SamplerKind::Standard, Pattern::Halton, 40);
    assert_eq!(a.len(), b.len());
    let p = PolarDistribution::new(&map).integral();
    let sum_a: f64 = a.iter().map(|l| luminance(l.rgb) as f64).sum();
    assert!((sum_a - p).abs() < 1e-5 * p, "{sum_a} vs {p}");
    for (x, y) in a.iter().zip(&b) {
        assert!(x.dir.angle_between(y.dir) < 1e-4);
        // (The powers are the importance weights L/(N·pdf): P/N only where the density is
        // constant inside a texel, which the standard inversion's is not near the zenith.)
    }
    let half = tempered_lights(&map, SamplerKind::Havran, Pattern::RelaxedHalton, 40, 0.5);
    let sum: f64 = half.iter().map(|l| luminance(l.rgb) as f64).sum();
    assert!((sum - p).abs() < 1e-5 * p, "{sum} vs {p}");
    // Progressive: 60 lights keep the first 40 where they were.
    let more = tempered_lights(&map, SamplerKind::Havran, Pattern::RelaxedHalton, 60, 0.5);
    for (x, y) in half.iter().zip(&more) {
        assert_eq!(x.index, y.index);
        assert!(x.dir.angle_between(y.dir) < 1e-6);
    }
}
