//! The light-field folder: `lightfield.toml` and one OpenEXR image `E'_mn` per filter position.
//!
//! ```toml
//! format = "heliar-lightfield"
//! version = 1
//! basis = "bellq"                 # Granier Eq. 6; the only basis
//!
//! [sampling]                      # the sampling plane S (z = 0 in the luminaire frame)
//! filters = [5, 5]                # M × N positions, centred on the axis
//! spacing_m = 0.01                # h
//!
//! [measurement]                   # the measurement plane M (z = −d)
//! distance_m = 0.5                # d
//! size_m = [0.4, 0.4]             # extent of the images in s and t, centred on the axis
//! resolution = [64, 64]           # W × H texels
//!
//! [images]
//! files = "filter_{m}_{n}.exr"    # {m} the column (u), {n} the row (v) of the position
//! ```
//!
//! The images hold `E'_mn` (see [`super`]), may be negative, and must be finite. A folder written
//! by the synthetic acquisition also has `truth.toml`, the emitter it measured
//! ([`super::synthetic::TorchEmitter`]).

use super::{FilterGrid, LightField, LightFieldError};
use crate::io::image::{ExrPrecision, LinearImage};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The manifest's name inside a light-field folder.
pub const MANIFEST: &str = "lightfield.toml";
/// The `format` value of a manifest.
pub const FORMAT: &str = "heliar-lightfield";
/// The manifest version this code reads and writes.
pub const VERSION: u32 = 1;
/// The default image name pattern.
pub const DEFAULT_FILES: &str = "filter_{m}_{n}.exr";

/// `lightfield.toml` as written.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Manifest {
    /// Always [`FORMAT`].
    pub format: String,
    /// Always [`VERSION`].
    pub version: u32,
    /// Always `"bellq"`.
    pub basis: String,
    /// The sampling plane.
    pub sampling: SamplingSection,
    /// The measurement plane.
    pub measurement: MeasurementSection,
    /// The images.
    pub images: ImagesSection,
}

/// `[sampling]`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SamplingSection {
    /// Filter positions `[M, N]`.
    pub filters: [usize; 2],
    /// Spacing `h` (metres).
    pub spacing_m: f64,
}

/// `[measurement]`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeasurementSection {
    /// Distance `d` from the sampling plane (metres).
    pub distance_m: f64,
    /// Extent `[S_w, S_h]` (metres).
    pub size_m: [f64; 2],
    /// Image size `[W, H]` (texels).
    pub resolution: [u32; 2],
}

/// `[images]`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ImagesSection {
    /// File name pattern with `{m}` and `{n}`.
    pub files: String,
}

/// The file name of position `(m, n)` under `pattern`.
pub fn image_name(pattern: &str, m: usize, n: usize) -> String {
    pattern.replace("{m}", &m.to_string()).replace("{n}", &n.to_string())
}

impl LightField {
    /// Reads and validates a light-field folder.
    pub fn load(dir: &Path) -> Result<Self, LightFieldError> {
        let path = dir.join(MANIFEST);
        let text = std::fs::read_to_string(&path).map_err(|source| LightFieldError::Io { path: path.clone(), source })?;
        let man: Manifest = toml::from_str(&text).map_err(|e| LightFieldError::Toml { path: path.clone(), message: e.to_string() })?;
        let field = |field: &str, message: String| LightFieldError::Field { path: path.clone(), field: field.into(), message };
        if man.format != FORMAT || man.version != VERSION {
            return Err(field("format", format!("'{}' version {} (this reader takes '{FORMAT}' version {VERSION})", man.format, man.version)));
        }
        if man.basis != "bellq" {
            return Err(field("basis", format!("'{}' (only \"bellq\", Granier Eq. 6)", man.basis)));
        }
        if !(man.images.files.contains("{m}") && man.images.files.contains("{n}")) {
            return Err(field("images.files", format!("'{}' must contain {{m}} and {{n}}", man.images.files)));
        }
        let grid = FilterGrid { counts: man.sampling.filters, spacing_m: man.sampling.spacing_m };
        if grid.counts.iter().any(|&c| c == 0 || c > super::MAX_FILTERS_PER_AXIS) {
            return Err(field("sampling.filters", format!("{:?}: each count must be in 1..={}", grid.counts, super::MAX_FILTERS_PER_AXIS)));
        }
        let want = man.measurement.resolution;
        let mut images = Vec::with_capacity(grid.len());
        for n in 0..grid.counts[1] {
            for m in 0..grid.counts[0] {
                let p = dir.join(image_name(&man.images.files, m, n));
                let img = LinearImage::read_exr(&p)?;
                if [img.width, img.height] != want {
                    return Err(LightFieldError::ImageSize { path: p, got: [img.width, img.height], want });
                }
                if let Some(i) = img.data.iter().position(|px| px.iter().any(|c| !c.is_finite())) {
                    return Err(LightFieldError::NonFinite { path: p, x: i as u32 % img.width, y: i as u32 / img.width });
                }
                images.push(img);
            }
        }
        LightField::new(grid, man.measurement.distance_m, man.measurement.size_m, images, &path)
    }

