//! Error of composited frames against reference frames: the same footage rendered again with
//! the virtual objects physically present, by an independent renderer.
//!
//! A scene may hold such frames in `reference/` (the bundled courtyard's come from its generator's
//! path tracer). `reference/reference.toml` lists them:
//!
//! ```toml
//! sequence = "hdr"                 # optional: the sequence they belong to (default: the first)
//! frames = [0, 6, 11]              # frame indices in that sequence
//! files = ["frame_000.exr", "frame_006.exr", "frame_011.exr"]
//! crop = { x = 107, y = 98, width = 73, height = 51 }   # footage pixels each EXR covers
//! ```
//!
//! Each EXR holds linear radiance in the footage's units over the crop (full frames are a crop of
//! the whole image).
//!
//! # How it works
//! Every crop pixel is classified by a ray through its centre (the camera's lens model) against
//! the virtual objects and the proxy: *object* (a virtual surface is the first hit), *shadow* (the
//! first hit is a proxy surface from which the objects block the sun) or *elsewhere*. Pixels next
//! to a change of class are *edges* (partly one class, partly another in an anti-aliased
//! reference). The metric is the relative RMSE `√(Σ(out − ref)² / Σ ref²)` over all three
//! channels of the object and shadow pixels, also given over the object, the shadow, their
//! interior (away from 1-px edges) and the rest of the crop (where it measures the footage's own
//! noise against the noise-free reference).

use crate::geometry::raycast::RayScene;
use crate::io::image::LinearImage;
use crate::scene::{Scene, SceneError};
use glam::Vec3;
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

/// A rectangle of footage pixels.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Crop {
    /// Left column.
    pub x: u32,
    /// Top row.
    pub y: u32,
    /// Width.
    pub width: u32,
    /// Height.
    pub height: u32,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ReferenceFile {
    sequence: Option<String>,
    frames: Vec<usize>,
    files: Vec<String>,
    crop: Crop,
    // Provenance the generator writes (sample counts); accepted, not used.
    #[serde(default)]
    sky_spp: Option<u32>,
    #[serde(default)]
    sun_spp: Option<u32>,
}

/// The reference frames of a scene.
#[derive(Clone, Debug)]
pub struct References {
    /// Sequence name (`None`: the scene's first sequence).
    pub sequence: Option<String>,
    /// Frame indices in that sequence.
    pub frames: Vec<usize>,
    /// The EXR file of each frame.
    pub files: Vec<PathBuf>,
    /// The footage pixels they cover.
    pub crop: Crop,
}

impl References {
    /// `scene/reference/reference.toml`, or `None` when the scene has none.
    pub fn load(scene: &Scene) -> Result<Option<Self>, SceneError> {
        let dir = scene.root.join("reference");
        let path = dir.join("reference.toml");
        if !path.exists() {
            return Ok(None);
        }
        let text = std::fs::read_to_string(&path).map_err(|source| SceneError::Read { path: path.clone(), source })?;
        let f: ReferenceFile = toml::from_str(&text).map_err(|e| SceneError::Parse { path: path.clone(), message: e.to_string() })?;
        let _ = (f.sky_spp, f.sun_spp);
        let invalid = |field: &str, message: String| SceneError::Invalid { path: path.clone(), field: field.into(), message };
        if f.frames.len() != f.files.len() {
            return Err(invalid("files", format!("{} files for {} frames", f.files.len(), f.frames.len())));
        }
        if f.crop.width == 0 || f.crop.height == 0 {
            return Err(invalid("crop", "is empty".into()));
        }
        let (w, h) = (scene.camera.intrinsics.width, scene.camera.intrinsics.height);
        if f.crop.x.saturating_add(f.crop.width) > w || f.crop.y.saturating_add(f.crop.height) > h {
            return Err(invalid("crop", format!("{:?} reaches past the {w}×{h} frame", f.crop)));
        }
        let seq = scene.sequence(f.sequence.as_deref()).ok_or_else(|| invalid("sequence", "no such sequence in scene.toml".into()))?;
        if let Some(&bad) = f.frames.iter().find(|&&i| i >= seq.files.len()) {
            return Err(invalid("frames", format!("frame {bad} is past the sequence's {} frames", seq.files.len())));
        }
        let files: Vec<PathBuf> = f.files.iter().map(|n| dir.join(n)).collect();
        if let Some(missing) = files.iter().find(|p| !p.exists()) {
            return Err(SceneError::Missing { path: missing.clone() });
        }
        Ok(Some(Self { sequence: f.sequence, frames: f.frames, files, crop: f.crop }))
    }

