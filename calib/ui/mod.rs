//! `heliar-calib ui`: the calibration app. Four tabs over the same steps as the subcommands
//! (the shared code is in `ops/`):
//!
//! - **Intrinsics**: chessboard views from a folder or a video → detected corners per view →
//!   pinhole or fisheye calibration with RMS error and coverage → camera file.
//! - **Pose**: click image points and pick their proxy points (3D view, vertex list or typed
//!   coordinates) → `solvePnP` with per-pair errors and the proxy outline drawn over the frame →
//!   the scene's camera file.
//! - **Mark**: click the frame or the environment map → ray cast → toggle the proxy node as a
//!   diffuse estimation surface (`proxy.diffuse_nodes`), marked nodes tinted.
//! - **HDR**: bracketed exposures and their times, optional lens-reflection and clean rectangles
//!   drawn with the mouse → Debevec merge → tone-mapped preview → EXR and response CSV.
//!
//! Every edit of a scene goes through `edit.rs` (validated on a copy, then swapped in), so the
//! app never leaves a half-valid scene. Each tab keeps its state in a plain struct whose actions
//! (`solve`, `save`, `toggle_at`, …) are callable without a window, which is how the tests drive
//! them besides clicking.

mod hdr;
mod intrinsics;
mod job;
mod mark;
mod picker;
mod pose;
mod scene;
#[cfg(test)]
mod tests;
mod view;

use anyhow::{Result, anyhow};
use egui::{Color32, RichText};
pub use scene::SceneState;
use std::path::{Path, PathBuf};

/// Which step the window shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Tab {
    /// Chessboard intrinsics.
    Intrinsics,
    /// Camera pose.
    Pose,
    /// Diffuse surfaces.
    Mark,
    /// HDR merge.
    Hdr,
}

/// How serious a message is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Level {
    /// Something was done.
    Info,
    /// Done, but doubtful.
    Warn,
    /// Not done; the message says why.
    Error,
}

/// The messages of a tab's last action.
#[derive(Clone, Debug, Default)]
pub struct Messages(pub Vec<(Level, String)>);

impl Messages {
    /// Starts a new action's messages.
    pub fn clear(&mut self) {
        self.0.clear();
    }

    /// Adds a message.
    pub fn push(&mut self, level: Level, text: impl Into<String>) {
        self.0.push((level, text.into()));
    }

    /// Replaces the messages by the outcome of an action.
    pub fn set_result(&mut self, r: Result<String>) {
        self.clear();
        match r {
            Ok(s) => self.push(Level::Info, s),
            Err(e) => self.push(Level::Error, format!("{e:#}")),
        }
    }

    /// Shows the messages in colour.
    pub fn ui(&self, ui: &mut egui::Ui) {
        for (level, text) in &self.0 {
            let (colour, prefix) = match level {
                Level::Info => (ui.visuals().text_color(), ""),
                Level::Warn => (Color32::from_rgb(230, 170, 40), "Warning: "),
                Level::Error => (Color32::from_rgb(235, 80, 70), "Error: "),
            };
            ui.label(RichText::new(format!("{prefix}{text}")).color(colour));
        }
    }
}

/// The app.
pub struct CalibApp {
    /// The open scene.
    pub scene: Option<SceneState>,
    /// The scene path field.
    pub scene_path: String,
    /// Why the scene could not be opened.
    pub scene_error: Option<String>,
    /// The tab shown.
    pub tab: Tab,
    /// Tab states.
    pub intrinsics: intrinsics::IntrinsicsTab,
    /// Pose tab.
    pub pose: pose::PoseTab,
    /// Mark tab.
    pub mark: mark::MarkTab,
    /// HDR tab.
    pub hdr: hdr::HdrTab,
    new_scene: Option<NewSceneForm>,
}

impl CalibApp {
    /// The app with saves that may overwrite inputs and files of a scene (`ui --force`); by
    /// default every Save and Export refuses to, as the subcommands do without `--force`.
    pub fn with_force(mut self, force: bool) -> Self {
        (self.intrinsics.force, self.pose.force, self.hdr.force) = (force, force, force);
        self
    }

    /// The app, with `scene` opened when given.
    pub fn new(scene: Option<&Path>) -> Self {
        let mut app = Self {
            scene: None,
            scene_path: scene.map(|p| p.display().to_string()).unwrap_or_default(),
            scene_error: None,
            tab: if scene.is_some() { Tab::Pose } else { Tab::Intrinsics },
            intrinsics: Default::default(),
            pose: Default::default(),
            mark: Default::default(),
            hdr: Default::default(),
            new_scene: None,
        };
        if let Some(dir) = scene {
            app.open_scene(dir);
        }
        app
    }

