//! HDR environment maps from an ordinary or phone camera (Cyberworlds §IV).
//!
//! # How it works
//! 1. **Bracketed exposures → radiance** (Debevec & Malik 1997, OpenCV photo): the camera
//!    response is recovered from three or more exposures of the same view (`CalibrateDebevec`),
//!    then the exposures are merged into relative radiance (`MergeDebevec`, weighted towards
//!    mid-range codes). The result is linear but in arbitrary units; heliar only needs relative
//!    radiance, because the bake finds `Pd` and `Pa` on the map itself.
//! 2. **Two fisheye shots → equirect.** A front and a back shot (each covering a bit more than a
//!    hemisphere) are resampled into the world-frame equirect map: each texel takes the shot whose
//!    optical axis is closer, feathered over [`FEATHER_DEG`] around the seam.
//! 3. **Lens-frame reflection.** A fisheye adaptor often reflects in the image; a clean rectangle
//!    is cloned over the reflection with Poisson blending (`seamlessClone`, Pérez et al. 2003), on
//!    each 8-bit exposure before merging.

use super::{OpenCvCalibError, Rgb8, linear_image_from_bgr_f32};
use crate::io::image::LinearImage;
use glam::{DMat3, DVec3, Vec3};
use opencv::core::{Mat, Point, Rect, Scalar, Vector, CV_8UC1};
use opencv::photo;
use opencv::prelude::*;

/// Width of the blend between the front and back shots around their seam, degrees.
pub const FEATHER_DEG: f64 = 6.0;

/// Recovers the camera response from bracketed 8-bit exposures and merges them. Returns the
/// relative radiance and the response (linear value per code, 256 rows, RGB).
pub fn merge_debevec(images: &[Rgb8], exposure_s: &[f32]) -> Result<(LinearImage, Vec<[f32; 3]>), OpenCvCalibError> {
    if images.len() < 3 {
        return Err(OpenCvCalibError::Input(format!("{} exposures; Debevec's method needs at least 3", images.len())));
    }
    if images.len() != exposure_s.len() {
        return Err(OpenCvCalibError::Input(format!("{} exposures but {} exposure times", images.len(), exposure_s.len())));
    }
    if exposure_s.iter().any(|t| !(t.is_finite() && *t > 0.0)) {
        return Err(OpenCvCalibError::Input("exposure times must be positive seconds".into()));
    }
    let (w, h) = (images[0].width, images[0].height);
    if let Some((i, im)) = images.iter().enumerate().find(|(_, im)| (im.width, im.height) != (w, h)) {
        return Err(OpenCvCalibError::Input(format!("exposure {i} is {}×{}, exposure 0 is {w}×{h}", im.width, im.height)));
    }
    let mut src = Vector::<Mat>::new();
    for im in images {
        src.push(im.to_bgr_mat()?);
    }
    let times = Mat::from_slice(exposure_s)?.try_clone()?;
    let mut response = Mat::default();
    let mut cal = photo::create_calibrate_debevec(70, 10.0, false)?;
    cal.process(&src, &mut response, &times)?;
    let mut merged = Mat::default();
    let mut merge = photo::create_merge_debevec()?;
    merge.process_with_response(&src, &mut merged, &times, &response)?;
    let img = linear_image_from_bgr_f32(&merged)?;
    let mut resp = Vec::with_capacity(256);
    for i in 0..256 {
        let v = response.at::<opencv::core::Vec3f>(i)?;
        resp.push([v[2], v[1], v[0]]);
    }
    Ok((img, resp))
}

/// Stitches a front and a back fisheye shot into a `width × width/2` equirect map in the world
/// frame. `world_from_front` is the front camera's orientation (OpenCV camera axes: +Z along the
/// optical axis); the back camera looks the opposite way, turned 180° about the camera's up (−Y)
/// axis. `project(d)` maps a unit direction in a shot's camera frame to its pixel coordinates,
/// `None` outside the lens' field of view.
pub fn stitch_fisheye_pair(
    front: &LinearImage,
    back: &LinearImage,
    world_from_front: DMat3,
    width: u32,
    project: &(dyn Fn(DVec3) -> Option<(f64, f64)> + Sync),
) -> LinearImage {
    let height = width / 2;
    let back_from_front = DMat3::from_rotation_y(std::f64::consts::PI);
    let front_from_world = world_from_front.transpose();
    let sample = |img: &LinearImage, uv: (f64, f64)| -> Option<Vec3> {
        let (x, y) = (uv.0.round(), uv.1.round());
        (x >= 0.0 && y >= 0.0 && x < img.width as f64 && y < img.height as f64).then(|| Vec3::from(img.get(x as u32, y as u32)))
    };
    LinearImage::from_fn(width, height, |x, y| {
        let d = crate::geometry::equirect::dir_from_texel_centre(x, y, width, height).as_dvec3();
        let df = front_from_world * d;
        let db = back_from_front * df;
        // Angle past the front hemisphere's edge, in degrees (positive: nearer the back axis).
        let past = (-df.z).asin().to_degrees();
        let wb = ((past / FEATHER_DEG) + 0.5).clamp(0.0, 1.0);
        let f = project(df).and_then(|uv| sample(front, uv));
        let b = project(db).and_then(|uv| sample(back, uv));
        let v = match (f, b) {
            (Some(f), Some(b)) => f * (1.0 - wb as f32) + b * wb as f32,
            (Some(f), None) => f,
            (None, Some(b)) => b,
            (None, None) => Vec3::ZERO,
        };
        v.to_array()
    })
}

