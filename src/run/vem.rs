//! The captured-VEM mode's frame loop: HDR environment frames → directional lights (the
//! decomposer, Havran 2005 §3–4), and with a scene, its virtual objects lit and shadowed by those
//! lights over the scene's footage (the VEM renderer, Havran §4–5).
//!
//! [`VemStage`] is the lighting stage: the capture's frames resampled into the polar map and
//! decomposed. [`VemScene`] is the renderer's side: the background of each frame (the scene's
//! footage frame, or the VEM seen through the camera) and the GPU render, tone mapped, written
//! as PNG. [`run_vem`] drives both over a sequence, one JSON line per frame.
//!
//! Objects with a motion follow it on the frame clock (the footage's frame times,
//! [`super::vem_motion`]): each frame's line names the objects that moved (`render.motion`), and
//! the renderer re-uploads their vertex buffer and bounds. A scene where nothing moves renders
//! and reports exactly as before. With `--object-light cuts` ([`super::vem_cuts`]) every frame's
//! polar map lights the objects through the visibility cuts (per vertex, and the receivers'
//! contact shadows) instead of the lights and shadow maps; each line then has `render.cuts`
//! (time, receivers evaluated) and `report.json` the median cut time.

use super::Observer;
use super::sink::Thumbs;
pub use super::vem_cuts::CutRecord;
use super::vem_cuts::{VemCuts, product_records};
use super::vem_motion::{MotionRecord, VemMotion};
use super::vem_summary::{ConfigOut, ProductTotal, RenderSummary, SkipCount};
use crate::gpu::{Gpu, GpuOptions};
use crate::io::frames::Frame;
use crate::io::image::{LinearImage, Rgb8};
use crate::render::frame::Skipped;
use crate::render::vem::{ObjectLight, VemLights, VemOutput, VemRenderConfig, VemRenderer, VemReport, environment_background, ground_radiance};
use crate::report::{JsonLines, median};
use crate::scene::Scene;
use crate::vem::capture::input::VemInput;
use crate::vem::capture::resample::ResampleStats;
use crate::vem::cluster::Cluster;
use crate::vem::polar::PolarMap;
use crate::vem::{Decomposer, FrameSummary, Light, Status, VemConfig};
use anyhow::{Context, Result};
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Width of a contact-sheet tile, pixels.
const SHEET_TILE_WIDTH: u32 = 240;
/// Tiles per contact-sheet row.
const SHEET_COLUMNS: u32 = 4;
/// Most thumbnails kept, halved (see [`Thumbs`]).
const SHEET_KEEP: usize = 8;

/// The VEM lighting stage: a capture sequence and its decomposer.
pub struct VemStage {
    /// The capture's frames.
    pub input: VemInput,
    /// The current frame's polar map.
    pub map: PolarMap,
    /// The decomposer (its temporal filter spans the frames given to it).
    pub dec: Decomposer,
}

/// A frame loaded and given to the decomposer, waiting for its lights.
#[derive(Clone, Debug)]
pub struct Loaded {
    /// Frame index in the capture.
    pub index: usize,
    /// Resampling counts.
    pub stats: ResampleStats,
    /// Decode and resample time, ms.
    pub decode_ms: f64,
    /// Time of the decomposer's call for this frame (its sampling, and the filtering of the
    /// frame given out then), ms.
    pub decompose_ms: f64,
}

/// What the stage did with one frame (a causal filter: the frame's summary is out at once).
#[derive(Clone, Debug)]
pub struct VemFrame {
    /// Frame index in the capture.
    pub index: usize,
    /// Resampling counts.
    pub stats: ResampleStats,
    /// The decomposer's summary.
    pub summary: FrameSummary,
    /// Decode and resample time, ms.
    pub decode_ms: f64,
    /// Decomposition time, ms.
    pub decompose_ms: f64,
}

