//! Reader tests: known values, round trips, symmetry expansions, the flux integral, and bad files.

use super::ies::{IesVersion, LengthUnit, Tilt};
use super::ldt::LampSet;
use super::*;
use glam::DVec3;
use std::path::Path;

/// A hand-written LM-63-2002 file: rotational, 1000 cd at nadir, dark above 90°.
const STREET_LAMP: &str = "IESNA:LM-63-2002\r
[TEST] 12345\r
[MANUFAC] heliar test lab\r
[LUMINAIRE] street lamp\r
[MORE] second line of the name\r
TILT=NONE\r
1 10000 2.0 5 1 1 2 0.5 0.5 0.1\r
0.5 1.0 100\r
0 22.5 45 67.5 90\r
0\r
1000 900,800\r
500 0\r
";

fn steps(lo: f64, hi: f64, step: f64) -> Vec<f64> {
    let n = ((hi - lo) / step).round() as usize;
    (0..=n).map(|i| lo + i as f64 * step).collect()
}

/// Symmetric in both the C0–C180 and the C90–C270 planes (so every IES/LDT symmetry can store it).
fn quadrant_symmetric(c: f64, g: f64) -> f64 {
    (300.0 + 100.0 * (2.0 * c.to_radians()).cos()) * g.to_radians().cos().max(0.0) + 5.0
}

fn ies_of(kind: PhotometricType, h: Vec<f64>, v: Vec<f64>, f: impl Fn(f64, f64) -> f64) -> IesFile {
    let candela = h.iter().flat_map(|&a| v.iter().map(move |&b| (a, b))).map(|(a, b)| f(a, b)).collect();
    IesFile {
        version: IesVersion::Lm63_2019,
        keywords: vec![("TEST".into(), "t".into()), ("LUMINAIRE".into(), "line one\nline two".into())],
        tilt: None,
        lamp_count: 1,
        lumens_per_lamp: -1.0,
        candela_multiplier: 1.0,
        photometric_type: kind,
        units: LengthUnit::Metres,
        size: [0.1, 0.2, 0.0],
        ballast_factor: 1.0,
        file_generation: 1.00001,
        input_watts: 40.0,
        vertical_deg: v,
        horizontal_deg: h,
        candela,
    }
}

fn ldt_of(isym: u8, mc: usize, f: impl Fn(f64, f64) -> f64) -> LdtFile {
    let dc = 360.0 / mc as f64;
    let c_deg: Vec<f64> = (0..mc).map(|i| i as f64 * dc).collect();
    let gamma_deg = steps(0.0, 180.0, 5.0);
    let mut f0 = LdtFile {
        header: "heliar".into(),
        type_indicator: 3,
        symmetry: isym,
        c_step_deg: dc,
        gamma_step_deg: 5.0,
        texts: ["r".into(), "street lamp".into(), "n".into(), "a.ldt".into(), "2026".into()],
        dimensions_mm: [500.0, 200.0, 100.0, 400.0, 150.0, 0.0, 0.0, 0.0, 0.0],
        downward_flux_fraction_pct: 100.0,
        light_output_ratio_pct: 80.0,
        conversion_factor: 1.0,
        tilt_deg: 0.0,
        lamp_sets: vec![LampSet { count: 1, kind: "LED".into(), flux_lm: 2000.0, colour: "3000K".into(), colour_rendering: "80".into(), watts: 20.0 }],
        direct_ratios: [0.5; 10],
        c_deg,
        gamma_deg,
        intensities: Vec::new(),
    };
    let planes = f0.stored_planes_deg();
    f0.intensities = planes.iter().flat_map(|&c| f0.gamma_deg.iter().map(|&g| (c, g)).collect::<Vec<_>>()).map(|(c, g)| f(c, g)).collect();
    f0
}

/// Deterministic directions over the sphere.
fn directions() -> Vec<DVec3> {
    crate::geometry::sampling::sphere_fibonacci(400).into_iter().map(|v| v.as_dvec3().normalize()).collect()
}

