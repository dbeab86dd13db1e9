//! The HDR tab: bracketed exposures and their times → optional lens-reflection and clean
//! rectangles drawn with the mouse → Debevec merge → tone-mapped preview → EXR + response CSV.

use super::job::Job;
use super::view::{ImageView, Picture, Transform, srgb8_from_linear};
use super::{Level, Messages};
use crate::ops::hdr::{self as ops, Rect};
use anyhow::{Context, Result, bail};
use egui::{Color32, Stroke};
use glam::DVec2;
use heliar::opencv_calib::Rgb8;
use heliar::opencv_calib::hdr::remove_reflection;
use heliar::io::image::LinearImage;
use std::path::PathBuf;
use std::sync::Arc;

/// The preview of the merged image is tone-mapped at most this wide.
const PREVIEW_WIDTH: u32 = 1600;

/// One exposure as typed.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Exposure {
    /// Image file.
    pub path: String,
    /// Exposure time (`1/250`, `0.004`, `4ms`).
    pub time: String,
}

/// What a drag on the image draws.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Draw {
    /// Nothing.
    Nothing,
    /// The lens reflection's rectangle.
    Reflection,
    /// The clean patch (same size as the reflection).
    Clean,
}

struct Loaded {
    key: Vec<Exposure>,
    images: Arc<Vec<Rgb8>>,
    times: Vec<f32>,
    pictures: Vec<Option<Picture>>,
}

/// A merge's result.
pub struct Merged {
    /// Relative radiance.
    pub image: LinearImage,
    /// Response, linear value per code (256 rows, RGB).
    pub response: Vec<[f32; 3]>,
    small: LinearImage,
}

/// The tab's state.
pub struct HdrTab {
    /// The exposures.
    pub rows: Vec<Exposure>,
    /// The exposure shown.
    pub shown: usize,
    /// Show the merged result instead of an exposure.
    pub show_result: bool,
    /// Show the exposure with the reflection removed.
    pub show_cleaned: bool,
    /// Lens reflection, `x, y, w, h`.
    pub reflection: Option<Rect>,
    /// Clean patch cloned over it.
    pub clean: Option<Rect>,
    /// What a drag draws.
    pub drawing: Draw,
    /// Preview exposure, stops.
    pub ev: f32,
    /// The last merge.
    pub result: Option<Merged>,
    /// Output EXR.
    pub output: String,
    /// What the last action said.
    pub messages: Messages,
    /// Save even over an exposure or a file of a scene (`heliar-calib ui --force`).
    pub force: bool,
    loaded: Option<Loaded>,
    job: Option<Job<(LinearImage, Vec<[f32; 3]>)>>,
    view: ImageView,
    drag_from: Option<DVec2>,
    preview: Option<(f32, Picture)>,
    cleaned: Option<((usize, Rect, Rect), Result<Picture, String>)>,
}

impl Default for HdrTab {
    fn default() -> Self {
        Self {
            rows: vec![Exposure::default(); 3],
            shown: 0,
            show_result: false,
            show_cleaned: false,
            reflection: None,
            clean: None,
            drawing: Draw::Nothing,
            ev: 0.0,
            result: None,
            output: "env.exr".into(),
            messages: Messages::default(),
            force: false,
            loaded: None,
            job: None,
            view: ImageView::default(),
            drag_from: None,
            preview: None,
            cleaned: None,
        }
    }
}

/// The rectangle of whole pixels spanned by two pixel positions, inside a `w × h` image.
fn rect_between(a: DVec2, b: DVec2, w: u32, h: u32) -> Rect {
    let clamp = |v: f64, hi: u32| (v + 0.5).floor().clamp(0.0, hi as f64 - 1.0) as i32;
    let (x0, x1) = (clamp(a.x.min(b.x), w), clamp(a.x.max(b.x), w));
    let (y0, y1) = (clamp(a.y.min(b.y), h), clamp(a.y.max(b.y), h));
    [x0, y0, x1 - x0 + 1, y1 - y0 + 1]
}