impl VemStage {
    /// Opens the capture `frames` (with its lens file `calib`) for `cfg`'s polar map.
    pub fn open(frames: &Path, calib: Option<&Path>, cfg: VemConfig) -> Result<Self> {
        let input = VemInput::open(frames, calib, cfg.polar_width, cfg.polar_height).with_context(|| format!("opening the VEM sequence {}", frames.display()))?;
        let map = PolarMap::new(cfg.polar_width, cfg.polar_height);
        Ok(Self { input, map, dec: Decomposer::new(cfg)? })
    }

    /// Frames in the capture.
    pub fn len(&self) -> usize {
        self.input.len()
    }

    /// True for an empty capture.
    pub fn is_empty(&self) -> bool {
        self.input.is_empty()
    }

    /// Loads capture frame `i` and decomposes it ([`Decomposer::process`]: with the zero-phase
    /// filter this frame's lights are unfiltered; footage goes through [`VemStage::push`]).
    pub fn light(&mut self, i: usize) -> Result<VemFrame> {
        let t = std::time::Instant::now();
        let stats = self.input.load(i, &mut self.map)?;
        let decode_ms = t.elapsed().as_secs_f64() * 1e3;
        let t = std::time::Instant::now();
        let summary = self.dec.process(&self.map);
        let decompose_ms = t.elapsed().as_secs_f64() * 1e3;
        Ok(VemFrame { index: i, stats, summary, decode_ms, decompose_ms })
    }

    /// Loads capture frame `i` and gives it to the decomposer ([`Decomposer::push`]): its
    /// loading record, and the summary of the frame whose lights are out now, if any.
    pub fn push(&mut self, i: usize) -> Result<(Loaded, Option<FrameSummary>)> {
        let t = std::time::Instant::now();
        let stats = self.input.load(i, &mut self.map)?;
        let decode_ms = t.elapsed().as_secs_f64() * 1e3;
        let t = std::time::Instant::now();
        let summary = self.dec.push(&self.map);
        let decompose_ms = t.elapsed().as_secs_f64() * 1e3;
        Ok((Loaded { index: i, stats, decode_ms, decompose_ms }, summary))
    }

    /// Decomposes the current map again (after a change of the light count).
    pub fn redo(&mut self) -> FrameSummary {
        self.dec.process(&self.map)
    }

    /// The current frame's lights as the renderer takes them.
    pub fn lights(&self, status: Status) -> VemLights<'_> {
        VemLights::of(&self.dec, status)
    }
}

/// The VEM renderer over footage: a scene's virtual objects lit and shadowed by a
/// [`VemStage`]'s lights, composited over a background and tone mapped (the live window's VEM
/// compositing and `heliar vem --scene` both render through it).
pub struct VemOverlay {
    renderer: VemRenderer,
}

impl VemOverlay {
    /// The renderer of `scene`'s camera, proxy (the shadow catcher; a ground plane without one)
    /// and virtual objects on `gpu`.
    pub fn new(gpu: Arc<Gpu>, scene: &Scene, cfg: VemRenderConfig) -> Result<Self> {
        let objects: Vec<&crate::geometry::Mesh> = scene.virtual_objects.iter().map(|o| &o.mesh).collect();
        let proxy = (!scene.proxy.triangles.is_empty()).then_some(&scene.proxy);
        Ok(Self { renderer: VemRenderer::new(gpu, &scene.camera, proxy, &objects, cfg)? })
    }

    /// The renderer.
    pub fn renderer(&self) -> &VemRenderer {
        &self.renderer
    }

    /// Sets the visibility cuts' light for the next renders (`VemRenderer::set_cut_light`).
    pub fn set_cut_light(&mut self, vertices: &[Vec<[[f32; 4]; 2]>], ratio: &[f32]) {
        self.renderer.set_cut_light(vertices, ratio);
    }

    /// Moves the virtual objects to `objects` (every object, set-up order, world coordinates).
    pub fn move_objects(&mut self, objects: &[&crate::geometry::Mesh]) -> Result<()> {
        Ok(self.renderer.move_objects(objects)?)
    }

