//! The Intrinsics tab: chessboard views → detected corners → calibration → camera file.

use super::job::{Job, Progress};
use super::view::{ImageView, Picture, thumbnail};
use super::{Level, Messages, SceneState};
use crate::ops::intrinsics::{self as ops, ViewSource};
use anyhow::{Context, Result, bail};
use egui::{Color32, Stroke};
use glam::DVec2;
use heliar::opencv_calib::chessboard::{Board, FisheyeCalibration, PinholeCalibration, calibrate_fisheye, calibrate_pinhole, detect_corners};
use opencv::core::{Point2f, Vector};
use std::path::{Path, PathBuf};

/// Views are kept at most this large (pixels per side) for display.
const PREVIEW_SIDE: u32 = 1024;

/// One chessboard view.
pub struct BoardView {
    /// File name or video frame.
    pub label: String,
    /// Size in pixels (0×0 when unreadable).
    pub size: (u32, u32),
    preview: Option<heliar::opencv_calib::Rgb8>,
    /// Detected inner corners (pixels), `None` when the board was not found.
    pub corners: Option<Vec<[f32; 2]>>,
    /// Why the view cannot be used (unreadable, wrong size).
    pub problem: Option<String>,
    /// Whether the calibration uses it.
    pub use_it: bool,
}

/// A calibration's result.
#[derive(Clone, Debug)]
pub enum Calibration {
    /// Pinhole + Brown–Conrady.
    Pinhole(PinholeCalibration),
    /// Kannala–Brandt fisheye.
    Fisheye(FisheyeCalibration),
}

/// A calibration with the image size it is for.
#[derive(Clone, Debug)]
pub struct CalibResult {
    /// The fitted model.
    pub model: Calibration,
    /// Image size.
    pub size: (u32, u32),
}

struct Detected {
    board: Board,
    size: Option<(u32, u32)>,
    stopped: bool,
}

enum Work {
    Detect(Job<(Vec<BoardView>, Detected)>),
    Calibrate(Job<CalibResult>),
}

/// The tab's state.
pub struct IntrinsicsTab {
    /// Read a video instead of a folder.
    pub from_video: bool,
    /// Folder of views.
    pub folder: String,
    /// Video file.
    pub video: String,
    /// Video frame step.
    pub every: u64,
    /// Inner corners, `COLSxROWS`.
    pub board: String,
    /// Square side, millimetres.
    pub square_mm: String,
    /// Fit the fisheye model.
    pub fisheye: bool,
    /// Free the k3 term.
    pub k3: bool,
    /// The views found by the last detection.
    pub views: Vec<BoardView>,
    /// The view shown.
    pub selected: usize,
    detected: Option<Detected>,
    /// The last calibration.
    pub result: Option<CalibResult>,
    /// Where Save writes.
    pub output: String,
    /// What the last action said.
    pub messages: Messages,
    /// Save even over an input or a file of a scene (`heliar-calib ui --force`).
    pub force: bool,
    work: Option<Work>,
    view: ImageView,
    picture: Option<(usize, Picture)>,
}

impl Default for IntrinsicsTab {
    fn default() -> Self {
        Self {
            from_video: false,
            folder: String::new(),
            video: String::new(),
            every: 10,
            board: "9x6".into(),
            square_mm: "25".into(),
            fisheye: false,
            k3: false,
            views: Vec::new(),
            selected: 0,
            detected: None,
            result: None,
            output: "camera.toml".into(),
            messages: Messages::default(),
            force: false,
            work: None,
            view: ImageView::default(),
            picture: None,
        }
    }
}

impl IntrinsicsTab {
    /// A scene was opened: save into its camera file by default.
    pub fn scene_opened(&mut self, s: &SceneState) {
        if self.output.trim().is_empty() || self.output == "camera.toml" {
            self.output = s.camera_file().display().to_string();
        }
    }

    fn board_from_fields(&self) -> Result<Board> {
        let mm: f64 = self.square_mm.trim().parse().with_context(|| format!("square size '{}': not a number of millimetres", self.square_mm.trim()))?;
        ops::parse_board(self.board.trim(), mm)
    }

