//! Stiff and extreme inputs of the VEM decomposition (issue 5 §7): a delta-peaked map, an
//! all-zero map, a uniform map, values from 1e-4 to 1e6, and NaN/Inf texels.
//! `cargo test --test suite vem_stiff:: -- --nocapture` prints each case's numbers.

use glam::Vec3;
use heliar::vem::eval::metrics::{irradiance_error, random_normals, reference_irradiance};
use heliar::vem::sampling::pattern::Pattern;
use heliar::vem::polar::{IrradianceReference, PolarMap, luminance};
use heliar::vem::sampling::SamplerKind;
use heliar::vem::{Decomposer, Light, Status, VemConfig, irradiance, lights_of_map};

const KINDS: [SamplerKind; 3] = [SamplerKind::Havran, SamplerKind::HavranCentres, SamplerKind::Standard];

fn finite(lights: &[Light]) -> bool {
    lights.iter().all(|l| l.dir.is_finite() && (l.dir.length() - 1.0).abs() < 1e-4 && l.rgb.iter().all(|c| c.is_finite() && *c >= 0.0))
}

fn decomposer(n: usize, kind: SamplerKind) -> Decomposer {
    Decomposer::new(VemConfig { lights: n, sampler: kind, clusters: Some(16), ..VemConfig::default() }).unwrap()
}

#[test]
fn a_single_sun_texel_gets_every_light() {
    let mut map = PolarMap::new(360, 90);
    let (i, j) = (250, 30);
    map.data[(j * 360 + i) as usize] = [2e5, 1.8e5, 1.5e5];
    let sun = map.texel_dir(i, j);
    let p = map.total_power();
    for kind in KINDS {
        let mut dec = decomposer(64, kind);
        for _ in 0..10 {
            let s = dec.process(&map);
            assert_eq!(s.status, Status::Ok);
        }
        let lights = dec.lights();
        assert!(finite(lights));
        // Every light inside the sun texel (1° × 1°) and carrying P/N of each channel.
        for l in lights {
            assert!(l.dir.dot(sun) > 0.9998, "{kind:?}: {l:?}");
            for c in 0..3 {
                assert!((l.rgb[c] as f64 * 64.0 - p[c]).abs() < 1e-3 * p[c], "{kind:?}: {l:?} vs {p:?}");
            }
        }
        // Irradiance is the sun's, P·max(n·sun, 0), at any normal (to the texel's angular size).
        for n in random_normals(50, 3) {
            let e = irradiance(lights, n)[1];
            let want = p[1] * n.dot(sun).max(0.0) as f64;
            assert!((e - want).abs() < 0.012 * p[1], "{kind:?}: {e} vs {want}");
        }
        // Clustering makes one light of them.
        assert_eq!(dec.clusters().len(), 1);
        assert_eq!(dec.clusters()[0].members, 64);
    }
}

#[test]
fn an_all_zero_map_is_dark_without_nan() {
    for kind in KINDS {
        let mut dec = decomposer(32, kind);
        // Dark from the start: no lights at all.
        let s = dec.process(&PolarMap::new(360, 90));
        assert_eq!(s.status, Status::Dark);
        assert_eq!((s.power, s.filtered_power), (0.0, 0.0));
        assert!(dec.lights().is_empty() && dec.clusters().is_empty());
        // Light, then darkness: the lights keep their directions and the power decays to 0
        // within the filter's length.
        let sky = PolarMap::from_fn(360, 90, |d| [1.0 + d.y, 1.0, 1.0]);
        for _ in 0..9 {
            dec.process(&sky);
        }
        let before: Vec<Light> = dec.lights().to_vec();
        let mut last = f64::MAX;
        for k in 0..12 {
            let s = dec.process(&PolarMap::new(360, 90));
            assert_eq!(s.status, Status::Dark);
            assert!(finite(dec.lights()) && dec.lights().len() == 32);
            assert!(s.filtered_power.is_finite() && s.filtered_power >= 0.0);
            if k >= 8 {
                assert_eq!(s.filtered_power, 0.0);
            }
            last = s.filtered_power;
            for (a, b) in before.iter().zip(dec.lights()) {
                assert!(a.dir.dot(b.dir) > 0.9999);
            }
        }
        assert_eq!(last, 0.0);
        assert!(dec.lights().iter().all(|l| l.rgb == [0.0; 3]));
        println!("{kind:?}: dark frames handled");
    }
}

