//! Photometric calibration of a VEM camera: the log-response fit `c = a + b·ln Y` from gray
//! patches (Havran et al. 2005, §5.1; the fit itself is `heliar::vem::capture::photometric`),
//! its tolerance, and the update of `calib/fisheye.toml`.

use anyhow::{Context, Result, bail};
use heliar::vem::capture::photometric::{FitReport, LogResponse};
use std::path::Path;

/// Largest relative luminance error (percent) over the fit and check patches that a fit may have
/// and still be written into a calibration file (`--max-error`; `--force` writes it anyway).
/// 8-bit codes alone cost a few percent (half a code at b = 0.05 is ≈ 4%), a luminance meter
/// another few; a fit 25% off on its own patches has mislabelled patches, codes that clip, or
/// a camera that is not logarithmic.
pub const MAX_FIT_ERROR_PCT: f64 = 25.0;

/// The worst relative error of a fit, percent: over the fit patches and, when there are any,
/// the check patches (NaN when either is).
pub fn worst_error_pct(report: &FitReport) -> f64 {
    let (fit, check) = (report.fit_max_rel_error, report.check_max_rel_error.unwrap_or(0.0));
    // `f64::max` would drop a NaN; a fit with one is not within any tolerance.
    if fit.is_nan() || check.is_nan() { f64::NAN } else { 100.0 * fit.max(check) }
}

/// Whether an error of `worst_pct` is within the tolerance `max_pct` (a NaN error is not).
pub fn within(worst_pct: f64, max_pct: f64) -> bool {
    worst_pct <= max_pct
}

/// Refuses a fit whose worst error exceeds `max_pct` (percent) unless `force`.
pub fn check_fit(report: &FitReport, max_pct: f64, patches: &Path, force: bool) -> Result<()> {
    let worst = worst_error_pct(report);
    if !within(worst, max_pct) && !force {
        bail!(
            "{}: the fit is off by up to {worst:.1}% in luminance (fit patches {:.1}%{}), above the tolerance of {max_pct}% (--max-error); not written (check the patches, or --force)",
            patches.display(),
            100.0 * report.fit_max_rel_error,
            report.check_max_rel_error.map_or(String::new(), |c| format!(", check patches {:.1}%", 100.0 * c))
        );
    }
    Ok(())
}

/// Writes the fit into the fisheye calibration `calib`'s `[response]` (kind = "log", the
/// patches file relative to it, `code_max`), after checking that the edited file loads.
pub fn write_into_calib(calib: &Path, patches: &Path, code_max: f64, _fit: &LogResponse) -> Result<()> {
    let text = std::fs::read_to_string(calib).with_context(|| format!("reading {}", calib.display()))?;
    let mut doc: toml_edit::DocumentMut = text.parse().with_context(|| format!("{}: not valid TOML", calib.display()))?;
    let dir = calib.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    let canon = |p: &Path| std::fs::canonicalize(p).with_context(|| format!("resolving {}", p.display()));
    let rel = pathdiff(&canon(patches)?, &canon(dir)?);
    let r = doc.entry("response").or_insert(toml_edit::table()).as_table_mut().with_context(|| format!("{}: [response] is not a table", calib.display()))?;
    r["kind"] = toml_edit::value("log");
    r["patches"] = toml_edit::value(rel);
    r["code_max"] = toml_edit::value(code_max);
    for k in ["a", "b", "table", "gamma"] {
        r.remove(k);
    }
    // Validate the edited file before it replaces the old one.
    let tmp = calib.with_file_name(format!(".{}.check-{}.toml", calib.file_stem().unwrap_or_default().to_string_lossy(), std::process::id()));
    std::fs::write(&tmp, doc.to_string()).with_context(|| format!("writing {}", tmp.display()))?;
    let checked = heliar::vem::capture::lens_file::FisheyeCalib::load(&tmp);
    std::fs::remove_file(&tmp).ok();
    checked.with_context(|| format!("the edited {} would not load", calib.display()))?;
    crate::edit::write_atomic(calib, doc.to_string().as_bytes())
}

/// `path` relative to `base` (both absolute), with `..` where needed.
pub fn pathdiff(path: &Path, base: &Path) -> String {
    let (p, b): (Vec<_>, Vec<_>) = (path.components().collect(), base.components().collect());
    let common = p.iter().zip(&b).take_while(|(x, y)| x == y).count();
    let mut out: Vec<String> = std::iter::repeat_n("..".to_string(), b.len() - common).collect();
    out.extend(p[common..].iter().map(|c| c.as_os_str().to_string_lossy().into_owned()));
    out.join("/")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fits_beyond_the_tolerance_are_refused_unless_forced() {
        let good = FitReport { fit_patches: 6, fit_max_rel_error: 0.04, check_max_rel_error: Some(0.06) };
        let bad = FitReport { fit_max_rel_error: 1818.35, ..good };
        assert!(check_fit(&good, MAX_FIT_ERROR_PCT, Path::new("p.csv"), false).is_ok());
        let e = check_fit(&bad, MAX_FIT_ERROR_PCT, Path::new("p.csv"), false).unwrap_err().to_string();
        assert!(e.contains("p.csv") && e.contains("181835.0%") && e.contains("--force"), "{e}");
        assert!(check_fit(&bad, MAX_FIT_ERROR_PCT, Path::new("p.csv"), true).is_ok());
        assert!(check_fit(&FitReport { fit_max_rel_error: f64::NAN, ..good }, 25.0, Path::new("p.csv"), false).is_err());
        assert_eq!(pathdiff(Path::new("/a/b/p.csv"), Path::new("/a/c")), "../b/p.csv");
    }
}