impl HdrTab {
    /// Reads the exposures (again, when the rows changed): times parsed, files read, sizes equal.
    pub fn load(&mut self) -> Result<String> {
        if self.loaded.as_ref().is_some_and(|l| l.key == self.rows) {
            return Ok(format!("{} exposures loaded", self.rows.len()));
        }
        self.loaded = None;
        self.cleaned = None;
        let mut images: Vec<Rgb8> = Vec::new();
        let mut times = Vec::new();
        let mut paths = Vec::new();
        for (i, r) in self.rows.iter().enumerate() {
            let path = PathBuf::from(r.path.trim());
            paths.push(path.clone());
            if path.as_os_str().is_empty() {
                bail!("exposure {}: give the image file", i + 1);
            }
            times.push(ops::parse_exposure_time(&r.time).with_context(|| format!("exposure {}: time '{}'", i + 1, r.time.trim()))?);
            let img = Rgb8::open(&path).with_context(|| format!("exposure {}", i + 1))?;
            if let Some(first) = images.first()
                && (first.width, first.height) != (img.width, img.height)
            {
                bail!("exposure {} ({}) is {}×{} but exposure 1 is {}×{}: bracketed shots must have one size", i + 1, path.display(), img.width, img.height, first.width, first.height);
            }
            images.push(img);
        }
        ops::check_times(&paths, &times)?;
        if images.len() < 3 {
            bail!("{} exposures; Debevec's method needs at least 3 (e.g. -2, 0, +2 EV)", images.len());
        }
        let n = images.len();
        self.loaded = Some(Loaded { key: self.rows.clone(), images: Arc::new(images), times, pictures: (0..n).map(|_| None).collect() });
        self.shown = self.shown.min(n - 1);
        Ok(format!("{n} exposures loaded"))
    }

    /// Where the shown image was drawn last.
    #[cfg(test)]
    pub fn view_transform(&self) -> Option<super::view::Transform> {
        self.view.last
    }

    /// Puts an image file into the first empty row, or a new one.
    pub fn add_file(&mut self, path: &str) {
        match self.rows.iter_mut().find(|r| r.path.trim().is_empty()) {
            Some(r) => r.path = path.to_owned(),
            None => self.rows.push(Exposure { path: path.to_owned(), time: String::new() }),
        }
    }

    fn image_size(&self) -> Option<(u32, u32)> {
        self.loaded.as_ref().and_then(|l| l.images.first()).map(|i| (i.width, i.height))
    }

    fn rectangles(&self) -> Result<Option<(Rect, Rect)>> {
        match (self.reflection, self.clean) {
            (None, None) => Ok(None),
            (Some(r), Some(c)) => Ok(Some((r, c))),
            (Some(_), None) => bail!("draw the clean rectangle too (a patch of the same size without the reflection), or clear the reflection"),
            (None, Some(_)) => bail!("draw the reflection's rectangle first"),
        }
    }

    /// Starts the merge (loading the exposures first if needed).
    pub fn start_merge(&mut self, ctx: Option<egui::Context>) {
        self.messages.clear();
        let r = (|| -> Result<()> {
            self.load()?;
            let rects = self.rectangles()?;
            let l = self.loaded.as_ref().context("no exposures")?;
            let (images, times) = (l.images.clone(), l.times.clone());
            self.job = Some(Job::spawn("Merging", ctx, move |_| ops::merge(&images, &times, rects)));
            Ok(())
        })();
        if let Err(e) = r {
            self.messages.push(Level::Error, format!("{e:#}"));
        }
    }

    fn merged(&mut self, r: Result<(LinearImage, Vec<[f32; 3]>)>) {
        match r {
            Ok((image, response)) => {
                let w = image.width.min(PREVIEW_WIDTH);
                let small = if w < image.width { image.resized(w, (image.height as u64 * w as u64 / image.width as u64).max(1) as u32) } else { image.clone() };
                self.messages.push(Level::Info, format!("merged {}×{} (relative radiance)", image.width, image.height));
                self.result = Some(Merged { image, response, small });
                self.preview = None;
                self.show_result = true;
            }
            Err(e) => self.messages.push(Level::Error, format!("{e:#}")),
        }
    }

    /// Waits for a running merge and takes its result.
    #[cfg(test)]
    pub fn wait_for_job(&mut self) {
        if let Some(j) = self.job.take() {
            let r = j.wait();
            self.merged(r);
        }
    }

