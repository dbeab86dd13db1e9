//! The live window's egui drawing: the feed, the status bar, the pass switches, the estimator,
//! the pass report and the plots. Plain functions of the app's state, so the tests drive them
//! headless with egui_kittest.

use super::{AmbientChoice, HistoryPoint, LiveApp};
use crate::render::Darkening;
use crate::live::source::SourceState;
use egui::{Color32, RichText};
use std::sync::atomic::Ordering;
use std::time::Duration;

/// How long the window waits for a new frame to show a move by hand before it composites the
/// last one again.
const RECOMPOSE_AFTER: Duration = Duration::from_millis(250);
/// The feed image's label (accessibility; the tests find the image by it).
pub const FEED_ALT_TEXT: &str = "the composited feed";

impl LiveApp {
    /// The whole window.
    pub fn ui(&mut self, ui: &mut egui::Ui) {
        if self.quit.as_ref().is_some_and(|q| q.load(Ordering::SeqCst)) {
            ui.ctx().send_viewport_cmd(egui::ViewportCommand::Close);
        }
        self.capture.watchdog();
        if self.process_in_ui {
            match self.capture.slot().take() {
                Some(c) => self.process(c),
                // A move by hand shows on the next frame; when none comes (paused, ended, a
                // still), the last one is composited again.
                None if self.objects_dirty && self.shown_at.back().is_none_or(|t| t.elapsed() > RECOMPOSE_AFTER) => {
                    self.recompose();
                }
                None => {}
            }
        }
        self.upload_texture(ui.ctx());
        egui::Panel::top("live_status").show(ui, |ui| self.status_bar_ui(ui));
        egui::Panel::right("live_controls").default_size(330.0).show(ui, |ui| {
            egui::ScrollArea::vertical().show(ui, |ui| {
                self.switches_ui(ui);
                ui.separator();
                self.estimator_ui(ui);
                ui.separator();
                self.passes_ui(ui);
                if let Some(v) = &mut self.vem {
                    ui.separator();
                    v.tick();
                    v.ui(ui);
                }
            });
        });
        egui::Panel::bottom("live_plots").default_size(200.0).show(ui, |ui| self.plots_ui(ui));
        egui::CentralPanel::default().show(ui, |ui| self.feed_ui(ui));
        // Poll for frames; after the end of a file, slowly (Ctrl-C and the VEM panel still act).
        let ended = self.capture.status().state == SourceState::Ended;
        ui.ctx().request_repaint_after(Duration::from_millis(if ended { 200 } else { 5 }));
    }

    fn upload_texture(&mut self, ctx: &egui::Context) {
        if !self.texture_dirty {
            return;
        }
        let Some(shown) = &self.last else { return };
        let img = if self.show_input { &shown.input } else { &shown.composited };
        let color = egui::ColorImage::from_rgb([img.width as usize, img.height as usize], &img.data);
        match &mut self.texture {
            Some(t) => t.set(color, egui::TextureOptions::LINEAR),
            None => self.texture = Some(ctx.load_texture("live_feed", color, egui::TextureOptions::LINEAR)),
        }
        self.texture_dirty = false;
    }

    fn status_bar_ui(&mut self, ui: &mut egui::Ui) {
        let status = self.capture.status();
        ui.horizontal(|ui| {
            ui.label(RichText::new(&self.title).strong());
            let line = self.source_line();
            let colour = match status.state {
                SourceState::Lost { .. } => Color32::from_rgb(235, 80, 70),
                SourceState::Ended => Color32::from_rgb(230, 170, 40),
                _ => ui.visuals().text_color(),
            };
            ui.label(RichText::new(line).color(colour));
        });
        ui.horizontal(|ui| {
            ui.label(format!("{:.1} fps", self.fps()));
            ui.label(format!("processed {}", self.processed));
            ui.label(format!("dropped {}", self.dropped()));
            if let Some(s) = &self.last {
                ui.label(format!("frame {:.0} ms, latency {:.0} ms", s.frame_ms, s.latency_ms));
                ui.label(format!("time {}", s.time.format("%Y-%m-%d %H:%M:%S%:z")));
            }
            if status.losses > 0 {
                ui.label(format!("lost {} times", status.losses));
            }
        });
        if let Some(e) = &self.error {
            ui.label(RichText::new(format!("Error: {e}")).color(Color32::from_rgb(235, 80, 70)));
        }
        if !self.clock_check.stuck().is_empty() {
            let n = self.clock_check.stuck().len();
            ui.label(RichText::new(format!("{n} frames had a time that did not increase: the clock is stuck or runs backwards")).color(Color32::from_rgb(230, 170, 40)));
        }
    }

