//! The peak detector on closed-form skies: one sun, a sun behind thin cloud, an overcast sky, two
//! lamps and a flickering lamp (issue 14).

use super::*;
use glam::Vec3;

fn sky_with_sun(i: u32, j: u32, e: f32) -> PolarMap {
    let mut m = PolarMap::from_fn(360, 90, |d| [0.5 + 0.3 * d.y, 0.6 + 0.3 * d.y, 0.9]);
    let sr = m.row_solid_angle(j);
    let k = (j * 360 + i) as usize;
    m.data[k] = m.data[k].map(|v| v + e / sr);
    m
}

#[test]
fn a_sun_becomes_one_light_with_its_power_and_the_rest_is_kept() {
    let map = sky_with_sun(100, 30, 10.0);
    let mut t = PeakTracker::new();
    t.split(&map, 4);
    assert_eq!(t.peaks().len(), 1);
    let p = t.peaks()[0];
    assert!(p.dir.dot(map.texel_dir(100, 30)) > 1.0 - 1e-6);
    assert!((p.rgb[1] - 10.0).abs() < 1e-3 * 10.0, "{:?}", p.rgb);
    let (a, b) = (map.total_power(), t.remainder().total_power());
    for c in 0..3 {
        assert!((a[c] - b[c] - p.rgb[c] as f64).abs() < 1e-4 * a[c]);
    }
}

#[test]
fn a_moving_sun_keeps_its_index_and_a_smooth_sky_has_no_peak() {
    let mut t = PeakTracker::new();
    t.split(&sky_with_sun(100, 30, 10.0), 4);
    let first = t.peaks()[0].index;
    assert!(first >= PEAK_INDEX_BASE);
    t.split(&sky_with_sun(101, 30, 9.0), 4);
    assert_eq!(t.peaks()[0].index, first);
    t.split(&sky_with_sun(101, 30, 0.0), 4);
    assert!(t.peaks().is_empty());
    t.split(&sky_with_sun(200, 60, 10.0), 4);
    assert_ne!(t.peaks()[0].index, first);
    t.split(&sky_with_sun(200, 60, 10.0), 0);
    assert!(t.peaks().is_empty());
}

/// A dim room (radiance `room`) with hard-edged lamps: (direction, angular radius, radiance).
fn room_with_lamps(room: f32, lamps: &[(Vec3, f32, f32)]) -> PolarMap {
    PolarMap::from_fn(360, 90, |d| {
        let lit = lamps.iter().find(|(c, r, _)| d.dot(*c) >= r.cos());
        [lit.map_or(room, |l| l.2); 3]
    })
}

/// The excess power `Σ (L − room)·ΔΩ` of the texels of `map` inside the cap around `c`.
fn cap_excess(map: &PolarMap, c: Vec3, r: f32, room: f32) -> f64 {
    let mut e = 0.0;
    for j in 0..map.height {
        for i in 0..map.width {
            if map.texel_dir(i, j).dot(c) >= r.cos() {
                e += (map.get(i, j)[1] - room) as f64 * map.row_solid_angle(j) as f64;
            }
        }
    }
    e
}

