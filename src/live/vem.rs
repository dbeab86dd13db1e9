//! The VEM panel of the live window (`--vem-input FRAMES --vem-calib calib/fisheye.toml`): a
//! captured video environment map sequence played at its capture rate through the lighting
//! stage of the VEM mode ([`VemStage`]: Havran et al. 2005), its lights drawn as dots on a polar
//! plot of the upper hemisphere, a slider for the light count that re-runs the decomposer on the
//! current map, and, when the panel has the scene's renderer ([`VemPanel::with_overlay`]), a
//! switch that lights and shadows the virtual objects with these lights over the feed through
//! the VEM renderer ([`VemOverlay`]): the same stage and renderer `heliar vem --scene` uses.
//! The overlay's objects are where their motions and the person's drags put them
//! ([`VemPanel::pose_objects`], issue 15 §1 "Live").

use crate::io::image::LinearImage;
use crate::render::vem::VemOutput;
use crate::run::vem::{VemOverlay, VemStage};
use crate::vem::{Light, Status, VemConfig};
use anyhow::{Context, Result};
use egui::{Color32, Pos2, Sense, Stroke, Vec2};
use glam::Mat4;
use std::path::Path;
use std::time::{Duration, Instant};

/// Largest light count the slider offers.
pub const MAX_LIGHTS: usize = 1024;

/// A VEM sequence being decomposed for the window.
pub struct VemPanel {
    stage: VemStage,
    status: Status,
    overlay: Option<VemOverlay>,
    /// The poses the overlay's objects stand in (`None` before the first
    /// [`VemPanel::pose_objects`]: as the scene places them).
    posed: Option<Vec<Option<Mat4>>>,
    /// The overlay's objects where they stand (empty before they first moved).
    meshes: Vec<crate::geometry::Mesh>,
    /// Light the virtual objects with the panel's lights (needs [`VemPanel::with_overlay`]).
    pub compose: bool,
    /// The slider's light count.
    pub light_count: usize,
    frame: Option<usize>,
    last: Option<Instant>,
    interval: Duration,
    decompose_ms: f64,
    error: Option<String>,
}

impl VemPanel {
    /// Opens the sequence (and its fisheye calibration) for `lights` lights, turned by `yaw_deg`
    /// about the up axis (its north looks toward that azimuth); prints the layout assumed.
    pub fn open(frames: &Path, calib: Option<&Path>, lights: usize, yaw_deg: f64) -> Result<Self> {
        // Live: the low-delay (minimum-phase) causal filter, about 1 frame instead of 4 at 21 Hz.
        let cfg = VemConfig { lights: lights.clamp(1, MAX_LIGHTS), temporal: crate::vem::fir::Temporal::MinimumPhase, ..VemConfig::default() };
        let interval = Duration::from_secs_f64(1.0 / cfg.rate_hz.max(1e-3));
        let light_count = cfg.lights;
        let mut stage = VemStage::open(frames, calib, cfg)?;
        stage.input.set_yaw_deg(yaw_deg).context("--vem-yaw")?;
        eprintln!("VEM layout: {}", stage.input.layout()?);
        Ok(Self { stage, status: Status::Dark, overlay: None, posed: None, meshes: Vec::new(), compose: false, light_count, frame: None, last: None, interval, decompose_ms: 0.0, error: None })
    }

    /// Gives the panel the scene's VEM renderer, so it can light the virtual objects; compositing
    /// starts switched on.
    pub fn with_overlay(mut self, overlay: VemOverlay) -> Self {
        self.overlay = Some(overlay);
        self.compose = true;
        self
    }

    /// True when the panel lights the virtual objects (it has the renderer, the switch is on and
    /// a frame has been decomposed).
    pub fn composes(&self) -> bool {
        self.compose && self.overlay.is_some() && self.frame.is_some()
    }

    /// Renders the virtual objects lit by the current lights over `background` (the feed,
    /// linear radiance); `None` when the panel does not compose.
    pub fn render_over(&mut self, background: &LinearImage, dt_s: f64) -> Option<Result<VemOutput>> {
        if !self.composes() {
            return None;
        }
        let overlay = self.overlay.as_mut()?;
        Some(overlay.render(&self.stage, self.status, background, dt_s))
    }

    /// Brings the overlay's objects to `poses` (`crate::run::motion::MovingObjects::poses_at`:
    /// their motions and the moves by hand), posing them with `meshes` only when a pose
    /// differs from where they stand; returns which objects moved (none without the overlay).
    /// The VEM renderer draws each light's shadow map every frame, so a moved object casts and
    /// receives its shadows at once; nothing else is kept of its old place.
    pub fn pose_objects(&mut self, poses: Vec<Option<Mat4>>, meshes: impl FnOnce(&[Option<Mat4>]) -> Vec<crate::geometry::Mesh>) -> Result<Vec<bool>> {
        let Some(overlay) = self.overlay.as_mut() else { return Ok(vec![false; poses.len()]) };
        let moved: Vec<bool> = match &self.posed {
            Some(was) => poses.iter().enumerate().map(|(k, p)| was.get(k) != Some(p)).collect(),
            // Where the scene placed them: an object already off its placement has moved.
            None => poses.iter().map(Option::is_some).collect(),
        };
        if moved.iter().any(|m| *m) {
            let meshes = meshes(&poses);
            overlay.move_objects(&meshes.iter().collect::<Vec<_>>()).context("moving the objects in the VEM overlay")?;
            self.meshes = meshes;
        }
        self.posed = Some(poses);
        Ok(moved)
    }