    /// Renders the stage's current lights (of `status`) over `background` (linear radiance in
    /// the camera's pixel grid); `dt_s` is the time since the previous frame.
    pub fn render(&mut self, stage: &VemStage, status: Status, background: &LinearImage, dt_s: f64) -> Result<VemOutput> {
        Ok(self.renderer.render(&stage.lights(status), background, dt_s)?)
    }
}

/// What the render adds to a frame's JSON line.
#[derive(Clone, Debug, Serialize)]
pub struct FrameRender {
    /// The PNG written.
    pub png: String,
    /// "footage" or "environment".
    pub background: &'static str,
    /// The frame's time and the objects that moved (only in scenes where some object moves).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub motion: Option<MotionRecord>,
    /// The visibility cuts' evaluation (only with `--object-light cuts`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cuts: Option<CutRecord>,
    /// Passes, lights, shadow maps, tone parameters, timings.
    #[serde(flatten)]
    pub report: VemReport,
}

/// The renderer's side of a VEM run over a scene: backgrounds, GPU render, PNG frames, the
/// contact sheet and the run's render summary.
pub struct VemScene {
    scene: Scene,
    overlay: VemOverlay,
    adapter: String,
    out_dir: PathBuf,
    dt_s: f64,
    sheet: Thumbs,
    reports: Vec<VemReport>,
    backgrounds: BTreeMap<&'static str, usize>,
    /// The moving objects (`None`: nothing moves, `super::vem_motion`).
    motion: Option<VemMotion>,
    /// The visibility cuts (`--object-light cuts`, `super::vem_cuts`).
    cuts: Option<VemCuts>,
    /// Time of the cuts' evaluation per frame, ms.
    cut_ms: Vec<f64>,
    /// Per object, its vertices' visibility products over the run (`--object-light cuts`).
    product_totals: BTreeMap<String, ProductTotal>,
}

impl VemScene {
    /// Loads the scene, opens the GPU and the renderer; frames go into `out_dir`; `rate_hz` is
    /// the capture rate (the tone mapper's smoothing).
    pub fn new(scene_dir: &Path, out_dir: &Path, cfg: VemRenderConfig, rate_hz: f64) -> Result<Self> {
        let scene = Scene::load(scene_dir).with_context(|| format!("loading scene {}", scene_dir.display()))?;
        Self::from_scene(scene, out_dir, cfg, rate_hz)
    }

    /// [`VemScene::new`] for a scene already loaded.
    pub fn from_scene(scene: Scene, out_dir: &Path, cfg: VemRenderConfig, rate_hz: f64) -> Result<Self> {
        check_footage_size(&scene)?;
        std::fs::create_dir_all(out_dir).with_context(|| format!("creating {}", out_dir.display()))?;
        let gpu = Arc::new(Gpu::new(GpuOptions { samples: 1 })?);
        let adapter = gpu.describe();
        let (object_light, ground_albedo) = (cfg.object_light, cfg.ground_albedo);
        let overlay = VemOverlay::new(gpu, &scene, cfg)?;
        let motion = VemMotion::for_scene(&scene, rate_hz);
        let cuts = match object_light {
            ObjectLight::Cuts => {
                let r = overlay.renderer();
                Some(VemCuts::load(&scene, r.canvas(), Some(r.receiver_mesh()), ground_albedo).map_err(anyhow::Error::msg).context("--object-light cuts")?)
            }
            ObjectLight::Lights => None,
        };
        Ok(Self {
            scene,
            overlay,
            adapter,
            out_dir: out_dir.to_owned(),
            dt_s: 1.0 / rate_hz,
            sheet: Thumbs::new(SHEET_KEEP, SHEET_TILE_WIDTH),
            reports: Vec::new(),
            backgrounds: BTreeMap::new(),
            motion,
            cuts,
            cut_ms: Vec::new(),
            product_totals: BTreeMap::new(),
        })
    }

    /// The GPU adapter.
    pub fn adapter(&self) -> &str {
        &self.adapter
    }

