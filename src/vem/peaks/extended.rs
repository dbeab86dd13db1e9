//! An extended peak (a lamp several degrees wide) as a few lights: its texels' excess energy cut
//! into `k` groups of equal luminance by a small kd-tree, one light per group at the group's
//! excess-energy centroid, carrying its power and its angular radius.
//!
//! The cuts fall between texels (a peak holds at most a few hundred), across the group's longer
//! spread in the tangent plane at the peak's centroid, and split the luminance in the ratio of
//! the two halves' light counts (as [`crate::vem::sampling::coherent_cut`] does over the whole
//! map). A lamp whose output changes uniformly (a flicker) keeps its cuts, so its lights keep
//! their directions and indices while their power follows the lamp.

use glam::{DVec3, Vec3};

/// One texel of a peak: its centre direction, its excess energy `(L − B)·ΔΩ` per channel, the
/// luminance of that (at least 0), its solid angle and its position in the map (ties).
#[derive(Clone, Copy, Debug)]
pub(super) struct PeakTexel {
    pub dir: DVec3,
    pub rgb: [f64; 3],
    pub y: f64,
    pub sr: f64,
    pub k: usize,
}

/// One light of a peak: direction, power per channel, angular radius (radians).
pub(super) type PeakLight = (Vec3, [f32; 3], f32);

/// Cuts `texels` into `k` groups (fewer only if there are fewer texels) and pushes one light per
/// group onto `out`, left to right, so the `s`-th light of a peak is the same group every frame
/// while the peak keeps its shape. `centre` is the peak's centroid (unit).
pub(super) fn split(texels: &mut [PeakTexel], k: usize, centre: DVec3, out: &mut Vec<PeakLight>) {
    let (t1, t2) = centre.any_orthonormal_pair();
    split_rec(texels, k.clamp(1, texels.len().max(1)), (t1, t2), out);
}

fn split_rec(texels: &mut [PeakTexel], k: usize, frame: (DVec3, DVec3), out: &mut Vec<PeakLight>) {
    if k <= 1 || texels.len() <= 1 {
        out.push(group_light(texels));
        return;
    }
    let (kl, kr) = (k / 2, k - k / 2);
    // The axis of the larger luminance-weighted spread in the tangent plane.
    let spread = |axis: DVec3| {
        let (mut s, mut s2, mut w) = (0.0, 0.0, 0.0);
        for t in texels.iter() {
            let x = t.dir.dot(axis);
            s += t.y * x;
            s2 += t.y * x * x;
            w += t.y;
        }
        if w > 0.0 { s2 / w - (s / w) * (s / w) } else { 0.0 }
    };
    let axis = if spread(frame.0) >= spread(frame.1) { frame.0 } else { frame.1 };
    texels.sort_unstable_by(|a, b| a.dir.dot(axis).total_cmp(&b.dir.dot(axis)).then(a.k.cmp(&b.k)));
    let total: f64 = texels.iter().map(|t| t.y).sum();
    // The first texel boundary reaching the target; a boundary on the target (equal texels,
    // common inside a lamp) within rounding, so that a uniformly scaled peak cuts alike.
    let target = total * kl as f64 / k as f64 - 1e-9 * total;
    let mut acc = 0.0;
    let mut left = texels.len();
    for (i, t) in texels.iter().enumerate() {
        acc += t.y;
        if acc >= target {
            left = i + 1;
            break;
        }
    }
    let left = left.clamp(kl, texels.len() - kr);
    let (a, b) = texels.split_at_mut(left);
    split_rec(a, kl, frame, out);
    split_rec(b, kr, frame, out);
}