    /// Object `k` where the overlay last put it (`None` before the objects first moved here:
    /// where the outdoor compositor has them).
    pub fn object_mesh(&self, k: usize) -> Option<&crate::geometry::Mesh> {
        self.meshes.get(k)
    }

    /// Loads and decomposes the next frame (the sequence loops).
    pub fn advance(&mut self) -> Result<()> {
        let i = self.frame.map_or(0, |f| (f + 1) % self.stage.len().max(1));
        let f = self.stage.light(i).with_context(|| format!("VEM frame {i}"))?;
        self.frame = Some(i);
        self.status = f.summary.status;
        self.decompose_ms = f.decompose_ms;
        Ok(())
    }

    /// Changes the light count and re-runs the decomposer on the current map.
    pub fn set_light_count(&mut self, n: usize) -> Result<()> {
        let n = n.clamp(1, MAX_LIGHTS);
        self.stage.dec.set_lights(n)?;
        self.light_count = n;
        if self.frame.is_some() {
            let t = Instant::now();
            self.status = self.stage.redo().status;
            self.decompose_ms = t.elapsed().as_secs_f64() * 1e3;
        }
        Ok(())
    }

    /// The current lights.
    pub fn lights(&self) -> &[Light] {
        self.stage.dec.lights()
    }

    /// Advances when a capture interval has passed (the window calls it every repaint).
    pub fn tick(&mut self) {
        if self.last.is_none_or(|t| t.elapsed() >= self.interval) {
            self.last = Some(Instant::now());
            if let Err(e) = self.advance() {
                self.error = Some(format!("{e:#}"));
            }
        }
    }

    /// The panel: slider, numbers and the polar plot.
    pub fn ui(&mut self, ui: &mut egui::Ui) {
        ui.heading("VEM lights");
        let mut n = self.light_count;
        if ui.add(egui::Slider::new(&mut n, 1..=MAX_LIGHTS).logarithmic(true).text("lights")).changed()
            && let Err(e) = self.set_light_count(n)
        {
            self.error = Some(format!("{e:#}"));
        }
        ui.label(format!("{} lights, frame {} of {}, decomposed in {:.2} ms", self.lights().len(), self.frame.map_or(0, |f| f + 1), self.stage.len(), self.decompose_ms));
        if self.overlay.is_some() {
            ui.checkbox(&mut self.compose, "Light the virtual objects with these lights");
        }
        if let Some(e) = &self.error {
            ui.label(egui::RichText::new(format!("Error: {e}")).color(Color32::from_rgb(235, 80, 70)));
        }
        self.polar_ui(ui);
    }

    /// The lights seen from above: the centre is the zenith, the rim the horizon, −Z up.
    fn polar_ui(&self, ui: &mut egui::Ui) {
        let side = ui.available_width().clamp(120.0, 300.0);
        let (rect, _) = ui.allocate_exact_size(Vec2::splat(side), Sense::hover());
        let p = ui.painter_at(rect);
        let (c, r) = (rect.center(), side / 2.0 - 4.0);
        p.circle_filled(c, r, Color32::from_gray(20));
        for k in [1.0, 2.0 / 3.0, 1.0 / 3.0] {
            p.circle_stroke(c, r * k, Stroke::new(1.0, Color32::from_gray(70)));
        }
        let lum = |l: &Light| 0.2126 * l.rgb[0] + 0.7152 * l.rgb[1] + 0.0722 * l.rgb[2];
        let max = self.lights().iter().map(lum).fold(0.0f32, f32::max).max(1e-12);
        for l in self.lights() {
            let elevation = l.dir.y.clamp(-1.0, 1.0).asin();
            let rho = r * (1.0 - elevation / std::f32::consts::FRAC_PI_2).clamp(0.0, 1.0);
            let horiz = Vec2::new(l.dir.x, l.dir.z);
            let d = if horiz.length() > 1e-6 { horiz.normalized() } else { Vec2::ZERO };
            let pos = Pos2::new(c.x + d.x * rho, c.y + d.y * rho);
            let s = (lum(l) / max).sqrt();
            let v = (80.0 + 175.0 * s) as u8;
            p.circle_filled(pos, 1.5 + 3.5 * s, Color32::from_rgb(v, v, (v as f32 * 0.8) as u8));
        }
    }
}