    /// Writes the EXR and the response CSV; neither may overwrite an exposure or a file of a
    /// scene unless [`HdrTab::force`] (the guard of `hdr -o`).
    pub fn save(&self) -> Result<String> {
        let m = self.result.as_ref().context("merge first")?;
        let out = PathBuf::from(self.output.trim());
        if !out.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr")) {
            bail!("the output '{}' must be an .exr file", out.display());
        }
        let inputs: Vec<PathBuf> = self.rows.iter().map(|r| PathBuf::from(r.path.trim())).filter(|p| !p.as_os_str().is_empty()).collect();
        let inputs: Vec<&std::path::Path> = inputs.iter().map(PathBuf::as_path).collect();
        crate::edit::check_output(&out, &inputs, self.force).context("the output EXR")?;
        crate::edit::check_output(&ops::response_path(&out), &inputs, self.force).context("the response CSV beside the output")?;
        let csv = ops::write_outputs(&out, &m.image, &m.response)?;
        Ok(format!("wrote {} and {}", out.display(), csv.display()))
    }

    /// The tab.
    pub fn ui(&mut self, ui: &mut egui::Ui) {
        if let Some(r) = self.job.as_mut().and_then(|j| j.poll()) {
            self.job = None;
            self.merged(r);
        }
        egui::Panel::left("hdr_controls").default_size(380.0).show(ui, |ui| {
            egui::ScrollArea::vertical().show(ui, |ui| self.controls_ui(ui));
        });
        egui::CentralPanel::default().show(ui, |ui| self.image_ui(ui));
    }

    fn controls_ui(&mut self, ui: &mut egui::Ui) {
        ui.heading("Bracketed exposures");
        ui.label("The same view at three or more exposure times (tripod, fixed focus and white balance). Drop the files on the window, or type their paths.");
        let mut remove = None;
        for (i, r) in self.rows.iter_mut().enumerate() {
            ui.horizontal(|ui| {
                if ui.selectable_label(self.shown == i && !self.show_result, format!("{}", i + 1)).clicked() {
                    self.shown = i;
                    self.show_result = false;
                }
                ui.add_sized([210.0, 20.0], egui::TextEdit::singleline(&mut r.path).hint_text("image file (shot.jpg)"));
                ui.add_sized([64.0, 20.0], egui::TextEdit::singleline(&mut r.time).hint_text("1/250 s"));
                if ui.small_button("×").on_hover_text("remove this exposure").clicked() {
                    remove = Some(i);
                }
            });
        }
        if let Some(i) = remove {
            self.rows.remove(i);
        }
        ui.horizontal(|ui| {
            if ui.button("Add exposure").clicked() {
                self.rows.push(Exposure::default());
            }
            if ui.button("Load").clicked() {
                let r = self.load();
                self.messages.set_result(r);
                self.show_result = false;
            }
        });
        ui.separator();
        ui.label("Lens reflection (optional): drag a rectangle ~8 px larger than the reflection, then place a clean patch of the same size.");
        ui.horizontal(|ui| {
            ui.radio_value(&mut self.drawing, Draw::Reflection, "Draw reflection");
            ui.radio_value(&mut self.drawing, Draw::Clean, "Place clean patch");
            ui.radio_value(&mut self.drawing, Draw::Nothing, "Off");
        });
        let fmt = |r: Option<Rect>| r.map_or("—".to_string(), |r| format!("{},{},{},{}", r[0], r[1], r[2], r[3]));
        ui.label(format!("reflection {}   clean {}", fmt(self.reflection), fmt(self.clean)));
        ui.horizontal(|ui| {
            if ui.button("Clear rectangles").clicked() {
                (self.reflection, self.clean, self.cleaned) = (None, None, None);
            }
            ui.checkbox(&mut self.show_cleaned, "Show with the reflection removed");
        });
        ui.separator();
        if self.job.is_none() && ui.button("Merge (Debevec)").clicked() {
            self.start_merge(Some(ui.ctx().clone()));
        }
        if let Some(j) = &self.job {
            j.progress_ui(ui);
        }
        if let Some(m) = &self.result {
            ui.checkbox(&mut self.show_result, "Show the merged image");
            ui.add(egui::Slider::new(&mut self.ev, -8.0..=8.0).text("preview EV"));
            response_ui(ui, &m.response);
            ui.horizontal(|ui| {
                let label = ui.label("Save to");
                ui.add(egui::TextEdit::singleline(&mut self.output).desired_width(200.0)).labelled_by(label.id);
            });
            if ui.button("Save EXR + response").clicked() {
                let r = self.save();
                self.messages.set_result(r);
            }
        }
        ui.separator();
        self.messages.ui(ui);
    }

    fn image_ui(&mut self, ui: &mut egui::Ui) {
        let mut view = std::mem::take(&mut self.view);
        let pic: &mut Picture = if self.show_result && self.result.is_some() {
            let ev = self.ev;
            if self.preview.as_ref().is_none_or(|(e, _)| *e != ev)
                && let Some(m) = &self.result
            {
                self.preview = Some((ev, Picture::from_rgb8("merged", &srgb8_from_linear(&m.small, ev)).with_size([m.image.width, m.image.height])));
            }
            match &mut self.preview {
                Some((_, p)) => p,
                None => {
                    self.view = view;
                    return;
                }
            }
        } else {
            match self.exposure_picture() {
                Some(p) => p,
                None => {
                    ui.label("Load the exposures to see them here.");
                    self.view = view;
                    return;
                }
            }
        };
        let (response, t) = view.show(ui, pic);
        self.view = view;
        self.draw_interaction(&response, &t);
        let painter = ui.painter_at(t.clip);
        for (r, colour, label) in [(self.reflection, Color32::from_rgb(255, 80, 80), "reflection"), (self.clean, Color32::from_rgb(80, 230, 120), "clean")] {
            if let Some(r) = r {
                let rect = t.pixel_rect(r);
                painter.rect_stroke(rect, 0.0, Stroke::new(2.0, colour), egui::StrokeKind::Outside);
                painter.text(rect.left_top(), egui::Align2::LEFT_BOTTOM, label, egui::FontId::proportional(13.0), colour);
            }
        }
    }

    /// The shown exposure's picture (with the reflection removed when asked and possible).
    fn exposure_picture(&mut self) -> Option<&mut Picture> {
        let shown = self.shown;
        if self.show_cleaned
            && let (Some(r), Some(c)) = (self.reflection, self.clean)
        {
            let key = (shown, r, c);
            if self.cleaned.as_ref().is_none_or(|(k, _)| *k != key) {
                let l = self.loaded.as_ref()?;
                let img = l.images.get(shown)?;
                let pic = remove_reflection(img, r, c).map(|im| Picture::from_rgb8("cleaned", &im)).map_err(|e| e.to_string());
                if let Err(e) = &pic {
                    self.messages.clear();
                    self.messages.push(Level::Error, e.clone());
                }
                self.cleaned = Some((key, pic));
            }
            if let Some((_, Ok(p))) = &mut self.cleaned {
                return Some(p);
            }
        }
        let l = self.loaded.as_mut()?;
        let img = l.images.get(shown)?;
        let slot = l.pictures.get_mut(shown)?;
        Some(slot.get_or_insert_with(|| Picture::from_rgb8(&format!("exposure{shown}"), img)))
    }

    fn draw_interaction(&mut self, response: &egui::Response, t: &Transform) {
        let Some((w, h)) = self.image_size() else { return };
        let pos = response.interact_pointer_pos().map(|p| t.pixel_from_screen(p));
        match self.drawing {
            Draw::Nothing => {}
            Draw::Reflection => {
                if response.drag_started_by(egui::PointerButton::Primary) {
                    let origin = response.ctx.input(|i| i.pointer.press_origin());
                    self.drag_from = origin.map(|p| t.pixel_from_screen(p)).or(pos);
                }
                if let (Some(a), Some(b)) = (self.drag_from, pos)
                    && response.dragged_by(egui::PointerButton::Primary)
                {
                    self.reflection = Some(rect_between(a, b, w, h));
                    // A new reflection invalidates the clean patch unless it still has its size.
                    if let (Some(r), Some(c)) = (self.reflection, &mut self.clean) {
                        c[2] = r[2];
                        c[3] = r[3];
                    }
                }
                if response.drag_stopped() {
                    self.drag_from = None;
                }
            }
            Draw::Clean => {
                let Some(r) = self.reflection else {
                    if response.clicked() {
                        self.messages.clear();
                        self.messages.push(Level::Error, "draw the reflection's rectangle first");
                    }
                    return;
                };
                if let Some(p) = pos
                    && (response.clicked() || response.dragged_by(egui::PointerButton::Primary))
                {
                    let x = (p.x.round() as i32 - r[2] / 2).clamp(0, (w as i32 - r[2]).max(0));
                    let y = (p.y.round() as i32 - r[3] / 2).clamp(0, (h as i32 - r[3]).max(0));
                    self.clean = Some([x, y, r[2], r[3]]);
                }
            }
        }
    }
}

