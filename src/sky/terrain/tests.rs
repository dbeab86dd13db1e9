use super::*;
use crate::geometry::equirect::dir_from_texel_centre;
use crate::sky::basis::{SkyBasis, SkyBasisSpec};
use crate::sky::quadrature::{CosineSet, irradiance};

fn sun_at(elevation_deg: f32, azimuth_deg: f32) -> Vec3 {
    let (e, a) = (elevation_deg.to_radians(), azimuth_deg.to_radians());
    Vec3::new(e.cos() * a.sin(), e.sin(), -e.cos() * a.cos())
}

#[test]
fn radiance_is_the_closed_form_and_linear() {
    let t = Terrain::new([0.8, 0.78, 0.75]).unwrap();
    let r = t.radiance(sun_at(30.0, 160.0) * 3.0).unwrap();
    for c in 0..3 {
        let a = t.albedo_rgb()[c];
        assert!((r.per_pa[c] - a / PI).abs() < 1e-7);
        // cos θ_sun = sin 30° = ½.
        assert!((r.per_pd[c] - a / PI * 0.5).abs() < 1e-6);
    }
    let (pa, pd) = ([0.3, 0.35, 0.45], [2.0, 1.8, 1.4]);
    let l = r.radiance(pa, pd);
    let l2 = r.radiance(pa.map(|v| 2.0 * v), pd.map(|v| 2.0 * v));
    let la = r.radiance(pa, [0.0; 3]);
    let ld = r.radiance([0.0; 3], pd);
    for c in 0..3 {
        assert!((l2[c] - 2.0 * l[c]).abs() < 1e-6 && (la[c] + ld[c] - l[c]).abs() < 1e-6);
        let exact = t.albedo_rgb()[c] / PI * (pa[c] + 0.5 * pd[c]);
        assert!((l[c] - exact).abs() < 1e-6);
    }
}

#[test]
fn sun_below_the_horizon_lights_no_terrain() {
    let t = Terrain::new([0.5; 3]).unwrap();
    let r = t.radiance(sun_at(-3.0, 90.0)).unwrap();
    assert_eq!(r.per_pd, [0.0; 3]);
    assert!((r.per_pa[0] - 0.5 / PI).abs() < 1e-7);
    assert!(t.radiance(Vec3::new(f32::NAN, 1.0, 0.0)).is_err());
    assert!(t.radiance(Vec3::ZERO).is_err());
    for bad in [[-0.1, 0.5, 0.5], [0.5, 1.01, 0.5], [0.5, 0.5, f32::NAN]] {
        assert!(matches!(Terrain::new(bad), Err(SkyError::Albedo { .. })), "{bad:?}");
    }
}

#[test]
fn wall_lit_by_terrain_and_sky() {
    // An unoccluded vertical wall sees the terrain over half its lobe: E_below = π/2, so it gets
    // ρ_t/2·(Pa + cos θ_sun·Pd) from the terrain and ½·Pa from a uniform sky.
    let sun = sun_at(10.0, 180.0);
    let basis = SkyBasis::new(sun, &SkyBasisSpec::uniform()).unwrap();
    let set = CosineSet::fibonacci(4096).unwrap();
    let e = irradiance(&basis, Vec3::Z, &set, |_| true).unwrap();
    let terrain = Terrain::new([0.8; 3]).unwrap().radiance(sun).unwrap().irradiance(e.below_horizon);
    let cos_sun = 10f32.to_radians().sin();
    // Horizon cut of the Fibonacci set: ≈ 5e-4 relative at M = 4096.
    assert!((terrain.per_pa[0] - 0.4).abs() < 2e-3, "{:?}", terrain.per_pa);
    assert!((terrain.per_pd[0] - 0.4 * cos_sun).abs() < 2e-3 * cos_sun.max(0.1), "{:?}", terrain.per_pd);
    assert!((e.per_shape[0] - 0.5).abs() < 2e-3);
}

/// A 128 × 64 map: sky above the horizon, proxy-covered texels (mask false) of arbitrary
/// radiance below it, terrain of albedo `rho` elsewhere, and every `outlier_every`-th open texel a
/// bright car (radiance × 4).
fn synthetic_map(rho: [f32; 3], capture: &CaptureLighting, outlier_every: usize, noise: f32) -> (Vec<[f32; 3]>, Vec<bool>) {
    let (w, h) = (128u32, 64u32);
    let lit = Terrain::new(rho).unwrap().radiance(capture.sun_dir_world).unwrap().radiance(capture.pa, capture.pd);
    let mut texels = Vec::new();
    let mut open = Vec::new();
    let mut n = 0usize;
    for j in 0..h {
        for i in 0..w {
            let d = dir_from_texel_centre(i, j, w, h);
            let covered = d.y < 0.0 && (d.x > 0.3 || d.y < -0.9);
            open.push(!covered);
            if d.y >= 0.0 {
                texels.push([5.0, 6.0, 9.0]);
            } else if covered {
                texels.push([0.01 * i as f32, 0.3, 50.0]);
            } else {
                n += 1;
                // Deterministic ±noise pattern with zero mean and a median of exactly 1.
                let f = 1.0 + noise * (((n * 7919) % 101) as f32 / 50.0 - 1.0);
                let k = if outlier_every > 0 && n % outlier_every == 0 { 4.0 } else { f };
                texels.push(lit.map(|v| v * k));
            }
        }
    }
    (texels, open)
}