#[test]
fn hand_written_ies_known_values() {
    let f = IesFile::parse(STREET_LAMP, Path::new("street.ies")).unwrap();
    assert_eq!(f.version, IesVersion::Lm63_2002);
    assert_eq!(f.keywords[2], ("LUMINAIRE".to_string(), "street lamp\nsecond line of the name".to_string()));
    let g = f.goniometric().unwrap();
    // nadir: 1000 × multiplier 2 × ballast factor 0.5
    assert_eq!(g.intensity_cd(-DVec3::Z), 1000.0);
    // γ = 30°: a third of the way from 900 to 800 (linear in γ), in any plane
    let d = PhotometricType::C.dir_from_angles(123.0, 30.0);
    assert!((g.intensity_cd(d) - (900.0 - 100.0 / 3.0)).abs() < 1e-9);
    // upward: nothing measured, nothing emitted
    assert_eq!(g.intensity_cd(DVec3::new(0.3, 0.0, 0.9).normalize()), 0.0);
    // illuminance 2 m below the lamp on the ground: 1000 / 4
    assert!((crate::lamps::FarField::irradiance_at(&g, DVec3::new(0.0, 0.0, -2.0), DVec3::Z) - 250.0).abs() < 1e-9);
}

#[test]
fn ies_round_trips_every_version_symmetry_and_tilt() {
    let v = steps(0.0, 180.0, 10.0);
    let mut files = vec![
        ies_of(PhotometricType::C, vec![0.0], v.clone(), |_, g| 100.0 + g),
        ies_of(PhotometricType::C, steps(0.0, 90.0, 15.0), v.clone(), quadrant_symmetric),
        ies_of(PhotometricType::C, steps(0.0, 360.0, 30.0), v.clone(), quadrant_symmetric),
        ies_of(PhotometricType::B, steps(-90.0, 90.0, 30.0), steps(-90.0, 90.0, 10.0), |h, v| 200.0 + h + v),
        ies_of(PhotometricType::A, steps(0.0, 90.0, 30.0), steps(-90.0, 90.0, 10.0), |h, v| 200.0 + h + v),
    ];
    files[1].version = IesVersion::Lm63_1995;
    files[2].version = IesVersion::Lm63_1986;
    files[2].keywords = vec![(String::new(), "free text of an old file".into())];
    files[3].tilt = Some(Tilt { lamp_to_luminaire_geometry: 1, angles_deg: vec![0.0, 45.0, 90.0], factors: vec![1.0, 0.95, 0.8] });
    for f in files {
        let text = f.to_text();
        let back = IesFile::parse(&text, Path::new("rt.ies")).unwrap_or_else(|e| panic!("{e}\n{text}"));
        assert_eq!(back, f);
        assert!(back.goniometric().is_ok());
    }
    let t = Tilt { lamp_to_luminaire_geometry: 1, angles_deg: vec![0.0, 45.0, 90.0], factors: vec![1.0, 0.95, 0.8] };
    assert!((t.factor_at(67.5) - 0.875).abs() < 1e-12 && t.factor_at(120.0) == 0.8);
}

#[test]
fn every_ies_symmetry_expands_to_the_same_intensities() {
    let v = steps(0.0, 180.0, 7.5);
    let full = ies_of(PhotometricType::C, steps(0.0, 360.0, 22.5), v.clone(), quadrant_symmetric).goniometric().unwrap();
    for h in [steps(0.0, 90.0, 22.5), steps(0.0, 180.0, 22.5), steps(90.0, 270.0, 22.5)] {
        let g = ies_of(PhotometricType::C, h.clone(), v.clone(), quadrant_symmetric).goniometric().unwrap();
        for d in directions() {
            // the same samples on the same expanded grid: equal to f64 rounding
            assert!((g.intensity_cd(d) - full.intensity_cd(d)).abs() < 1e-9, "{h:?} at {d}");
        }
    }
    let rot = ies_of(PhotometricType::C, vec![0.0], v.clone(), |_, g| 100.0 + g).goniometric().unwrap();
    let rot_full = ies_of(PhotometricType::C, steps(0.0, 360.0, 45.0), v, |_, g| 100.0 + g).goniometric().unwrap();
    for d in directions() {
        assert!((rot.intensity_cd(d) - rot_full.intensity_cd(d)).abs() < 1e-9);
    }
}

