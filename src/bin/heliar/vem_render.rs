//! `heliar vem --scene SCENE … --output OUT_DIR`: the scene's virtual objects lit and shadowed by
//! every VEM frame's lights, over the scene's footage (or the VEM seen through the camera), tone
//! mapped; frames, JSON lines, a report and a contact sheet in `OUT_DIR`.

use anyhow::{Context, Result};
use heliar::io::frames::Frame;
use heliar::io::image::LinearImage;
use heliar::render::frame::Skipped;
use heliar::io::image::{Rgb8, write_contact_sheet};
use heliar::gpu::{Gpu, GpuOptions};
use heliar::report::median;
use heliar::scene::Scene;
use heliar::render::vem::{VemLights, VemRenderConfig, VemRenderer, VemReport, environment_background, ground_radiance};
use heliar::vem::polar::PolarMap;
use heliar::vem::{Decomposer, Status};
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Width of a contact-sheet tile, pixels.
const SHEET_TILE_WIDTH: u32 = 240;
/// Tiles per contact-sheet row.
const SHEET_COLUMNS: u32 = 4;
/// Most frames on the contact sheet (evenly spaced).
const SHEET_FRAMES: usize = 12;

/// The compositing half of a `heliar vem` run.
pub struct VemCompositing {
    scene: Scene,
    renderer: VemRenderer,
    adapter: String,
    out_dir: PathBuf,
    dt_s: f64,
    sheet: Vec<(usize, Rgb8)>,
    frames: usize,
    reports: Vec<VemReport>,
    backgrounds: BTreeMap<&'static str, usize>,
}

/// What the render adds to a frame's JSON line.
#[derive(Serialize)]
pub struct FrameRender {
    /// The PNG written.
    pub png: String,
    /// "footage" or "environment".
    pub background: &'static str,
    /// Passes, lights, shadow maps, tone parameters, timings.
    #[serde(flatten)]
    pub report: VemReport,
}

#[derive(Serialize)]
struct SkipCount {
    pass: &'static str,
    reason: String,
    frames: usize,
}

#[derive(Serialize)]
struct Summary<'a> {
    scene: String,
    adapter: String,
    frames: usize,
    receivers: &'static str,
    virtual_objects: usize,
    backgrounds: &'a BTreeMap<&'static str, usize>,
    /// Lights in H and L, and shadow maps, per frame (median over the run).
    median_lights: f64,
    median_glossy_lights: f64,
    median_shadow_maps: f64,
    config: ConfigOut,
    passes_run: BTreeMap<&'static str, usize>,
    passes_skipped: Vec<SkipCount>,
    median_ms: BTreeMap<&'static str, f64>,
    mean_list_fraction: f64,
    contact_sheet: String,
}

#[derive(Serialize)]
struct ConfigOut {
    shadow_slots: usize,
    tile: u32,
    culling: bool,
    shadows: bool,
}

impl VemCompositing {
    /// Loads the scene and opens the GPU.
    pub fn new(scene_dir: &Path, out_dir: &Path, cfg: VemRenderConfig, rate_hz: f64) -> Result<Self> {
        let scene = Scene::load(scene_dir).with_context(|| format!("loading scene {}", scene_dir.display()))?;
        std::fs::create_dir_all(out_dir).with_context(|| format!("creating {}", out_dir.display()))?;
        let gpu = Arc::new(Gpu::new(GpuOptions { samples: 1 })?);
        let adapter = gpu.describe();
        eprintln!("GPU: {adapter}");
        let objects: Vec<&heliar::geometry::Mesh> = scene.virtual_objects.iter().map(|o| &o.mesh).collect();
        let proxy = (!scene.proxy.triangles.is_empty()).then_some(&scene.proxy);
        let renderer = VemRenderer::new(gpu, &scene.camera, proxy, &objects, cfg)?;
        Ok(Self {
            scene,
            renderer,
            adapter,
            out_dir: out_dir.to_owned(),
            dt_s: 1.0 / rate_hz,
            sheet: Vec::new(),
            frames: 0,
            reports: Vec::new(),
            backgrounds: BTreeMap::new(),
        })
    }

    /// The frame's background: the scene's footage frame `i` when its first sequence has one,
    /// else the VEM map seen through the camera (the ground below the horizon).
    fn background(&self, i: usize, map: &PolarMap, dec: &Decomposer) -> Result<(LinearImage, &'static str)> {
        if let Some(seq) = self.scene.sequences.first()
            && let Some(path) = seq.files.get(i)
        {
            let frame = Frame::load(path).with_context(|| format!("reading footage {}", path.display()))?;
            let want = (self.scene.camera.intrinsics.width, self.scene.camera.intrinsics.height);
            if (frame.width, frame.height) == want {
                return Ok((seq.photometry.linearizer().linear_image(&frame), "footage"));
            }
            eprintln!("note: {} is {}×{}, not the camera's {}×{}: using the environment", path.display(), frame.width, frame.height, want.0, want.1);
        }
        let ground = ground_radiance(&dec.region_lists().1.lights, self.renderer.config().ground_albedo);
        Ok((environment_background(map, &self.scene.camera, ground), "environment"))
    }

    /// Renders frame `i` and writes its PNG.
    pub fn frame(&mut self, i: usize, total: usize, map: &PolarMap, dec: &Decomposer, status: Status) -> Result<FrameRender> {
        let (bg, kind) = self.background(i, map, dec)?;
        let out = self.renderer.render(&VemLights::of(dec, status), &bg, self.dt_s)?;
        let (w, h) = (bg.width, bg.height);
        let rgb: Vec<u8> = out.srgb.chunks_exact(4).flat_map(|p| [p[0], p[1], p[2]]).collect();
        let png = self.out_dir.join(format!("frame_{i:04}.png"));
        image::save_buffer(&png, &rgb, w, h, image::ExtendedColorType::Rgb8).with_context(|| format!("writing {}", png.display()))?;
        let stride = total.div_ceil(SHEET_FRAMES).max(1);
        if i.is_multiple_of(stride) {
            self.sheet.push((i, Rgb8 { width: w, height: h, data: rgb }.shrink_to(SHEET_TILE_WIDTH)));
        }
        self.frames += 1;
        *self.backgrounds.entry(kind).or_default() += 1;
        self.reports.push(out.report.clone());
        Ok(FrameRender { png: png.display().to_string(), background: kind, report: out.report })
    }

    /// Writes the contact sheet and `report.json`; returns the report's path.
    pub fn finish(self) -> Result<PathBuf> {
        let sheet_path = self.out_dir.join("contact_sheet.png");
        let tiles: Vec<Rgb8> = self.sheet.into_iter().map(|(_, t)| t).collect();
        write_contact_sheet(&sheet_path, &tiles, SHEET_COLUMNS, 4)?;
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
        let cfg = self.renderer.config();
        let summary = Summary {
            scene: self.scene.root.display().to_string(),
            adapter: self.adapter.clone(),
            frames: self.frames,
            receivers: self.renderer.receivers_kind(),
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
        };
        let path = self.out_dir.join("report.json");
        std::fs::write(&path, serde_json::to_string_pretty(&summary)?).with_context(|| format!("writing {}", path.display()))?;
        Ok(path)
    }
}
