use super::*;
use crate::sky::quadrature::{CosineSet, irradiance};

fn sun_at(elevation_deg: f32, azimuth_deg: f32) -> Vec3 {
    let (e, a) = (elevation_deg.to_radians(), azimuth_deg.to_radians());
    Vec3::new(e.cos() * a.sin(), e.sin(), -e.cos() * a.cos())
}

fn full_spec() -> SkyBasisSpec {
    SkyBasisSpec { preetham_turbidity: Some(3.0), ..SkyBasisSpec::default() }
}

/// `∫_{y>0} L(ω)·ω_y dω` by the midpoint rule on a `n × 2n` grid in zenith angle and azimuth
/// (independent of the Gauss–Legendre grid that normalises the shapes).
fn midpoint_horizontal(f: impl Fn(Vec3) -> f32, n: usize) -> f64 {
    let (dt, dp) = (std::f64::consts::FRAC_PI_2 / n as f64, PI / n as f64);
    let mut sum = 0.0;
    for a in 0..n {
        let t = (a as f64 + 0.5) * dt;
        for b in 0..2 * n {
            let p = (b as f64 + 0.5) * dp;
            let d = glam::DVec3::new(t.sin() * p.sin(), t.cos(), -t.sin() * p.cos()).as_vec3();
            sum += f(d) as f64 * t.cos() * t.sin();
        }
    }
    sum * dt * dp
}

#[test]
fn every_shape_has_unit_horizontal_irradiance() {
    // Midpoint rule on 400 × 800 cells (0.11°): error O(h²/w²) ≈ 1e-4 for the narrowest lobe
    // (5°), far less for the others.
    let narrow = SkyBasisSpec { circumsolar_width_deg: Some(CIRCUMSOLAR_WIDTH_MIN_DEG), horizon_width_deg: Some(HORIZON_WIDTH_MIN_DEG), preetham_turbidity: Some(9.5) };
    for elev in [70.0, 30.0, 10.0, 2.0, 0.0, -5.0] {
        for spec in [full_spec(), narrow.clone()] {
            let basis = SkyBasis::new(sun_at(elev, 130.0), &spec).unwrap();
            for k in 0..basis.len() {
                let e = midpoint_horizontal(|d| basis.radiance(k, d), 400);
                assert!((e - 1.0).abs() < 1e-3, "sun {elev}°, {} of {spec:?}: {e}", basis.name(k));
            }
        }
    }
}

#[test]
fn cosine_set_irradiance_of_the_default_basis() {
    // What the estimator will use: the Fibonacci cosine set. For the default shapes and Preetham
    // its worst error at M = 4096 is 2.8e-3 (measured; 8e-3 at M = 1024), with the circumsolar
    // lobe on the horizon, where few cosine-weighted directions fall.
    let set = CosineSet::fibonacci(4096).unwrap();
    for elev in [70.0, 30.0, 10.0, 2.0, 0.0] {
        let basis = SkyBasis::new(sun_at(elev, 130.0), &full_spec()).unwrap();
        let e = irradiance(&basis, Vec3::Y, &set, |_| true).unwrap();
        for (k, ek) in e.per_shape.iter().enumerate() {
            assert!((ek - 1.0).abs() < 5e-3, "sun {elev}°, {}: {ek}", basis.name(k));
        }
        assert_eq!(e.below_horizon, 0.0);
    }
}

#[test]
fn normalisation_against_closed_forms() {
    // Circumsolar lobe with the sun at the zenith: ∫ e^{κ(μ−1)} μ dω = 2π(1/κ − 1/κ² + e^{−κ}/κ²).
    for w in [CIRCUMSOLAR_WIDTH_MIN_DEG, 25.0, CIRCUMSOLAR_WIDTH_MAX_DEG] {
        let basis = SkyBasis::new(Vec3::Y, &SkyBasisSpec { circumsolar_width_deg: Some(w), horizon_width_deg: None, preetham_turbidity: None }).unwrap();
        let k = 1.0 / (1.0 - w.to_radians().cos());
        let exact = 2.0 * PI * (1.0 / k - 1.0 / (k * k) + (-k).exp() / (k * k));
        // At the sun the normalised radiance is 1/exact.
        let got = basis.radiance(1, Vec3::Y) as f64;
        assert!((got * exact - 1.0).abs() < 1e-6, "{w}°: {got} vs {}", 1.0 / exact);
    }
    // The horizon band's closed form agrees with the numerical integral.
    let basis = SkyBasis::new(Vec3::Y, &SkyBasisSpec { circumsolar_width_deg: None, horizon_width_deg: Some(12.0), preetham_turbidity: None }).unwrap();
    let numeric = hemisphere_integral(|d| basis.radiance(1, d.as_vec3()) as f64);
    assert!((numeric - 1.0).abs() < 1e-6, "{numeric}");
    // Uniform: 1/π everywhere above the horizon.
    assert!((basis.radiance(0, Vec3::new(0.3, 0.2, 0.1)) as f64 - 1.0 / PI).abs() < 1e-7);
}

#[test]
fn uniform_shape_on_tilted_normals() {
    // Irradiance of a uniform sky of unit horizontal irradiance on normal n is (1 + n_y)/2.
    let basis = SkyBasis::new(sun_at(20.0, 0.0), &SkyBasisSpec::uniform()).unwrap();
    let set = CosineSet::fibonacci(4096).unwrap();
    for n in [Vec3::Y, Vec3::X, Vec3::NEG_Z, Vec3::new(0.3, 0.8, 0.1), Vec3::new(0.0, -0.6, 0.8), Vec3::NEG_Y] {
        let n = n.normalize();
        let e = irradiance(&basis, n, &set, |_| true).unwrap();
        let exact = (1.0 + n.y) / 2.0;
        // The horizon cuts the cosine lobe: measured worst error 4.4e-4 at M = 4096.
        assert!((e.per_shape[0] - exact).abs() < 2e-3, "{n}: {} vs {exact}", e.per_shape[0]);
        // The rest of the lobe looks below the horizon: ∫_{y<0} max(n·ω, 0) dω = π(1 − n_y)/2
        // (measured worst error 1.4e-3).
        let below = PI as f32 * (1.0 - n.y) / 2.0;
        assert!((e.below_horizon - below).abs() < 6e-3, "{n}: {} vs {below}", e.below_horizon);
    }
}

