//! The Pose tab: 2D–3D pairs (image points clicked on the frame, proxy points picked in the 3D
//! view, the vertex list or typed) → `solvePnP` → per-pair errors and the proxy's outline over
//! the frame → the scene's camera file.

use super::picker::ProxyPicker;
use super::scene::FrameChooser;
use super::view::{ImageView, Transform, marker};
use super::{Level, Messages, SceneState};
use crate::ops::pose as ops;
use anyhow::{Context, Result, bail};
use egui::{Color32, Stroke};
use glam::{DVec2, DVec3};
use heliar::opencv_calib::pose::{PoseFit, solve_pose};
use heliar::camera::Camera;
use std::path::{Path, PathBuf};

/// A click closer than this (screen points) to an image point selects or drags it.
const GRAB_PT: f32 = 8.0;

/// One 2D–3D pair; either half may still be missing.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Pair {
    /// Image point, pixels.
    pub pixel: Option<DVec2>,
    /// Proxy point, world metres.
    pub world: Option<DVec3>,
    /// The proxy point as typed.
    pub world_text: String,
}

/// A solved pose and what it says about the pairs.
pub struct Solution {
    /// The fit.
    pub fit: PoseFit,
    /// The camera with the solved pose.
    pub camera: Camera,
    /// Reprojection error of each complete pair, pixels (in pair order).
    pub errors_px: Vec<f64>,
    /// The pairs it was solved from.
    used: (Vec<DVec2>, Vec<DVec3>),
    outline: Vec<Vec<DVec2>>,
}

/// The tab's state.
#[derive(Default)]
pub struct PoseTab {
    /// The pairs.
    pub pairs: Vec<Pair>,
    /// The selected pair.
    pub selected: Option<usize>,
    /// The last solve.
    pub solution: Option<Solution>,
    /// The frame shown.
    pub frame: FrameChooser,
    /// The frame's view.
    pub view: ImageView,
    picker: ProxyPicker,
    /// Draw the outline with the scene's current pose too.
    pub show_current: bool,
    /// Pairs CSV for import and export.
    pub pairs_file: String,
    /// Export even over the imported pairs or a file of a scene (`heliar-calib ui --force`).
    pub force: bool,
    /// The pairs file last imported (an input Export does not overwrite).
    imported: Option<PathBuf>,
    /// What the last action said.
    pub messages: Messages,
    outline_cache: Option<(u64, Vec<[DVec3; 2]>, Vec<Vec<DVec2>>)>,
    dragging: Option<usize>,
}

/// A coordinate for display and editing (millimetres, no trailing zeros).
fn fmt_m(x: f64) -> String {
    format!("{}", (x * 1000.0).round() / 1000.0)
}

impl PoseTab {
    /// A scene was opened: its pairs no longer apply.
    pub fn scene_opened(&mut self) {
        self.solution = None;
        self.outline_cache = None;
    }

    /// An image point clicked at `uv`: completes the selected pair if it has none, otherwise
    /// starts a new pair.
    pub fn add_pixel(&mut self, uv: DVec2) {
        match self.selected.and_then(|i| self.pairs.get_mut(i)) {
            Some(p) if p.pixel.is_none() => p.pixel = Some(uv),
            _ => {
                self.pairs.push(Pair { pixel: Some(uv), ..Pair::default() });
                self.selected = Some(self.pairs.len() - 1);
            }
        }
    }

    /// A proxy point picked: completes the selected pair if it has none, otherwise starts a new
    /// pair.
    pub fn add_world(&mut self, p: DVec3) {
        let text = format!("{}, {}, {}", fmt_m(p.x), fmt_m(p.y), fmt_m(p.z));
        match self.selected.and_then(|i| self.pairs.get_mut(i)) {
            Some(pair) if pair.world.is_none() => {
                pair.world = Some(p);
                pair.world_text = text;
            }
            _ => {
                self.pairs.push(Pair { world: Some(p), world_text: text, ..Pair::default() });
                self.selected = Some(self.pairs.len() - 1);
            }
        }
    }