#[test]
fn type_b_and_c_files_of_one_distribution_agree() {
    // I = 1000 cos²γ below the horizon, tabulated as type C and as type B (tan B = cos C tan γ,
    // sin β = sin C sin γ). Each table interpolates the function on a 2.5° grid with the bilinear
    // error bound Δ²/8·(|I_hh| + |I_vv|): 0.48 cd for type C (I depends on γ only, |I''| ≤ 2000),
    // 0.95 cd for type B (I = 1000 cos²B cos²β). So they agree within 1.5 cd.
    let f = |d: DVec3| 1000.0 * d.z.min(0.0).powi(2);
    let c = ies_of(PhotometricType::C, steps(0.0, 360.0, 2.5), steps(0.0, 90.0, 2.5), |h, v| f(PhotometricType::C.dir_from_angles(h, v))).goniometric().unwrap();
    let b = ies_of(PhotometricType::B, steps(-90.0, 90.0, 2.5), steps(-90.0, 90.0, 2.5), |h, v| f(PhotometricType::B.dir_from_angles(h, v))).goniometric().unwrap();
    for d in directions().into_iter().filter(|d| d.z < -0.05) {
        assert!((c.intensity_cd(d) - b.intensity_cd(d)).abs() < 1.5, "{d}: {} vs {}", c.intensity_cd(d), b.intensity_cd(d));
        assert!((c.intensity_cd(d) - f(d)).abs() < 0.5);
    }
}

#[test]
fn ldt_round_trips_and_every_isym_expands_alike() {
    let full = ldt_of(0, 24, quadrant_symmetric);
    let g_full = full.goniometric().unwrap();
    for isym in 0..=4u8 {
        let f = if isym == 1 { ldt_of(1, 24, |_, g| 100.0 + g) } else { ldt_of(isym, 24, quadrant_symmetric) };
        let back = LdtFile::parse(&f.to_text(), Path::new("rt.ldt")).unwrap_or_else(|e| panic!("Isym {isym}: {e}"));
        assert_eq!(back, f);
        if isym != 1 {
            let g = back.goniometric().unwrap();
            for d in directions() {
                assert!((g.intensity_cd(d) - g_full.intensity_cd(d)).abs() < 1e-9, "Isym {isym} at {d}");
            }
        }
    }
    // nadir: cd/klm × 2000 lm / 1000
    assert!((g_full.intensity_cd(-DVec3::Z) - quadrant_symmetric(0.0, 0.0) * 2.0).abs() < 1e-9);
}

#[test]
fn ldt_and_ies_of_one_lamp_agree_and_flux_matches_the_closed_form() {
    // A Lambertian downlight, I = I₀ cos γ: Φ = π I₀. LDT in cd/klm for 2000 lm.
    let ldt = ldt_of(1, 1, |_, g| 300.0 * g.to_radians().cos().max(0.0));
    let g = ldt.goniometric().unwrap();
    let i0 = 600.0;
    // the interpolant is piecewise linear in γ at 5° steps: relative error below 0.2 %
    assert!((g.flux_lm() / (std::f64::consts::PI * i0) - 1.0).abs() < 2e-3, "{}", g.flux_lm());
    let ies = ies_of(PhotometricType::C, vec![0.0], ldt.gamma_deg.clone(), |_, v| i0 * v.to_radians().cos().max(0.0)).goniometric().unwrap();
    for d in directions() {
        assert!((ies.intensity_cd(d) - g.intensity_cd(d)).abs() < 1e-9);
    }
}

/// The error of parsing `text` as `name`, as a string.
fn ies_err(text: &str) -> String {
    IesFile::parse(text, Path::new("bad.ies")).unwrap_err().to_string()
}

#[test]
fn bad_ies_files_name_file_line_and_field() {
    let cases: Vec<(String, &[&str])> = vec![
        // truncated inside the candela values
        (STREET_LAMP[..STREET_LAMP.len() - 6].to_string(), &["bad.ies", "ends after line 12", "candela values #4"]),
        // one value too many
        (STREET_LAMP.replace("500 0", "500 0 7"), &["bad.ies:12", "candela values", "'7'"]),
        // vertical angles out of order
        (STREET_LAMP.replace("0 22.5 45 67.5 90", "0 45 22.5 67.5 90"), &["bad.ies:9", "vertical angles", "not increasing"]),
        (STREET_LAMP.replace("900,800", "900,-800"), &["bad.ies:11", "candela values", "-800"]),
        (STREET_LAMP.replace("900,800", "900,NaN"), &["bad.ies:11", "candela values #2", "not finite"]),
        (STREET_LAMP.replace("900,800", "900,8x0"), &["bad.ies:11", "'8x0' is not a number"]),
        (STREET_LAMP.replace("5 1 1 2", "5 1 4 2"), &["bad.ies:7", "photometric type", "4"]),
        (STREET_LAMP.replace("1 10000 2.0 5", "1 10000 2.0 0"), &["bad.ies:7", "number of vertical angles"]),
        (STREET_LAMP.replace("TILT=NONE", "TILT=lamp.tlt"), &["bad.ies:6", "TILT", "lamp.tlt"]),
        (STREET_LAMP.replace("TILT=NONE", "[OTHER] x"), &["bad.ies", "TILT= line"]),
        (STREET_LAMP.replace("\r\n0\r\n1000", "\r\n45\r\n1000"), &["bad.ies:10", "horizontal angles", "symmetry"]),
    ];
    for (text, needles) in cases {
        let e = ies_err(&text);
        for n in needles {
            assert!(e.contains(n), "'{n}' not in: {e}");
        }
    }
    // a missing file names itself
    let e = IesFile::read(Path::new("/nonexistent/lamp.ies")).unwrap_err().to_string();
    assert!(e.contains("/nonexistent/lamp.ies"), "{e}");
}

