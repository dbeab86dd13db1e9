//! `heliar.Scene`: a loaded scene folder, and the factories of its estimator and compositor.

use crate::compositor::{Compositor, CompositorSettings};
use crate::estimator::Estimator;
use crate::{parse_time, py_err, sun_dict};
use anyhow::Context;
use heliar::geometry::raycast::RayScene;
use heliar::io::frames::Photometry;
use heliar::scene::LoadOptions;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;
use std::sync::Arc;

/// A scene folder (`scene.toml`, camera, proxy, virtual objects, sequences), loaded and checked
/// as `heliar` loads it. Immutable; share it freely between threads.
#[pyclass(frozen, module = "heliar._heliar")]
pub struct Scene {
    pub(crate) scene: Arc<heliar::scene::Scene>,
    pub(crate) ray: Arc<RayScene>,
}

impl Scene {
    /// The photometric calibration of `sequence` (its exposure), else the camera's; `exposure`
    /// overrides it.
    pub(crate) fn photometry(&self, sequence: Option<&str>, exposure: Option<f32>) -> anyhow::Result<Photometry> {
        let mut p = match sequence {
            Some(name) => heliar::run::source::pick_sequence(&self.scene, Some(name)).context("sequence")?.photometry.clone(),
            None => self.scene.photometry.clone(),
        };
        if let Some(e) = exposure {
            if !(e.is_finite() && e > 0.0) {
                anyhow::bail!("exposure {e}: must be positive");
            }
            p.exposure = e;
        }
        Ok(p)
    }

    fn sequence(&self, name: Option<&str>) -> PyResult<&heliar::scene::Sequence> {
        heliar::run::source::pick_sequence(&self.scene, name).map_err(py_err)
    }
}

#[pymethods]
impl Scene {
    /// Loads and checks the scene folder `path` (the folder holding `scene.toml`).
    /// `allow_outside_scene` lets the manifest name files outside the folder (as
    /// `heliar --allow-outside-scene`). Raises `HeliarError` with the command line's message.
    #[staticmethod]
    #[pyo3(signature = (path, allow_outside_scene=false))]
    fn load(py: Python<'_>, path: PathBuf, allow_outside_scene: bool) -> PyResult<Self> {
        let (scene, ray) = py
            .detach(|| -> anyhow::Result<_> {
                let scene = heliar::scene::Scene::load_with(&path, &LoadOptions { allow_outside_scene })
                    .with_context(|| format!("loading scene {}", path.display()))?;
                let mut scene = scene;
                let ray = Arc::new(RayScene::new(scene.proxy.clone()));
                // `terrain_albedo = "map"` (the default): measured (or read from its cache) once
                // here, as the command line does, so every stage sees the same terrain.
                heliar::envmap::bake::terrain::resolve_scene(&mut scene, &ray)
                    .with_context(|| format!("measuring the terrain albedo on the environment map of {}", path.display()))?;
                Ok((scene, ray))
            })
            .map_err(py_err)?;
        Ok(Self { scene: Arc::new(scene), ray })
    }

    /// The scene folder.
    #[getter]
    fn root(&self) -> PathBuf {
        self.scene.root.clone()
    }

    /// The manifest's `name`.
    #[getter]
    fn name(&self) -> String {
        self.scene.manifest.name.clone()
    }

    /// The camera's image width in pixels (frames must have it).
    #[getter]
    fn width(&self) -> u32 {
        self.scene.camera.intrinsics.width
    }

    /// The camera's image height in pixels.
    #[getter]
    fn height(&self) -> u32 {
        self.scene.camera.intrinsics.height
    }

    /// Names of the scene's sequences, in the manifest's order.
    #[getter]
    fn sequences(&self) -> Vec<String> {
        self.scene.sequences.iter().map(|s| s.name.clone()).collect()
    }

    /// The frame files of `sequence` (default: the first), in order.
    #[pyo3(signature = (sequence=None))]
    fn frame_files(&self, sequence: Option<&str>) -> PyResult<Vec<PathBuf>> {
        Ok(self.sequence(sequence)?.files.clone())
    }

    /// The capture times (RFC 3339) of the frames of `sequence` (default: the first).
    #[pyo3(signature = (sequence=None))]
    fn frame_times(&self, sequence: Option<&str>) -> PyResult<Vec<String>> {
        Ok(self.sequence(sequence)?.times.iter().map(|t| t.to_rfc3339()).collect())
    }