/// The light of one group: the excess-energy centroid, the summed power (each channel at least
/// 0) and the radius of the uniform disc with the same luminance-weighted angular spread
/// (`⟨α²⟩ = R²/2`; each texel adds its own extent, `ΔΩ/6` for a square of that area).
fn group_light(texels: &[PeakTexel]) -> PeakLight {
    let (mut rgb, mut c, mut w) = ([0.0f64; 3], DVec3::ZERO, 0.0);
    for t in texels {
        for ch in 0..3 {
            rgb[ch] += t.rgb[ch];
        }
        c += t.dir * t.y;
        w += t.y;
    }
    let dir = c.try_normalize().or_else(|| texels.iter().fold(DVec3::ZERO, |a, t| a + t.dir).try_normalize()).unwrap_or(DVec3::Y);
    let m2 = if w > 0.0 { texels.iter().map(|t| t.y * (t.dir.dot(dir).clamp(-1.0, 1.0).acos().powi(2) + t.sr / 6.0)).sum::<f64>() / w } else { 0.0 };
    (dir.as_vec3(), rgb.map(|v| v.max(0.0) as f32), (2.0 * m2).sqrt() as f32)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A uniform disc of angular radius `r` around `c`, sampled on a fine tangent grid.
    fn disc(c: DVec3, r: f64, step: f64) -> Vec<PeakTexel> {
        let (t1, t2) = c.any_orthonormal_pair();
        let n = (r / step).ceil() as i64;
        let mut out = Vec::new();
        for a in -n..=n {
            for b in -n..=n {
                let (x, y) = (a as f64 * step, b as f64 * step);
                if x * x + y * y <= r * r {
                    let dir = (c + t1 * x + t2 * y).normalize();
                    out.push(PeakTexel { dir, rgb: [step * step; 3], y: step * step, sr: step * step, k: out.len() });
                }
            }
        }
        out
    }

    #[test]
    fn a_uniform_disc_gives_one_light_at_its_centre_with_its_radius() {
        // Closed form: for a uniform disc ⟨α²⟩ = R²/2, so the radius comes back (to the grid's
        // step, 2%), and the centroid is the disc's centre.
        let c = DVec3::new(0.2, 0.9, -0.3).normalize();
        let r = 6f64.to_radians();
        let mut t = disc(c, r, r / 40.0);
        let mut out = Vec::new();
        split(&mut t, 1, c, &mut out);
        assert_eq!(out.len(), 1);
        // f32 output: the unit vectors agree to 1e-5 (0.0006°).
        assert!((out[0].0.as_dvec3() - c).length() < 1e-5, "{:?} vs {c:?}", out[0].0);
        assert!((out[0].2 as f64 - r).abs() < 0.02 * r, "{} vs {r}", out[0].2);
        let area: f64 = t.iter().map(|x| x.y).sum();
        assert!((out[0].1[0] as f64 - area).abs() < 1e-5 * area);
    }

    #[test]
    fn k_lights_share_the_power_equally_and_keep_their_order_when_scaled() {
        let c = DVec3::new(-0.25, 0.92, 0.3).normalize();
        let mut t = disc(c, 6f64.to_radians(), 0.2f64.to_radians());
        let total: f64 = t.iter().map(|x| x.y).sum();
        let mut a = Vec::new();
        split(&mut t, 10, c, &mut a);
        assert_eq!(a.len(), 10);
        for l in &a {
            // Equal shares up to one texel of the ~2800 in the disc (10 per light: 1/280 = 0.4%).
            assert!((l.1[0] as f64 - total / 10.0).abs() < 0.01 * total / 10.0, "{:?}", l.1);
            assert!(l.2 > 0.0 && (l.2 as f64) < 4f64.to_radians());
        }
        // A flicker scales every texel: the same groups, the same directions.
        for x in t.iter_mut() {
            x.rgb = x.rgb.map(|v| v * 1.25);
            x.y *= 1.25;
        }
        let mut b = Vec::new();
        split(&mut t, 10, c, &mut b);
        for (x, y) in a.iter().zip(&b) {
            assert!((x.0 - y.0).length() < 1e-6, "{:?} vs {:?}", x.0, y.0);
            assert!((y.1[0] / x.1[0] - 1.25).abs() < 1e-4);
        }
    }
}