    /// Reads reference `k` and checks it covers the crop.
    pub fn image(&self, k: usize) -> Result<LinearImage, SceneError> {
        let path = &self.files[k];
        let img = LinearImage::read_exr(path).map_err(|e| SceneError::Parse { path: path.clone(), message: e.to_string() })?;
        if (img.width, img.height) != (self.crop.width, self.crop.height) {
            return Err(SceneError::Invalid {
                path: path.clone(),
                field: "size".into(),
                message: format!("is {}×{} but the crop is {}×{}", img.width, img.height, self.crop.width, self.crop.height),
            });
        }
        Ok(img)
    }
}

/// Pixel class: neither the objects nor their shadow.
pub const ELSEWHERE: u8 = 0;
/// Pixel class: a virtual object.
pub const OBJECT: u8 = 1;
/// Pixel class: a proxy surface the objects shadow.
pub const SHADOW: u8 = 2;

/// The class of every crop pixel for one sun direction (and the lit lamps).
#[derive(Clone, Debug)]
pub struct Classes {
    /// The crop.
    pub crop: Crop,
    /// [`OBJECT`], [`SHADOW`] or [`ELSEWHERE`] per crop pixel (row-major).
    pub class: Vec<u8>,
    /// Pixels within one pixel of a change of class.
    pub edge: Vec<bool>,
}

impl Classes {
    /// Classifies the crop (see the module docs); `objects` holds the virtual objects alone,
    /// `proxy` the real proxy, `sun` the unit direction toward the sun.
    pub fn new(scene: &Scene, objects: &RayScene, proxy: &RayScene, crop: Crop, sun: Vec3) -> Self {
        Self::with_lamps(scene, objects, proxy, crop, Some(sun), &[])
    }

    /// As [`Classes::new`], with the shadow toward the sun when `sun` is given and toward the
    /// lit lamps at `lamps` (world positions; issue 16's "object and its lamp shadow"): a proxy
    /// pixel is *shadow* when the objects block the sun or any of the lamps from it.
    pub fn with_lamps(scene: &Scene, objects: &RayScene, proxy: &RayScene, crop: Crop, sun: Option<Vec3>, lamps: &[Vec3]) -> Self {
        let blocks_lamp = |p: Vec3, n: Vec3| {
            lamps.iter().any(|&at| {
                let o = p + n * crate::geometry::raycast::RAY_EPSILON_M;
                let d = at - o;
                let dist = d.length();
                dist > 0.0 && objects.occluded(o, d / dist, dist)
            })
        };
        let class: Vec<u8> = (0..crop.width * crop.height)
            .map(|i| {
                let (col, row) = (crop.x + i % crop.width, crop.y + i / crop.width);
                let Some((o, d)) = scene.camera.pixel_ray(col, row) else { return ELSEWHERE };
                let (o, d) = (o.as_vec3(), d.as_vec3());
                match (objects.intersect(o, d, f32::MAX), proxy.intersect(o, d, f32::MAX)) {
                    (Some(s), p) if p.is_none_or(|p| s.t < p.t) => OBJECT,
                    (_, Some(p)) if sun.is_some_and(|sun| !objects.sees_direction(p.point, p.normal, sun)) || blocks_lamp(p.point, p.normal) => SHADOW,
                    _ => ELSEWHERE,
                }
            })
            .collect();
        let edge = edges(crop.width, crop.height, &class);
        Self { crop, class, edge }
    }

    /// Pixels of `class`.
    pub fn count(&self, class: u8) -> usize {
        self.class.iter().filter(|&&c| c == class).count()
    }
}

/// Pixels of a `w × h` row-major image within one pixel (8-neighbourhood) of a change of `f`:
/// the 1-px edges that comparisons against anti-aliased references leave out or report apart.
pub fn edges<T: PartialEq + Copy>(w: u32, h: u32, f: &[T]) -> Vec<bool> {
    let (w, h) = (w as i64, h as i64);
    (0..w * h)
        .map(|i| {
            let (x, y, v) = (i % w, i / w, f[i as usize]);
            (-1..=1).any(|dy| {
                (-1..=1).any(|dx| {
                    let (xx, yy) = (x + dx, y + dy);
                    xx >= 0 && yy >= 0 && xx < w && yy < h && f[(yy * w + xx) as usize] != v
                })
            })
        })
        .collect()
}

