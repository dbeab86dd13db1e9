//! Python bindings of heliar (`import heliar`): thin wrappers over the library, with numpy arrays
//! in and out. The Rust crate stays the single implementation; every function here converts its
//! arguments, calls the library and converts the result.
//!
//! | Python | library |
//! |---|---|
//! | `heliar.Scene.load` | [`heliar::scene::Scene::load_with`] |
//! | `Scene.estimator()` → `Estimator.estimate` | [`heliar::estimate::Estimator`] (Jensen §3.1) |
//! | `Scene.compositor()` → `Compositor.composite` | [`heliar::render::Compositor`] and the probe source of [`heliar::run::outdoor`] |
//! | `heliar.vem.Decomposer` | [`heliar::vem::Decomposer`] (Havran et al. 2005) |
//! | `heliar.sun` | [`heliar::sun::sun_position`] (NREL SPA) |
//!
//! Errors carry the command line's messages (the same contexts, printed the way `heliar` prints
//! them: the causes joined by `: `). Estimation and compositing run with the GIL released; each
//! object keeps its state behind a mutex, so one object may be used from several threads (calls
//! on the same object run one at a time).

mod array;
mod compositor;
mod estimator;
mod scene;
mod vem;

use chrono::{DateTime, FixedOffset};
use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyString};

create_exception!(_heliar, HeliarError, PyException, "An error of the heliar library (the message is the command line's).");

/// An `anyhow` error as a Python exception with the command line's text (`error: {e:#}`).
pub(crate) fn py_err(e: anyhow::Error) -> PyErr {
    HeliarError::new_err(format!("{e:#}"))
}

/// A poisoned lock (a panic inside an earlier call) as a Python exception.
pub(crate) fn poisoned<T>(_: T) -> PyErr {
    HeliarError::new_err("an earlier call on this object panicked; create a new one")
}

/// A time given as an RFC 3339 string or a timezone-aware `datetime` (its `isoformat()`).
pub(crate) fn parse_time(time: &Bound<'_, PyAny>) -> PyResult<DateTime<FixedOffset>> {
    let text: String = if let Ok(s) = time.cast::<PyString>() {
        s.to_string()
    } else if time.hasattr("isoformat")? {
        time.call_method0("isoformat")?.extract()?
    } else {
        return Err(pyo3::exceptions::PyTypeError::new_err(format!(
            "time: expected an RFC 3339 string or a datetime, got {}",
            time.get_type().name()?
        )));
    };
    DateTime::parse_from_rfc3339(text.trim()).map_err(|e| {
        pyo3::exceptions::PyValueError::new_err(format!(
            "time '{text}' is not RFC 3339 with offset ({e}); give a string like 2024-06-21T15:30:00+02:00 or a timezone-aware datetime"
        ))
    })
}

/// A JSON value as Python objects (dicts, lists, floats, strings), through the `json` module.
pub(crate) fn to_py<'py>(py: Python<'py>, v: &impl serde::Serialize) -> PyResult<Bound<'py, PyAny>> {
    let text = serde_json::to_string(v).map_err(|e| HeliarError::new_err(e.to_string()))?;
    py.import("json")?.call_method1("loads", (text,))
}

/// Solar position (NREL SPA) seen from latitude `lat` and longitude `lon` (degrees, east
/// positive) at `time` (RFC 3339 string or timezone-aware datetime).
///
/// Returns a dict with the fields of `heliar sun`: `time`, `latitude_deg`, `longitude_deg`,
/// `elevation_m`, `zenith_deg`, `apparent_zenith_deg`, `azimuth_deg` (clockwise from north) and
/// `above_horizon`.
#[pyfunction]
#[pyo3(signature = (lat, lon, time, elevation=0.0, pressure=None, temperature=None))]
fn sun<'py>(py: Python<'py>, lat: f64, lon: f64, time: &Bound<'py, PyAny>, elevation: f64, pressure: Option<f64>, temperature: Option<f64>) -> PyResult<Bound<'py, PyDict>> {
    let t = parse_time(time)?;
    let mut o = heliar::sun::Observer::new(lat, lon, elevation);
    if let Some(p) = pressure {
        o.pressure_mbar = p;
    }
    if let Some(c) = temperature {
        o.temperature_c = c;
    }
    o.validate().map_err(|(field, msg)| {
        let option = match field {
            "latitude_deg" => "lat",
            "longitude_deg" => "lon",
            "elevation_m" => "elevation",
            "pressure_mbar" => "pressure",
            "temperature_c" => "temperature",
            other => other,
        };
        pyo3::exceptions::PyValueError::new_err(format!("{option}: {msg} (the limits of scene.toml's place.{field})"))
    })?;
    let p = heliar::sun::sun_position(&o, &t).map_err(|e| py_err(e.into()))?;
    sun_dict(py, &t, &o, &p)
}

/// The dict of one solar position, keyed as `heliar sun` prints it.
pub(crate) fn sun_dict<'py>(py: Python<'py>, t: &DateTime<FixedOffset>, o: &heliar::sun::Observer, p: &heliar::sun::SunPosition) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("time", t.to_rfc3339())?;
    d.set_item("latitude_deg", o.latitude_deg)?;
    d.set_item("longitude_deg", o.longitude_deg)?;
    d.set_item("elevation_m", o.elevation_m)?;
    d.set_item("zenith_deg", p.zenith_deg)?;
    d.set_item("apparent_zenith_deg", p.apparent_zenith_deg)?;
    d.set_item("azimuth_deg", p.azimuth_deg)?;
    d.set_item("above_horizon", p.above_horizon())?;
    Ok(d)
}

/// Decodes a frame file as heliar reads footage: `.exr` → float32 HxWx3 (linear), 8-bit
/// `.png` → uint8 HxWx3, 16-bit `.png` → uint16 HxWx3 (codes).
#[pyfunction]
fn read_frame<'py>(py: Python<'py>, path: std::path::PathBuf) -> PyResult<Bound<'py, PyAny>> {
    let frame = py.detach(|| heliar::io::frames::Frame::load(&path)).map_err(|e| py_err(e.into()))?;
    array::frame_to_numpy(py, &frame)
}

/// The native module `heliar._heliar` (the package `heliar` re-exports it).
#[pymodule]
fn _heliar(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("HeliarError", m.py().get_type::<HeliarError>())?;
    m.add_function(wrap_pyfunction!(sun, m)?)?;
    m.add_function(wrap_pyfunction!(read_frame, m)?)?;
    m.add_class::<scene::Scene>()?;
    m.add_class::<estimator::Estimator>()?;
    m.add_class::<estimator::Estimate>()?;
    m.add_class::<compositor::Compositor>()?;
    m.add_class::<compositor::Lighting>()?;
    m.add_class::<vem::Decomposer>()?;
    Ok(())
}
