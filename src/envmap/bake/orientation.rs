//! Is the environment map turned the way the scene says? (issue 13 §5)
//!
//! The bake knows, per texel, whether the capture centre sees the proxy there or the open sky
//! ([`super::SKY`]). In the captured map the open sky is, over the upper hemisphere, the bright
//! part, and walls and roofs the darker part. The check scores that agreement: the
//! solid-angle-weighted fraction of upper-hemisphere texels that one luminance threshold (the
//! best one) classifies as the geometry predicts. It is scored for the map as read and for the map
//! turned about the vertical in [`YAW_STEPS`] steps; a turn that agrees clearly better (by more
//! than [`WARN_MARGIN`]) is named in a warning. A map rolled by half a turn, for instance, puts
//! the sky where the proxy's buildings are and scores far lower than the right one.

use super::SKY;
use crate::geometry::equirect::texel_solid_angle;
use crate::io::image::LinearImage;
use serde::{Deserialize, Serialize};

/// Turns tried, evenly over 360°.
pub const YAW_STEPS: usize = 24;
/// A turn whose agreement beats the map as read by more than this (fraction) is warned about.
pub const WARN_MARGIN: f64 = 0.05;
/// Each class (sky, proxy) must hold at least this fraction of the upper hemisphere's solid
/// angle for the check to mean anything.
pub const MIN_CLASS_FRACTION: f64 = 0.02;

/// The check's result (`bake.json`).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Orientation {
    /// Agreement of the map as read, fraction of the upper hemisphere's solid angle.
    pub agreement: f64,
    /// The turn about +Y (degrees, the map's columns shifted toward +x by `yaw/360·width`) that
    /// agrees best.
    pub best_yaw_deg: f64,
    /// Its agreement.
    pub best_agreement: f64,
}

impl Orientation {
    /// A warning when another turn agrees clearly better.
    pub fn warning(&self) -> Option<String> {
        (self.best_yaw_deg != 0.0 && self.best_agreement - self.agreement > WARN_MARGIN).then(|| {
            format!(
                "warning: the environment map agrees with the proxy on {:.1}% of the upper hemisphere as read, but on {:.1}% turned by {:.0}° about the vertical: check its orientation (north at the centre column, +Y up)",
                100.0 * self.agreement,
                100.0 * self.best_agreement,
                self.best_yaw_deg
            )
        })
    }
}

/// Scores `img` against `node` (per texel, [`SKY`] or a proxy node; both `img.width ×
/// img.height`); `None` when the upper hemisphere is nearly all sky or all proxy.
pub fn check(node: &[u32], img: &LinearImage) -> Option<Orientation> {
    let (w, h) = (img.width as usize, img.height as usize);
    if node.len() != w * h || w < YAW_STEPS {
        return None;
    }
    let rows = h / 2;
    let weight: Vec<f64> = (0..rows).map(|j| texel_solid_angle(j as u32, img.width, img.height) as f64).collect();
    let total: f64 = weight.iter().sum::<f64>() * w as f64;
    let sky: f64 = (0..rows * w).filter(|&k| node[k] == SKY).map(|k| weight[k / w]).sum();
    if !(sky > MIN_CLASS_FRACTION * total && total - sky > MIN_CLASS_FRACTION * total) {
        return None;
    }
    let luminance = |p: [f32; 3]| {
        let l = 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2];
        if l.is_finite() { l } else { 0.0 }
    };
    let score = |shift: usize| -> f64 {
        // (luminance of the map texel read at the predicted texel, predicted sky, weight)
        let mut t: Vec<(f32, bool, f64)> = (0..rows * w)
            .map(|k| {
                let (i, j) = (k % w, k / w);
                (luminance(img.data[j * w + (i + shift) % w]), node[k] == SKY, weight[j])
            })
            .collect();
        t.sort_by(|a, b| a.0.total_cmp(&b.0));
        // Threshold below every texel: all called sky. Moving it up past a texel calls it proxy.
        let mut right = sky;
        let mut best = right;
        for (_, is_sky, wt) in &t {
            right += if *is_sky { -wt } else { *wt };
            best = best.max(right);
        }
        best / total
    };
    let scores: Vec<f64> = (0..YAW_STEPS).map(|s| score(s * w / YAW_STEPS)).collect();
    let (best, best_agreement) = scores.iter().copied().enumerate().fold((0, scores[0]), |a, (s, v)| if v > a.1 { (s, v) } else { a });
    Some(Orientation { agreement: scores[0], best_yaw_deg: (best * 360 / YAW_STEPS) as f64, best_agreement })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A map whose sky is bright where the predicted mask says sky (one side of the horizon's
    /// upper half open, the other built up), read straight and rolled by half a turn.
    #[test]
    fn a_map_rolled_by_half_a_turn_is_named() {
        let (w, h) = (96u32, 48u32);
        let node: Vec<u32> = (0..w * h).map(|k| if (k % w) < w / 2 || (k / w) < h / 8 { SKY } else { 3 }).collect();
        let img = LinearImage::from_fn(w, h, |x, y| if node[(y * w + x) as usize] == SKY { [2.0, 2.2, 3.0] } else { [0.2, 0.2, 0.18] });
        let right = check(&node, &img).expect("both classes");
        assert!(right.agreement > 0.999 && right.best_yaw_deg == 0.0 && right.warning().is_none(), "{right:?}");
        let rolled = LinearImage::from_fn(w, h, |x, y| img.get((x + w / 2) % w, y));
        let o = check(&node, &rolled).unwrap();
        assert_eq!(o.best_yaw_deg, 180.0, "{o:?}");
        assert!(o.best_agreement > 0.999 && o.agreement < 0.85, "{o:?}");
        assert!(o.warning().is_some_and(|m| m.contains("180°")));
        // All sky: nothing to compare.
        assert!(check(&vec![SKY; (w * h) as usize], &img).is_none());
    }
}