/// Relative RMSE over pixel pairs, all channels: `√(Σ(a − b)² / Σ b²)`.
pub fn relative_rmse<'a>(pairs: impl IntoIterator<Item = (&'a [f32; 3], &'a [f32; 3])>) -> f64 {
    let (mut num, mut den) = (0.0f64, 0.0f64);
    for (a, b) in pairs {
        for c in 0..3 {
            num += ((a[c] - b[c]) as f64).powi(2);
            den += (b[c] as f64).powi(2);
        }
    }
    (num / den.max(1e-30)).sqrt()
}

/// A composite's error against a reference frame (relative RMSEs; see the module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct CompositeError {
    /// Object and shadow pixels.
    pub object_and_shadow: f64,
    /// Object pixels.
    pub object: f64,
    /// Shadow pixels.
    pub shadow: f64,
    /// Object and shadow pixels away from 1-px edges.
    pub interior: f64,
    /// The rest of the crop.
    pub elsewhere: f64,
    /// Object and shadow pixels.
    pub pixels: usize,
    /// Of those, away from edges.
    pub interior_pixels: usize,
    /// Mean radiance (channel mean) of the composite over the object pixels.
    pub object_mean: f64,
    /// Mean radiance of the reference over the object pixels.
    pub object_mean_reference: f64,
    /// Mean radiance of `out` over the shadow pixels (channels averaged).
    pub shadow_mean: f64,
    /// Mean radiance of the reference over the shadow pixels.
    pub shadow_mean_reference: f64,
}

/// The error of `out` (a whole footage frame) against `reference` (the crop of [`Classes`]).
pub fn composite_error(classes: &Classes, out: &LinearImage, reference: &LinearImage) -> CompositeError {
    let crop = classes.crop;
    let n = (crop.width * crop.height) as usize;
    let pair = |i: usize| {
        let (x, y) = (i as u32 % crop.width, i as u32 / crop.width);
        (out.get(crop.x + x, crop.y + y), reference.get(x, y))
    };
    let pairs: Vec<([f32; 3], [f32; 3])> = (0..n).map(pair).collect();
    let select = |f: &dyn Fn(usize) -> bool| -> Vec<usize> { (0..n).filter(|&i| f(i)).collect() };
    let rmse = |idx: &[usize]| relative_rmse(idx.iter().map(|&i| (&pairs[i].0, &pairs[i].1)));
    let c = &classes.class;
    let both = select(&|i| c[i] != ELSEWHERE);
    let interior = select(&|i| c[i] != ELSEWHERE && !classes.edge[i]);
    let object = select(&|i| c[i] == OBJECT);
    let shadow = select(&|i| c[i] == SHADOW);
    let mean = |idx: &[usize], k: usize| {
        idx.iter().map(|&i| { let p = if k == 0 { pairs[i].0 } else { pairs[i].1 }; (p[0] + p[1] + p[2]) as f64 / 3.0 }).sum::<f64>() / idx.len().max(1) as f64
    };
    CompositeError {
        object_and_shadow: rmse(&both),
        object: rmse(&object),
        shadow: rmse(&shadow),
        interior: rmse(&interior),
        elsewhere: rmse(&select(&|i| c[i] == ELSEWHERE)),
        pixels: both.len(),
        interior_pixels: interior.len(),
        object_mean: mean(&object, 0),
        object_mean_reference: mean(&object, 1),
        shadow_mean: mean(&shadow, 0),
        shadow_mean_reference: mean(&shadow, 1),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn edges_mark_the_8_neighbourhood_of_a_change() {
        // A 4×3 image with one odd pixel at (1, 1): it and its eight neighbours are edges, the
        // last column is not.
        let mut f = [0u8; 12];
        f[5] = 1;
        let e = edges(4, 3, &f);
        let want: Vec<bool> = (0..12).map(|i| i % 4 != 3).collect();
        assert_eq!(e, want);
        assert!(edges(4, 3, &[7u8; 12]).iter().all(|&x| !x));
    }

    #[test]
    fn relative_rmse_of_a_uniform_scale_is_the_scale_error() {
        let a = [[1.1f32, 2.2, 3.3]; 4];
        let b = [[1.0f32, 2.0, 3.0]; 4];
        let e = relative_rmse(a.iter().zip(&b));
        assert!((e - 0.1).abs() < 1e-6, "{e}");
        assert_eq!(relative_rmse(b.iter().zip(&b)), 0.0);
    }
}
