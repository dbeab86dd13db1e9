//! The canvas rectangle the 3D passes need: the virtual objects and the real surfaces their
//! shadows can reach. Outside it the depth prepass, the shadow volumes, their resolves, the masks
//! and the shading have nothing to contribute (the composite leaves those pixels as the footage,
//! because the cleared layers say so), so each of those passes is scissored to it. On a software
//! rasteriser the full-canvas passes (five mask draws and two resolves, each over every
//! multisample) and the large real volumes cost in proportion to the area they cover.

use crate::gpu::canvas::{Canvas, NEAR_M};
use crate::render::receivers::{Receivers, swept_box_contains};
use glam::{DVec3, Vec3};
use rayon::prelude::*;

/// Canvas pixels added on every side: MSAA edges, the bilinear taps of the lens warp and the 3×3
/// lookups of the shading pass reach one or two pixels beyond what they cover.
const REGION_MARGIN_PX: u32 = 4;
/// Above this share of the canvas the whole canvas is used (a scissor would save nothing).
const FULL_CANVAS_SHARE: f64 = 0.8;

/// A rectangle of canvas pixels.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub struct Rect {
    /// Left column.
    pub x: u32,
    /// Top row.
    pub y: u32,
    /// Width.
    pub width: u32,
    /// Height.
    pub height: u32,
}

struct Bounds {
    lo: (f64, f64),
    hi: (f64, f64),
}

impl Bounds {
    fn empty() -> Self {
        Self { lo: (f64::MAX, f64::MAX), hi: (f64::MIN, f64::MIN) }
    }
    fn add(&mut self, x: f64, y: f64) {
        self.lo = (self.lo.0.min(x), self.lo.1.min(y));
        self.hi = (self.hi.0.max(x), self.hi.1.max(y));
    }
    fn is_empty(&self) -> bool {
        self.lo.0 > self.hi.0
    }
}

/// The rectangle for the objects' boxes `bounds` and, with a sun `l`, the footage pixels whose
/// proxy point lies in a box's shadow sweep, mapped through the lens warp. `None` means the whole
/// canvas: a box reaches behind the near plane (its projection is unbounded), or the rectangle
/// would cover most of the canvas anyway.
pub fn canvas_region(canvas: &Canvas, receivers: &Receivers, bounds: &[(Vec3, Vec3)], sun: Option<Vec3>) -> Option<Rect> {
    let mut b = Bounds::empty();
    for (lo, hi) in bounds {
        for k in 0..8 {
            let c = DVec3::new(if k & 1 == 0 { lo.x } else { hi.x } as f64, if k & 2 == 0 { lo.y } else { hi.y } as f64, if k & 4 == 0 { lo.z } else { hi.z } as f64);
            if canvas.pose.camera_from_world(c).z <= NEAR_M {
                return None;
            }
            let p = canvas.canvas_from_world(c)?;
            b.add(p.x, p.y);
        }
    }
    if let Some(l) = sun {
        let reached: Vec<(f64, f64)> = receivers
            .point
            .par_iter()
            .enumerate()
            .filter_map(|(i, p)| {
                let p = (*p)?;
                if !bounds.iter().any(|bx| swept_box_contains(*bx, l, p)) {
                    return None;
                }
                let w = canvas.warp[i];
                (w[0] >= 0.0).then_some((w[0] as f64, w[1] as f64))
            })
            .collect();
        for (x, y) in reached {
            b.add(x, y);
        }
    }
    if b.is_empty() {
        return None;
    }
    let m = REGION_MARGIN_PX as f64;
    let x0 = (b.lo.0 - m).floor().max(0.0) as u32;
    let y0 = (b.lo.1 - m).floor().max(0.0) as u32;
    let x1 = ((b.hi.0 + m).ceil().max(0.0) as u32 + 1).min(canvas.intrinsics.width);
    let y1 = ((b.hi.1 + m).ceil().max(0.0) as u32 + 1).min(canvas.intrinsics.height);
    if x1 <= x0 || y1 <= y0 {
        // Objects and shadows entirely off the canvas: nothing to draw, but a scissor must not
        // be empty, so one corner pixel (whose clear layers the composite leaves alone).
        return Some(Rect { x: 0, y: 0, width: 1, height: 1 });
    }
    let r = Rect { x: x0, y: y0, width: x1 - x0, height: y1 - y0 };
    let share = (r.width as f64 * r.height as f64) / (canvas.intrinsics.width as f64 * canvas.intrinsics.height as f64);
    (share <= FULL_CANVAS_SHARE).then_some(r)
}

/// Sets `rect` (or the whole canvas) as the pass's scissor.
pub fn set_scissor(pass: &mut wgpu::RenderPass<'_>, rect: Option<Rect>) {
    if let Some(r) = rect {
        pass.set_scissor_rect(r.x, r.y, r.width, r.height);
    }
}