    /// The frame's background: the scene's footage frame `i` when its first sequence has one,
    /// else (past the footage's end) the VEM map seen through the camera (the ground below the
    /// horizon). A footage frame of another size than the camera's is an error naming the file
    /// and both sizes (its header is checked before the pixels are decoded): it is never
    /// rescaled nor silently replaced.
    fn background(&self, i: usize, stage: &VemStage, map: &PolarMap) -> Result<(LinearImage, &'static str)> {
        if let Some(seq) = self.scene.sequences.first()
            && let Some(path) = seq.files.get(i)
        {
            let k = &self.scene.camera.intrinsics;
            let frame = Frame::load_sized(path, k.width, k.height)
                .map_err(anyhow::Error::new)
                .with_context(|| format!("reading footage of sequence '{}' (the camera calibration {} is {}×{})", seq.name, self.scene.camera_path.display(), k.width, k.height))?;
            return Ok((seq.photometry.linearizer().linear_image(&frame), "footage"));
        }
        let ground = ground_radiance(&stage.dec.region_lists().1.lights, self.overlay.renderer().config().ground_albedo);
        Ok((environment_background(map, &self.scene.camera, ground), "environment"))
    }

    /// Renders frame `i` (its polar map `map`) with the stage's current lights and writes its PNG;
    /// moving objects are posed for the frame's time first (`super::vem_motion`).
    pub fn frame(&mut self, i: usize, stage: &VemStage, map: &PolarMap, status: Status) -> Result<FrameRender> {
        let motion = match &mut self.motion {
            Some(m) => {
                let (record, meshes) = m.advance(i);
                if let Some(meshes) = meshes {
                    self.overlay.move_objects(&meshes).with_context(|| format!("moving the objects at frame {i}"))?;
                }
                Some(record)
            }
            None => None,
        };
        let first = self.cut_ms.is_empty();
        let cuts = match &mut self.cuts {
            Some(c) => {
                let t = std::time::Instant::now();
                let poses = self.motion.as_ref().map(VemMotion::poses).unwrap_or_default();
                let f = c.evaluate(map, &poses).map_err(anyhow::Error::msg).with_context(|| format!("the visibility cuts at frame {i}"))?;
                self.overlay.set_cut_light(&f.vertices, &f.ratio);
                let cuts_ms = t.elapsed().as_secs_f64() * 1e3;
                self.cut_ms.push(cuts_ms);
                let products = product_records(&self.scene, &f, motion.as_ref().map_or(&[][..], |m| &m.moved[..]), first);
                for p in &products {
                    self.product_totals.entry(p.object.clone()).or_default().add(p.reused, p.walked, f.receiver_products.reused);
                }
                Some(CutRecord { cuts_ms, receivers: f.receivers_evaluated, receivers_reused_product: f.receiver_products.reused, products, products_kept_bytes: f.kept_bytes })
            }
            None => None,
        };
        let (bg, kind) = self.background(i, stage, map)?;
        let out = self.overlay.render(stage, status, &bg, self.dt_s)?;
        let (w, h) = (bg.width, bg.height);
        let rgb: Vec<u8> = out.srgb.chunks_exact(4).flat_map(|p| [p[0], p[1], p[2]]).collect();
        let png = self.out_dir.join(format!("frame_{i:04}.png"));
        crate::io::write_via_temp(&png, |tmp| {
            image::save_buffer(tmp, &rgb, w, h, image::ExtendedColorType::Rgb8).map_err(|source| crate::io::IoError::Png { path: png.clone(), source })
        })
        .with_context(|| format!("writing {}", png.display()))?;
        if self.sheet.wants(i) {
            self.sheet.push(i, &Rgb8 { width: w, height: h, data: rgb });
        }
        *self.backgrounds.entry(kind).or_default() += 1;
        self.reports.push(out.report.clone());
        Ok(FrameRender { png: png.display().to_string(), background: kind, motion, cuts, report: out.report })
    }

