//! `heliar.Estimator` and `heliar.Estimate`: the per-frame sun and sky intensities (Jensen §3.1,
//! `heliar::estimate`), with the GIL released while a frame is estimated.

use crate::array::frame_from_numpy;
use crate::{parse_time, poisoned, py_err, to_py};
use anyhow::Context;
use heliar::estimate::FrameEstimate;
use heliar::geometry::raycast::RayScene;
use heliar::io::frames::{Linearizer, Photometry};
use pyo3::prelude::*;
use std::sync::{Arc, Mutex};

/// The estimator's state: its temporal smoothing spans the frames given to it.
struct State {
    est: heliar::estimate::Estimator,
    next_index: usize,
}

/// Estimates the sun (`pd`) and sky (`pa`) irradiance of frames of one scene. Its temporal
/// smoother runs over the frames in the order they are given, like `heliar estimate` over a
/// sequence. Calls on one estimator run one at a time (from any thread); the GIL is released
/// while a frame is estimated.
#[pyclass(frozen, module = "heliar._heliar")]
pub struct Estimator {
    state: Mutex<State>,
    lin: Linearizer,
    size: (u32, u32),
    photometry: Photometry,
}

impl Estimator {
    /// Sets up the estimator (as `heliar estimate` does) with the frames' calibration.
    pub(crate) fn build(scene: &heliar::scene::Scene, ray: Arc<RayScene>, photometry: Photometry) -> anyhow::Result<Self> {
        let est = heliar::estimate::Estimator::new(scene, ray).with_context(|| format!("setting up the estimator for {}", scene.root.display()))?;
        let k = &scene.camera.intrinsics;
        Ok(Self { state: Mutex::new(State { est, next_index: 0 }), lin: photometry.linearizer(), size: (k.width, k.height), photometry })
    }
}

#[pymethods]
impl Estimator {
    /// Estimates one frame taken at `time` (RFC 3339 string or timezone-aware datetime).
    ///
    /// `frame`: H×W×3 numpy array of the camera's size, float32 linear camera values (as an EXR
    /// frame) or uint8/uint16 codes (linearised through the camera response, as a PNG frame).
    /// `index` seeds the frame's draw of pixels (default: one more than the last call's, from
    /// 0), so the same frames with the same indices give the same estimates as
    /// `heliar estimate`.
    #[pyo3(signature = (frame, time, index=None))]
    fn estimate(&self, py: Python<'_>, frame: &Bound<'_, PyAny>, time: &Bound<'_, PyAny>, index: Option<usize>) -> PyResult<Estimate> {
        let frame = frame_from_numpy("frame", frame, Some(self.size))?;
        let t = parse_time(time)?;
        let e = py
            .detach(|| -> anyhow::Result<FrameEstimate> {
                let mut s = self.state.lock().map_err(|_| anyhow::anyhow!("an earlier call on this estimator panicked; create a new one"))?;
                let i = index.unwrap_or(s.next_index);
                let e = s.est.estimate(i, &t, &frame, &self.lin).with_context(|| format!("frame {i} at {}", t.to_rfc3339()))?;
                s.next_index = i + 1;
                Ok(e)
            })
            .map_err(py_err)?;
        Ok(Estimate { e })
    }

    /// The exposure frames are linearised with (camera linear value per unit radiance).
    #[getter]
    fn exposure(&self) -> f32 {
        self.photometry.exposure
    }

    /// The index the next `estimate` call uses when none is given.
    #[getter]
    fn next_index(&self) -> PyResult<usize> {
        Ok(self.state.lock().map_err(poisoned)?.next_index)
    }
}

/// One frame's estimate: the fields of a `heliar estimate` JSON line. RGB values are tuples of
/// three floats, or None where the frame could not give them (see `status` and `fallback`).
#[pyclass(frozen, module = "heliar._heliar")]
pub struct Estimate {
    pub(crate) e: FrameEstimate,
}

fn snake<T: serde::Serialize + std::fmt::Debug>(v: &T) -> String {
    serde_json::to_value(v).ok().and_then(|v| v.as_str().map(str::to_owned)).unwrap_or_else(|| format!("{v:?}"))
}

#[pymethods]
impl Estimate {
    /// The frame index given to the estimator.
    #[getter]
    fn frame(&self) -> usize {
        self.e.frame
    }
    /// The frame's time, RFC 3339.
    #[getter]
    fn time(&self) -> String {
        self.e.time.clone()
    }
    /// `ok`, `sun_not_separable`, `no_direct_sun`, `night`, `too_few_samples`, `saturated` or `dark_frame`.
    #[getter]
    fn status(&self) -> String {
        snake(&self.e.status)
    }
    /// What was reported instead when `pd` and `pa` could not be separated, else None.
    #[getter]
    fn fallback(&self) -> Option<String> {
        self.e.fallback.as_ref().map(snake)
    }
    /// The sun's irradiance on a surface facing it (RGB).
    #[getter]
    fn pd(&self) -> Option<[f64; 3]> {
        self.e.pd
    }
    /// The sky's irradiance on an unoccluded horizontal surface (RGB).
    #[getter]
    fn pa(&self) -> Option<[f64; 3]> {
        self.e.pa
    }
    /// Standard error of `pd`.
    #[getter]
    fn pd_se(&self) -> Option<[f64; 3]> {
        self.e.pd_se
    }
    /// Standard error of `pa`.
    #[getter]
    fn pa_se(&self) -> Option<[f64; 3]> {
        self.e.pa_se
    }
    /// Condition number of the fit's normal matrix.
    #[getter]
    fn condition_number(&self) -> Option<f64> {
        self.e.condition_number
    }
    /// RMS residual of the fit per channel.
    #[getter]
    fn residual_rms(&self) -> Option<[f64; 3]> {
        self.e.residual_rms
    }
    /// The sun: `zenith_deg`, `apparent_zenith_deg`, `azimuth_deg`, `above_horizon`, `dir_world`.
    #[getter]
    fn sun<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.e.sun)
    }
    /// The temporally smoothed `{"pd": …, "pa": …}` the renderer uses, or None.
    #[getter]
    fn smoothed<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.e.smoothed)
    }
    /// Sample counts (`available`, `drawn`, `usable`, `clipped`, `invalid`, `censored`, `lit`, `inliers`).
    #[getter]
    fn samples<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.e.samples)
    }
    /// Whether later stages should redo their lighting work (relight the probes).
    #[getter]
    fn relight(&self) -> bool {
        self.e.relight
    }
    /// Estimation time, ms.
    #[getter]
    fn estimate_ms(&self) -> f64 {
        self.e.estimate_ms
    }
    /// All fields as a dict (the `heliar estimate` JSON line without its file fields).
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.e)
    }
    /// All fields as one JSON line.
    fn to_json(&self) -> PyResult<String> {
        serde_json::to_string(&self.e).map_err(|e| py_err(e.into()))
    }
    fn __repr__(&self) -> String {
        let f = |v: Option<[f64; 3]>| v.map_or("None".into(), |v| format!("({:.4}, {:.4}, {:.4})", v[0], v[1], v[2]));
        format!("Estimate(frame={}, status={:?}, pd={}, pa={})", self.e.frame, self.status(), f(self.e.pd), f(self.e.pa))
    }
}