    /// Solar position at the scene's place at `time`, as `heliar sun --scene` gives it (with
    /// `dir_world`, the unit direction toward the sun in the scene frame).
    fn sun<'py>(&self, py: Python<'py>, time: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyDict>> {
        let t = parse_time(time)?;
        let o = self.scene.observer;
        let p = heliar::sun::sun_position(&o, &t).map_err(|e| py_err(e.into()))?;
        let d = sun_dict(py, &t, &o, &p)?;
        d.set_item("dir_world", self.scene.geo.sun_dir_in_world(&p).to_array())?;
        Ok(d)
    }

    /// Bakes the environment maps into `SCENE/baked/` (as `heliar bake`), or returns at once
    /// when the cache is up to date. Returns True when the cache was used.
    #[pyo3(signature = (force=false))]
    fn bake(&self, py: Python<'_>, force: bool) -> PyResult<bool> {
        let (scene, ray) = (self.scene.clone(), self.ray.clone());
        py.detach(move || heliar::envmap::bake::bake_cached(&scene, ray, force, &|_: &str, _: u64, _: u64| {}))
            .map(|(_, cached)| cached)
            .map_err(|e| py_err(anyhow::Error::new(e).context(format!("baking {}", self.scene.root.display()))))
    }

    /// The estimator of this scene (Jensen §3.1): pixel map, sample pool and weighted-ambient
    /// factors are set up now (about 0.1–0.3 s). Frames are linearised with `sequence`'s
    /// calibration (default: the camera's; `exposure` overrides the exposure). `samples`
    /// overrides `[estimator] samples`; `sun_bounce=False` leaves the bounce term out.
    #[pyo3(signature = (sequence=None, samples=None, sun_bounce=true, exposure=None))]
    fn estimator(&self, py: Python<'_>, sequence: Option<&str>, samples: Option<usize>, sun_bounce: bool, exposure: Option<f32>) -> PyResult<Estimator> {
        let photometry = self.photometry(sequence, exposure).map_err(py_err)?;
        let mut scene = (*self.scene).clone();
        if let Some(n) = samples {
            scene.estimator.samples = n;
            scene.estimator.pool_size = scene.estimator.pool_size.max(n);
            scene.estimator.validate().map_err(|(field, msg)| {
                let option = if field == "samples" { "samples" } else { field };
                pyo3::exceptions::PyValueError::new_err(format!("{option} {n}: {msg} (the rule of scene.toml's estimator.{field})"))
            })?;
        }
        scene.estimator.sun_bounce = scene.estimator.sun_bounce && sun_bounce;
        let ray = self.ray.clone();
        py.detach(move || Estimator::build(&scene, ray, photometry)).map_err(py_err)
    }

    /// The GPU compositor of this scene (wgpu; lavapipe or llvmpipe without a GPU), with the
    /// settings of `heliar augment`: `samples` (MSAA 1 or 4), `darkening` ("differential",
    /// "normal", "constant"), `ambient` ("auto", "volume", "uniform"; the irradiance volume
    /// bakes first when its cache is stale), `transfer_paths` (paths per pixel of the objects'
    /// ambient transfer, 0 to turn it off), `volumes` ("cpu", "compute"), `sun_bounce`.
    /// Frames are linearised and written back with `sequence`'s calibration (default: the
    /// camera's; `exposure` overrides the exposure).
    #[pyo3(signature = (sequence=None, samples=4, darkening="differential", ambient="auto", transfer_paths=heliar::render::object_transfer::TRANSFER_PATHS, volumes="cpu", sun_bounce=true, exposure=None))]
    #[allow(clippy::too_many_arguments)]
    fn compositor(
        &self,
        py: Python<'_>,
        sequence: Option<&str>,
        samples: u32,
        darkening: &str,
        ambient: &str,
        transfer_paths: u32,
        volumes: &str,
        sun_bounce: bool,
        exposure: Option<f32>,
    ) -> PyResult<Compositor> {
        let photometry = self.photometry(sequence, exposure).map_err(py_err)?;
        let settings = CompositorSettings::parse(samples, darkening, ambient, transfer_paths, volumes, sun_bounce)?;
        let start = self.scene.sequence(sequence).and_then(|q| q.times.first().copied());
        let (scene, ray) = (self.scene.clone(), self.ray.clone());
        py.detach(move || Compositor::build(&scene, ray, settings, photometry, start)).map_err(py_err)
    }

    fn __repr__(&self) -> String {
        format!("Scene({:?}, {}×{}, sequences={:?})", self.scene.root.display().to_string(), self.width(), self.height(), self.sequences())
    }
}