    /// Opens (or reopens) a scene folder; an error is shown in the top bar.
    pub fn open_scene(&mut self, dir: &Path) {
        match SceneState::load(dir) {
            Ok(s) => {
                self.scene_path = dir.display().to_string();
                self.intrinsics.scene_opened(&s);
                self.pose.scene_opened();
                self.scene = Some(s);
                self.scene_error = None;
            }
            Err(e) => self.scene_error = Some(format!("{e:#}")),
        }
    }

    /// Blocks until the tabs' background jobs have ended and takes their results (for tests).
    #[cfg(test)]
    pub fn wait_for_jobs(&mut self) {
        self.intrinsics.wait_for_job();
        self.hdr.wait_for_job();
    }

    /// Files dropped on the window: a scene folder opens; otherwise they fill the current tab's
    /// inputs (a chessboard folder or video, pairs CSV or frame, exposures).
    pub fn files_dropped(&mut self, paths: &[PathBuf]) {
        if let Some(scene) = paths.iter().find(|p| p.join(heliar::scene::MANIFEST_FILE).is_file()) {
            self.open_scene(&scene.clone());
            return;
        }
        let ext = |p: &Path| p.extension().map(|e| e.to_string_lossy().to_ascii_lowercase()).unwrap_or_default();
        let is_image = |p: &Path| crate::ops::intrinsics::IMAGE_EXTENSIONS.contains(&ext(p).as_str()) || ext(p) == "exr";
        for p in paths {
            let text = p.display().to_string();
            match self.tab {
                Tab::Intrinsics if p.is_dir() => (self.intrinsics.folder, self.intrinsics.from_video) = (text, false),
                Tab::Intrinsics if is_image(p) => {
                    (self.intrinsics.folder, self.intrinsics.from_video) = (p.parent().map(|d| d.display().to_string()).unwrap_or_default(), false);
                }
                Tab::Intrinsics => (self.intrinsics.video, self.intrinsics.from_video) = (text, true),
                Tab::Pose if ext(p) == "csv" => {
                    self.pose.pairs_file = text;
                    let r = self.pose.import(p);
                    self.pose.messages.set_result(r);
                }
                Tab::Pose => self.pose.frame.other = text,
                Tab::Mark => self.mark.frame.other = text,
                Tab::Hdr => self.hdr.add_file(&text),
            }
        }
    }

    /// The whole window.
    pub fn ui(&mut self, ui: &mut egui::Ui) {
        let dropped: Vec<PathBuf> = ui.input(|i| i.raw.dropped_files.iter().map(|f| f.path().to_owned()).collect());
        if !dropped.is_empty() {
            self.files_dropped(&dropped);
        }
        egui::Panel::top("scene_bar").show(ui, |ui| self.top_bar_ui(ui));
        egui::CentralPanel::default().show(ui, |ui| match self.tab {
            Tab::Intrinsics => self.intrinsics.ui(ui, self.scene.as_mut()),
            Tab::Hdr => self.hdr.ui(ui),
            Tab::Pose | Tab::Mark => match self.scene.as_mut() {
                Some(state) if self.tab == Tab::Pose => self.pose.ui(ui, state),
                Some(state) => self.mark.ui(ui, state),
                None => {
                    ui.add_space(20.0);
                    ui.label("Open a scene folder above (or create one with “New scene…”): the pose and the diffuse surfaces are stored in a scene.");
                }
            },
        });
    }

    fn top_bar_ui(&mut self, ui: &mut egui::Ui) {
        ui.add_space(4.0);
        ui.horizontal(|ui| {
            ui.label("Scene folder:");
            let r = ui.add(egui::TextEdit::singleline(&mut self.scene_path).hint_text("scenes/my-place").desired_width(320.0));
            let enter = r.lost_focus() && ui.input(|i| i.key_pressed(egui::Key::Enter));
            if ui.button(if self.scene.is_some() { "Reload" } else { "Open" }).clicked() || enter {
                if self.scene_path.trim().is_empty() {
                    self.scene_error = Some("give the scene folder (the one holding scene.toml)".into());
                } else {
                    let dir = PathBuf::from(self.scene_path.trim());
                    self.open_scene(&dir);
                }
            }
            if ui.selectable_label(self.new_scene.is_some(), "New scene…").clicked() {
                self.new_scene = if self.new_scene.is_some() { None } else { Some(NewSceneForm::default()) };
            }
            match (&self.scene_error, &self.scene) {
                (Some(e), _) => {
                    ui.label(RichText::new(format!("Error: {e}")).color(Color32::from_rgb(235, 80, 70)));
                }
                (None, Some(s)) => {
                    ui.label(s.summary());
                }
                (None, None) => {}
            }
        });
        if let Some(form) = &mut self.new_scene
            && let Some(dir) = form.ui(ui)
        {
            self.new_scene = None;
            self.open_scene(&dir);
        }
        ui.horizontal(|ui| {
            for (tab, name) in [(Tab::Intrinsics, "1 Intrinsics"), (Tab::Pose, "2 Pose"), (Tab::Mark, "3 Mark surfaces"), (Tab::Hdr, "4 HDR map")] {
                ui.selectable_value(&mut self.tab, tab, RichText::new(name).strong());
            }
        });
        ui.add_space(2.0);
    }
}