fn capture() -> CaptureLighting {
    CaptureLighting { pd: [2.2, 1.9, 1.4], pa: [0.35, 0.42, 0.6], sun_dir_world: sun_at(8.0, 150.0) }
}

#[test]
fn albedo_round_trip() {
    let rho = [0.8, 0.78, 0.75];
    let (texels, open) = synthetic_map(rho, &capture(), 5, 0.0);
    let env = EquirectView { width: 128, height: 64, texels: &texels };
    let est = estimate_albedo(env, &open, capture(), &AlbedoSettings::default()).unwrap();
    assert!(est.fallback.is_none() && est.texels_used > 1000, "{est:?}");
    // 20% outliers do not move the median; the rest are exact up to f32 rounding.
    for c in 0..3 {
        assert!((est.albedo_rgb[c] - rho[c]).abs() < 1e-5, "{est:?}");
    }
    // ±5% texture in 101 levels: the median level is exactly 1 (measured error 0); the tolerance
    // allows one level (1e-3) of shift by the solid-angle weighting.
    let (texels, open) = synthetic_map([0.08; 3], &capture(), 0, 0.05);
    let env = EquirectView { width: 128, height: 64, texels: &texels };
    let est = estimate_albedo(env, &open, capture(), &AlbedoSettings::default()).unwrap();
    for c in 0..3 {
        assert!((est.albedo_rgb[c] - 0.08).abs() < 1e-3 * 0.08, "{est:?}");
    }
}

#[test]
fn albedo_fallbacks_and_clamps() {
    let settings = AlbedoSettings::default();
    let (mut texels, open) = synthetic_map([0.5; 3], &capture(), 0, 0.0);
    // Everything covered by the proxy: too few texels.
    let closed = vec![false; open.len()];
    let est = estimate_albedo(env(&texels), &closed, capture(), &settings).unwrap();
    assert_eq!(est.fallback, Some(AlbedoFallback::TooFewTexels));
    assert_eq!((est.albedo_rgb, est.texels_used), (settings.fallback_rgb, 0));
    // Night: no light on the terrain at capture.
    let dark = CaptureLighting { pd: [1.0; 3], pa: [0.0, 0.1, 0.1], sun_dir_world: sun_at(-5.0, 0.0) };
    assert_eq!(estimate_albedo(env(&texels), &open, dark, &settings).unwrap().fallback, Some(AlbedoFallback::NoCaptureLight(0)));
    // NaN and negative texels are counted and skipped.
    let first_open_below = (0..open.len()).find(|&k| open[k] && k > open.len() * 3 / 4).unwrap();
    texels[first_open_below] = [f32::NAN, 0.0, 0.0];
    texels[first_open_below + 1] = [-1.0, 0.0, 0.0];
    let est = estimate_albedo(env(&texels), &open, capture(), &settings).unwrap();
    assert_eq!(est.texels_invalid, 2);
    assert!((est.albedo_rgb[0] - 0.5).abs() < 1e-5);
    // A map far too bright for the stated lighting clamps at 1.
    let bright: Vec<[f32; 3]> = texels.iter().map(|t| t.map(|v| v * 10.0)).collect();
    assert_eq!(estimate_albedo(env(&bright), &open, capture(), &settings).unwrap().albedo_rgb, [1.0; 3]);
    // Size mismatches are errors.
    assert!(matches!(estimate_albedo(env(&texels), &open[1..], capture(), &settings), Err(SkyError::Size { .. })));
    let short = EquirectView { width: 128, height: 64, texels: &texels[1..] };
    assert!(matches!(estimate_albedo(short, &open, capture(), &settings), Err(SkyError::Size { .. })));
}

/// The 128 × 64 map of [`synthetic_map`] as a view.
fn env(texels: &[[f32; 3]]) -> EquirectView<'_> {
    EquirectView { width: 128, height: 64, texels }
}

#[test]
fn weighted_median_picks_the_half_weight_value() {
    let mut s = vec![(3.0, 1.0), (1.0, 1.0), (2.0, 1.0)];
    assert_eq!(weighted_median(&mut s), 2.0);
    let mut s = vec![(1.0, 0.1), (2.0, 0.1), (9.0, 5.0)];
    assert_eq!(weighted_median(&mut s), 9.0);
}
