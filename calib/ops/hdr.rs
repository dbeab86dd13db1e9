//! HDR images from bracketed exposures: exposure times, the optional removal of a lens
//! reflection, the merge, and the EXR and response files.

use anyhow::{Context, Result, bail};
use heliar::opencv_calib::Rgb8;
use heliar::opencv_calib::hdr::{merge_debevec, remove_reflection};
use heliar::io::image::{ExrPrecision, LinearImage};
use std::path::{Path, PathBuf};

/// A rectangle `x, y, w, h` in pixels.
pub type Rect = [i32; 4];

/// An exposure time in seconds from `0.004`, `1/250` or `4ms`.
pub fn parse_exposure_time(s: &str) -> Result<f32> {
    let t = s.trim();
    let v = if let Some((n, d)) = t.split_once('/') {
        let (n, d): (f64, f64) = (n.trim().parse()?, d.trim().parse()?);
        n / d
    } else if let Some(ms) = t.strip_suffix("ms") {
        ms.trim().parse::<f64>()? / 1000.0
    } else {
        t.strip_suffix('s').unwrap_or(t).trim().parse::<f64>()?
    };
    if !(v.is_finite() && v > 0.0) {
        bail!("must be a positive time");
    }
    Ok(v as f32)
}

/// Checks the exposure times of a bracket before anything is merged: one per exposure, each a
/// positive number of seconds, and all different (two exposures with the same time add no
/// range: the response cannot be recovered and the merge comes out flat). `images` names the
/// exposures in the errors.
pub fn check_times(images: &[PathBuf], times_s: &[f32]) -> Result<()> {
    if images.len() != times_s.len() {
        bail!("{} times for {} exposures; give one time per exposure, in the same order", times_s.len(), images.len());
    }
    if let Some((p, t)) = images.iter().zip(times_s).find(|(_, t)| !(t.is_finite() && **t > 0.0)) {
        bail!("{}: exposure time {t} s; times must be positive seconds", p.display());
    }
    let mut order: Vec<(f32, &PathBuf)> = times_s.iter().copied().zip(images).collect();
    order.sort_by(|a, b| a.0.total_cmp(&b.0));
    if let Some(w) = order.windows(2).find(|w| w[1].0 <= w[0].0) {
        bail!(
            "{} and {} both have exposure time {} s; a bracket needs a different time for each exposure",
            w[0].1.display(),
            w[1].1.display(),
            w[0].0
        );
    }
    Ok(())
}

/// Covers the lens reflection `reflection` with the clean patch `clean` (same size) in every
/// exposure, then recovers the response and merges (Debevec–Malik). Returns the relative radiance
/// and the response (256 rows, RGB).
pub fn merge(images: &[Rgb8], times_s: &[f32], reflection: Option<(Rect, Rect)>) -> Result<(LinearImage, Vec<[f32; 3]>)> {
    let cleaned: Vec<Rgb8>;
    let images = match reflection {
        Some((r, c)) => {
            cleaned = images.iter().enumerate().map(|(i, im)| remove_reflection(im, r, c).with_context(|| format!("exposure {}", i + 1))).collect::<Result<_>>()?;
            &cleaned
        }
        None => images,
    };
    Ok(merge_debevec(images, times_s)?)
}

/// Writes the merged image as a float EXR at `out` and the response beside it
/// (`*.response.csv`, rows `r,g,b` per code 0…255), each atomically. Returns the CSV's path.
pub fn write_outputs(out: &Path, merged: &LinearImage, response: &[[f32; 3]]) -> Result<PathBuf> {
    if let Some(parent) = out.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(parent).with_context(|| format!("creating {}", parent.display()))?;
    }
    heliar::io::write_via_temp(out, |tmp| merged.write_exr(tmp, ExrPrecision::Float)).with_context(|| format!("writing {}", out.display()))?;
    let csv: String = std::iter::once("r,g,b\n".to_string()).chain(response.iter().map(|r| format!("{},{},{}\n", r[0], r[1], r[2]))).collect();
    let rpath = response_path(out);
    crate::edit::write_atomic(&rpath, csv.as_bytes())?;
    Ok(rpath)
}

/// Where the response of the merge written to `out` goes: `*.response.csv` beside it.
pub fn response_path(out: &Path) -> PathBuf {
    out.with_extension("response.csv")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exposure_times_in_the_usual_notations() {
        for (s, t) in [("0.004", 0.004), ("1/250", 0.004), ("4ms", 0.004), (" 2 s", 2.0), ("1/4", 0.25)] {
            assert!((parse_exposure_time(s).unwrap() - t).abs() < 1e-7, "{s}");
        }
        for s in ["", "0", "-1", "1/0", "fast", "nan"] {
            assert!(parse_exposure_time(s).is_err(), "{s}");
        }
    }

    #[test]
    fn brackets_need_distinct_positive_times() {
        let names: Vec<PathBuf> = ["a.png", "b.png", "c.png"].iter().map(PathBuf::from).collect();
        assert!(check_times(&names, &[0.25, 0.004, 0.016]).is_ok());
        let e = check_times(&names, &[0.004, 0.016, 0.004]).unwrap_err().to_string();
        assert!(e.contains("a.png") && e.contains("c.png") && e.contains("0.004"), "{e}");
        assert!(check_times(&names, &[0.004, 0.0, 0.016]).unwrap_err().to_string().contains("b.png"));
        assert!(check_times(&names, &[0.004, 0.016]).unwrap_err().to_string().contains("2 times for 3"));
    }
}