    fn source(&self) -> Result<ViewSource> {
        if self.from_video {
            let v = self.video.trim();
            if v.is_empty() {
                bail!("give the chessboard video's path");
            }
            if self.every == 0 {
                bail!("the frame step must be at least 1");
            }
            Ok(ViewSource::Video { path: PathBuf::from(v), every: self.every })
        } else {
            let d = self.folder.trim();
            if d.is_empty() {
                bail!("give the folder of chessboard images");
            }
            Ok(ViewSource::Images(PathBuf::from(d)))
        }
    }

    /// Starts corner detection on the chosen views (checks the inputs first).
    pub fn start_detection(&mut self, ctx: Option<egui::Context>) {
        self.messages.clear();
        let started = (|| -> Result<()> {
            let board = self.board_from_fields()?;
            let source = self.source()?;
            self.work = Some(Work::Detect(Job::spawn("Detecting corners", ctx, move |p| detect_views(&source, board, p)).cancellable()));
            Ok(())
        })();
        if let Err(e) = started {
            self.messages.push(Level::Error, format!("{e:#}"));
        }
    }

    /// Starts the calibration on the views in use.
    pub fn start_calibration(&mut self, ctx: Option<egui::Context>) {
        self.messages.clear();
        let started = (|| -> Result<()> {
            let d = self.detected.as_ref().context("detect the corners first")?;
            if self.board_from_fields().ok() != Some(d.board) {
                bail!("the board settings changed since the detection; detect again");
            }
            let (w, h) = d.size.context("no readable views")?;
            let views: Vec<Vec<[f32; 2]>> = self.views.iter().filter(|v| v.use_it && v.problem.is_none()).filter_map(|v| v.corners.clone()).collect();
            if views.len() < heliar::opencv_calib::chessboard::MIN_VIEWS {
                bail!("{} views with the board in use; at least {} are needed (vary the board's tilt and position)", views.len(), heliar::opencv_calib::chessboard::MIN_VIEWS);
            }
            let (board, fisheye, k3) = (d.board, self.fisheye, self.k3);
            self.work = Some(Work::Calibrate(Job::spawn("Calibrating", ctx, move |_| calibrate(&views, board, (w, h), fisheye, k3))));
            Ok(())
        })();
        if let Err(e) = started {
            self.messages.push(Level::Error, format!("{e:#}"));
        }
    }

    /// Takes a finished job's result.
    fn poll(&mut self) {
        let done = match &mut self.work {
            Some(Work::Detect(j)) => j.poll().map(|r| r.map(|(views, d)| self.detection_done(views, d))),
            Some(Work::Calibrate(j)) => j.poll().map(|r| r.map(|c| self.calibration_done(c))),
            None => None,
        };
        self.finish(done);
    }

    /// Waits for the running job and takes its result.
    #[cfg(test)]
    pub fn wait_for_job(&mut self) {
        let done = match self.work.take() {
            Some(Work::Detect(j)) => Some(j.wait().map(|(views, d)| self.detection_done(views, d))),
            Some(Work::Calibrate(j)) => Some(j.wait().map(|c| self.calibration_done(c))),
            None => None,
        };
        self.finish(done);
    }

    fn finish(&mut self, done: Option<Result<()>>) {
        if let Some(r) = done {
            self.work = None;
            if let Err(e) = r {
                self.messages.push(Level::Error, format!("{e:#}"));
            }
        }
    }

    fn detection_done(&mut self, views: Vec<BoardView>, d: Detected) {
        let found = views.iter().filter(|v| v.corners.is_some()).count();
        self.messages.push(Level::Info, format!("board found in {found} of {} views", views.len()));
        if d.stopped {
            self.messages.push(Level::Warn, format!("detection stopped after {} views", views.len()));
        }
        if views.iter().any(|v| v.problem.is_some()) {
            self.messages.push(Level::Warn, format!("{} views cannot be used (see the list)", views.iter().filter(|v| v.problem.is_some()).count()));
        }
        self.selected = views.iter().position(|v| v.corners.is_some()).unwrap_or(0);
        self.views = views;
        self.detected = Some(d);
        self.result = None;
        self.picture = None;
    }