    /// Removes pair `i`.
    pub fn remove(&mut self, i: usize) {
        if i < self.pairs.len() {
            self.pairs.remove(i);
            self.selected = match self.selected {
                Some(s) if s == i => None,
                Some(s) if s > i => Some(s - 1),
                s => s,
            };
        }
    }

    /// The complete pairs; an error names the first incomplete one.
    pub fn complete_pairs(&self) -> Result<(Vec<DVec2>, Vec<DVec3>)> {
        let (mut px, mut world) = (Vec::new(), Vec::new());
        for (i, p) in self.pairs.iter().enumerate() {
            match (p.pixel, p.world) {
                (Some(a), Some(b)) => {
                    px.push(a);
                    world.push(b);
                }
                (None, _) => bail!("pair {} has no image point: select it and click the point on the frame", i + 1),
                (_, None) if p.world_text.trim().is_empty() => bail!("pair {} has no proxy point: pick a vertex or type x, y, z", i + 1),
                (_, None) => bail!("pair {}: '{}' is not a proxy point x, y, z (metres)", i + 1, p.world_text.trim()),
            }
        }
        Ok((px, world))
    }

    /// Solves the pose from the complete pairs; messages say how well it fits.
    pub fn solve(&mut self, state: &SceneState) -> Result<()> {
        self.messages.clear();
        let r = (|| -> Result<Solution> {
            let (px, world) = self.complete_pairs()?;
            let k = &state.scene.camera.intrinsics;
            ops::check_inside(k, &px, "the pairs")?;
            ops::check_pairs(&px, &world, "the pairs")?;
            let fit = solve_pose(k, &px, &world)?;
            let camera = Camera { intrinsics: k.clone(), pose: fit.pose() };
            let errors_px = ops::pair_errors_px(&camera, &px, &world);
            let outline = ops::project_outline(&camera, self.outline_edges(state));
            Ok(Solution { fit, camera, errors_px, used: (px, world), outline })
        })();
        match r {
            Ok(s) => {
                let worst = s.errors_px.iter().enumerate().max_by(|a, b| a.1.total_cmp(b.1)).map_or(0, |(i, _)| i);
                self.messages.push(Level::Info, format!("RMS reprojection error {:.2} px, largest {:.2} px (pair {})", s.fit.rms_px, s.fit.max_px, worst + 1));
                let eye = s.camera.pose.translation;
                self.messages.push(Level::Info, format!("camera at ({}, {}, {}) m", fmt_m(eye.x), fmt_m(eye.y), fmt_m(eye.z)));
                for w in ops::warnings(&s.fit) {
                    self.messages.push(Level::Warn, w);
                }
                self.solution = Some(s);
                Ok(())
            }
            Err(e) => {
                self.messages.push(Level::Error, format!("{e:#}"));
                Err(e)
            }
        }
    }

    /// Stores the solved pose in the scene's camera file (validated, atomic).
    pub fn save(&mut self, state: &mut SceneState) -> Result<String> {
        let s = self.solution.as_ref().context("solve the pose first")?;
        if self.complete_pairs().ok().as_ref() != Some(&s.used) {
            bail!("the pairs changed since the last solve; solve again before saving");
        }
        let (scene, path) = ops::save_pose(&state.dir, &state.scene, &s.fit, false)?;
        state.replace(scene);
        self.outline_cache = None;
        Ok(format!("updated {} (RMS {:.2} px, max {:.2} px)", path.display(), s.fit.rms_px, s.fit.max_px))
    }

    /// Replaces the pairs by those of a CSV file.
    pub fn import(&mut self, path: &Path) -> Result<String> {
        let (px, world) = ops::read_pairs(path)?;
        self.pairs = px.iter().zip(&world).map(|(p, w)| Pair { pixel: Some(*p), world: Some(*w), world_text: format!("{}, {}, {}", fmt_m(w.x), fmt_m(w.y), fmt_m(w.z)) }).collect();
        self.selected = None;
        self.imported = Some(path.to_owned());
        Ok(format!("read {} pairs from {}", self.pairs.len(), path.display()))
    }