#[test]
fn two_lamps_are_two_peaks_with_their_power_split_over_a_few_lights() {
    // Hard-edged discs on a constant room: the background is exactly `room`, so each peak's
    // lights carry exactly the excess of the disc's texels (f32 sums: 1e-4), at its centroid.
    let (a, b) = (Vec3::new(-0.3, 0.9, 0.3).normalize(), Vec3::new(0.6, 0.5, -0.4).normalize());
    let r = 3f32.to_radians();
    let map = room_with_lamps(0.2, &[(a, r, 60.0), (b, r, 30.0)]);
    let mut t = PeakTracker::new();
    t.split(&map, 63);
    let groups: std::collections::BTreeMap<u32, Vec<Light>> = t.peaks().iter().fold(Default::default(), |mut g, l| {
        g.entry((l.index - PEAK_INDEX_BASE) / MAX_PEAK_LIGHTS as u32).or_default().push(*l);
        g
    });
    assert_eq!(groups.len(), 2, "{:?}", t.peaks());
    for (lamp, lights) in [a, b].iter().zip(groups.values()) {
        // A 3° disc is 0.0086 sr: 3 lights of at most PEAK_LIGHT_SR each.
        assert_eq!(lights.len(), 3, "{lights:?}");
        let want = cap_excess(&map, *lamp, r, 0.2);
        let got: f64 = lights.iter().map(|l| l.rgb[1] as f64).sum();
        assert!((got - want).abs() < 1e-4 * want, "{got} vs {want}");
        let c = lights.iter().fold(Vec3::ZERO, |s, l| s + l.dir * l.rgb[1]).normalize();
        assert!(c.dot(*lamp) > 0.2f32.to_radians().cos(), "centroid {c:?} vs {lamp:?}");
        // Each light stands for a third of the disc: radius between a sixth and the disc's.
        assert!(lights.iter().all(|l| l.radius > 0.5f32.to_radians() && l.radius < r), "{lights:?}");
    }
}

#[test]
fn a_sun_behind_thin_cloud_is_still_one_peak_and_an_overcast_sky_has_none() {
    // The sun dimmed to 30% inside a bright 5° cloud glow (twice the sky) is still a peak; its
    // power is the sun's (the glow's gradient over the ring: 2%).
    let mut map = sky_with_sun(100, 30, 3.0);
    let sun = map.texel_dir(100, 30);
    for j in 0..90 {
        for i in 0..360 {
            if map.texel_dir(i, j).dot(sun) > 5f32.to_radians().cos() {
                let k = (j * 360 + i) as usize;
                map.data[k] = map.data[k].map(|v| v + 0.6);
            }
        }
    }
    let mut t = PeakTracker::new();
    t.split(&map, 8);
    assert_eq!(t.peaks().len(), 1);
    assert!((t.peaks()[0].rgb[1] - 3.0).abs() < 0.02 * 3.0, "{:?}", t.peaks()[0].rgb);
    // Overcast: a bright, soft cloud deck and no compact source.
    let overcast = PolarMap::from_fn(360, 90, |d| [1.0 + 2.0 * d.y.powi(2) + 0.5 * (3.0 * d.x).sin().abs(); 3]);
    t.split(&overcast, 8);
    assert!(t.peaks().is_empty());
}

#[test]
fn a_flickering_lamp_keeps_its_lights_in_place_and_leaves_no_flicker_in_the_remainder() {
    // The indoor sequence's lamp (6° radius, ±25% per frame, box-filtered edges): its lights
    // keep count, indices and directions, and the remainder does not change with it (the
    // partly covered texels around the lamp go with the peak, not the remainder).
    use crate::vem::eval::synth;
    let maps: Vec<PolarMap> = (0..6).map(|k| synth::render_polar(&synth::indoor_lamp(k, synth::RATE_HZ), 360, 90, 2)).collect();
    let mut t = PeakTracker::new();
    let mut first: Option<(Vec<Light>, [f64; 3])> = None;
    for m in &maps {
        t.split(m, 299);
        let lights = t.peaks().to_vec();
        // 0.034 sr of disc and part of its edge: 10 lights.
        assert!((9..=11).contains(&lights.len()), "{}", lights.len());
        let rest = t.remainder().total_power();
        match &first {
            None => first = Some((lights, rest)),
            Some((l0, r0)) => {
                assert_eq!(l0.len(), lights.len());
                for (x, y) in l0.iter().zip(&lights) {
                    assert_eq!(x.index, y.index);
                    // Unit vectors 2e-4 apart are 0.01° apart.
                    assert!((x.dir - y.dir).length() < 2e-4, "{:?} vs {:?}", x.dir, y.dir);
                }
                // The map's power changes by up to ±8% from frame to frame; the remainder by less
                // than 0.05% (the background ring moves a little with the lamp's glow).
                assert!((rest[1] - r0[1]).abs() < 5e-4 * r0[1], "{rest:?} vs {r0:?}");
            }
        }
    }
}