    fn switches_ui(&mut self, ui: &mut egui::Ui) {
        ui.heading("Passes");
        ui.checkbox(&mut self.switches.virtual_objects, "Virtual objects");
        ui.add_enabled_ui(self.switches.virtual_objects, |ui| {
            ui.checkbox(&mut self.switches.virtual_volumes, "Virtual shadows (shadow volumes)");
            ui.checkbox(&mut self.switches.real_volumes, "Real shadows on the objects");
            ui.checkbox(&mut self.switches.transfer, "Per-pixel ambient transfer (off: probes × occlusion)");
        });
        ui.label("Darkening of real pixels:");
        ui.horizontal(|ui| {
            ui.radio_value(&mut self.darkening, Darkening::Differential, "differential");
            ui.radio_value(&mut self.darkening, Darkening::Normal, "normal");
            ui.radio_value(&mut self.darkening, Darkening::Constant, "constant");
        });
        ui.label("Ambient light of the objects:");
        let mut a = self.ambient();
        ui.add_enabled_ui(self.can_switch_ambient(), |ui| {
            ui.horizontal(|ui| {
                ui.radio_value(&mut a, AmbientChoice::Uniform, "uniform sky");
                ui.radio_value(&mut a, AmbientChoice::Volume, "irradiance volume");
            });
        });
        if a != self.ambient() {
            self.set_ambient(a);
        }
        if ui.checkbox(&mut self.show_input, "Show the input").changed() {
            self.texture_dirty = true;
        }
        if self.can_move_objects() {
            ui.separator();
            ui.heading("Objects");
            ui.label("Drag an object to move it over the ground; scroll over it to turn it.");
            if ui.button("Reset objects").clicked() {
                self.reset_objects();
            }
        }
    }

    fn estimator_ui(&mut self, ui: &mut egui::Ui) {
        ui.heading("Estimator");
        let Some(s) = &self.last else {
            ui.label("waiting for the first frame");
            return;
        };
        let e = &s.record.estimate;
        ui.label(RichText::new(self.estimator_status().unwrap_or_default()).strong());
        let rgb = |v: glam::Vec3| format!("{:.3}, {:.3}, {:.3}", v.x, v.y, v.z);
        egui::Grid::new("estimator").num_columns(2).show(ui, |ui| {
            ui.label("Pd (used)");
            ui.label(rgb(s.record.lighting.pd));
            ui.end_row();
            ui.label("Pa (used)");
            ui.label(rgb(s.record.lighting.pa));
            ui.end_row();
            ui.label("condition number");
            ui.label(e.condition_number.map_or("—".into(), |c| format!("{c:.1}")));
            ui.end_row();
            ui.label("residual RMS");
            ui.label(e.residual_rms.map_or("—".into(), |r| format!("{:.3}, {:.3}, {:.3}", r[0], r[1], r[2])));
            ui.end_row();
            ui.label("samples");
            ui.label(format!("{} inliers of {} usable", e.samples.inliers, e.samples.usable));
            ui.end_row();
            ui.label("relight");
            ui.label(format!("{} ({}, {})", if s.record.relight.ran { "yes" } else { "no" }, s.record.relight.source, s.record.relight.reason));
            ui.end_row();
            ui.label("sun");
            ui.label(format!("zenith {:.2}°, azimuth {:.2}°", e.sun.position.zenith_deg, e.sun.position.azimuth_deg));
            ui.end_row();
            ui.label("times");
            ui.label(format!("estimate {:.1} ms, composite {:.1} ms", s.record.estimate_ms, s.record.composite_ms));
            ui.end_row();
        });
    }

    fn passes_ui(&mut self, ui: &mut egui::Ui) {
        ui.heading("Pass report");
        let Some(s) = &self.last else { return };
        ui.label(format!("ran: {}", s.passes.ran.join(", ")));
        if !s.passes.moved.is_empty() {
            ui.label(format!("moved: {}", s.passes.moved.join(", ")));
        }
        for k in &s.passes.skipped {
            ui.label(format!("skipped {}: {}", k.pass, k.reason));
        }
        let t = &s.passes.timings;
        ui.label(format!("volumes {:.1} ms, upload {:.1} ms, GPU {:.1} ms, read-back {:.1} ms", t.volume_build_ms, t.upload_ms, t.gpu_ms, t.readback_ms));
        if let Some(v) = &s.vem {
            ui.label(format!("VEM renderer ran: {}", v.ran.join(", ")));
            for k in &v.skipped {
                ui.label(format!("skipped {}: {}", k.pass, k.reason));
            }
            ui.label(format!("{} lights, {} shadow maps, {:.1} ms", v.lights, v.shadow_maps, v.timings.total_ms));
        }
    }

