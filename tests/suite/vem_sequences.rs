//! The VEM pipeline on synthetic sequences: fisheye HDR and LDR frames through calibration,
//! resampling, decomposition and the temporal filter (issue 5 §1–§3).

use heliar::io::frames::{Frame, FrameData, Linearizer, Response};
use heliar::io::image::{ExrPrecision, LinearImage};
use heliar::vem::capture::lens_file::fisheye_toml;
use heliar::camera::Camera;
use heliar::vem::capture::input::VemInput;
use heliar::vem::eval::metrics::{irradiance_error, motion, random_normals, reference_irradiance};
use heliar::vem::sampling::pattern::Pattern;
use heliar::vem::capture::photometric::LogResponse;
use heliar::vem::polar::{IrradianceReference, PolarMap, luminance};
use heliar::vem::capture::resample::{Projection, Resampler};
use heliar::vem::sampling::SamplerKind;
use heliar::vem::eval::synth::{self, Environment, RATE_HZ, indoor_lamp, outdoor, render_fisheye, render_polar};
use heliar::vem::{Decomposer, VemConfig, lights_of_map};
use std::path::PathBuf;

fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("heliar-vem-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn hdr(img: LinearImage) -> Frame {
    Frame { width: img.width, height: img.height, data: FrameData::Hdr(img) }
}

#[test]
fn fisheye_frames_give_the_irradiance_of_the_sky() {
    // An HDR fisheye of the sunny and the clouded sky, through resampling and 300 lights, against
    // brute force over a fine polar rendering of the same analytic sky.
    let cam = Camera::equidistant_up(256, 180.0);
    let mut rs = Resampler::new(&Projection::Fisheye(cam.clone()), 256, 256, 360, 90);
    let lin = Linearizer::new(&Response::Linear, 1.0, 1.0, None);
    let normals = random_normals(256, 21);
    for k in [0usize, 10] {
        let sky = outdoor(k, RATE_HZ);
        let truth = render_polar(&sky, 720, 180, 2);
        let reference = reference_irradiance(&IrradianceReference::new(&truth, 1), &normals);
        let mut map = PolarMap::new(360, 90);
        let st = rs.resample(&hdr(render_fisheye(&sky, &cam, 3)), &lin, &mut map);
        assert_eq!((st.invalid_pixels, st.uncovered_texels), (0, 0));
        let (p, q) = (map.total_power(), truth.total_power());
        assert!(((p[1] - q[1]) / q[1]).abs() < 0.01, "frame {k}: power {p:?} vs {q:?}");
        let mut dec = Decomposer::new(VemConfig { lights: 300, ..VemConfig::default() }).unwrap();
        dec.process(&map);
        let e = irradiance_error(dec.lights(), &normals, &reference);
        println!("frame {k}: irradiance error {:.2}% rms, p95 {:.2}% of max", 100.0 * e.rel_rms, 100.0 * e.p95_of_max);
        // Resampling (≈1° texels from 0.7° pixels) and 300 lights: measured 0.8% and 1.7%.
        assert!(e.rel_rms < 0.03, "frame {k}: {e:?}");
    }
}

#[test]
fn adding_lights_never_moves_existing_ones() {
    let frames: Vec<PolarMap> = (0..16).map(|k| render_polar(&outdoor(k, RATE_HZ), 180, 45, 1)).collect();
    for kind in [SamplerKind::Havran, SamplerKind::Standard] {
        let cfg = VemConfig { polar_width: 180, polar_height: 45, lights: 16, sampler: kind, ..VemConfig::default() };
        let (mut fixed, mut varying) = (Decomposer::new(cfg.clone()).unwrap(), Decomposer::new(cfg).unwrap());
        for (t, f) in frames.iter().enumerate() {
            // The light count changes on the fly: 16 → 200 → 64 → 16.
            let n = match t {
                0..4 => 16,
                4..8 => 200,
                8..12 => 64,
                _ => 16,
            };
            varying.set_lights(n).unwrap();
            fixed.process(f);
            varying.process(f);
            assert_eq!(varying.lights().len(), n);
            for (a, b) in fixed.lights().iter().zip(varying.lights()) {
                assert_eq!(a.index, b.index);
                assert_eq!(a.dir, b.dir, "{kind:?} frame {t}: light {} moved", a.index);
            }
        }
    }
    // Unfiltered, and with the relaxed samples: the first lights of a larger set are the lights
    // of a smaller one, bit for bit.
    let map = render_polar(&outdoor(3, RATE_HZ), 360, 90, 1);
    let small = lights_of_map(&map, SamplerKind::Havran, Pattern::RelaxedHalton, 10);
    let large = lights_of_map(&map, SamplerKind::Havran, Pattern::RelaxedHalton, 1000);
    assert_eq!(small.iter().map(|l| l.dir).collect::<Vec<_>>(), large[..10].iter().map(|l| l.dir).collect::<Vec<_>>());
}

