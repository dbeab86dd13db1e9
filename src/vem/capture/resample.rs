//! Resampling of input frames (fisheye, equirect or polar) into the polar map (Havran §5.1: "the
//! environment map captured using a fish-eye lens has to be transformed to the uniform polar
//! coordinates").
//!
//! # How it works
//! The mapping is fixed for a calibration, so [`Resampler::new`] precomputes it once as a sparse
//! matrix (CSR: per polar texel, source pixels and weights) and every frame is a gather over it.
//! Each polar texel is box-filtered: it is split into `n_x × n_y` sub-samples, enough that they are
//! at most about a source pixel apart (from the local scale of the projection, at most
//! [`MAX_SUBSAMPLES`] per side), and each sub-sample reads the source bilinearly (pixel centres
//! at integer coordinates). Per frame only the source pixels the matrix references are linearised.
//! Pixels that are NaN, infinite or negative are left out of their texels' averages (the other
//! taps are renormalised) and counted; a texel whose every tap is invalid becomes black and is
//! counted too. Texels outside the lens's field of view are black and reported as uncovered.
//!
//! # Orientation
//! Equirect and polar frames are in the crate's layout (crate docs, "Equirectangular maps"):
//! row 0 the zenith, the centre column looking north (`−Z`), columns growing toward east (`+X`).
//! A **yaw** ([`Resampler::with_yaw`]) is a rotation of the input about the up axis: the input's
//! north (its centre column, or a fisheye's `−Z`) looks toward world azimuth `yaw`, clockwise
//! from north. The world direction of azimuth `a` is read from the input at azimuth `a − yaw`,
//! so the polar map, and every light taken from it, is in the world frame.

use crate::camera::Camera;
use crate::vem::polar::{PolarMap, dir_from_polar, polar_from_dir};
use crate::geometry::equirect::texel_from_dir;
use crate::io::frames::{Frame, Linearizer, PixelState};
use glam::{DVec2, Vec3};

/// Largest number of sub-samples per texel side.
pub const MAX_SUBSAMPLES: u32 = 8;
/// Source coordinates this close to a pixel centre (pixels) are snapped to it, so that rounding
/// in the direction round trip does not blend neighbours when the grids coincide.
const SNAP_PX: f64 = 2e-3;
/// Slack (pixels) when counting sub-samples, so that rounding does not add a sub-sample.
const COUNT_SLACK_PX: f64 = 0.05;

/// How a frame's pixels map to world directions.
#[derive(Clone, Debug, PartialEq)]
pub enum Projection {
    /// A calibrated fisheye.
    Fisheye(Camera),
    /// A full-sphere equirect map in the world frame (crate convention, width = 2 × height).
    Equirect,
    /// A polar map in the world frame (this module's convention, width = 4 × height).
    Polar,
}

/// `d` turned about the up axis (`+Y`) by `rad` of azimuth, clockwise from north seen from
/// above (north `−Z` → east `+X`): the direction of azimuth `a` goes to azimuth `a + rad`.
pub fn rotate_azimuth(d: Vec3, rad: f32) -> Vec3 {
    let (s, c) = rad.sin_cos();
    Vec3::new(d.x * c - d.z * s, d.y, d.z * c + d.x * s)
}

impl Projection {
    /// Source pixel coordinates (pixel centres at integers) of a world direction.
    fn source(&self, d: Vec3, w: u32, h: u32) -> Option<DVec2> {
        match self {
            Projection::Fisheye(cam) => cam.pixel_from_world_dir(d.as_dvec3()),
            Projection::Equirect => {
                let (x, y) = texel_from_dir(d, w, h);
                Some(DVec2::new(x as f64 - 0.5, y as f64 - 0.5))
            }
            Projection::Polar => polar_from_dir(d, w, h).map(|(x, y)| DVec2::new(x as f64 - 0.5, y as f64 - 0.5)),
        }
    }

    /// Whether source pixel `(c, r)` looks at a direction the calibration covers.
    fn sees(&self, c: u32, r: u32) -> bool {
        match self {
            Projection::Fisheye(cam) => cam.world_dir_from_pixel(DVec2::new(c as f64, r as f64)).is_some(),
            _ => true,
        }
    }

    fn wraps(&self) -> bool {
        !matches!(self, Projection::Fisheye(_))
    }
}