    /// Writes the complete pairs as CSV (for `heliar-calib pose --pairs`); not over the pairs
    /// file they were imported from nor over a file of a scene, unless [`PoseTab::force`].
    pub fn export(&self, path: &Path) -> Result<String> {
        let (px, world) = self.complete_pairs()?;
        crate::edit::check_output(path, &self.imported.iter().map(PathBuf::as_path).collect::<Vec<_>>(), self.force)?;
        crate::edit::write_atomic(path, ops::pairs_csv(&px, &world).as_bytes())?;
        Ok(format!("wrote {} pairs to {}", px.len(), path.display()))
    }

    fn outline_edges(&mut self, state: &SceneState) -> &[[DVec3; 2]] {
        if self.outline_cache.as_ref().is_none_or(|(v, _, _)| *v != state.version) {
            let edges = ops::outline_edges(&state.scene.proxy);
            let current = ops::project_outline(&state.scene.camera, &edges);
            self.outline_cache = Some((state.version, edges, current));
        }
        self.outline_cache.as_ref().map_or(&[], |(_, e, _)| e.as_slice())
    }

    /// The tab.
    pub fn ui(&mut self, ui: &mut egui::Ui, state: &mut SceneState) {
        egui::Panel::left("pose_controls").default_size(400.0).show(ui, |ui| {
            egui::ScrollArea::vertical().show(ui, |ui| self.controls_ui(ui, state));
        });
        egui::Panel::right("pose_picker").default_size(340.0).show(ui, |ui| {
            let assigned: Vec<(usize, DVec3)> = self.pairs.iter().enumerate().filter_map(|(i, p)| p.world.map(|w| (i, w))).collect();
            if let Some(p) = self.picker.ui(ui, state, &assigned) {
                self.add_world(p);
            }
        });
        egui::CentralPanel::default().show(ui, |ui| self.frame_ui(ui, state));
    }

    fn controls_ui(&mut self, ui: &mut egui::Ui, state: &mut SceneState) {
        self.frame.ui(ui, state);
        ui.label("Click a point on the frame, then pick the same point on the proxy (3D view or list, right), or type its x, y, z. At least 4 pairs, better 6–10 spread over the image.");
        ui.separator();
        let errors: Option<&Vec<f64>> = self.solution.as_ref().map(|s| &s.errors_px);
        let mut remove = None;
        let mut err_i = 0;
        egui::Grid::new("pairs").num_columns(5).striped(true).show(ui, |ui| {
            ui.label("#");
            ui.label("pixel u, v");
            ui.label("proxy x, y, z (m)");
            ui.label("error");
            ui.label("");
            ui.end_row();
            for (i, p) in self.pairs.iter_mut().enumerate() {
                if ui.selectable_label(self.selected == Some(i), format!("{}", i + 1)).clicked() {
                    self.selected = Some(i);
                }
                ui.label(p.pixel.map_or("click the frame".into(), |u| format!("{:.1}, {:.1}", u.x, u.y)));
                let bad = !p.world_text.trim().is_empty() && p.world.is_none();
                let edit = egui::TextEdit::singleline(&mut p.world_text).hint_text("pick or type").text_color_opt(bad.then_some(Color32::from_rgb(235, 80, 70)));
                if ui.add_sized([130.0, 20.0], edit).changed() {
                    p.world = crate::ops::scene::parse_vec3(&p.world_text, "proxy point").ok().map(DVec3::from);
                }
                let complete = p.pixel.is_some() && p.world.is_some();
                let e = if complete { errors.and_then(|e| e.get(err_i)).copied() } else { None };
                err_i += complete as usize;
                ui.label(e.map_or(String::new(), |e| format!("{e:.2} px")));
                if ui.small_button("×").on_hover_text("remove this pair").clicked() {
                    remove = Some(i);
                }
                ui.end_row();
            }
        });
        if let Some(i) = remove {
            self.remove(i);
        }
        ui.horizontal(|ui| {
            if ui.button("New pair").clicked() {
                self.pairs.push(Pair::default());
                self.selected = Some(self.pairs.len() - 1);
            }
            if ui.button("Solve").clicked() {
                let _ = self.solve(state);
            }
            if ui.add_enabled(self.solution.is_some(), egui::Button::new("Save pose")).clicked() {
                let r = self.save(state);
                self.messages.set_result(r);
            }
        });
        ui.checkbox(&mut self.show_current, "Show the scene's current pose (grey)");
        ui.horizontal(|ui| {
            ui.add(egui::TextEdit::singleline(&mut self.pairs_file).hint_text("pairs.csv").desired_width(160.0));
            if ui.button("Import").clicked() {
                let path = std::path::PathBuf::from(self.pairs_file.trim());
                let r = self.import(&path);
                self.messages.set_result(r);
            }
            if ui.button("Export").clicked() {
                let r = self.export(Path::new(self.pairs_file.trim()));
                self.messages.set_result(r);
            }
        });
        ui.separator();
        self.messages.ui(ui);
    }

