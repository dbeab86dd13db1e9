//! Picking proxy points: a wireframe 3D view of the proxy (drag to orbit, scroll to zoom, click
//! a vertex) and a vertex list filtered by node. Vertices shared by several triangles appear once.

use super::SceneState;
use egui::{Color32, Pos2, Sense, Stroke, Vec2};
use glam::DVec3;
use heliar::camera::{Camera, Intrinsics, Pose};
use std::collections::HashMap;

/// A pointer closer than this (screen points) to a projected vertex picks it.
const PICK_PT: f32 = 10.0;
/// Half the vertical field of view of the 3D view.
const HALF_FOV_RAD: f64 = 0.45;

/// A proxy vertex.
#[derive(Clone, Debug, PartialEq)]
pub struct Vertex {
    /// World position, metres.
    pub p: DVec3,
    /// Index of the first node it belongs to.
    pub node: usize,
}

/// The proxy's vertices and the orbit camera.
#[derive(Default)]
pub struct ProxyPicker {
    /// Unique vertices.
    pub vertices: Vec<Vertex>,
    edges: Vec<[DVec3; 2]>,
    version: u64,
    bounds: Option<(DVec3, DVec3)>,
    yaw: f64,
    pitch: f64,
    distance: f64,
    target: DVec3,
    node_filter: Option<usize>,
    hovered: Option<usize>,
}

