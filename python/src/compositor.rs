//! `heliar.Compositor` and `heliar.Lighting`: virtual objects composited into a frame on the
//! GPU (`heliar::render::Compositor`), with the probe source's relight hook of
//! `heliar::run::outdoor` (Jensen §3.3–3.4, §4.2). The GIL is released while compositing.

use crate::array::{codes_to_numpy, frame_from_numpy, linear_to_numpy};
use crate::estimator::Estimate;
use crate::{poisoned, py_err, to_py};
use anyhow::Context;
use glam::Vec3;
use heliar::geometry::raycast::RayScene;
use heliar::gpu::{Gpu, GpuOptions};
use heliar::io::frames::{FrameData, Linearizer, Photometry};
use heliar::irradiance::sources::ProbeSource;
use heliar::render::{Builder, CompositorConfig, Darkening, PassReport, VideoFrame};
use heliar::run::motion::MovingObjects;
use heliar::run::outdoor::{Ambient, RelightReport, cached_bake, lighting_of, probe_source};
use chrono::{DateTime, FixedOffset};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use std::sync::{Arc, Mutex};

/// The lighting a frame is composited with: the sun's direction (unit, toward the sun, scene
/// frame), `pd` and `pa` (RGB, scaled radiance units; see the crate's conventions).
#[pyclass(frozen, module = "heliar._heliar")]
pub struct Lighting {
    l: heliar::lighting::Lighting,
}

#[pymethods]
impl Lighting {
    #[new]
    #[pyo3(signature = (sun_dir, pd, pa, above_horizon=true))]
    fn new(sun_dir: [f32; 3], pd: [f32; 3], pa: [f32; 3], above_horizon: bool) -> PyResult<Self> {
        let all = sun_dir.iter().chain(&pd).chain(&pa);
        if all.clone().any(|v| !v.is_finite()) {
            return Err(PyValueError::new_err("Lighting: sun_dir, pd and pa must be finite"));
        }
        let d = Vec3::from(sun_dir);
        if (d.length() - 1.0).abs() > 1e-3 {
            return Err(PyValueError::new_err(format!("Lighting: sun_dir {sun_dir:?} is not a unit vector (length {:.4})", d.length())));
        }
        Ok(Self { l: heliar::lighting::Lighting { sun_dir: d, above_horizon, pd: Vec3::from(pd), pa: Vec3::from(pa), sky: heliar::lighting::FrameSky::Declared, lamps: heliar::lighting::LampScales::NONE } })
    }
    #[getter]
    fn sun_dir(&self) -> [f32; 3] {
        self.l.sun_dir.to_array()
    }
    #[getter]
    fn pd(&self) -> [f32; 3] {
        self.l.pd.to_array()
    }
    #[getter]
    fn pa(&self) -> [f32; 3] {
        self.l.pa.to_array()
    }
    #[getter]
    fn above_horizon(&self) -> bool {
        self.l.above_horizon
    }
    fn __repr__(&self) -> String {
        format!("Lighting(sun_dir={:?}, pd={:?}, pa={:?}, above_horizon={})", self.sun_dir(), self.pd(), self.pa(), self.l.above_horizon)
    }
}

/// The compositor settings of `heliar augment`, parsed from Python's strings.
pub(crate) struct CompositorSettings {
    samples: u32,
    darkening: Darkening,
    ambient: Ambient,
    transfer_paths: u32,
    builder: Builder,
    sun_bounce: bool,
}

impl CompositorSettings {
    pub(crate) fn parse(samples: u32, darkening: &str, ambient: &str, transfer_paths: u32, volumes: &str, sun_bounce: bool) -> PyResult<Self> {
        let bad = |what: &str, got: &str, want: &str| PyValueError::new_err(format!("{what} '{got}': expected one of {want}"));
        let darkening = match darkening {
            "differential" => Darkening::Differential,
            "normal" => Darkening::Normal,
            "constant" => Darkening::Constant,
            o => return Err(bad("darkening", o, "differential, normal, constant")),
        };
        let ambient = match ambient {
            "auto" => Ambient::Auto,
            "volume" => Ambient::Volume,
            "uniform" => Ambient::Uniform,
            o => return Err(bad("ambient", o, "auto, volume, uniform")),
        };
        let builder = match volumes {
            "cpu" => Builder::Cpu,
            "compute" => Builder::Compute,
            o => return Err(bad("volumes", o, "cpu, compute")),
        };
        if samples != 1 && samples != 4 {
            return Err(PyValueError::new_err(format!("samples {samples}: MSAA samples must be 1 or 4")));
        }
        Ok(Self { samples, darkening, ambient, transfer_paths, builder, sun_bounce })
    }
}