    fn calibration_done(&mut self, c: CalibResult) {
        match &c.model {
            Calibration::Pinhole(p) => {
                self.messages.push(Level::Info, format!("RMS reprojection error {:.3} px over {} views, coverage {:.0}%", p.rms_px, p.views, 100.0 * p.coverage));
                for w in ops::warnings(p) {
                    self.messages.push(Level::Warn, w);
                }
            }
            Calibration::Fisheye(f) => self.messages.push(Level::Info, format!("RMS reprojection error {:.3} px over {} views", f.rms_px, f.views)),
        }
        self.result = Some(c);
    }

    /// Writes the result: a pinhole model into a camera file (through the scene's validated edit
    /// when it is the open scene's camera file), a fisheye model as a JSON report.
    pub fn save(&mut self, scene: Option<&mut SceneState>) -> Result<String> {
        let c = self.result.as_ref().context("calibrate first")?;
        let out = PathBuf::from(self.output.trim());
        if out.as_os_str().is_empty() {
            bail!("give the camera file to write");
        }
        let (w, h) = c.size;
        let source = PathBuf::from(if self.from_video { self.video.trim() } else { self.folder.trim() });
        let inputs: Vec<&Path> = [source.as_path()].into_iter().filter(|p| !p.as_os_str().is_empty()).collect();
        match &c.model {
            Calibration::Fisheye(f) => {
                if !out.extension().is_some_and(|e| e == "json") {
                    bail!("a fisheye (Kannala–Brandt) calibration cannot go into a camera file (Brown–Conrady only); give a .json file for its report");
                }
                crate::edit::check_output(&out, &inputs, self.force)?;
                crate::edit::write_atomic(&out, serde_json::to_string_pretty(&ops::fisheye_json(w, h, f))?.as_bytes())?;
                Ok(format!("wrote {}", out.display()))
            }
            Calibration::Pinhole(p) => {
                let scene_camera = scene.as_ref().is_some_and(|s| same_file(&s.camera_file(), &out));
                if !scene_camera {
                    // Not the open scene's camera file: an output like `intrinsics -o`.
                    crate::edit::check_output(&out, &inputs, self.force)?;
                }
                let existing = ops::read_camera_file(&out)?;
                let text = ops::camera_toml_with_intrinsics(existing.as_deref(), &out, w, h, p)?;
                match scene.filter(|s| same_file(&s.camera_file(), &out)) {
                    Some(s) => {
                        let rel = PathBuf::from(&s.scene.manifest.camera.file);
                        let new = crate::edit::edit_scene(&s.dir, &[(rel, text.into_bytes())])?;
                        s.replace(new);
                        Ok(format!("updated the scene's camera file {} (RMS {:.3} px)", out.display(), p.rms_px))
                    }
                    None => {
                        crate::edit::write_atomic(&out, text.as_bytes())?;
                        Ok(format!("wrote {} (RMS {:.3} px over {} views)", out.display(), p.rms_px, p.views))
                    }
                }
            }
        }
    }

    /// The tab.
    pub fn ui(&mut self, ui: &mut egui::Ui, scene: Option<&mut SceneState>) {
        self.poll();
        let mut scene = scene;
        egui::Panel::left("intrinsics_controls").default_size(360.0).show(ui, |ui| {
            egui::ScrollArea::vertical().show(ui, |ui| self.controls_ui(ui, scene.as_deref_mut()));
        });
        egui::CentralPanel::default().show(ui, |ui| self.view_ui(ui));
    }