#[test]
fn visibility_callback_blocks_light() {
    let basis = SkyBasis::new(sun_at(40.0, 90.0), &SkyBasisSpec::default()).unwrap();
    let set = CosineSet::fibonacci(4096).unwrap();
    // Half the sky (x > 0) hidden from a horizontal surface: the uniform shape gives ½.
    let e = irradiance(&basis, Vec3::Y, &set, |d| d.x <= 0.0).unwrap();
    assert!((e.per_shape[0] - 0.5).abs() < 2e-3, "{}", e.per_shape[0]);
    // The sun is east (+X): hiding the east half removes most of the circumsolar light.
    assert!(e.per_shape[1] < 0.35, "{}", e.per_shape[1]);
    // Everything hidden: nothing arrives.
    let none = irradiance(&basis, Vec3::Y, &set, |_| false).unwrap();
    assert!(none.per_shape.iter().all(|v| *v == 0.0) && none.below_horizon == 0.0);
    assert!(irradiance(&basis, Vec3::ZERO, &set, |_| true).is_err());
}

#[test]
fn shapes_follow_the_sun() {
    let sun = sun_at(15.0, 200.0);
    let basis = SkyBasis::new(sun, &full_spec()).unwrap();
    let away = sun_at(15.0, 20.0);
    for k in [1, 3] {
        assert!(basis.radiance(k, sun) > 5.0 * basis.radiance(k, away), "{}", basis.name(k));
    }
    // The horizon band is brighter at the horizon than at the zenith, by e^{1/sin 12°}.
    let ratio = basis.radiance(2, Vec3::X) / basis.radiance(2, Vec3::Y);
    assert!((ratio - (1.0 / 12f32.to_radians().sin()).exp()).abs() < 1e-3 * ratio, "{ratio}");
    let mut all = vec![0.0; 4];
    for d in [sun, away, Vec3::new(0.2, 0.7, -0.1)] {
        basis.radiances(d, &mut all);
        for k in 0..4 {
            assert_eq!(all[k], basis.radiance(k, d));
        }
    }
}

#[test]
fn model_horizontal_irradiance_is_the_sum_of_weights() {
    let basis = SkyBasis::new(sun_at(25.0, 45.0), &full_spec()).unwrap();
    let w = vec![[0.2, 0.25, 0.4], [0.1, 0.08, 0.05], [0.05, 0.06, 0.07], [0.02, 0.03, 0.01]];
    let model = SkyModel::new(basis, w).unwrap();
    let pa = model.horizontal_irradiance();
    assert!((pa[0] - 0.37).abs() < 1e-6 && (pa[2] - 0.53).abs() < 1e-6);
    let set = CosineSet::fibonacci(16_384).unwrap();
    let mut e = [0.0f32; 3];
    for d in set.around(Vec3::Y) {
        let l = model.radiance(d);
        for c in 0..3 {
            e[c] += l[c] * set.weight();
        }
    }
    for c in 0..3 {
        assert!((e[c] - pa[c]).abs() < 1e-3 * pa[c], "{e:?} vs {pa:?}");
    }
    let uniform = SkyModel::uniform(Vec3::Y, [0.5, 0.6, 0.7]).unwrap();
    assert!((uniform.radiance(Vec3::new(1.0, 0.1, 0.0))[1] - 0.6 / std::f32::consts::PI).abs() < 1e-7);
}

#[test]
fn invalid_inputs() {
    let bad = [
        SkyBasisSpec { circumsolar_width_deg: Some(1.0), ..SkyBasisSpec::default() },
        SkyBasisSpec { circumsolar_width_deg: Some(f64::NAN), ..SkyBasisSpec::default() },
        SkyBasisSpec { horizon_width_deg: Some(90.0), ..SkyBasisSpec::default() },
    ];
    for spec in bad {
        assert!(matches!(SkyBasis::new(Vec3::Y, &spec), Err(SkyError::Parameter { .. })), "{spec:?}");
    }
    let t = SkyBasisSpec { preetham_turbidity: Some(1.0), ..SkyBasisSpec::default() };
    assert!(matches!(SkyBasis::new(Vec3::Y, &t), Err(SkyError::Turbidity { .. })));
    assert!(matches!(SkyBasis::new(Vec3::splat(f32::NAN), &SkyBasisSpec::default()), Err(SkyError::BadDirection { .. })));
    let basis = SkyBasis::new(Vec3::Y, &SkyBasisSpec::default()).unwrap();
    assert_eq!(basis.radiance(0, Vec3::new(f32::NAN, 1.0, 0.0)), 0.0);
    assert_eq!(basis.radiance(1, Vec3::NEG_Y), 0.0);
    assert_eq!(basis.radiance(7, Vec3::Y), 0.0);
    assert!(matches!(SkyModel::new(basis.clone(), vec![[1.0; 3]]), Err(SkyError::Size { .. })));
    assert!(matches!(SkyModel::new(basis, vec![[1.0; 3], [f32::NAN; 3], [0.0; 3]]), Err(SkyError::Parameter { .. })));
}