/// Counts from resampling one frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct ResampleStats {
    /// Referenced source pixels that were NaN, infinite or negative (left out).
    pub invalid_pixels: usize,
    /// Referenced source pixels at or above the clipping level (used as they are: a lower bound).
    pub clipped_pixels: usize,
    /// Polar texels whose every tap was invalid (set to black).
    pub empty_texels: usize,
    /// Polar texels outside the lens's field of view (black).
    pub uncovered_texels: usize,
}

/// The precomputed frame → polar map resampling.
#[derive(Clone, Debug)]
pub struct Resampler {
    /// Polar map size.
    pub polar_width: u32,
    /// Polar map size.
    pub polar_height: u32,
    /// Source frame size.
    pub source_width: u32,
    /// Source frame size.
    pub source_height: u32,
    /// Source pixels referenced (row-major indices).
    pixels: Vec<u32>,
    /// Per polar texel, its range of `entries` (`W·H + 1` offsets).
    offsets: Vec<u32>,
    /// `(index into pixels, weight)`.
    entries: Vec<(u32, f32)>,
    uncovered: usize,
    /// Per frame: linear values of the referenced pixels and whether they are usable.
    scratch: Vec<[f32; 3]>,
    valid: Vec<bool>,
}

impl Resampler {
    /// Precomputes the mapping from `source_width × source_height` frames to a
    /// `polar_width × polar_height` polar map (no yaw).
    pub fn new(projection: &Projection, source_width: u32, source_height: u32, polar_width: u32, polar_height: u32) -> Self {
        Self::with_yaw(projection, source_width, source_height, polar_width, polar_height, 0.0)
    }

    /// [`Resampler::new`] for an input turned by `yaw_deg` about the up axis (module docs,
    /// "Orientation"): its north looks toward world azimuth `yaw_deg`. A non-finite yaw counts as
    /// 0 (callers validate it: [`super::input::VemInput::set_yaw_deg`]).
    pub fn with_yaw(projection: &Projection, source_width: u32, source_height: u32, polar_width: u32, polar_height: u32, yaw_deg: f64) -> Self {
        let yaw = if yaw_deg.is_finite() { (-yaw_deg.rem_euclid(360.0)).to_radians() as f32 } else { 0.0 };
        let (sw, sh) = (source_width, source_height);
        let wraps = projection.wraps();
        let mut compact = vec![u32::MAX; (sw as usize) * (sh as usize)];
        // Per source pixel: 0 not checked yet, 1 inside the field of view, 2 outside.
        let mut sees = vec![0u8; (sw as usize) * (sh as usize)];
        let mut pixels = Vec::new();
        let mut offsets = Vec::with_capacity((polar_width * polar_height + 1) as usize);
        let mut entries = Vec::new();
        let mut uncovered = 0;
        let mut taps: Vec<(u32, f32)> = Vec::new();
        offsets.push(0);
        // Horizontal source distance, across the seam for wrapping projections.
        let dx = |a: f64, b: f64| {
            let d = (a - b).abs();
            if wraps { d.min(sw as f64 - d) } else { d }
        };
        for j in 0..polar_height {
            for i in 0..polar_width {
                taps.clear();
                let at = |x: f32, y: f32| projection.source(rotate_azimuth(dir_from_polar(x, y, polar_width, polar_height), yaw), sw, sh);
                let (xc, yc) = (i as f32 + 0.5, j as f32 + 0.5);
                // Local scale: source distance across the texel in x and y.
                let span = |a: Option<DVec2>, b: Option<DVec2>| match (a, b) {
                    (Some(a), Some(b)) => dx(a.x, b.x).hypot(a.y - b.y),
                    _ => 1.0,
                };
                // (Measured inside the texel, over half its size: the zenith has no azimuth.)
                let count = |s: f64| ((2.0 * s - COUNT_SLACK_PX).ceil() as u32).clamp(1, MAX_SUBSAMPLES);
                let nx = count(span(at(xc - 0.25, yc), at(xc + 0.25, yc)));
                let ny = count(span(at(xc, yc - 0.25), at(xc, yc + 0.25)));
                let sub_w = 1.0 / (nx * ny) as f32;
                for b in 0..ny {
                    for a in 0..nx {
                        let x = i as f32 + (a as f32 + 0.5) / nx as f32;
                        let y = j as f32 + (b as f32 + 0.5) / ny as f32;
                        let Some(p) = at(x, y) else { continue };
                        bilinear_taps(p, (sw, sh), wraps, projection, &mut sees, sub_w, &mut taps);
                    }
                }
                taps.sort_by_key(|t| t.0);
                let total: f32 = taps.iter().map(|t| t.1).sum();
                if taps.is_empty() || !(total > 0.0) {
                    uncovered += 1;
                } else {
                    let mut k = 0;
                    while k < taps.len() {
                        let px = taps[k].0;
                        let mut w = 0.0;
                        while k < taps.len() && taps[k].0 == px {
                            w += taps[k].1;
                            k += 1;
                        }
                        let slot = &mut compact[px as usize];
                        if *slot == u32::MAX {
                            *slot = pixels.len() as u32;
                            pixels.push(px);
                        }
                        entries.push((*slot, w / total));
                    }
                }
                offsets.push(entries.len() as u32);
            }
        }
        Self { polar_width, polar_height, source_width, source_height, pixels, offsets, entries, uncovered, scratch: Vec::new(), valid: Vec::new() }
    }