struct State {
    comp: heliar::render::Compositor,
    probes: Box<dyn ProbeSource + Send>,
    /// The lighting the probes were last relit for (None before the first frame).
    relit_for: Option<heliar::lighting::Lighting>,
    /// The scene's moving objects, when it has any and the compositor knows the sequence's start
    /// (`heliar augment`'s `OutdoorSession::follow_motion`).
    motion: Option<MovingObjects>,
    /// The index of the next frame composited with a time.
    next_index: usize,
}

/// Composites the scene's virtual objects into frames on the GPU, as `heliar augment` does:
/// lit by a frame's estimate, shadowed by the proxy, casting shadows onto it. Calls on one
/// compositor run one at a time (from any thread); the GIL is released while compositing.
#[pyclass(frozen, module = "heliar._heliar")]
pub struct Compositor {
    state: Mutex<State>,
    lin: Linearizer,
    photometry: Photometry,
    size: (u32, u32),
    gpu: String,
}

impl Compositor {
    /// The GPU, the compositor and the probe source (baking first when the irradiance volume
    /// is wanted and its cache is stale), as `heliar augment` sets them up.
    /// `start` is the time of the sequence's first frame: with it, objects that have a motion
    /// follow it on the frames' times, as in `heliar augment`.
    pub(crate) fn build(scene: &heliar::scene::Scene, ray: Arc<RayScene>, s: CompositorSettings, photometry: Photometry, start: Option<DateTime<FixedOffset>>) -> anyhow::Result<Self> {
        let mut config = CompositorConfig::for_scene(scene);
        config.darkening = s.darkening;
        config.sun_bounce = config.sun_bounce && s.sun_bounce;
        config.builder = s.builder;
        config.transfer_paths = s.transfer_paths;
        let gpu = Arc::new(Gpu::new(GpuOptions { samples: s.samples.max(1) })?);
        let mut comp = heliar::render::Compositor::for_scene(gpu.clone(), scene, ray.clone(), config)
            .with_context(|| format!("setting up the compositor for {}", scene.root.display()))?;
        let motion = start.and_then(|t0| MovingObjects::for_scene(scene, t0)).map(|m| m.attach(scene, &mut comp));
        let probes = probe_source(scene, ray, s.ambient, |sc, r| cached_bake(sc, r, &|_: &str, _: u64, _: u64| {}))?;
        let k = &scene.camera.intrinsics;
        Ok(Self {
            state: Mutex::new(State { comp, probes, relit_for: None, motion, next_index: 0 }),
            lin: photometry.linearizer(),
            photometry,
            size: (k.width, k.height),
            gpu: gpu.describe(),
        })
    }
}

/// The lighting to composite with, and whether the probes must be relit for it.
fn lighting_arg(lighting: &Bound<'_, PyAny>) -> PyResult<(heliar::lighting::Lighting, Option<bool>)> {
    if let Ok(e) = lighting.cast::<Estimate>() {
        let e = e.get();
        return Ok((lighting_of(&e.e), Some(e.e.relight)));
    }
    if let Ok(l) = lighting.cast::<Lighting>() {
        return Ok((l.get().l, None));
    }
    Err(pyo3::exceptions::PyTypeError::new_err(format!(
        "lighting: expected an Estimate (from Estimator.estimate) or a Lighting, got {}",
        lighting.get_type().name()?
    )))
}

