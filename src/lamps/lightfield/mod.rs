//! Measured near-field light sources (Granier §2–3): a light field recorded through a grid of
//! filters on a sampling plane, as one image per filter position on a measurement plane.
//!
//! - [`bellq`]: the basis (Eq. 6), its dual filter, the filter grid, Gauss–Legendre rules.
//! - [`folder`]: the folder format (`lightfield.toml` + one EXR per filter position).
//! - [`reconstruct`]: irradiance at any point — exact (Eq. 5), shift-invariant (Eq. 11) and the
//!   textured spot lights (Eq. 14).
//! - [`synthetic`]: a known emitter (a torch) and the simulated acquisition through the filters.
//! - [`curves`]: the approximation-error curves and the sweep behind `heliar bench lamps`.
//!
//! # The representation
//! In the luminaire frame the sampling plane `S` is `z = 0` (coordinates `(u, v)`) and the
//! measurement plane `M` is `z = −d` (`(s, t)`). Filter position `(m, n)` of a grid with spacing
//! `h` transmits `φ'((u − u_m)/h) φ'((v − v_n)/h)` (the dual of the bellq basis) and the camera
//! records the irradiance `E_mn(s, t) = ∫_S cos²θ/R² · φ'_mn · L du dv` (Eq. 2). With the basis of
//! Eq. 3 the radiance along the ray from `(u, v)` to `(s, t)` is reconstructed exactly as
//! `L̃ = R²/cos²θ · Σ Φ_mn(u, v) E_mn(s, t) / h²` (Eq. 5; the `1/h²` because our filters are
//! dimensionless transmittances).
//!
//! The files store `E'_mn = E_mn · R_c²/cos²θ_c`, the measurement with the geometric term of the
//! filter centre `c_mn = (u_m, v_n, 0)` divided out (Eq. 8–10), so that the shift-invariant
//! reconstruction is simply `L̃ ≈ Σ Φ_mn E'_mn / h²` (Eq. 11). The exact one multiplies each term by
//! `g_c/g = (R/R_c)⁴` (for parallel planes `cos θ = d/R`, so `cos²θ/R² = d²/R⁴`).
//!
//! # Image coordinates
//! An image of `W × H` texels covers `s ∈ [−S_w/2, S_w/2]`, `t ∈ [−S_h/2, S_h/2]`; texel
//! `(i, j)` (column, row) has its centre at `s = (i + ½) S_w/W − S_w/2`, `t = (j + ½) S_h/H −
//! S_h/2` (rows grow with `t`, i.e. with `+Y`). Lookups are bilinear between texel centres,
//! clamped to the edge texels inside the plane and zero outside it (light that missed the screen
//! was not measured).

pub mod bellq;
pub mod curves;
pub mod folder;
pub mod reconstruct;
pub mod synthetic;
#[cfg(test)]
mod tests;

pub use bellq::FilterGrid;
pub use reconstruct::{Footprint, Quadrature};

use crate::io::image::LinearImage;
use glam::DVec2;
use std::path::PathBuf;

/// Most filter positions along one axis a light field may have.
pub const MAX_FILTERS_PER_AXIS: usize = 64;

/// Errors building, reading or writing a light field.
#[derive(Debug, thiserror::Error)]
pub enum LightFieldError {
    /// `lightfield.toml` could not be read or written.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The OS error.
        source: std::io::Error,
    },
    /// `lightfield.toml` is not valid TOML or misses a field (the message names it).
    #[error("{}: {message}", path.display())]
    Toml {
        /// The file.
        path: PathBuf,
        /// What the TOML reader said.
        message: String,
    },
    /// A field has a value out of its range.
    #[error("{}: {field}: {message}", path.display())]
    Field {
        /// The file (`lightfield.toml`, or `<memory>` for a light field built in code).
        path: PathBuf,
        /// The field.
        field: String,
        /// What is wrong.
        message: String,
    },
    /// A filter image could not be read or written.
    #[error(transparent)]
    Image(#[from] crate::io::IoError),
    /// A filter image has the wrong size.
    #[error("{}: image is {got:?} texels but lightfield.toml says measurement.resolution = {want:?}", path.display())]
    ImageSize {
        /// The image.
        path: PathBuf,
        /// Its size.
        got: [u32; 2],
        /// The size the manifest asks for.
        want: [u32; 2],
    },
    /// A filter image has a NaN or infinite texel.
    #[error("{}: texel ({x}, {y}) is not finite", path.display())]
    NonFinite {
        /// The image.
        path: PathBuf,
        /// Column.
        x: u32,
        /// Row.
        y: u32,
    },
}

/// A measured light field: the filter grid, the measurement plane and the images `E'_mn`.
#[derive(Clone, Debug, PartialEq)]
pub struct LightField {
    grid: FilterGrid,
    distance_m: f64,
    size_m: [f64; 2],
    /// `E'_mn` per filter position, in [`FilterGrid::index`] order.
    images: Vec<LinearImage>,
}