#[test]
fn the_filter_removes_the_lamps_flicker_and_delays_by_four_frames() {
    // The lamp flickers by ±25% at 115 Hz, seen at 21 Hz as 10 Hz: the paper's filter passes
    // under 9% there.
    let frames: Vec<PolarMap> = (0..60).map(|k| render_polar(&indoor_lamp(k, RATE_HZ), 180, 45, 1)).collect();
    let mut dec = Decomposer::new(VemConfig { polar_width: 180, polar_height: 45, lights: 64, ..VemConfig::default() }).unwrap();
    let (mut raw, mut filtered) = (vec![], vec![]);
    for f in &frames {
        let s = dec.process(f);
        raw.push(s.power);
        filtered.push(s.filtered_power);
        let sum: f64 = dec.lights().iter().map(|l| luminance(l.rgb) as f64).sum();
        assert!((sum - s.filtered_power).abs() < 1e-4 * sum);
    }
    let swing = |v: &[f64]| {
        let m = v.iter().sum::<f64>() / v.len() as f64;
        (v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / v.len() as f64).sqrt() / m
    };
    let (r, f) = (swing(&raw[10..]), swing(&filtered[10..]));
    println!("lamp flicker: raw {:.2}% rms, filtered {:.2}% rms", 100.0 * r, 100.0 * f);
    assert!(r > 0.05 && f < r / 5.0, "raw {r} filtered {f}");
    // A step: the sun going behind the cloud shows in the filtered power 4 frames later (half
    // way between the levels at the delay).
    let frames: Vec<PolarMap> = (0..24).map(|k| render_polar(&outdoor(k, RATE_HZ), 180, 45, 1)).collect();
    let mut dec = Decomposer::new(VemConfig { polar_width: 180, polar_height: 45, lights: 16, ..VemConfig::default() }).unwrap();
    let s: Vec<(f64, f64)> = frames.iter().map(|f| dec.process(f)).map(|s| (s.power, s.filtered_power)).collect();
    let half = (s[0].0 + s[10].0) / 2.0;
    let cross = |v: &dyn Fn(usize) -> f64| (0..24).find(|&k| v(k) < half).unwrap();
    let (t_raw, t_filt) = (cross(&|k| s[k].0), cross(&|k| s[k].1));
    assert!((t_filt as i64 - t_raw as i64 - 4).abs() <= 1, "raw crosses at {t_raw}, filtered at {t_filt}");
}