    fn frame_ui(&mut self, ui: &mut egui::Ui, state: &SceneState) {
        if self.show_current {
            self.outline_edges(state);
        }
        let Some(pic) = self.frame.picture(state) else {
            if let Some(e) = &self.frame.error {
                ui.colored_label(Color32::from_rgb(235, 80, 70), e);
            }
            return;
        };
        let (response, t) = self.view.show(ui, pic);
        self.interact(&response, &t);
        let painter = t.image_painter(ui);
        if self.show_current
            && let Some((_, _, current)) = &self.outline_cache
        {
            for line in current {
                t.polyline(&painter, line, Stroke::new(1.0, Color32::from_gray(170)));
            }
        }
        if let Some(s) = &self.solution {
            for line in &s.outline {
                t.polyline(&painter, line, Stroke::new(1.2, Color32::from_rgb(255, 220, 0)));
            }
        }
        for (i, p) in self.pairs.iter().enumerate() {
            let Some(uv) = p.pixel else { continue };
            let colour = if self.selected == Some(i) { Color32::from_rgb(60, 220, 255) } else { Color32::from_rgb(255, 60, 60) };
            marker(&painter, t.screen_from_pixel(uv), colour, &format!("{}", i + 1));
            if let (Some(s), Some(w)) = (&self.solution, p.world)
                && let Some(q) = s.camera.project_world(w)
            {
                let (a, b) = (t.screen_from_pixel(uv), t.screen_from_pixel(q));
                painter.line_segment([a, b], Stroke::new(1.5, Color32::from_rgb(255, 0, 255)));
                painter.circle_stroke(b, 3.0, Stroke::new(1.5, Color32::from_rgb(255, 0, 255)));
            }
        }
    }

    /// Clicks and drags on the frame.
    fn interact(&mut self, response: &egui::Response, t: &Transform) {
        let near = |pairs: &[Pair], pos: egui::Pos2| {
            pairs.iter().enumerate().filter_map(|(i, p)| p.pixel.map(|uv| (i, t.screen_from_pixel(uv).distance(pos)))).filter(|(_, d)| *d < GRAB_PT).min_by(|a, b| a.1.total_cmp(&b.1)).map(|(i, _)| i)
        };
        if response.drag_started_by(egui::PointerButton::Primary) {
            // Where the button went down, not where the drag was recognised a few points later.
            let origin = response.ctx.input(|i| i.pointer.press_origin()).or(response.interact_pointer_pos());
            self.dragging = origin.and_then(|pos| near(&self.pairs, pos));
            self.selected = self.dragging.or(self.selected);
        }
        if let (Some(i), Some(pos)) = (self.dragging, response.interact_pointer_pos())
            && response.dragged_by(egui::PointerButton::Primary)
            && let Some(p) = self.pairs.get_mut(i)
        {
            let uv = t.pixel_from_screen(pos);
            if t.on_image(uv) {
                p.pixel = Some(uv);
            }
        }
        if response.drag_stopped() {
            self.dragging = None;
        }
        if response.clicked()
            && let Some(pos) = response.interact_pointer_pos()
        {
            let uv = t.pixel_from_screen(pos);
            match near(&self.pairs, pos) {
                Some(i) => self.selected = Some(i),
                None if t.on_image(uv) => self.add_pixel(uv),
                None => {}
            }
        }
        if response.secondary_clicked()
            && let Some(i) = response.interact_pointer_pos().and_then(|pos| near(&self.pairs, pos))
        {
            self.remove(i);
        }
    }
}