impl eframe::App for CalibApp {
    fn ui(&mut self, ui: &mut egui::Ui, _frame: &mut eframe::Frame) {
        CalibApp::ui(self, ui);
    }
}

/// The form that creates a scene folder (the `new` subcommand).
#[derive(Default)]
struct NewSceneForm {
    folder: String,
    proxy: String,
    camera: String,
    lat: String,
    lon: String,
    elevation: String,
    north: String,
    diffuse: String,
    messages: Messages,
}

impl NewSceneForm {
    /// The form; returns the folder once a scene was created.
    fn ui(&mut self, ui: &mut egui::Ui) -> Option<PathBuf> {
        let mut created = None;
        ui.group(|ui| {
            egui::Grid::new("new_scene").num_columns(4).show(ui, |ui| {
                for (label, value, hint) in [
                    ("New folder", &mut self.folder, "scenes/my-place"),
                    ("Proxy glTF", &mut self.proxy, "proxy.glb"),
                    ("Camera file", &mut self.camera, "camera.toml (from the Intrinsics tab)"),
                    ("Latitude °N", &mut self.lat, "57.0488"),
                    ("Longitude °E", &mut self.lon, "9.9217"),
                    ("Elevation m", &mut self.elevation, "0"),
                    ("North x,y,z", &mut self.north, "0,0,-1"),
                    ("Diffuse nodes", &mut self.diffuse, "ground, facade (comma-separated)"),
                ] {
                    ui.label(label);
                    ui.add(egui::TextEdit::singleline(value).hint_text(hint).desired_width(220.0));
                    if label.starts_with("Camera") || label.starts_with("Elevation") || label.starts_with("Proxy") || label.starts_with("North") {
                        ui.end_row();
                    }
                }
                ui.end_row();
            });
            if ui.button("Create scene").clicked() {
                match self.create() {
                    Ok(dir) => created = Some(dir),
                    Err(e) => self.messages.set_result(Err(e)),
                }
            }
            self.messages.ui(ui);
        });
        created
    }

    fn create(&self) -> Result<PathBuf> {
        let num = |s: &str, what: &str, default: Option<f64>| -> Result<f64> {
            match (s.trim(), default) {
                ("", Some(d)) => Ok(d),
                (t, _) => t.parse::<f64>().ok().filter(|v| v.is_finite()).ok_or_else(|| anyhow!("{what} '{t}': not a number")),
            }
        };
        let path = |s: &str, what: &str| -> Result<PathBuf> {
            let t = s.trim();
            if t.is_empty() { Err(anyhow!("{what}: give a path")) } else { Ok(PathBuf::from(t)) }
        };
        let out = path(&self.folder, "new folder")?;
        let n = crate::ops::scene::NewScene {
            proxy: path(&self.proxy, "proxy glTF")?,
            camera: path(&self.camera, "camera file")?,
            latitude_deg: num(&self.lat, "latitude", None)?,
            longitude_deg: num(&self.lon, "longitude", None)?,
            elevation_m: num(&self.elevation, "elevation", Some(0.0))?,
            north: if self.north.trim().is_empty() { [0.0, 0.0, -1.0] } else { crate::ops::scene::parse_vec3(&self.north, "north")? },
            diffuse: self.diffuse.split(',').map(|s| s.trim().to_owned()).filter(|s| !s.is_empty()).collect(),
        };
        crate::ops::scene::create(&out, &n)?;
        Ok(out)
    }
}

/// Opens the window (blocks until it is closed); `force`: saves may overwrite inputs and files
/// of a scene.
pub fn run(scene: Option<PathBuf>, force: bool) -> Result<()> {
    let options = eframe::NativeOptions {
        viewport: egui::ViewportBuilder::default().with_inner_size([1400.0, 860.0]).with_title("heliar-calib"),
        renderer: eframe::Renderer::Wgpu,
        ..Default::default()
    };
    eframe::run_native("heliar-calib", options, Box::new(move |_cc| Ok(Box::new(CalibApp::new(scene.as_deref()).with_force(force)))))
        .map_err(|e| anyhow!("cannot open the calibration window: {e} (the app needs a display; the subcommands intrinsics, pose, mark, hdr and new work without one)"))
}