    /// Writes the contact sheet and `report.json`; returns the report's path.
    pub fn finish(self) -> Result<PathBuf> {
        let sheet_path = self.out_dir.join("contact_sheet.png");
        self.sheet.write(&sheet_path, SHEET_COLUMNS)?;
        let mut ran: BTreeMap<&'static str, usize> = BTreeMap::new();
        let mut skipped: BTreeMap<(&'static str, String), usize> = BTreeMap::new();
        for r in &self.reports {
            for p in &r.ran {
                *ran.entry(p).or_default() += 1;
            }
            for Skipped { pass, reason } in &r.skipped {
                *skipped.entry((pass, reason.clone())).or_default() += 1;
            }
        }
        let med = |f: fn(&VemReport) -> f64| median(&self.reports.iter().map(f).collect::<Vec<_>>());
        let median_ms = BTreeMap::from([
            ("prepare", med(|r| r.timings.prepare_ms)),
            ("upload", med(|r| r.timings.upload_ms)),
            ("gpu", med(|r| r.timings.gpu_ms)),
            ("readback", med(|r| r.timings.readback_ms)),
            ("tonemap", med(|r| r.timings.tonemap_ms)),
            ("total", med(|r| r.timings.total_ms)),
        ]);
        let cfg = self.overlay.renderer().config();
        let summary = RenderSummary {
            scene: self.scene.root.display().to_string(),
            adapter: self.adapter.clone(),
            frames: self.reports.len(),
            receivers: self.overlay.renderer().receivers_kind(),
            virtual_objects: self.scene.virtual_objects.len(),
            backgrounds: &self.backgrounds,
            median_lights: med(|r| r.lights as f64),
            median_glossy_lights: med(|r| r.glossy_lights as f64),
            median_shadow_maps: med(|r| r.shadow_maps as f64),
            config: ConfigOut { shadow_slots: cfg.shadow_slots, tile: cfg.tile, culling: cfg.culling, shadows: cfg.shadows },
            passes_run: ran,
            passes_skipped: skipped.into_iter().map(|((pass, reason), frames)| SkipCount { pass, reason, frames }).collect(),
            median_ms,
            mean_list_fraction: self.reports.iter().map(|r| r.list_fraction).sum::<f64>() / self.reports.len().max(1) as f64,
            contact_sheet: sheet_path.display().to_string(),
            moved_frames: self.motion.as_ref().map(VemMotion::moved_frames),
            object_light: self.cuts.as_ref().map(|_| "cuts"),
            median_cuts_ms: self.cuts.as_ref().map(|_| median(&self.cut_ms)),
            visibility_products: self.cuts.as_ref().map(|_| self.product_totals.clone()),
        };
        let path = self.out_dir.join("report.json");
        crate::io::write_atomic(&path, serde_json::to_string_pretty(&summary)?.as_bytes()).with_context(|| format!("writing {}", path.display()))?;
        Ok(path)
    }
}

/// A frame's JSON line.
#[derive(Serialize)]
struct Record<'a> {
    frame: usize,
    file: String,
    #[serde(flatten)]
    summary: FrameSummary,
    #[serde(flatten)]
    input: ResampleStats,
    delay_frames: usize,
    lights: &'a [Light],
    #[serde(skip_serializing_if = "Option::is_none")]
    clusters: Option<&'a [Cluster]>,
    region_list_fraction: f64,
    decode_ms: f64,
    decompose_ms: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    render: Option<FrameRender>,
}

/// What a VEM run measured, for the terminal summary and the plot.
#[derive(Clone, Debug, Default)]
pub struct VemRunStats {
    /// Frames per status.
    pub statuses: BTreeMap<Status, usize>,
    /// Decode + resample time per frame, ms.
    pub decode_ms: Vec<f64>,
    /// Decomposition time per frame, ms.
    pub decompose_ms: Vec<f64>,
    /// `(time s, power)` of every frame, raw and filtered.
    pub power: Vec<(f64, f64, f64)>,
}