impl LightField {
    /// Builds and validates a light field (`images` in [`FilterGrid::index`] order, all the same
    /// size, finite). `origin` names the source in errors.
    pub fn new(grid: FilterGrid, distance_m: f64, size_m: [f64; 2], images: Vec<LinearImage>, origin: &std::path::Path) -> Result<Self, LightFieldError> {
        let field = |field: &str, message: String| LightFieldError::Field { path: origin.to_owned(), field: field.into(), message };
        if grid.counts.iter().any(|&c| c == 0 || c > MAX_FILTERS_PER_AXIS) {
            return Err(field("sampling.filters", format!("{:?}: each count must be in 1..={MAX_FILTERS_PER_AXIS}", grid.counts)));
        }
        for (name, v) in [("sampling.spacing_m", grid.spacing_m), ("measurement.distance_m", distance_m), ("measurement.size_m[0]", size_m[0]), ("measurement.size_m[1]", size_m[1])] {
            if !(v.is_finite() && v > 0.0) {
                return Err(field(name, format!("{v} must be finite and > 0")));
            }
        }
        if images.len() != grid.len() {
            return Err(field("images", format!("{} images for {} filter positions", images.len(), grid.len())));
        }
        let (w, h) = (images[0].width, images[0].height);
        if w == 0 || h == 0 {
            return Err(field("measurement.resolution", "images must have at least one texel".into()));
        }
        for (k, img) in images.iter().enumerate() {
            if (img.width, img.height) != (w, h) {
                return Err(field("images", format!("image #{k} is {}×{}, image #0 is {w}×{h}", img.width, img.height)));
            }
            if let Some(i) = img.data.iter().position(|p| p.iter().any(|c| !c.is_finite())) {
                return Err(LightFieldError::NonFinite { path: origin.join(format!("#{k}")), x: i as u32 % w, y: i as u32 / w });
            }
        }
        Ok(Self { grid, distance_m, size_m, images })
    }

    /// The filter grid.
    pub fn grid(&self) -> &FilterGrid {
        &self.grid
    }

    /// Distance `d` between the sampling and the measurement plane (metres).
    pub fn distance_m(&self) -> f64 {
        self.distance_m
    }

    /// Extent of the images on the measurement plane (metres).
    pub fn size_m(&self) -> [f64; 2] {
        self.size_m
    }

    /// The images `E'_mn`.
    pub fn images(&self) -> &[LinearImage] {
        &self.images
    }

    /// The same light field with every image replaced by `f(image)` (e.g. a storage round trip
    /// or a resampling); `f` must keep all images one size.
    pub fn map_images(&self, f: impl Fn(&LinearImage) -> LinearImage) -> Result<Self, LightFieldError> {
        Self::new(self.grid, self.distance_m, self.size_m, self.images.iter().map(f).collect(), std::path::Path::new("<memory>"))
    }

    /// Texel centre `(s, t)` of column `i`, row `j` (module docs).
    pub fn texel_centre(&self, i: u32, j: u32) -> DVec2 {
        let img = &self.images[0];
        DVec2::new((i as f64 + 0.5) * self.size_m[0] / img.width as f64 - 0.5 * self.size_m[0], (j as f64 + 0.5) * self.size_m[1] / img.height as f64 - 0.5 * self.size_m[1])
    }

    /// `E'_k(s, t)`: bilinear between texel centres, zero outside the measurement plane.
    pub fn sample(&self, k: usize, st: DVec2) -> [f64; 3] {
        let img = &self.images[k];
        let (hw, hh) = (0.5 * self.size_m[0], 0.5 * self.size_m[1]);
        if !(st.x.abs() <= hw && st.y.abs() <= hh) {
            return [0.0; 3];
        }
        let fx = ((st.x + hw) / self.size_m[0] * img.width as f64 - 0.5).clamp(0.0, img.width as f64 - 1.0);
        let fy = ((st.y + hh) / self.size_m[1] * img.height as f64 - 0.5).clamp(0.0, img.height as f64 - 1.0);
        let (x0, y0) = (fx.floor() as u32, fy.floor() as u32);
        let (x1, y1) = ((x0 + 1).min(img.width - 1), (y0 + 1).min(img.height - 1));
        let (tx, ty) = (fx - x0 as f64, fy - y0 as f64);
        let (a, b, c, d) = (img.get(x0, y0), img.get(x1, y0), img.get(x0, y1), img.get(x1, y1));
        [0, 1, 2].map(|ch| {
            let top = a[ch] as f64 * (1.0 - tx) + b[ch] as f64 * tx;
            let bottom = c[ch] as f64 * (1.0 - tx) + d[ch] as f64 * tx;
            top * (1.0 - ty) + bottom * ty
        })
    }
}
