//! numpy arrays ↔ heliar frames, with the checks a frame from Python needs (a file's frame is
//! checked by the decoder; an array is checked here).
//!
//! - `float32` H×W×3: linear camera values, as an EXR frame (`FrameData::Hdr`).
//! - `uint8` / `uint16` H×W×3: codes through the camera response, as an 8/16-bit PNG frame.

use heliar::io::frames::{Frame, FrameData};
use heliar::io::image::LinearImage;
use numpy::{PyArray1, PyArrayMethods, PyReadonlyArray3, PyUntypedArray, PyUntypedArrayMethods};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;

/// What a frame array must be, for error messages.
const FRAME_FORMS: &str = "an H×W×3 numpy array of float32 (linear camera values, as an EXR frame) or uint8/uint16 (codes through the camera response, as a PNG frame)";

/// The shape of `obj` when it is a numpy array of 3 dimensions with 3 channels.
fn frame_shape(what: &str, obj: &Bound<'_, PyAny>) -> PyResult<(usize, usize)> {
    let arr = obj.cast::<PyUntypedArray>().map_err(|_| {
        PyTypeError::new_err(format!("{what}: expected {FRAME_FORMS}, got {}", obj.get_type().name().map(|n| n.to_string()).unwrap_or_default()))
    })?;
    let shape = arr.shape();
    if shape.len() != 3 || shape[2] != 3 {
        return Err(PyValueError::new_err(format!("{what}: shape {shape:?} is not H×W×3; expected {FRAME_FORMS}")));
    }
    Ok((shape[0], shape[1]))
}

/// The values of a 3-d array in row-major order (any strides).
fn values<T: numpy::Element + Copy>(a: &PyReadonlyArray3<'_, T>) -> Vec<T> {
    // `as_slice` also accepts a Fortran-ordered array, whose memory order is not row-major.
    match a.as_slice() {
        Ok(s) if a.is_c_contiguous() => s.to_vec(),
        _ => a.as_array().iter().copied().collect(),
    }
}

/// A frame array as a heliar frame. `size` is the camera's (width, height) when the frame must
/// have it. Non-finite values are refused (a file's NaN pixels are skipped by the estimator, but
/// an array with NaN is almost always a bug upstream, so it is named here).
pub fn frame_from_numpy(what: &str, obj: &Bound<'_, PyAny>, size: Option<(u32, u32)>) -> PyResult<Frame> {
    let (h, w) = frame_shape(what, obj)?;
    if let Some((want_w, want_h)) = size
        && (w as u64, h as u64) != (want_w as u64, want_h as u64)
    {
        return Err(PyValueError::new_err(format!(
            "{what}: image is {w}×{h} but the camera calibration says {want_w}×{want_h} (a frame of this scene must have the camera's size)"
        )));
    }
    let (width, height) = (w as u32, h as u32);
    if let Ok(a) = obj.extract::<PyReadonlyArray3<'_, f32>>() {
        let v = values(&a);
        if let Some(i) = v.iter().position(|x| !x.is_finite()) {
            let bad = v.iter().filter(|x| !x.is_finite()).count();
            let p = i / 3;
            return Err(PyValueError::new_err(format!(
                "{what}: {bad} values are NaN or infinite (the first at row {}, column {}, channel {}); linear frames must be finite",
                p / w,
                p % w,
                i % 3
            )));
        }
        let data = v.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
        return Ok(Frame { width, height, data: FrameData::Hdr(LinearImage { width, height, data }) });
    }
    if let Ok(a) = obj.extract::<PyReadonlyArray3<'_, u8>>() {
        let codes = values(&a).into_iter().map(u16::from).collect();
        return Ok(Frame { width, height, data: FrameData::Ldr { bits: 8, codes } });
    }
    if let Ok(a) = obj.extract::<PyReadonlyArray3<'_, u16>>() {
        return Ok(Frame { width, height, data: FrameData::Ldr { bits: 16, codes: values(&a) } });
    }
    let dtype = obj.getattr("dtype").and_then(|d| d.str()).map(|s| s.to_string()).unwrap_or_else(|_| "?".into());
    Err(PyTypeError::new_err(format!("{what}: dtype {dtype} is not supported; expected {FRAME_FORMS}")))
}

/// A linear image as a float32 H×W×3 array.
pub fn linear_to_numpy<'py>(py: Python<'py>, img: &LinearImage) -> PyResult<Bound<'py, PyAny>> {
    let flat: Vec<f32> = img.data.iter().flatten().copied().collect();
    let a = PyArray1::from_vec(py, flat).reshape([img.height as usize, img.width as usize, 3])?;
    Ok(a.into_any())
}

/// Codes as a uint8 or uint16 H×W×3 array.
pub fn codes_to_numpy<'py>(py: Python<'py>, width: u32, height: u32, bits: u32, codes: &[u16]) -> PyResult<Bound<'py, PyAny>> {
    let shape = [height as usize, width as usize, 3];
    if bits == 16 {
        Ok(PyArray1::from_slice(py, codes).reshape(shape)?.into_any())
    } else {
        let bytes: Vec<u8> = codes.iter().map(|&c| c.min(255) as u8).collect();
        Ok(PyArray1::from_vec(py, bytes).reshape(shape)?.into_any())
    }
}

/// A heliar frame as an array (float32 for HDR, uint8/uint16 codes for LDR).
pub fn frame_to_numpy<'py>(py: Python<'py>, frame: &Frame) -> PyResult<Bound<'py, PyAny>> {
    match &frame.data {
        FrameData::Hdr(img) => linear_to_numpy(py, img),
        FrameData::Ldr { bits, codes } => codes_to_numpy(py, frame.width, frame.height, *bits as u32, codes),
    }
}

/// An N×3 float32 array of vectors.
pub fn rows_to_numpy<'py>(py: Python<'py>, rows: &[[f32; 3]]) -> PyResult<Bound<'py, PyAny>> {
    let flat: Vec<f32> = rows.iter().flatten().copied().collect();
    Ok(PyArray1::from_vec(py, flat).reshape([rows.len(), 3])?.into_any())
}

/// An H×W×3 float32 array as rows of RGB (a polar map), refusing other shapes and dtypes.
pub fn rgb_rows(what: &str, obj: &Bound<'_, PyAny>) -> PyResult<(usize, usize, Vec<[f32; 3]>)> {
    let (h, w) = frame_shape(what, obj)?;
    let a: PyReadonlyArray3<'_, f32> = obj.extract().map_err(|_| {
        let dtype = obj.getattr("dtype").and_then(|d| d.str()).map(|s| s.to_string()).unwrap_or_else(|_| "?".into());
        PyTypeError::new_err(format!("{what}: dtype {dtype} is not supported; expected float32 linear radiance"))
    })?;
    let v = values(&a);
    Ok((h, w, v.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect()))
}