/// Covers `target` (x, y, w, h in pixels) with the clean patch `source` of the same size by
/// seamless cloning, removing a lens frame's reflection. The target should exceed the reflection by
/// about 8 px on every side: OpenCV solves the Poisson equation on the rectangle's interior, whose
/// outer ring becomes the boundary condition.
pub fn remove_reflection(img: &Rgb8, target: [i32; 4], source: [i32; 4]) -> Result<Rgb8, OpenCvCalibError> {
    let [tx, ty, tw, th] = target;
    let [sx, sy, sw, sh] = source;
    let (w, h) = (img.width as i32, img.height as i32);
    for (name, [x, y, rw, rh]) in [("target", target), ("source", source)] {
        // seamlessClone needs a one-pixel border around the patch inside the image.
        if rw < 3 || rh < 3 || x < 1 || y < 1 || x + rw >= w || y + rh >= h {
            return Err(OpenCvCalibError::Input(format!("{name} rectangle {x},{y},{rw},{rh} must lie inside the {w}×{h} image with a 1-pixel border")));
        }
    }
    if (tw, th) != (sw, sh) {
        return Err(OpenCvCalibError::Input("target and source rectangles must have the same size".into()));
    }
    let m = img.to_bgr_mat()?;
    // The canonical use: the clean patch alone as source, an all-white mask of its size, placed
    // with its centre on the target's centre.
    let patch = Mat::roi(&m, Rect::new(sx, sy, sw, sh))?.try_clone()?;
    let mask = Mat::new_rows_cols_with_default(sh, sw, CV_8UC1, Scalar::all(255.0))?;
    let mut out = Mat::default();
    photo::seamless_clone(&patch, &m, &mask, Point::new(tx + tw / 2, ty + th / 2), &mut out, photo::NORMAL_CLONE)?;
    let px: &[opencv::core::Vec3b] = out.data_typed()?;
    Ok(Rgb8 { width: img.width, height: img.height, data: px.iter().flat_map(|p| [p[2], p[1], p[0]]).collect() })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::image::srgb_u8_from_linear;

    /// A radiance map spanning 4 decades: a gradient sky, a bright disc and dark corners.
    fn radiance(w: u32, h: u32) -> LinearImage {
        LinearImage::from_fn(w, h, |x, y| {
            let (u, v) = (x as f32 / w as f32, y as f32 / h as f32);
            let disc = ((u - 0.7).powi(2) + (v - 0.3).powi(2)).sqrt() < 0.08;
            let base = 0.01 * 10f32.powf(2.0 * u) * (0.5 + v);
            let l = if disc { 30.0 } else { base };
            [l, l * 0.8, l * 0.6]
        })
    }

    #[test]
    fn bracketed_exposures_merge_to_the_known_radiance() {
        let truth = radiance(160, 120);
        let times = [1.0 / 250.0, 1.0 / 60.0, 1.0 / 15.0, 1.0 / 4.0, 1.0];
        // An sRGB camera: code = sRGB(k·t·L), clipped; k makes the middle exposure well exposed.
        let k = 4.0;
        let shots: Vec<Rgb8> = times
            .iter()
            .map(|t| Rgb8 {
                width: truth.width,
                height: truth.height,
                data: truth.data.iter().flat_map(|p| p.map(|v| srgb_u8_from_linear(k * t * v))).collect(),
            })
            .collect();
        let (merged, response) = merge_debevec(&shots, &times).unwrap();
        assert_eq!(response.len(), 256);
        // Relative radiance: compare after the best global scale (median ratio), in texels that at
        // least one exposure records between codes 20 and 235.
        let usable = |i: usize| times.iter().any(|t| (0..3).any(|c| { let code = k * t * truth.data[i][c]; code > 0.007 && code < 0.92 }));
        let mut ratios: Vec<f64> = (0..truth.data.len()).filter(|&i| usable(i)).map(|i| (merged.data[i][1] / truth.data[i][1]) as f64).collect();
        ratios.sort_by(|a, b| a.total_cmp(b));
        let s = ratios[ratios.len() / 2] as f32;
        let mut errs = Vec::new();
        for i in (0..truth.data.len()).filter(|&i| usable(i)) {
            for c in 0..3 {
                errs.push(((merged.data[i][c] / s - truth.data[i][c]) / truth.data[i][c]).abs() as f64);
            }
        }
        let mean = errs.iter().sum::<f64>() / errs.len() as f64;
        // The acceptance: relative error < 5% in unclipped regions.
        assert!(mean < 0.05, "mean relative error {mean}");
        assert!(merge_debevec(&shots[..2], &times[..2]).is_err());
    }

    #[test]
    fn seamless_clone_removes_a_reflection() {
        // A smooth gradient with a dark "frame reflection" bar; a clean patch beside it is cloned in.
        let (w, h) = (120u32, 80u32);
        let clean = |x: u32, y: u32| [(60 + x / 2) as u8, (80 + y / 2) as u8, 120];
        let mut img = Rgb8 { width: w, height: h, data: (0..h).flat_map(|y| (0..w).flat_map(move |x| clean(x, y))).collect() };
        for y in 30..50 {
            for x in 40..60 {
                let i = ((y * w + x) * 3) as usize;
                img.data[i..i + 3].copy_from_slice(&[10, 10, 10]);
            }
        }
        // The rectangle exceeds the reflection by 10 px on every side (OpenCV solves the Poisson
        // equation inside the rectangle, so a tight one keeps the dark edge as its boundary).
        let fixed = remove_reflection(&img, [30, 20, 40, 40], [75, 20, 40, 40]).unwrap();
        let err = |im: &Rgb8| -> f64 {
            let mut e = 0.0;
            for y in 30..50 {
                for x in 40..60 {
                    let i = ((y * w + x) * 3) as usize;
                    let c = clean(x, y);
                    e += (0..3).map(|k| (im.data[i + k] as f64 - c[k] as f64).abs()).sum::<f64>();
                }
            }
            e / (20.0 * 20.0 * 3.0)
        };
        assert!(err(&img) > 50.0);
        assert!(err(&fixed) < 4.0, "mean abs error after cloning: {}", err(&fixed));
        assert!(remove_reflection(&img, [0, 0, 10, 10], [70, 28, 10, 10]).is_err());
    }

    #[test]
    fn fisheye_pair_stitches_a_known_world() {
        // Equidistant fisheye (r = f·θ) with 190° field of view; the world is coloured by
        // direction, so the stitched map must equal the colour of each texel's direction.
        let (size, f) = (200u32, 200.0 / 2.0 / (95f64.to_radians()));
        let project = |d: DVec3| -> Option<(f64, f64)> {
            let th = d.z.clamp(-1.0, 1.0).acos();
            if th > 95f64.to_radians() {
                return None;
            }
            let r = f * th;
            let phi = d.y.atan2(d.x);
            Some((size as f64 / 2.0 + r * phi.cos(), size as f64 / 2.0 + r * phi.sin()))
        };
        let colour = |d: DVec3| [(d.x * 0.5 + 0.5) as f32, (d.y * 0.5 + 0.5) as f32, (d.z * 0.5 + 0.5) as f32];
        let world_from_front = DMat3::from_cols(DVec3::X, DVec3::NEG_Y, DVec3::NEG_Z); // looking north, level
        let shot = |world_from_cam: DMat3| {
            LinearImage::from_fn(size, size, |x, y| {
                let (u, v) = (x as f64 - size as f64 / 2.0, y as f64 - size as f64 / 2.0);
                let th = (u * u + v * v).sqrt() / f;
                let phi = v.atan2(u);
                let d = DVec3::new(th.sin() * phi.cos(), th.sin() * phi.sin(), th.cos());
                colour(world_from_cam * d)
            })
        };
        let front = shot(world_from_front);
        let back = shot(world_from_front * DMat3::from_rotation_y(std::f64::consts::PI).transpose());
        let eq = stitch_fisheye_pair(&front, &back, world_from_front, 128, &project);
        let mut worst = 0.0f32;
        for y in 4..60 {
            for x in 0..128 {
                let d = crate::geometry::equirect::dir_from_texel_centre(x, y, 128, 64).as_dvec3();
                let want = Vec3::from(colour(d));
                worst = worst.max((Vec3::from(eq.get(x, y)) - want).abs().max_element());
            }
        }
        // Nearest-pixel sampling of a 200-px fisheye: about one fisheye pixel of colour change.
        assert!(worst < 0.03, "worst channel error {worst}");
    }
}