/// The per-axis median of the vertices and the distance from it within which three quarters of
/// them lie.
fn robust_extent(vertices: &[Vertex]) -> (DVec3, f64) {
    if vertices.is_empty() {
        return (DVec3::ZERO, 1.0);
    }
    let median = |f: fn(&DVec3) -> f64| {
        let mut v: Vec<f64> = vertices.iter().map(|x| f(&x.p)).collect();
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let c = DVec3::new(median(|p| p.x), median(|p| p.y), median(|p| p.z));
    let mut d: Vec<f64> = vertices.iter().map(|v| (v.p - c).length()).collect();
    d.sort_by(f64::total_cmp);
    (c, d[(d.len() * 3 / 4).min(d.len() - 1)].max(0.1))
}

impl ProxyPicker {
    fn prepare(&mut self, state: &SceneState) {
        if self.version == state.version {
            return;
        }
        self.version = state.version;
        let mesh = &state.scene.proxy;
        let mut seen: HashMap<[i64; 3], usize> = HashMap::new();
        self.vertices.clear();
        for (t, tri) in mesh.triangles.iter().enumerate() {
            for &i in tri {
                let p = mesh.positions[i as usize].as_dvec3();
                let key = (p * 1e4).round().as_i64vec3().to_array();
                if !seen.contains_key(&key) {
                    seen.insert(key, self.vertices.len());
                    self.vertices.push(Vertex { p, node: mesh.tri_node[t] as usize });
                }
            }
        }
        self.edges = crate::ops::pose::outline_edges(mesh);
        let bounds = mesh.bounds().map(|(lo, hi)| (lo.as_dvec3(), hi.as_dvec3()));
        if bounds != self.bounds {
            // A new proxy: look at it from the side the scene's camera sees it from.
            self.bounds = bounds;
            // Framed on where most vertices are (a large ground plane has only four corners).
            let (target, radius) = robust_extent(&self.vertices);
            self.target = target;
            self.distance = radius / HALF_FOV_RAD.sin() * 1.1;
            let back = -state.scene.camera.pose.rotation.z_axis;
            self.yaw = back.x.atan2(back.z);
            self.pitch = back.y.asin().max(0.35);
            self.node_filter = None;
        }
    }

    fn camera(&self, w: f32, h: f32) -> Option<Camera> {
        let (cp, sp) = (self.pitch.cos(), self.pitch.sin());
        let eye = self.target + self.distance * DVec3::new(cp * self.yaw.sin(), sp, cp * self.yaw.cos());
        let f = 0.5 * h as f64 / HALF_FOV_RAD.tan();
        let intrinsics = Intrinsics::brown_conrady(w as u32, h as u32, f, f, w as f64 / 2.0 - 0.5, h as f64 / 2.0 - 0.5, [0.0; 5]);
        Some(Camera { intrinsics, pose: Pose::look_at(eye, self.target, DVec3::Y)? })
    }

    /// The 3D view and the vertex list; returns the vertex picked this frame. `assigned` are the
    /// pairs' proxy points (pair index, point), labelled in the view.
    pub fn ui(&mut self, ui: &mut egui::Ui, state: &SceneState, assigned: &[(usize, DVec3)]) -> Option<DVec3> {
        self.prepare(state);
        let mut picked = None;
        ui.label("Proxy: drag to turn, scroll to zoom, click a corner");
        let size = Vec2::new(ui.available_width(), (ui.available_height() * 0.55).clamp(160.0, 420.0));
        let (rect, response) = ui.allocate_exact_size(size, Sense::click_and_drag());
        if response.dragged_by(egui::PointerButton::Primary) {
            let d = response.drag_delta();
            self.yaw -= d.x as f64 * 0.01;
            self.pitch = (self.pitch + d.y as f64 * 0.01).clamp(-1.5, 1.5);
        }
        if response.hovered() {
            let scroll = ui.input(|i| i.smooth_scroll_delta.y);
            self.distance = (self.distance * (-scroll as f64 * 0.002).exp()).max(0.05);
        }
        let painter = ui.painter_at(rect);
        painter.rect_filled(rect, 0.0, Color32::from_gray(18));
        let Some(cam) = self.camera(rect.width(), rect.height()) else { return None };
        let screen = |p: DVec3| cam.project_world(p).map(|uv| rect.min + Vec2::new(uv.x as f32 + 0.5, uv.y as f32 + 0.5));
        for [a, b] in &self.edges {
            if let (Some(a), Some(b)) = (screen(*a), screen(*b)) {
                painter.line_segment([a, b], Stroke::new(1.0, Color32::from_gray(150)));
            }
        }
        let projected: Vec<Option<Pos2>> = self.vertices.iter().map(|v| screen(v.p)).collect();
        if let Some(pos) = response.hover_pos() {
            self.hovered = projected.iter().enumerate().filter_map(|(i, q)| q.map(|q| (i, q.distance(pos)))).filter(|(_, d)| *d < PICK_PT).min_by(|a, b| a.1.total_cmp(&b.1)).map(|(i, _)| i);
        }
        for q in projected.iter().flatten() {
            painter.circle_filled(*q, 2.0, Color32::from_gray(200));
        }
        for (pair, w) in assigned {
            if let Some(q) = screen(*w) {
                painter.circle_filled(q, 4.5, Color32::from_rgb(255, 150, 40));
                painter.text(q + Vec2::new(5.0, -5.0), egui::Align2::LEFT_BOTTOM, format!("{}", pair + 1), egui::FontId::proportional(13.0), Color32::from_rgb(255, 150, 40));
            }
        }
        if let Some(h) = self.hovered
            && let (Some(Some(q)), Some(v)) = (projected.get(h), self.vertices.get(h))
        {
            painter.circle_stroke(*q, 6.0, Stroke::new(2.0, Color32::WHITE));
            let name = state.scene.proxy.nodes.get(v.node).map_or("", |n| n.name.as_str());
            painter.text(*q + Vec2::new(8.0, 8.0), egui::Align2::LEFT_TOP, format!("{name} ({:.2}, {:.2}, {:.2})", v.p.x, v.p.y, v.p.z), egui::FontId::proportional(13.0), Color32::WHITE);
            if response.clicked() {
                picked = Some(v.p);
            }
        }
        ui.horizontal(|ui| {
            let label = ui.label("Vertices of");
            let nodes = &state.scene.proxy.nodes;
            let current = self.node_filter.and_then(|i| nodes.get(i)).map_or("all nodes", |n| n.name.as_str());
            egui::ComboBox::from_id_salt("vertex_node")
                .selected_text(current)
                .show_ui(ui, |ui| {
                    ui.selectable_value(&mut self.node_filter, None, "all nodes");
                    for (i, n) in nodes.iter().enumerate() {
                        ui.selectable_value(&mut self.node_filter, Some(i), &n.name);
                    }
                })
                .response
                .labelled_by(label.id);
        });
        egui::ScrollArea::vertical().id_salt("vertex_list").show(ui, |ui| {
            for (i, v) in self.vertices.iter().enumerate().filter(|(_, v)| self.node_filter.is_none_or(|n| n == v.node)) {
                let name = state.scene.proxy.nodes.get(v.node).map_or("", |n| n.name.as_str());
                let r = ui.selectable_label(self.hovered == Some(i), format!("{name}: {:.2}, {:.2}, {:.2}", v.p.x, v.p.y, v.p.z));
                if r.hovered() {
                    self.hovered = Some(i);
                }
                if r.clicked() {
                    picked = Some(v.p);
                }
            }
        });
        picked
    }
}