#[test]
fn a_uniform_map_gives_the_closed_form_irradiance() {
    // Radiance 1 over the upper hemisphere: E = π facing up, π/2 facing the horizon, 0 facing
    // down, for any normal E = π(1 + n_y)/2.
    let map = PolarMap::from_fn(360, 90, |_| [1.0; 3]);
    for kind in KINDS {
        for n in [64usize, 256, 1024] {
            let l = lights_of_map(&map, kind, Pattern::RelaxedHalton, n);
            assert!(finite(&l));
            let mut worst = 0.0f64;
            for nrm in random_normals(200, 9) {
                let want = std::f64::consts::PI * (1.0 + nrm.y as f64) / 2.0;
                worst = worst.max((irradiance(&l, nrm)[0] - want).abs() / std::f64::consts::PI);
            }
            println!("uniform {kind:?} N={n}: worst error {:.3}% of π", 100.0 * worst);
            // Over 200 random normals the worst error falls as 1/N (measured: Havran 10.5%, 2.7%,
            // 0.67% of π at N = 64, 256, 1024; standard 7.2%, 2.1%, 0.36%).
            assert!(worst < 8.0 / n as f64, "{kind:?} N={n}: {worst}");
        }
    }
}

#[test]
fn values_from_1e_minus_4_to_1e6() {
    // A dim sky (1e-4), a bright cloud edge (10), a sun (1e6 over a few texels) in one map.
    let sun = Vec3::new(-0.4, 0.7, 0.2).normalize();
    let cloud = Vec3::new(0.6, 0.4, -0.5).normalize();
    let map = PolarMap::from_fn(360, 90, |d| {
        if d.dot(sun) > 0.99995 {
            [1e6, 9e5, 8e5]
        } else if d.dot(cloud) > 0.97 {
            [10.0; 3]
        } else {
            [1e-4, 2e-4, 3e-4]
        }
    });
    let p = map.total_power();
    let normals = random_normals(256, 4);
    let reference = reference_irradiance(&IrradianceReference::new(&map, 2), &normals);
    for kind in KINDS {
        let mut dec = decomposer(256, kind);
        let s = dec.process(&map);
        assert!((s.power_rgb[0] - p[0]).abs() < 1e-6 * p[0]);
        let l = dec.lights();
        assert!(finite(l));
        let total: f64 = l.iter().map(|x| luminance(x.rgb) as f64).sum();
        assert!((total - s.filtered_power).abs() < 1e-4 * total);
        let e = irradiance_error(l, &normals, &reference);
        println!("1e-4…1e6 {kind:?}: irradiance error {:.3}% rms", 100.0 * e.rel_rms);
        // The paper's centre-to-centre blending spreads part of the sun's power along its
        // almucantar (measured 13% rms here); the default blending and the standard inversion
        // do not (measured 0.4% and 0.3%).
        let bound = if kind == SamplerKind::HavranCentres { 0.3 } else { 0.02 };
        assert!(e.rel_rms < bound, "{kind:?}: {e:?}");
    }
}

#[test]
fn nan_and_inf_texels_are_sanitised_and_counted() {
    let mut map = PolarMap::from_fn(360, 90, |d| [1.0 + d.y, 1.0, 0.5]);
    map.data[100] = [f32::NAN, 1.0, 1.0];
    map.data[5000] = [1.0, f32::INFINITY, 1.0];
    map.data[9000] = [1.0, 1.0, f32::NEG_INFINITY];
    map.data[12000] = [-3.0, 1.0, 1.0];
    for kind in KINDS {
        let m = map.clone();
        let mut dec = decomposer(128, kind);
        let s = dec.process(&m);
        assert_eq!(s.sanitized_texels, 4);
        assert_eq!(s.status, Status::Ok);
        assert!(s.power.is_finite() && s.filtered_power.is_finite());
        assert!(finite(dec.lights()));
        // An all-NaN map is dark, not NaN.
        let nan = PolarMap::from_fn(360, 90, |_| [f32::NAN; 3]);
        let s = decomposer(16, kind).process(&nan);
        assert_eq!((s.status, s.sanitized_texels), (Status::Dark, 360 * 90));
    }
}
