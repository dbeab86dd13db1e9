//! Photometric calibration of LDR fisheye frames (Havran §5.1): the logarithmic camera response
//! fitted from gray patches of known luminance.
//!
//! # How it works
//! The paper's HDR camera has a logarithmic response. With normalised codes `c ∈ [0, 1]`, the
//! model is `c = a + b·ln Y`, fitted by least squares of the codes against `ln Y` over the patches
//! (the paper uses six). Patches marked `check` are left out of the fit and only measure it (the
//! paper keeps two such measurements). Inverted, `Y = exp((c − a)/b)`; [`LogResponse::response`]
//! tabulates that at every 16-bit code, which is exact at every 8-bit code too (`65535 = 257·255`),
//! so frames go through the crate's usual [`crate::io::frames::Linearizer`].
//!
//! A response recovered from bracketed exposures (Debevec & Malik style) arrives as a table
//! (`kind = "table"` in the calibration file), read by [`super::lens_file`].

use crate::io::frames::Response;

/// Rows of the tabulated response (one per 16-bit code).
pub const TABLE_ROWS: usize = 65536;

/// Which role a gray patch plays.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PatchRole {
    /// Used in the fit.
    Fit,
    /// Held out to check the fit.
    Check,
}

/// One gray patch: its normalised code and known luminance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Patch {
    /// Camera code normalised to `[0, 1]`.
    pub code: f64,
    /// Known luminance (any unit; the frames come out in it).
    pub luminance: f64,
    /// Fit or check.
    pub role: PatchRole,
}

/// A logarithmic response `c = a + b·ln Y`.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct LogResponse {
    /// Offset (normalised code at `Y = 1`).
    pub a: f64,
    /// Slope (normalised code per natural-log unit of luminance), positive.
    pub b: f64,
}

/// How well a fit matches the patches.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct FitReport {
    /// Patches used in the fit.
    pub fit_patches: usize,
    /// Largest relative luminance error over the fit patches.
    pub fit_max_rel_error: f64,
    /// Largest relative luminance error over the check patches (`None` without any).
    pub check_max_rel_error: Option<f64>,
}

impl LogResponse {
    /// Least-squares fit over the `Fit` patches; `Err` with a message when it cannot be made
    /// (fewer than two patches, non-positive luminance, codes that do not grow with luminance).
    pub fn fit(patches: &[Patch]) -> Result<(Self, FitReport), String> {
        for (i, p) in patches.iter().enumerate() {
            if !(p.luminance.is_finite() && p.luminance > 0.0) {
                return Err(format!("patch {}: luminance {} must be positive", i + 1, p.luminance));
            }
            if !(p.code.is_finite() && (0.0..=1.0).contains(&p.code)) {
                return Err(format!("patch {}: code {} is outside [0, code_max]", i + 1, p.code));
            }
        }
        let fit: Vec<&Patch> = patches.iter().filter(|p| p.role == PatchRole::Fit).collect();
        if fit.len() < 2 {
            return Err(format!("{} fit patches: at least 2 are needed (the paper uses 6)", fit.len()));
        }
        let n = fit.len() as f64;
        let mx = fit.iter().map(|p| p.luminance.ln()).sum::<f64>() / n;
        let my = fit.iter().map(|p| p.code).sum::<f64>() / n;
        let sxx: f64 = fit.iter().map(|p| (p.luminance.ln() - mx).powi(2)).sum();
        let sxy: f64 = fit.iter().map(|p| (p.luminance.ln() - mx) * (p.code - my)).sum();
        if !(sxx > 1e-12) {
            return Err("all fit patches have the same luminance".into());
        }
        let b = sxy / sxx;
        if !(b > 1e-9) {
            return Err(format!("codes do not grow with luminance (slope {b:.3e})"));
        }
        let r = Self { a: my - b * mx, b };
        let err = |p: &&Patch| (r.luminance(p.code) - p.luminance).abs() / p.luminance;
        let check: Vec<f64> = patches.iter().filter(|p| p.role == PatchRole::Check).map(|p| err(&p)).collect();
        let report = FitReport {
            fit_patches: fit.len(),
            fit_max_rel_error: fit.iter().map(err).fold(0.0, f64::max),
            check_max_rel_error: (!check.is_empty()).then(|| check.iter().cloned().fold(0.0, f64::max)),
        };
        Ok((r, report))
    }

    /// Luminance of normalised code `c`.
    pub fn luminance(&self, c: f64) -> f64 {
        ((c - self.a) / self.b).exp()
    }

    /// The response as a table at every 16-bit code (see the module docs).
    pub fn response(&self) -> Response {
        Response::Table((0..TABLE_ROWS).map(|i| [self.luminance(i as f64 / (TABLE_ROWS - 1) as f64) as f32; 3]).collect())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::frames::{Frame, FrameData, Linearizer};

    #[test]
    fn recovers_a_known_log_response_and_linearises_frames() {
        // A camera with c = 0.2 + 0.06·ln Y over eight orders of magnitude (the paper's sensor).
        let truth = LogResponse { a: 0.2, b: 0.06 };
        let lum = [0.05, 1.0, 20.0, 400.0, 8000.0, 1.6e5, 3.0, 900.0];
        let patches: Vec<Patch> = lum
            .iter()
            .enumerate()
            .map(|(i, &y)| Patch {
                // 8-bit quantisation of the code.
                code: ((truth.a + truth.b * f64::ln(y)) * 255.0).round() / 255.0,
                luminance: y,
                role: if i < 6 { PatchRole::Fit } else { PatchRole::Check },
            })
            .collect();
        let (r, rep) = LogResponse::fit(&patches).unwrap();
        assert!((r.a - truth.a).abs() < 0.005 && (r.b - truth.b).abs() < 0.001, "{r:?}");
        // Half a code step is 1/(2·255·0.06) = 3.3% in luminance.
        assert!(rep.fit_max_rel_error < 0.05 && rep.check_max_rel_error.unwrap() < 0.05, "{rep:?}");
        let lin = Linearizer::new(&r.response(), 1.0, 1.0, None);
        let code = ((truth.a + truth.b * f64::ln(400.0)) * 255.0).round() as u16;
        let frame = Frame { width: 1, height: 1, data: FrameData::Ldr { bits: 8, codes: vec![code; 3] } };
        let (v, _) = lin.radiance(&frame, 0);
        assert!((v[1] as f64 - 400.0).abs() < 0.05 * 400.0, "{v:?}");
    }

    #[test]
    fn bad_patches_are_refused() {
        let p = |code, luminance| Patch { code, luminance, role: PatchRole::Fit };
        assert!(LogResponse::fit(&[p(0.5, 1.0)]).unwrap_err().contains("at least 2"));
        assert!(LogResponse::fit(&[p(0.5, 1.0), p(0.4, 10.0)]).unwrap_err().contains("do not grow"));
        assert!(LogResponse::fit(&[p(0.5, -1.0), p(0.6, 10.0)]).unwrap_err().contains("positive"));
    }
}