    /// Number of polar texels outside the source's field of view.
    pub fn uncovered_texels(&self) -> usize {
        self.uncovered
    }

    /// Number of source pixels the resampling reads.
    pub fn referenced_pixels(&self) -> usize {
        self.pixels.len()
    }

    /// Number of weights in the precomputed matrix (the per-frame cost).
    pub fn entries(&self) -> usize {
        self.entries.len()
    }

    /// Resamples one frame (of the size given to [`Resampler::new`]) into `out`.
    pub fn resample(&mut self, frame: &Frame, lin: &Linearizer, out: &mut PolarMap) -> ResampleStats {
        let mut stats = ResampleStats { uncovered_texels: self.uncovered, ..Default::default() };
        self.scratch.clear();
        self.valid.clear();
        for &p in &self.pixels {
            let (v, s) = lin.radiance(frame, p as usize);
            let ok = s != PixelState::Invalid && crate::vem::sampling::is_valid(&v);
            stats.invalid_pixels += usize::from(!ok);
            stats.clipped_pixels += usize::from(ok && s == PixelState::Clipped);
            self.scratch.push(v);
            self.valid.push(ok);
        }
        if out.width != self.polar_width || out.height != self.polar_height {
            *out = PolarMap::new(self.polar_width, self.polar_height);
        }
        if stats.invalid_pixels == 0 {
            // Every tap usable: the weights of a texel already sum to 1.
            for (t, o) in out.data.iter_mut().enumerate() {
                let mut acc = [0.0f32; 3];
                for &(k, w) in &self.entries[self.offsets[t] as usize..self.offsets[t + 1] as usize] {
                    let v = self.scratch[k as usize];
                    acc[0] += w * v[0];
                    acc[1] += w * v[1];
                    acc[2] += w * v[2];
                }
                *o = acc;
            }
            return stats;
        }
        for (t, o) in out.data.iter_mut().enumerate() {
            let (a, b) = (self.offsets[t] as usize, self.offsets[t + 1] as usize);
            let (mut acc, mut wsum) = ([0.0f32; 3], 0.0f32);
            for &(k, w) in &self.entries[a..b] {
                if self.valid[k as usize] {
                    let v = self.scratch[k as usize];
                    for c in 0..3 {
                        acc[c] += w * v[c];
                    }
                    wsum += w;
                }
            }
            *o = if wsum > 0.0 {
                acc.map(|c| c / wsum)
            } else {
                if b > a {
                    stats.empty_texels += 1;
                }
                [0.0; 3]
            };
        }
        stats
    }
}