#[pymethods]
impl Compositor {
    /// Composites the virtual objects into `frame` with `lighting` (an `Estimate`: its
    /// smoothed values, relighting the probes when it says `relight`, as `heliar augment`; or a
    /// `Lighting`: the probes are relit whenever it changes).
    ///
    /// Returns `(image, report)`. `image` has the frame's form: float32 camera-linear values
    /// (what `augment --format exr` writes, in half floats) for a float32 frame, codes through
    /// the camera response (what a PNG output holds) for a uint8/uint16 frame; pixels the
    /// objects leave alone keep the input's values. `report` is the pass report of the
    /// per-frame JSON line (`ran`, `skipped` with reasons, timings) plus `relight` and
    /// `composite_ms`.
    ///
    /// `time` (RFC 3339 or a timezone-aware datetime) is the frame's capture time: objects with
    /// a motion are posed for it first, as `heliar augment` does, and the report lists those
    /// that moved. Without it they stay where they last stood.
    #[pyo3(signature = (frame, lighting, time=None))]
    fn composite<'py>(&self, py: Python<'py>, frame: &Bound<'py, PyAny>, lighting: &Bound<'py, PyAny>, time: Option<&Bound<'py, PyAny>>) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>)> {
        let frame = frame_from_numpy("frame", frame, Some(self.size))?;
        let (light, wants) = lighting_arg(lighting)?;
        let time = time.map(crate::parse_time).transpose()?;
        let (rendered, passes, relight, ms) = py
            .detach(|| -> anyhow::Result<_> {
                let mut s = self.state.lock().map_err(|_| anyhow::anyhow!("an earlier call on this compositor panicked; create a new one"))?;
                let relight = relight_if_needed(&mut s, &light, wants);
                let video = VideoFrame::from_frame(&frame, &self.lin);
                let t = std::time::Instant::now();
                let st = &mut *s;
                let moved = match (&mut st.motion, &time) {
                    (Some(m), Some(time)) => {
                        let f = m.advance(st.next_index, time);
                        m.apply(&mut st.comp, &f, st.probes.relighter())?;
                        st.next_index += 1;
                        Some(f)
                    }
                    _ => None,
                };
                let (rendered, mut passes) = st.comp.render(&video, &light)?;
                if let (Some(m), Some(f)) = (&st.motion, &moved) {
                    m.report(f, &mut passes);
                }
                let ms = t.elapsed().as_secs_f64() * 1e3;
                let out = match &frame.data {
                    FrameData::Hdr(_) => Err(heliar::render::output::camera_linear(&rendered.image, rendered.precision, &video, &frame, &self.photometry)),
                    FrameData::Ldr { .. } => Ok(heliar::render::output::encode_codes(&rendered.image, rendered.precision, &video, &frame, &self.photometry)),
                };
                Ok((out, passes, relight, ms))
            })
            .map_err(py_err)?;
        let image = match rendered {
            Err(linear) => linear_to_numpy(py, &linear)?,
            Ok((bits, codes)) => codes_to_numpy(py, self.size.0, self.size.1, bits, &codes)?,
        };
        Ok((image, report_dict(py, &passes, &relight, ms)?))
    }

    /// The GPU adapter in use.
    #[getter]
    fn gpu(&self) -> String {
        self.gpu.clone()
    }

    /// The compositor's set-up warnings (open meshes and the like).
    #[getter]
    fn warnings(&self) -> PyResult<Vec<String>> {
        Ok(self.state.lock().map_err(poisoned)?.comp.warnings().to_vec())
    }
}

/// Relights the probes when the lighting asks for it (`wants`: the estimate's `relight`; None:
/// whenever the lighting changed), as `OutdoorStage::light` does.
fn relight_if_needed(s: &mut State, light: &heliar::lighting::Lighting, wants: Option<bool>) -> RelightReport {
    let source = s.probes.name();
    let first = s.relit_for.is_none();
    let run = first || wants.unwrap_or(s.relit_for != Some(*light));
    if !run {
        return RelightReport { ran: false, source, reason: "lighting unchanged (relight = false)".into(), ms: 0.0 };
    }
    let t = std::time::Instant::now();
    let grid = s.probes.relight(light);
    s.comp.set_probes(grid);
    s.relit_for = Some(*light);
    let reason = if first { "first frame" } else { "lighting changed" };
    RelightReport { ran: true, source, reason: reason.into(), ms: t.elapsed().as_secs_f64() * 1e3 }
}

fn report_dict<'py>(py: Python<'py>, passes: &PassReport, relight: &RelightReport, ms: f64) -> PyResult<Bound<'py, PyAny>> {
    let d = to_py(py, passes)?;
    d.set_item("relight", to_py(py, relight)?)?;
    d.set_item("composite_ms", ms)?;
    Ok(d)
}
