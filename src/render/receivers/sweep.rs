//! Where a virtual object's shadow can fall: the box swept away from the sun, or away from a
//! point lamp.

use glam::Vec3;

/// Whether `p` lies in the box `(lo, hi)` or in its shadow sweep along `−l`: moving from `p`
/// toward the sun, does the ray pass through the box?
pub fn swept_box_contains((lo, hi): (Vec3, Vec3), l: Vec3, p: Vec3) -> bool {
    // Slab test of the ray p + t·l, t ≥ 0.
    let (mut t0, mut t1) = (0.0f32, f32::MAX);
    for a in 0..3 {
        if l[a].abs() < 1e-12 {
            if p[a] < lo[a] || p[a] > hi[a] {
                return false;
            }
        } else {
            let (ta, tb) = ((lo[a] - p[a]) / l[a], (hi[a] - p[a]) / l[a]);
            t0 = t0.max(ta.min(tb));
            t1 = t1.min(ta.max(tb));
        }
    }
    t0 <= t1
}

/// Whether the segment from `p` to the lamp at `lamp` passes through the box `(lo, hi)` (`p`
/// inside the box counts): where the box's shadow from a point lamp can fall.
pub fn box_between((lo, hi): (Vec3, Vec3), lamp: Vec3, p: Vec3) -> bool {
    let d = lamp - p;
    let (mut t0, mut t1) = (0.0f32, 1.0f32);
    for a in 0..3 {
        if d[a].abs() < 1e-12 {
            if p[a] < lo[a] || p[a] > hi[a] {
                return false;
            }
        } else {
            let (ta, tb) = ((lo[a] - p[a]) / d[a], (hi[a] - p[a]) / d[a]);
            t0 = t0.max(ta.min(tb));
            t1 = t1.min(ta.max(tb));
        }
    }
    t0 <= t1
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn swept_box() {
        let b = (Vec3::ZERO, Vec3::ONE);
        let l = Vec3::new(0.0, 1.0, 0.0);
        assert!(swept_box_contains(b, l, Vec3::new(0.5, -3.0, 0.5)));
        assert!(swept_box_contains(b, l, Vec3::new(0.5, 0.5, 0.5)));
        assert!(!swept_box_contains(b, l, Vec3::new(0.5, 3.0, 0.5)));
        assert!(!swept_box_contains(b, l, Vec3::new(1.5, -3.0, 0.5)));
        let l = Vec3::new(1.0, 1.0, 0.0).normalize();
        assert!(swept_box_contains(b, l, Vec3::new(-1.5, -1.5, 0.5)));
        assert!(!swept_box_contains(b, l, Vec3::new(1.5, -1.5, 0.5)));
    }

    #[test]
    fn box_between_a_point_and_a_lamp() {
        let b = (Vec3::ZERO, Vec3::ONE);
        let lamp = Vec3::new(0.5, 4.0, 0.5);
        assert!(box_between(b, lamp, Vec3::new(0.5, -1.0, 0.5)), "right below");
        assert!(box_between(b, lamp, Vec3::new(0.5, 0.5, 0.5)), "inside");
        // The shadow widens away from the lamp: 3 m below the box's top it reaches 1.5 m out.
        assert!(box_between(b, lamp, Vec3::new(-0.4, -2.0, 0.5)));
        assert!(!box_between(b, lamp, Vec3::new(-1.8, -2.0, 0.5)));
        // Beyond the lamp, or between it and the box: no.
        assert!(!box_between(b, lamp, Vec3::new(0.5, 5.0, 0.5)));
        assert!(!box_between(b, lamp, Vec3::new(0.5, 2.0, 0.5)));
    }
}