#[test]
fn ldr_fisheye_with_a_log_response_fitted_from_gray_patches() {
    // An 8-bit log camera (c = 0.2 + 0.055·ln Y, as the paper's HDRC sensor) films the indoor
    // room; six gray patches calibrate it, two check it.
    let dir = temp_dir("ldr");
    let truth = LogResponse { a: 0.2, b: 0.055 };
    let code = |y: f64| ((truth.a + truth.b * y.max(1e-6).ln()).clamp(0.0, 1.0) * 255.0).round();
    let mut csv = String::from("code,luminance,role\n");
    for (i, y) in [0.05, 0.3, 2.0, 10.0, 40.0, 120.0, 1.0, 25.0].iter().enumerate() {
        csv += &format!("{},{y},{}\n", code(*y), if i < 6 { "fit" } else { "check" });
    }
    std::fs::write(dir.join("patches.csv"), csv).unwrap();
    let cam = Camera::equidistant_up(160, 180.0);
    let toml = fisheye_toml(&cam, "ldr test").replace("kind = \"linear\"", "kind = \"log\"\npatches = \"patches.csv\"\nsaturation = 1.0");
    std::fs::write(dir.join("fisheye.toml"), toml).unwrap();
    let room = indoor_lamp(0, RATE_HZ);
    let img = render_fisheye(&room, &cam, 2);
    let frames = dir.join("frames");
    std::fs::create_dir_all(&frames).unwrap();
    let bytes: Vec<u8> = img.data.iter().flat_map(|p| p.map(|v| code(v as f64) as u8)).collect();
    image::save_buffer(frames.join("f0.png"), &bytes, 160, 160, image::ExtendedColorType::Rgb8).unwrap();
    img.write_exr(&dir.join("hdr.exr"), ExrPrecision::Float).unwrap();
    let mut ldr = VemInput::open(&frames, Some(&dir.join("fisheye.toml")), 360, 90).unwrap();
    let (lr, rep) = ldr.calib.as_ref().unwrap().log_response.unwrap();
    let rep = rep.unwrap();
    assert!((lr.b - truth.b).abs() < 0.002 && rep.check_max_rel_error.unwrap() < 0.05, "{lr:?} {rep:?}");
    let mut map = PolarMap::new(360, 90);
    ldr.load(0, &mut map).unwrap();
    let hdr_calib = dir.join("hdr.toml");
    std::fs::write(&hdr_calib, fisheye_toml(&cam, "hdr")).unwrap();
    let mut hdr_in = VemInput::open(&dir.join("hdr.exr"), Some(&hdr_calib), 360, 90).unwrap();
    let mut hmap = PolarMap::new(360, 90);
    hdr_in.load(0, &mut hmap).unwrap();
    let (p, q) = (map.total_power(), hmap.total_power());
    // 8-bit log quantisation: ±1/(2·255·0.055) = ±3.6% per pixel, averaging out.
    println!("LDR log power {:.3} vs HDR {:.3}", p[1], q[1]);
    assert!(((p[1] - q[1]) / q[1]).abs() < 0.02, "{p:?} vs {q:?}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn equirect_frames_in_files_give_the_lights_of_the_polar_map() {
    let dir = temp_dir("equirect");
    let sky = outdoor(2, RATE_HZ);
    let eq = LinearImage::from_fn(720, 360, |x, y| {
        let d = heliar::geometry::equirect::dir_from_texel_centre(x, y, 720, 360);
        if d.y < 0.0 { [0.05; 3] } else { sky.radiance(d) }
    });
    eq.write_exr(&dir.join("sky.exr"), ExrPrecision::Float).unwrap();
    let mut input = VemInput::open(&dir.join("sky.exr"), None, 360, 90).unwrap();
    let mut map = PolarMap::new(360, 90);
    input.load(0, &mut map).unwrap();
    let direct = render_polar(&synth::OutdoorSky { sun_irradiance: [0.0; 3], ..sky }, 360, 90, 1);
    let (p, q) = (map.total_power(), direct.total_power());
    assert!(((p[2] - q[2]) / q[2]).abs() < 0.01, "{p:?} vs {q:?}");
    // A frame of the wrong shape without a calibration is refused, naming the file.
    LinearImage::new(300, 100).write_exr(&dir.join("odd.exr"), ExrPrecision::Half).unwrap();
    let e = VemInput::open(&dir.join("odd.exr"), None, 360, 90).unwrap().load(0, &mut map).unwrap_err().to_string();
    assert!(e.contains("odd.exr") && e.contains("--calib"), "{e}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn too_many_invalid_pixels_reject_the_frame_by_name() {
    let dir = temp_dir("nan");
    let mut img = LinearImage::from_fn(360, 90, |_, y| [1.0 + y as f32 * 0.01; 3]);
    for i in 0..100 {
        img.data[i * 7] = [f32::NAN, 0.0, 0.0];
    }
    img.write_exr(&dir.join("few.exr"), ExrPrecision::Float).unwrap();
    for i in 0..5000 {
        img.data[i * 3] = [f32::INFINITY; 3];
    }
    img.write_exr(&dir.join("many.exr"), ExrPrecision::Float).unwrap();
    let mut map = PolarMap::new(360, 90);
    let st = VemInput::open(&dir.join("few.exr"), None, 360, 90).unwrap().load(0, &mut map).unwrap();
    assert_eq!(st.invalid_pixels, 100);
    assert!(map.data.iter().all(|p| p.iter().all(|c| c.is_finite())));
    let e = VemInput::open(&dir.join("many.exr"), None, 360, 90).unwrap().load(0, &mut map).unwrap_err().to_string();
    assert!(e.contains("many.exr") && e.contains("NaN, infinite or negative"), "{e}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn the_default_blend_keeps_lights_steadier_than_the_papers_next_to_a_sun() {
    // Measured over the synthetic local changes: the paper's centre-to-centre interpolation moves
    // the lights 8× more between consecutive frames of the outdoor sequence (the sun's ring
    // borrows its neighbours' azimuths); the default blend and the standard inversion stay close.
    let mut worse = 0;
    for (name, a, b) in synth::local_changes(360, 90) {
        let m = |k| motion(&lights_of_map(&a, k, Pattern::RelaxedHalton, 300), &lights_of_map(&b, k, Pattern::RelaxedHalton, 300)).mean_rad;
        let (h, c, s) = (m(SamplerKind::Havran), m(SamplerKind::HavranCentres), m(SamplerKind::Standard));
        println!("{name:14} mean motion: havran {:.4}°, centres {:.4}°, standard {:.4}°", h.to_degrees(), c.to_degrees(), s.to_degrees());
        assert!(h.is_finite() && h < 1f64.to_radians(), "{name}: {h}");
        if c > 2.0 * h {
            worse += 1;
        }
    }
    assert!(worse >= 2, "the centre blend should be clearly less steady on the sunny changes");
}