/// Appends the bilinear taps of source point `p` (weights times `weight`) to `taps`: pixel
/// centres within `SNAP_PX` snap (so same-grid inputs copy), columns wrap for wrapping
/// projections, and pixels outside the lens's field of view (cached in `sees`: 0 not checked,
/// 1 inside, 2 outside) are left out.
fn bilinear_taps(p: DVec2, (sw, sh): (u32, u32), wraps: bool, projection: &Projection, sees: &mut [u8], weight: f32, taps: &mut Vec<(u32, f32)>) {
    let snap = |v: f64| if (v - v.round()).abs() < SNAP_PX { v.round() } else { v };
    let (x0, y0) = (snap(p.x).floor(), snap(p.y).floor());
    let p = DVec2::new(snap(p.x), snap(p.y));
    let (fx, fy) = ((p.x - x0) as f32, (p.y - y0) as f32);
    for (ox, oy, w) in [(0, 0, (1.0 - fx) * (1.0 - fy)), (1, 0, fx * (1.0 - fy)), (0, 1, (1.0 - fx) * fy), (1, 1, fx * fy)] {
        if w <= 0.0 {
            continue;
        }
        let mut c = x0 as i64 + ox;
        let mut r = y0 as i64 + oy;
        if wraps {
            c = c.rem_euclid(sw as i64);
            r = r.clamp(0, sh as i64 - 1);
        } else if c < 0 || r < 0 || c >= sw as i64 || r >= sh as i64 {
            continue;
        } else {
            let seen = &mut sees[(r as u32 * sw + c as u32) as usize];
            if *seen == 0 {
                *seen = if projection.sees(c as u32, r as u32) { 1 } else { 2 };
            }
            if *seen == 2 {
                continue;
            }
        }
        taps.push(((r as u32) * sw + c as u32, w * weight));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::frames::{FrameData, Response};
    use crate::io::image::LinearImage;

    fn hdr(img: LinearImage) -> Frame {
        Frame { width: img.width, height: img.height, data: FrameData::Hdr(img) }
    }

    /// A smooth sky with a brighter region: radiance as a function of direction.
    fn sky(d: Vec3) -> [f32; 3] {
        let g = 1.0 + 2.0 * d.y.max(0.0) + (3.0 * d.x).sin().abs();
        [g, 0.5 * g, 0.25 * g + d.z.abs()]
    }

    #[test]
    fn fisheye_frames_resample_to_the_polar_map() {
        let cam = Camera::equidistant_up(400, 180.0);
        // Render the fisheye from the sky function (pixel centres).
        let img = LinearImage::from_fn(400, 400, |u, v| {
            cam.world_dir_from_pixel(DVec2::new(u as f64, v as f64)).map_or([0.0; 3], |d| sky(d.as_vec3()))
        });
        let mut rs = Resampler::new(&Projection::Fisheye(cam), 400, 400, 360, 90);
        assert_eq!(rs.uncovered_texels(), 0);
        let mut map = PolarMap::new(360, 90);
        let lin = Linearizer::new(&Response::Linear, 1.0, 1.0, None);
        let st = rs.resample(&hdr(img), &lin, &mut map);
        assert_eq!(st, ResampleStats::default());
        let truth = PolarMap::from_fn(360, 90, sky);
        let mut worst = 0.0f32;
        for (a, b) in map.data.iter().zip(&truth.data) {
            for c in 0..3 {
                worst = worst.max((a[c] - b[c]).abs() / b[c].max(0.1));
            }
        }
        // Box filter over ~1° texels of a function with gradients of ~3/rad: ≲ 3%.
        assert!(worst < 0.03, "worst relative difference {worst}");
        // Energy: total power within 0.5%.
        let (p, q) = (map.total_power(), truth.total_power());
        assert!(((p[0] - q[0]) / q[0]).abs() < 0.005, "{p:?} {q:?}");
    }

    #[test]
    fn equirect_and_polar_inputs_and_invalid_pixels() {
        let eq = LinearImage::from_fn(720, 360, |x, y| sky(crate::geometry::equirect::dir_from_texel_centre(x, y, 720, 360)));
        let mut rs = Resampler::new(&Projection::Equirect, 720, 360, 360, 90);
        let lin = Linearizer::new(&Response::Linear, 1.0, 1.0, None);
        let mut map = PolarMap::new(360, 90);
        rs.resample(&hdr(eq.clone()), &lin, &mut map);
        let truth = PolarMap::from_fn(360, 90, sky);
        for (a, b) in map.data.iter().zip(&truth.data) {
            assert!((a[0] - b[0]).abs() < 0.03 * b[0], "{a:?} {b:?}");
        }
        // A polar frame of the default size is copied exactly.
        let mut rs = Resampler::new(&Projection::Polar, 360, 90, 360, 90);
        let img = LinearImage { width: 360, height: 90, data: truth.data.clone() };
        let mut out = PolarMap::new(360, 90);
        rs.resample(&hdr(img.clone()), &lin, &mut out);
        for (a, b) in out.data.iter().zip(&truth.data) {
            assert!((a[1] - b[1]).abs() < 1e-5 * b[1]);
        }
        // NaN and Inf pixels are left out and counted.
        let mut bad = img;
        bad.data[1000] = [f32::NAN, 0.0, 0.0];
        bad.data[2000] = [0.0, f32::INFINITY, 0.0];
        let st = rs.resample(&hdr(bad), &lin, &mut out);
        assert_eq!(st.invalid_pixels, 2);
        assert!(out.data.iter().all(|p| p.iter().all(|c| c.is_finite())));
        assert_eq!(st.empty_texels, 2);
    }
}