    fn plots_ui(&mut self, ui: &mut egui::Ui) {
        use egui_plot::{Legend, Line, Plot, PlotPoints};
        let series = |f: &dyn Fn(&HistoryPoint) -> Option<f64>| -> PlotPoints<'static> { self.history.iter().filter_map(|p| f(p).map(|y| [p.t_s, y])).collect::<Vec<_>>().into() };
        let h = (ui.available_height() - 8.0).max(60.0);
        ui.columns(2, |cols| {
            Plot::new("live_irradiance").height(h).legend(Legend::default()).x_axis_label("s").include_y(0.0).show(&mut cols[0], |p| {
                p.line(Line::new("Pd (fit)", series(&|q| q.pd)));
                p.line(Line::new("Pa (fit)", series(&|q| q.pa)));
                p.line(Line::new("Pd (used)", series(&|q| Some(q.pd_used))));
                p.line(Line::new("Pa (used)", series(&|q| Some(q.pa_used))));
            });
            Plot::new("live_residual").height(h).legend(Legend::default()).x_axis_label("s").include_y(0.0).show(&mut cols[1], |p| {
                p.line(Line::new("residual RMS", series(&|q| q.residual_rms)));
            });
        });
    }

    /// Dragging and turning the objects on the shown frame (`super::drag`).
    fn pointer_ui(&mut self, r: &egui::Response, ui: &egui::Ui, scale: f32) {
        // Footage pixel coordinates, pixel centres at integers.
        let px = |p: egui::Pos2| (((p.x - r.rect.min.x) / scale) as f64 - 0.5, ((p.y - r.rect.min.y) / scale) as f64 - 0.5);
        // A drag is recognised once the pointer has travelled a little: it begins where the
        // button went down.
        if r.drag_started()
            && let Some((x, y)) = ui.input(|i| i.pointer.press_origin()).map(px)
        {
            self.begin_drag(x, y);
        }
        let mut result = Ok(());
        if r.dragged()
            && let Some((x, y)) = r.interact_pointer_pos().map(px)
        {
            result = self.drag_to(x, y);
        }
        if r.drag_stopped() {
            self.end_drag();
        }
        let scroll = ui.input(|i| i.smooth_scroll_delta.y);
        let turned = match r.hover_pos().map(px) {
            Some((x, y)) if scroll != 0.0 => match self.pick_object(x, y).or(self.selected_object()) {
                Some(k) => self.turn_object(k, scroll * super::drag::TURN_DEG_PER_SCROLL_POINT),
                None => Ok(()),
            },
            _ => Ok(()),
        };
        if let Err(e) = result.and(turned) {
            self.error = Some(e);
        }
    }

    fn feed_ui(&mut self, ui: &mut egui::Ui) {
        let status = self.capture.status();
        if let SourceState::Lost { reason, .. } = &status.state {
            let every = self.capture.options().retry;
            let every = if every >= Duration::from_secs(1) { format!("{:.0} s", every.as_secs_f64()) } else { format!("{} ms", every.as_millis()) };
            ui.label(RichText::new(format!("Camera lost — retrying every {every}. {reason}")).color(Color32::from_rgb(235, 80, 70)).strong());
        }
        match (&self.texture, &self.last) {
            (Some(t), Some(s)) => {
                let (w, h) = (s.composited.width as f32, s.composited.height as f32);
                let avail = ui.available_size();
                let k = (avail.x / w).min(avail.y / h).max(0.1);
                let image = egui::Image::new((t.id(), egui::vec2(w * k, h * k))).alt_text(FEED_ALT_TEXT);
                if self.can_move_objects() {
                    let r = ui.add(image.sense(egui::Sense::click_and_drag()));
                    self.pointer_ui(&r, ui, k);
                } else {
                    ui.add(image);
                }
            }
            _ => {
                ui.label("waiting for frames…");
            }
        }
    }
}