    fn controls_ui(&mut self, ui: &mut egui::Ui, scene: Option<&mut SceneState>) {
        let busy = self.work.is_some();
        ui.heading("Chessboard views");
        ui.horizontal(|ui| {
            ui.radio_value(&mut self.from_video, false, "Image folder");
            ui.radio_value(&mut self.from_video, true, "Video");
        });
        if self.from_video {
            ui.add(egui::TextEdit::singleline(&mut self.video).hint_text("board.mp4").desired_width(300.0));
            ui.horizontal(|ui| {
                ui.label("Use every");
                ui.add(egui::DragValue::new(&mut self.every).range(1..=1000)).on_hover_text("frame step");
                ui.label("th frame");
            });
        } else {
            ui.add(egui::TextEdit::singleline(&mut self.folder).hint_text("folder of PNG/JPEG views").desired_width(300.0));
        }
        egui::Grid::new("board").num_columns(2).show(ui, |ui| {
            ui.label("Inner corners");
            ui.add(egui::TextEdit::singleline(&mut self.board).hint_text("9x6").desired_width(80.0));
            ui.end_row();
            ui.label("Square (mm)");
            ui.add(egui::TextEdit::singleline(&mut self.square_mm).hint_text("25").desired_width(80.0));
            ui.end_row();
        });
        ui.checkbox(&mut self.fisheye, "Fisheye lens (Kannala–Brandt)");
        ui.add_enabled(!self.fisheye, egui::Checkbox::new(&mut self.k3, "Fit k3 (very wide lenses, corners covered)"));
        if ui.add_enabled(!busy, egui::Button::new("Detect corners")).clicked() {
            self.start_detection(Some(ui.ctx().clone()));
        }
        if let Some(Work::Detect(j)) = &self.work {
            j.progress_ui(ui);
        }
        if !self.views.is_empty() {
            ui.separator();
            egui::ScrollArea::vertical().id_salt("views").max_height(220.0).show(ui, |ui| {
                for (i, v) in self.views.iter_mut().enumerate() {
                    ui.horizontal(|ui| {
                        ui.add_enabled(v.problem.is_none() && v.corners.is_some(), egui::Checkbox::without_text(&mut v.use_it)).on_hover_text("use this view");
                        let name = Path::new(&v.label).file_name().map_or(v.label.clone(), |n| n.to_string_lossy().into_owned());
                        let status = match (&v.problem, &v.corners) {
                            (Some(p), _) => p.clone(),
                            (None, Some(c)) => format!("{} corners", c.len()),
                            (None, None) => "not found".into(),
                        };
                        if ui.selectable_label(self.selected == i, format!("{name}: {status}")).clicked() {
                            self.selected = i;
                        }
                    });
                }
            });
            if ui.add_enabled(!busy, egui::Button::new("Calibrate")).clicked() {
                self.start_calibration(Some(ui.ctx().clone()));
            }
            if let Some(Work::Calibrate(j)) = &self.work {
                j.progress_ui(ui);
            }
        }
        if let Some(c) = &self.result {
            ui.separator();
            result_ui(ui, c);
            ui.horizontal(|ui| {
                let label = ui.label("Save to");
                ui.add(egui::TextEdit::singleline(&mut self.output).desired_width(220.0)).labelled_by(label.id);
            });
            if ui.button("Save camera file").clicked() {
                let r = self.save(scene);
                self.messages.set_result(r);
            }
        }
        ui.separator();
        self.messages.ui(ui);
    }

    fn view_ui(&mut self, ui: &mut egui::Ui) {
        let Some(v) = self.views.get(self.selected) else {
            ui.label("Detected views appear here, with their corners.");
            return;
        };
        if self.picture.as_ref().is_none_or(|(i, _)| *i != self.selected) {
            self.picture = v.preview.as_ref().map(|p| (self.selected, Picture::from_rgb8(&v.label, p).with_size([v.size.0, v.size.1])));
        }
        ui.label(match (&v.problem, &v.corners) {
            (Some(p), _) => format!("{}: {p}", v.label),
            (None, Some(c)) => format!("{}: {} corners", v.label, c.len()),
            (None, None) => format!("{}: board not found", v.label),
        });
        let Some((_, pic)) = &mut self.picture else { return };
        let (_, t) = self.view.show(ui, pic);
        let painter = t.image_painter(ui);
        if let (Some(corners), Some(d)) = (&v.corners, &self.detected) {
            // OpenCV's drawing: one colour per row, rows joined in order, the first corner ringed.
            let cols = d.board.cols as usize;
            for (r, row) in corners.chunks(cols.max(1)).enumerate() {
                let colour: Color32 = egui::ecolor::Hsva::new(r as f32 / d.board.rows.max(1) as f32 * 0.8, 0.9, 1.0, 1.0).into();
                let pts: Vec<DVec2> = row.iter().map(|c| DVec2::new(c[0] as f64, c[1] as f64)).collect();
                t.polyline(&painter, &pts, Stroke::new(1.5, colour));
                for p in &pts {
                    painter.circle_stroke(t.screen_from_pixel(*p), 4.0, Stroke::new(1.5, colour));
                }
            }
            if let Some(c) = corners.first() {
                painter.circle_stroke(t.screen_from_pixel(DVec2::new(c[0] as f64, c[1] as f64)), 9.0, Stroke::new(2.0, Color32::WHITE));
            }
        }
    }
}

