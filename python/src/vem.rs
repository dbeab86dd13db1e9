//! `heliar.vem.Decomposer`: a captured environment map's polar map turned into temporally
//! coherent directional lights (Havran et al. 2005, `heliar::vem`), as `heliar vem` does per frame.

use crate::array::{rgb_rows, rows_to_numpy};
use crate::{poisoned, py_err, to_py};
use heliar::vem::polar::PolarMap;
use heliar::vem::sampling::SamplerKind;
use heliar::vem::sampling::pattern::Pattern;
use heliar::vem::{VemConfig, VemError};
use numpy::PyArray1;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::sync::Mutex;

/// The per-frame light decomposition of a sequence of polar maps (upper hemisphere, row 0 at
/// the zenith, H×W×3 float32 linear radiance; `heliar vem` resamples captures to 90×360). The
/// lights keep their index from frame to frame and their directions and the frame power pass a
/// temporal FIR filter, so feed the maps in capture order.
#[pyclass(frozen, module = "heliar._heliar")]
pub struct Decomposer {
    inner: Mutex<heliar::vem::Decomposer>,
}

#[pymethods]
impl Decomposer {
    /// `lights`: N equal-power lights (default 300). `sampler`: "coherent-cut"
    /// (default), "havran", "havran-centres", "standard" or "median-cut". `rate_hz`: capture rate the temporal
    /// filter is designed for (default the paper's 21 Hz). `clusters`: cluster the lights into
    /// at most this many. `peaks`: give the sun, lamps and other compact peaks lights of their
    /// own (default `None`: on with the coherent cut, off with the other samplers).
    /// `relax`: relaxed Halton samples (the paper's), else plain Halton.
    #[new]
    #[pyo3(signature = (lights=300, sampler="coherent-cut", rate_hz=heliar::vem::fir::PAPER_RATE_HZ, clusters=None, peaks=None, relax=true))]
    fn new(py: Python<'_>, lights: usize, sampler: &str, rate_hz: f64, clusters: Option<usize>, peaks: Option<bool>, relax: bool) -> PyResult<Self> {
        let sampler = match sampler {
            "havran" => SamplerKind::Havran,
            "havran-centres" => SamplerKind::HavranCentres,
            "standard" => SamplerKind::Standard,
            "median-cut" => SamplerKind::MedianCut,
            "coherent-cut" => SamplerKind::CoherentCut,
            o => return Err(PyValueError::new_err(format!("sampler '{o}': expected one of havran, havran-centres, standard, median-cut, coherent-cut"))),
        };
        let pattern = if relax { Pattern::RelaxedHalton } else { Pattern::Halton };
        let cfg = VemConfig { lights, sampler, pattern, rate_hz, clusters, peaks, ..VemConfig::default() };
        let d = py.detach(|| heliar::vem::Decomposer::new(cfg)).map_err(vem_err)?;
        Ok(Self { inner: Mutex::new(d) })
    }

    /// Processes the next polar map (H×W×3 float32). Returns a dict: `index` (N uint32),
    /// `dir` (N×3 unit directions toward the lights, scene frame), `rgb` (N×3 irradiance on a
    /// surface facing each light, so Σ rgb·max(n·l, 0) is the irradiance at normal n), and the
    /// frame's `status` ("ok" or "dark"), `power_rgb`, `power`, `filtered_power`, `held` and
    /// `sanitized_texels` (NaN, infinite or negative texels taken as black), as in a
    /// `heliar vem` line.
    fn decompose<'py>(&self, py: Python<'py>, map: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyDict>> {
        let (h, w, data) = rgb_rows("map", map)?;
        if w < 4 || h < 2 {
            return Err(PyValueError::new_err(format!("map: {h}×{w} is smaller than a 2×4 polar map")));
        }
        let map = PolarMap { width: w as u32, height: h as u32, data };
        let (summary, lights) = py
            .detach(|| {
                let mut d = self.inner.lock().map_err(poisoned)?;
                let s = d.process(&map);
                Ok::<_, PyErr>((s, d.lights().to_vec()))
            })?;
        let out = PyDict::new(py);
        let index: Vec<u32> = lights.iter().map(|l| l.index).collect();
        let dirs: Vec<[f32; 3]> = lights.iter().map(|l| l.dir.to_array()).collect();
        let rgb: Vec<[f32; 3]> = lights.iter().map(|l| l.rgb).collect();
        out.set_item("index", PyArray1::from_vec(py, index))?;
        out.set_item("dir", rows_to_numpy(py, &dirs)?)?;
        out.set_item("rgb", rows_to_numpy(py, &rgb)?)?;
        let s = to_py(py, &summary)?;
        for (k, v) in s.cast::<PyDict>()?.iter() {
            out.set_item(k, v)?;
        }
        Ok(out)
    }

    /// The light count.
    #[getter]
    fn lights(&self) -> PyResult<usize> {
        Ok(self.inner.lock().map_err(poisoned)?.config().lights)
    }
}

fn vem_err(e: VemError) -> PyErr {
    py_err(e.into())
}