    /// The manifest describing this light field (images named [`DEFAULT_FILES`]).
    pub fn manifest(&self) -> Manifest {
        let img = &self.images()[0];
        Manifest {
            format: FORMAT.into(),
            version: VERSION,
            basis: "bellq".into(),
            sampling: SamplingSection { filters: self.grid().counts, spacing_m: self.grid().spacing_m },
            measurement: MeasurementSection { distance_m: self.distance_m(), size_m: self.size_m(), resolution: [img.width, img.height] },
            images: ImagesSection { files: DEFAULT_FILES.into() },
        }
    }

    /// Writes the folder (created if needed): the manifest and float EXR images.
    pub fn save(&self, dir: &Path) -> Result<(), LightFieldError> {
        std::fs::create_dir_all(dir).map_err(|source| LightFieldError::Io { path: dir.to_owned(), source })?;
        let path = dir.join(MANIFEST);
        let man = self.manifest();
        let text = toml::to_string(&man).map_err(|e| LightFieldError::Toml { path: path.clone(), message: e.to_string() })?;
        std::fs::write(&path, text).map_err(|source| LightFieldError::Io { path: path.clone(), source })?;
        let g = self.grid();
        for n in 0..g.counts[1] {
            for m in 0..g.counts[0] {
                self.images()[g.index(m, n)].write_exr(&dir.join(image_name(&man.images.files, m, n)), ExrPrecision::Float)?;
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tmp(name: &str) -> std::path::PathBuf {
        let d = std::env::temp_dir().join(format!("heliar-lf-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        d
    }

    fn small() -> LightField {
        let grid = FilterGrid { counts: [3, 2], spacing_m: 0.01 };
        let images = (0..6).map(|k| LinearImage::from_fn(8, 4, |x, y| [k as f32 - 2.5, x as f32 * 0.25, y as f32 * -1e-3])).collect();
        LightField::new(grid, 0.3, [0.2, 0.1], images, Path::new("<test>")).unwrap()
    }

    #[test]
    fn folder_round_trip() {
        let dir = tmp("rt");
        let lf = small();
        lf.save(&dir).unwrap();
        assert_eq!(LightField::load(&dir).unwrap(), lf);
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn bad_folders_name_the_file_and_field() {
        let dir = tmp("bad");
        small().save(&dir).unwrap();
        let man = dir.join(MANIFEST);
        let good = std::fs::read_to_string(&man).unwrap();
        let cases = [
            (good.replace("distance_m = 0.3", "distance_m = -0.3"), "measurement.distance_m"),
            (good.replace("basis = \"bellq\"", "basis = \"box\""), "basis"),
            (good.replace("filters = [3, 2]", "filters = [3, 3]"), "filter_0_2.exr"),
            (good.replace("resolution = [8, 4]", "resolution = [8, 5]"), "measurement.resolution"),
            (good.replace("[images]", "[images]\nextra = 1"), "extra"),
            (good.replace("spacing_m = 0.01", ""), "spacing_m"),
        ];
        for (text, needle) in cases {
            std::fs::write(&man, &text).unwrap();
            let e = LightField::load(&dir).unwrap_err().to_string();
            assert!(e.contains(needle), "{needle}: {e}");
            assert!(e.contains(&dir.display().to_string()), "{e}");
        }
        // a NaN texel names the image and the texel
        std::fs::write(&man, &good).unwrap();
        let mut img = LinearImage::new(8, 4);
        img.set(5, 2, [f32::NAN, 0.0, 0.0]);
        img.write_exr(&dir.join("filter_1_0.exr"), ExrPrecision::Float).unwrap();
        let e = LightField::load(&dir).unwrap_err().to_string();
        assert!(e.contains("filter_1_0.exr") && e.contains("(5, 2)"), "{e}");
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn sampling_is_bilinear_and_zero_outside() {
        let lf = small();
        // texel centres reproduce the texels
        let c = lf.texel_centre(3, 1);
        assert!((lf.sample(0, c)[1] - 0.75).abs() < 1e-12);
        // halfway between columns 3 and 4: the mean
        let mid = (lf.texel_centre(3, 1) + lf.texel_centre(4, 1)) * 0.5;
        assert!((lf.sample(0, mid)[1] - 0.875).abs() < 1e-12);
        // outside the plane: nothing
        assert_eq!(lf.sample(0, glam::DVec2::new(0.11, 0.0)), [0.0; 3]);
    }
}
