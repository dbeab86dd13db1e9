//! The Mark tab: click the frame (or the environment map) → ray cast → toggle the proxy node
//! under the pointer as a diffuse estimation surface. Marked nodes are tinted (green: listed in
//! the manifest, blue: marked by the glTF extras), the node under the pointer is highlighted.

use super::scene::FrameChooser;
use super::view::{ImageView, Picture, Transform, srgb8_from_linear};
use super::{Messages, SceneState};
use crate::ops::mark::{self as ops, Marked};
use anyhow::{Context, Result, bail};
use egui::{Color32, Pos2, Rect, Vec2};
use glam::{DVec2, DVec3};
use heliar::io::image::LinearImage;
use heliar::camera::View;
use rayon::prelude::*;

/// Node maps (for tints and hovering) have at most this many cells; larger images are sampled.
const MAX_MAP_CELLS: u32 = 400_000;
/// No proxy geometry in a cell.
const NONE: u32 = u32::MAX;

/// The node seen through each cell of an image (for tints, hovering and pixel counts).
pub struct NodeMap {
    /// Image pixels per cell side.
    step: u32,
    w: u32,
    h: u32,
    nodes: Vec<u32>,
}

impl NodeMap {
    fn build(state: &SceneState, view: View, size: [u32; 2]) -> Self {
        let step = ((size[0] as f64 * size[1] as f64 / MAX_MAP_CELLS as f64).sqrt().ceil() as u32).max(1);
        let (w, h) = (size[0].div_ceil(step), size[1].div_ceil(step));
        let nodes = (0..h)
            .into_par_iter()
            .flat_map_iter(|j| {
                let view = view;
                (0..w).map(move |i| {
                    let (x, y) = ((i * step + step / 2).min(size[0] - 1), (j * step + step / 2).min(size[1] - 1));
                    view.ray(x, y).and_then(|(o, d)| ops::node_along(&state.scene, &state.rays, o, d)).map_or(NONE, |n| n as u32)
                })
            })
            .collect();
        Self { step, w, h, nodes }
    }

    fn at(&self, uv: DVec2) -> Option<usize> {
        let (i, j) = ((uv.x + 0.5) / self.step as f64, (uv.y + 0.5) / self.step as f64);
        if i < 0.0 || j < 0.0 || i >= self.w as f64 || j >= self.h as f64 {
            return None;
        }
        let n = self.nodes[j as usize * self.w as usize + i as usize];
        (n != NONE).then_some(n as usize)
    }
}

/// The tab's state.
#[derive(Default)]
pub struct MarkTab {
    /// Show the environment map instead of the camera frame.
    pub on_env: bool,
    /// The frame shown.
    pub frame: FrameChooser,
    /// The view (frame or map).
    pub view: ImageView,
    /// The node under the pointer.
    pub hovered: Option<usize>,
    /// What the last action said.
    pub messages: Messages,
    env: Option<(u64, Result<Picture, String>)>,
    map: Option<((u64, bool), NodeMap)>,
    tint: Option<((u64, bool, Option<usize>), Picture)>,
}