fn result_ui(ui: &mut egui::Ui, c: &CalibResult) {
    egui::Grid::new("calibration").num_columns(2).striped(true).show(ui, |ui| {
        let mut row = |k: &str, v: String| {
            ui.label(k);
            ui.label(v);
            ui.end_row();
        };
        row("image", format!("{}×{}", c.size.0, c.size.1));
        match &c.model {
            Calibration::Pinhole(p) => {
                row("model", "pinhole + Brown–Conrady".into());
                row("fx, fy", format!("{:.2}, {:.2}", p.fx, p.fy));
                row("cx, cy", format!("{:.2}, {:.2}", p.cx, p.cy));
                row("k1 k2 p1 p2 k3", p.distortion.iter().map(|k| format!("{k:.4}")).collect::<Vec<_>>().join(" "));
                row("RMS error", format!("{:.3} px", p.rms_px));
                row("coverage", format!("{:.0}%", 100.0 * p.coverage));
                row("views", p.views.to_string());
            }
            Calibration::Fisheye(f) => {
                row("model", "fisheye (Kannala–Brandt)".into());
                row("fx, fy", format!("{:.2}, {:.2}", f.fx, f.fy));
                row("cx, cy", format!("{:.2}, {:.2}", f.cx, f.cy));
                row("k1 k2 k3 k4", f.k.iter().map(|k| format!("{k:.4}")).collect::<Vec<_>>().join(" "));
                row("RMS error", format!("{:.3} px", f.rms_px));
                row("views", f.views.to_string());
            }
        }
    });
}

/// True when `a` and `b` name the same file (or would, once created).
fn same_file(a: &Path, b: &Path) -> bool {
    match (std::fs::canonicalize(a), std::fs::canonicalize(b)) {
        (Ok(x), Ok(y)) => x == y,
        _ => a == b,
    }
}

/// Detects the board in every view of `source`.
fn detect_views(source: &ViewSource, board: Board, progress: &Progress) -> Result<(Vec<BoardView>, Detected)> {
    let total = match source {
        ViewSource::Images(dir) => ops::list_images(dir)?.len(),
        ViewSource::Video { .. } => 0,
    };
    let mut views = Vec::new();
    let mut size = None;
    ops::for_each_view(source, |img, label| {
        if progress.cancelled() {
            return Ok(false);
        }
        let mut v = BoardView { label, size: (0, 0), preview: None, corners: None, problem: None, use_it: false };
        match img {
            Err(e) => v.problem = Some(format!("unreadable: {e:#}")),
            Ok(img) => {
                v.size = (img.width, img.height);
                if let Err(e) = ops::check_view_size(&mut size, &img, "this view") {
                    v.problem = Some(format!("{e:#}").replacen("this view: ", "", 1));
                } else {
                    match detect_corners(&img, &board) {
                        Ok(c) => v.corners = c.map(|c| c.iter().map(|p| [p.x, p.y]).collect()),
                        Err(e) => v.problem = Some(format!("detection failed: {e}")),
                    }
                }
                v.use_it = v.corners.is_some() && v.problem.is_none();
                v.preview = Some(thumbnail(&img, PREVIEW_SIDE));
            }
        }
        views.push(v);
        progress.set(views.len(), total);
        Ok(true)
    })?;
    if views.is_empty() {
        bail!("no views");
    }
    Ok((views, Detected { board, size, stopped: progress.cancelled() }))
}

/// Calibrates from corner sets.
fn calibrate(views: &[Vec<[f32; 2]>], board: Board, (w, h): (u32, u32), fisheye: bool, k3: bool) -> Result<CalibResult> {
    let sets: Vec<Vector<Point2f>> = views.iter().map(|v| v.iter().map(|c| Point2f::new(c[0], c[1])).collect()).collect();
    let model = if fisheye {
        Calibration::Fisheye(calibrate_fisheye(&sets, &board, w, h)?)
    } else {
        Calibration::Pinhole(calibrate_pinhole(&sets, &board, w, h, k3)?)
    };
    Ok(CalibResult { model, size: (w, h) })
}