/// The recovered response: log linear value against code, per channel.
fn response_ui(ui: &mut egui::Ui, response: &[[f32; 3]]) {
    ui.label("Recovered response (log value against code)");
    let (rect, _) = ui.allocate_exact_size(egui::vec2(ui.available_width().min(300.0), 110.0), egui::Sense::hover());
    let painter = ui.painter_at(rect);
    painter.rect_filled(rect, 0.0, Color32::from_gray(20));
    let logs: Vec<[f32; 3]> = response.iter().map(|r| r.map(|v| v.max(1e-6).ln())).collect();
    let (lo, hi) = logs.iter().flatten().fold((f32::MAX, f32::MIN), |(a, b), v| (a.min(*v), b.max(*v)));
    if !(hi > lo) {
        return;
    }
    for (c, colour) in [Color32::from_rgb(240, 80, 80), Color32::from_rgb(80, 220, 80), Color32::from_rgb(90, 140, 255)].into_iter().enumerate() {
        let pts: Vec<egui::Pos2> = logs
            .iter()
            .enumerate()
            .map(|(i, l)| egui::pos2(rect.left() + rect.width() * i as f32 / (logs.len().max(2) - 1) as f32, rect.bottom() - rect.height() * (l[c] - lo) / (hi - lo)))
            .collect();
        painter.line(pts, Stroke::new(1.2, colour));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dragged_rectangles_cover_whole_pixels_inside_the_image() {
        assert_eq!(rect_between(DVec2::new(10.2, 5.0), DVec2::new(3.6, 8.4), 100, 50), [4, 5, 7, 4]);
        assert_eq!(rect_between(DVec2::new(-20.0, -3.0), DVec2::new(500.0, 2.0), 100, 50), [0, 0, 100, 3]);
    }
}