impl MarkTab {
    /// The environment map's ray source, when the scene has a map and it has been loaded.
    fn env_view(&self, state: &SceneState) -> Option<View<'static>> {
        let spec = state.scene.manifest.envmap.as_ref()?;
        let (_, Ok(pic)) = self.env.as_ref()? else { return None };
        Some(View::Equirect { centre: DVec3::from(spec.capture_center), width: pic.size[0], height: pic.size[1] })
    }

    /// The node seen at pixel `uv` of the current view.
    pub fn node_at(&mut self, state: &SceneState, uv: DVec2) -> Result<usize> {
        if !self.on_env {
            return ops::node_at_pixel(&state.scene, &state.rays, uv);
        }
        self.load_env(state);
        let Some(View::Equirect { centre, width, height }) = self.env_view(state) else { bail!("the scene has no environment map to click on") };
        if !(uv.x >= -0.5 && uv.y >= -0.5 && uv.x <= width as f64 - 0.5 && uv.y <= height as f64 - 0.5) {
            bail!("texel {:.1},{:.1} is outside the {width}×{height} map", uv.x, uv.y);
        }
        let d = heliar::geometry::equirect::dir_from_texel(uv.x as f32 + 0.5, uv.y as f32 + 0.5, width, height).as_dvec3();
        ops::node_along(&state.scene, &state.rays, centre, d).with_context(|| format!("texel {:.0},{:.0} looks at the sky, not at proxy geometry", uv.x, uv.y))
    }

    /// Marks or unmarks the node seen at `uv` (one validated, atomic edit of the manifest).
    pub fn toggle_at(&mut self, state: &mut SceneState, uv: DVec2) -> Result<String> {
        let node = self.node_at(state, uv)?;
        self.toggle_node(state, node)
    }

    /// Marks node `index` if it is not marked, unmarks it if the manifest lists it. A node the
    /// glTF extras mark is not unmarked by a click (`heliar-calib mark --unmark` records the
    /// override); one unmarked that way is marked again by a click.
    pub fn toggle_node(&mut self, state: &mut SceneState, index: usize) -> Result<String> {
        let name = state.scene.proxy.nodes.get(index).map(|n| n.name.clone()).context("no such node")?;
        let m = ops::marked(&state.scene, index);
        if m == Marked::Extras {
            bail!(
                "'{name}' is marked in the proxy's glTF extras ({}); edit the proxy, or override it with `heliar-calib mark --unmark --node {name}` (proxy.not_diffuse_nodes)",
                state.scene.manifest.proxy.file
            );
        }
        let (unmark, verb) = if m == Marked::Manifest { (true, "unmarked") } else { (false, "marked") };
        let extras = if state.scene.manifest.proxy.not_diffuse_nodes.is_empty() { Vec::new() } else { ops::marked_by_extras(&state.scene)? };
        let (list, not) = ops::updated_lists(&state.scene, std::slice::from_ref(&name), unmark, |n| !unmark && extras.iter().any(|x| x == n));
        let not = (not != state.scene.manifest.proxy.not_diffuse_nodes).then_some(not);
        let scene = ops::set_marks(&state.dir, &list, not.as_deref()).with_context(|| format!("'{name}' was not {verb}"))?;
        state.replace(scene);
        let still = if verb == "unmarked" && ops::marked(&state.scene, index) == Marked::Extras { " (the glTF extras still mark it)" } else { "" };
        Ok(format!("{verb} '{name}'{still}; scene.toml: proxy.diffuse_nodes = {list:?}"))
    }

    fn load_env(&mut self, state: &SceneState) {
        if self.env.as_ref().is_some_and(|(v, _)| *v == state.version) {
            return;
        }
        let pic = match state.scene.manifest.envmap.as_ref().and_then(|e| e.file.as_ref()) {
            None => Err("the scene has no environment map".to_string()),
            Some(f) => {
                let path = state.dir.join(f);
                LinearImage::read_exr(&path).map(|img| Picture::from_rgb8("envmap", &srgb8_from_linear(&img, 0.0))).map_err(|e| e.to_string())
            }
        };
        self.env = Some((state.version, pic));
    }

    /// The tab.
    pub fn ui(&mut self, ui: &mut egui::Ui, state: &mut SceneState) {
        let has_env = state.scene.manifest.envmap.as_ref().is_some_and(|e| e.file.is_some());
        self.on_env &= has_env;
        let counts = self.map.as_ref().filter(|(k, _)| *k == (state.version, self.on_env)).map(|(_, m)| {
            let mut c = vec![0usize; state.scene.proxy.nodes.len()];
            for &n in &m.nodes {
                if let Some(x) = c.get_mut(n as usize) {
                    *x += 1;
                }
            }
            c
        });
        egui::Panel::left("mark_controls").default_size(340.0).show(ui, |ui| {
            ui.horizontal(|ui| {
                ui.radio_value(&mut self.on_env, false, "Camera frame");
                ui.add_enabled_ui(has_env, |ui| ui.radio_value(&mut self.on_env, true, "Environment map"));
            });
            if !self.on_env {
                self.frame.ui(ui, state);
            }
            ui.label("Click a surface to mark or unmark it. Mark brick, plaster, paving: matt, dry surfaces; not glass, water, metal or vegetation.");
            ui.separator();
            let mut toggle = None;
            egui::Grid::new("nodes").num_columns(3).striped(true).show(ui, |ui| {
                for (i, n) in state.scene.proxy.nodes.iter().enumerate() {
                    let m = ops::marked(&state.scene, i);
                    let mut on = m != Marked::No;
                    let r = ui.add_enabled(m != Marked::Extras, egui::Checkbox::new(&mut on, &n.name));
                    if r.clicked() {
                        toggle = Some(i);
                    }
                    ui.label(match m {
                        Marked::No => "",
                        Marked::Manifest => "manifest",
                        Marked::Extras => "glTF extras",
                    });
                    ui.label(counts.as_ref().and_then(|c| c.get(i)).filter(|c| **c > 0).map_or(String::new(), |c| format!("{c} px")));
                    ui.end_row();
                }
            });
            if let Some(i) = toggle {
                let r = self.toggle_node(state, i);
                self.messages.set_result(r);
            }
            ui.separator();
            self.messages.ui(ui);
        });
        egui::CentralPanel::default().show(ui, |ui| self.image_ui(ui, state));
    }

    fn image_ui(&mut self, ui: &mut egui::Ui, state: &mut SceneState) {
        let key = (state.version, self.on_env);
        let (pic, view) = if self.on_env {
            self.load_env(state);
            let view = self.env_view(state);
            match (&mut self.env, view) {
                (Some((_, Ok(p))), Some(v)) => (p, v),
                (Some((_, Err(e))), _) => {
                    ui.colored_label(Color32::from_rgb(235, 80, 70), e.as_str());
                    return;
                }
                _ => return,
            }
        } else {
            match self.frame.picture(state) {
                Some(p) => (p, View::Camera(&state.scene.camera)),
                None => {
                    ui.colored_label(Color32::from_rgb(235, 80, 70), self.frame.error.clone().unwrap_or_default());
                    return;
                }
            }
        };
        if self.map.as_ref().is_none_or(|(k, _)| *k != key) {
            self.map = Some((key, NodeMap::build(state, view, pic.size)));
        }
        let (response, t) = self.view.show(ui, pic);
        let Some((_, map)) = &self.map else { return };
        self.hovered = response.hover_pos().and_then(|p| map.at(t.pixel_from_screen(p)));
        let tint_key = (state.version, self.on_env, self.hovered);
        if self.tint.as_ref().is_none_or(|(k, _)| *k != tint_key) {
            self.tint = Some((tint_key, tint(state, map, self.hovered)));
        }
        if let Some((_, tint)) = &mut self.tint {
            draw_map_picture(ui, &t, map, tint);
        }
        if let (Some(h), Some(pos)) = (self.hovered, response.hover_pos()) {
            let name = state.scene.proxy.nodes.get(h).map_or("", |n| n.name.as_str());
            let what = match ops::marked(&state.scene, h) {
                Marked::No => "click to mark",
                Marked::Manifest => "marked; click to unmark",
                Marked::Extras => "marked in the glTF extras",
            };
            ui.painter_at(t.clip).text(pos + Vec2::new(14.0, 14.0), egui::Align2::LEFT_TOP, format!("{name}: {what}"), egui::FontId::proportional(14.0), Color32::WHITE);
        }
        if response.clicked()
            && let Some(pos) = response.interact_pointer_pos()
        {
            let r = self.toggle_at(state, t.pixel_from_screen(pos));
            self.messages.set_result(r);
        }
    }
}

