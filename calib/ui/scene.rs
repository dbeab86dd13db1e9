//! The open scene, and the choice of the frame the pose and mark tabs show.

use super::view::{Picture, srgb8_from_linear};
use anyhow::{Context, Result, bail};
use heliar::opencv_calib::Rgb8;
use heliar::geometry::raycast::RayScene;
use heliar::io::image::LinearImage;
use heliar::scene::Scene;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// Counts scene loads, so cached views know when the scene they were made for has changed.
static LOADS: AtomicU64 = AtomicU64::new(0);

/// A loaded scene folder with its ray-cast structure.
pub struct SceneState {
    /// The folder.
    pub dir: PathBuf,
    /// The validated scene.
    pub scene: Scene,
    /// Ray casts against the proxy.
    pub rays: RayScene,
    /// Changes whenever the scene is (re)loaded; caches compare it.
    pub version: u64,
}

impl SceneState {
    /// Loads and validates `dir`.
    pub fn load(dir: &Path) -> Result<Self> {
        let scene = Scene::load(dir).with_context(|| format!("loading {}", dir.display()))?;
        Ok(Self::from_scene(dir, scene))
    }

    /// Wraps a scene that was just loaded (e.g. returned by an edit).
    pub fn from_scene(dir: &Path, scene: Scene) -> Self {
        let rays = RayScene::new(scene.proxy.clone());
        Self { dir: dir.to_owned(), scene, rays, version: LOADS.fetch_add(1, Ordering::Relaxed) + 1 }
    }

    /// Replaces the scene after an edit.
    pub fn replace(&mut self, scene: Scene) {
        *self = Self::from_scene(&self.dir.clone(), scene);
    }

    /// The camera file's path.
    pub fn camera_file(&self) -> PathBuf {
        self.dir.join(&self.scene.manifest.camera.file)
    }

    /// One line about the scene for the top bar.
    pub fn summary(&self) -> String {
        let s = &self.scene;
        let k = &s.camera.intrinsics;
        format!(
            "{}: camera {}×{}, {} proxy triangles in {} nodes ({} marked diffuse), {} sequence(s){}",
            s.manifest.name,
            k.width,
            k.height,
            s.proxy.triangles.len(),
            s.proxy.nodes.len(),
            s.proxy.nodes.iter().filter(|n| n.diffuse).count(),
            s.sequences.len(),
            if s.manifest.envmap.as_ref().is_some_and(|e| e.file.is_some()) { ", environment map" } else { "" }
        )
    }
}

/// Reads an image for display: EXR (linear, shown with an automatic exposure) or any 8-bit
/// format [`Rgb8::open`] reads.
pub fn read_display_image(path: &Path) -> Result<Rgb8> {
    if !path.is_file() {
        bail!("{}: no such file", path.display());
    }
    if path.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr")) {
        Ok(srgb8_from_linear(&LinearImage::read_exr(path)?, 0.0))
    } else {
        Ok(Rgb8::open(path)?)
    }
}

/// Which frame a tab shows: a frame of one of the scene's sequences, or another image file of
/// the camera's size.
#[derive(Default)]
pub struct FrameChooser {
    /// Sequence index.
    pub sequence: usize,
    /// Frame index within the sequence.
    pub index: usize,
    /// Another image file (used when not empty).
    pub other: String,
    /// The picture shown, and what it was made from.
    loaded: Option<(String, Picture)>,
    /// Why the frame cannot be shown.
    pub error: Option<String>,
}

impl FrameChooser {
    /// The chooser's controls.
    pub fn ui(&mut self, ui: &mut egui::Ui, state: &SceneState) {
        let seqs = &state.scene.sequences;
        if !seqs.is_empty() {
            self.sequence = self.sequence.min(seqs.len() - 1);
            ui.horizontal(|ui| {
                let label = ui.label("Frame:");
                egui::ComboBox::from_id_salt("sequence")
                    .selected_text(&seqs[self.sequence].name)
                    .show_ui(ui, |ui| {
                        for (i, s) in seqs.iter().enumerate() {
                            ui.selectable_value(&mut self.sequence, i, &s.name);
                        }
                    })
                    .response
                    .labelled_by(label.id);
                let n = seqs[self.sequence].files.len();
                ui.add(egui::DragValue::new(&mut self.index).range(0..=n.saturating_sub(1)).prefix("#")).on_hover_text("frame number");
            });
        }
        ui.horizontal(|ui| {
            ui.label("or image:");
            ui.add(egui::TextEdit::singleline(&mut self.other).hint_text("path to a PNG/JPEG/EXR frame").desired_width(180.0));
        });
    }

    /// The file to show.
    pub fn path(&self, state: &SceneState) -> Option<PathBuf> {
        if !self.other.trim().is_empty() {
            return Some(PathBuf::from(self.other.trim()));
        }
        let seq = state.scene.sequences.get(self.sequence)?;
        seq.files.get(self.index.min(seq.files.len().saturating_sub(1))).cloned()
    }

    /// The picture of the chosen frame, loaded when the choice changes; `None` (and
    /// [`Self::error`] set) when there is none or it cannot be used.
    pub fn picture(&mut self, state: &SceneState) -> Option<&mut Picture> {
        let Some(path) = self.path(state) else {
            self.error = Some("the scene has no frames: give an image of the camera's view".into());
            self.loaded = None;
            return None;
        };
        let k = &state.scene.camera.intrinsics;
        let key = format!("{}|{}×{}", path.display(), k.width, k.height);
        if self.loaded.as_ref().is_none_or(|(key0, _)| *key0 != key) {
            self.loaded = None;
            let loaded = read_display_image(&path).and_then(|img| {
                if (img.width, img.height) != (k.width, k.height) {
                    bail!("{}: {}×{} but the camera is calibrated for {}×{}", path.display(), img.width, img.height, k.width, k.height);
                }
                Ok(Picture::from_rgb8(&key, &img))
            });
            match loaded {
                Ok(p) => {
                    self.loaded = Some((key, p));
                    self.error = None;
                }
                Err(e) => {
                    // Remember the failure so the file is not read again every frame.
                    self.error = Some(format!("{e:#}"));
                    self.loaded = Some((key, Picture::from_rgb8("none", &Rgb8 { width: 1, height: 1, data: vec![0; 3] })));
                }
            }
        }
        if self.error.is_some() {
            return None;
        }
        self.loaded.as_mut().map(|(_, p)| p)
    }
}