/// Decomposes every frame of `stage` (rendering it with `scene` when given), one JSON line each
/// into `out`, in frame order. With the zero-phase filter a frame's line (and render) waits for
/// the frames its window needs; its lights describe it (`describes_frame`). `rate_hz` gives the
/// frame times of the plot; `clusters` adds the clustered lights to the lines.
pub fn run_vem(stage: &mut VemStage, mut scene: Option<&mut VemScene>, out: &mut JsonLines, rate_hz: f64, clusters: bool, obs: &mut dyn Observer) -> Result<VemRunStats> {
    let delay = stage.dec.delay_frames();
    let mut stats = VemRunStats::default();
    // Frames loaded whose lines are not written yet (with their maps when rendering).
    let mut waiting: std::collections::VecDeque<(Loaded, Option<PolarMap>)> = std::collections::VecDeque::new();
    obs.start("vem", Some(stage.len()), 0);
    for i in 0..stage.len() {
        let (loaded, summary) = stage.push(i)?;
        waiting.push_back((loaded, scene.is_some().then(|| stage.map.clone())));
        if let Some(summary) = summary {
            write_frame(stage, scene.as_deref_mut(), out, &mut waiting, summary, (delay, rate_hz, clusters), &mut stats)?;
            obs.advance();
        }
    }
    while let Some(summary) = stage.dec.flush() {
        write_frame(stage, scene.as_deref_mut(), out, &mut waiting, summary, (delay, rate_hz, clusters), &mut stats)?;
        obs.advance();
    }
    obs.finish();
    Ok(stats)
}

/// Renders (with `scene`) and writes the line of the frame `summary` belongs to, the oldest
/// waiting one.
fn write_frame(
    stage: &VemStage,
    scene: Option<&mut VemScene>,
    out: &mut JsonLines,
    waiting: &mut std::collections::VecDeque<(Loaded, Option<PolarMap>)>,
    summary: FrameSummary,
    (delay, rate_hz, clusters): (usize, f64, bool),
    stats: &mut VemRunStats,
) -> Result<()> {
    let (f, map) = waiting.pop_front().context("the decomposer gave out a frame that was not loaded")?;
    anyhow::ensure!(f.index as u64 == summary.frame, "the decomposer gave out frame {} for frame {}", summary.frame, f.index);
    let i = f.index;
    *stats.statuses.entry(summary.status).or_default() += 1;
    stats.power.push((i as f64 / rate_hz, summary.power, summary.filtered_power));
    stats.decode_ms.push(f.decode_ms);
    stats.decompose_ms.push(f.decompose_ms);
    let render = match (scene, &map) {
        (Some(s), Some(map)) => Some(s.frame(i, stage, map, summary.status)?),
        _ => None,
    };
    let (_, lists) = stage.dec.region_lists();
    out.write(&Record {
        frame: i,
        file: stage.input.files[i].display().to_string(),
        summary,
        input: f.stats,
        delay_frames: delay,
        lights: stage.dec.lights(),
        clusters: clusters.then(|| stage.dec.clusters()),
        region_list_fraction: lists.mean_fraction(),
        decode_ms: f.decode_ms,
        decompose_ms: f.decompose_ms,
        render,
    })?;
    Ok(())
}

/// Every footage frame of the scene's first sequence (the backgrounds) has the camera's size:
/// checked from the headers before anything is rendered or written, so a frame of another size
/// (a 1×1 thumbnail, footage of another camera) stops the run at once, naming the file and both
/// sizes, instead of being rescaled or replaced.
fn check_footage_size(scene: &Scene) -> Result<()> {
    let Some(seq) = scene.sequences.first() else { return Ok(()) };
    let k = &scene.camera.intrinsics;
    for path in &seq.files {
        let (w, h) = crate::io::checked_header_size(path)?;
        if (w, h) != (k.width, k.height) {
            let e = crate::io::IoError::Size { path: path.clone(), got_w: w, got_h: h, want_w: k.width, want_h: k.height };
            return Err(anyhow::Error::new(e).context(format!("footage of sequence '{}' (the camera calibration {} is {}×{})", seq.name, scene.camera_path.display(), k.width, k.height)));
        }
    }
    Ok(())
}