/// Tint colours (RGBA) for marked nodes, by how they are marked, and the hovered node.
fn tint(state: &SceneState, map: &NodeMap, hovered: Option<usize>) -> Picture {
    let marks: Vec<Marked> = (0..state.scene.proxy.nodes.len()).map(|i| ops::marked(&state.scene, i)).collect();
    let rgba: Vec<u8> = map
        .nodes
        .iter()
        .flat_map(|&n| {
            let m = marks.get(n as usize).copied();
            let base = match m {
                Some(Marked::Manifest) => [40, 220, 90, 105],
                Some(Marked::Extras) => [60, 140, 255, 105],
                _ => [0, 0, 0, 0],
            };
            if n != NONE && hovered == Some(n as usize) { [base[0].max(200), base[1].max(200), base[2].max(200), 80] } else { base }
        })
        .collect();
    Picture::from_rgba_nearest("tint", [map.w * map.step, map.h * map.step], [map.w, map.h], &rgba)
}

/// Draws a picture made of node-map cells over the image.
fn draw_map_picture(ui: &egui::Ui, t: &Transform, map: &NodeMap, pic: &mut Picture) {
    let size = Vec2::new((map.w * map.step) as f32, (map.h * map.step) as f32) * t.scale();
    let rect = Rect::from_min_size(t.rect.min, size);
    t.image_painter(ui).image(pic.texture(ui.ctx()), rect, Rect::from_min_max(Pos2::ZERO, Pos2::new(1.0, 1.0)), Color32::WHITE);
}