#[test]
fn bad_ldt_files_name_file_line_and_field() {
    let good = ldt_of(2, 24, quadrant_symmetric).to_text();
    let lines: Vec<&str> = good.lines().collect();
    let with_line = |k: usize, v: &str| {
        let mut l = lines.clone();
        l[k - 1] = v;
        l.join("\n")
    };
    let n = lines.len();
    let last_line = format!("bad.ldt:{n}");
    let last_needles = [last_line.as_str(), "intensities", "-1"];
    let cases: Vec<(String, &[&str])> = vec![
        (lines[..n - 3].join("\n"), &["bad.ldt", "ends after line", "intensities"]),
        (format!("{good}12\n"), &["bad.ldt:", "end of file", "'12'"]),
        (with_line(3, "5"), &["bad.ldt:3", "Isym", "5"]),
        (with_line(4, "23"), &["bad.ldt:4", "Mc", "multiple of 2"]),
        (with_line(24, "abc"), &["bad.ldt:24", "conversion factor", "'abc'"]),
        // the first γ angle line comes after 26 + 6 + 10 + 24 C-angle lines
        (with_line(26 + 6 + 10 + 24 + 2, "0"), &["bad.ldt:67", "γ angles", "increase"]),
        (with_line(n, "-1"), &last_needles),
    ];
    for (text, needles) in cases {
        let e = LdtFile::parse(&text, Path::new("bad.ldt")).unwrap_err().to_string();
        for s in needles {
            assert!(e.contains(s), "'{s}' not in: {e}");
        }
    }
}

#[test]
fn the_luminous_opening_is_a_disc_of_its_area() {
    use std::f64::consts::PI;
    let near = |a: f64, b: f64| (a - b).abs() < 1e-12;
    let mut f = ies_of(PhotometricType::C, vec![0.0], steps(0.0, 90.0, 45.0), |_, _| 100.0);
    // A 0.1 m × 0.2 m rectangle (height 0): a disc of the same area.
    assert!(near(f.opening_radius_m(), (0.02 / PI).sqrt()));
    assert!(near(f.goniometric().unwrap().opening_radius_m(), (0.02 / PI).sqrt()));
    // LM-63-2002: negative width and length are a circle of that diameter.
    f.size = [-0.3, -0.3, 0.0];
    assert!(near(f.opening_radius_m(), 0.15));
    // Feet.
    f.units = LengthUnit::Feet;
    assert!(near(f.opening_radius_m(), 0.15 * 0.3048));
    // A point, and a vertical opening by its height.
    f.size = [0.0; 3];
    assert_eq!(f.opening_radius_m(), 0.0);
    f.units = LengthUnit::Metres;
    f.size = [0.0, 0.0, 0.4];
    assert!(near(f.opening_radius_m(), 0.2));
    // The hand-written street lamp: 0.5 m × 0.5 m.
    let street = IesFile::parse(STREET_LAMP, Path::new("street.ies")).unwrap();
    assert!(near(street.opening_radius_m(), (0.25 / PI).sqrt()));
    // EULUMDAT: the luminous area 400 mm × 150 mm; a width of 0 is a circle of that diameter.
    let mut l = ldt_of(1, 1, |_, _| 100.0);
    assert!(near(l.opening_radius_m(), (0.4 * 0.15 / PI).sqrt()));
    l.dimensions_mm[4] = 0.0;
    assert!(near(l.opening_radius_m(), 0.2));
    assert!(near(l.goniometric().unwrap().opening_radius_m(), 0.2));
}
