//! The GPU side of `heliar bench lamps` (issue 16 §5): the compositor's frame time with lamps on
//! the software GPU, against the light field's grid, the frame size and object, and the number
//! of far-field lamps; and the shadow-map size against the scene's path-traced references.
//!
//! Frame times are the median of [`TIMED_FRAMES`] renders of one footage frame after a warm-up
//! render, each after `Compositor::invalidate` (stencil and lamp shadow maps redrawn: the cost of
//! a frame in which something moved), incl. readback. The time-only sweeps light the frame as at
//! night (`Pd = 0`, a dim uniform `Pa`, zero probes, every lamp at `k = 1`), so the lamp stage is
//! the work that varies.

use anyhow::{Context, Result, bail};
use glam::Vec3;
use heliar::geometry::Mesh;
use heliar::gpu::{Gpu, GpuOptions};
use heliar::io::image::LinearImage;
use heliar::lamps::Lamp;
use heliar::lamps::lightfield::{FilterGrid, LightField};
use heliar::lamps::model::Model;
use heliar::lighting::{LampScales, Lighting};
use heliar::render::frame::pass;
use heliar::render::lamps::LampOptions;
use heliar::render::{Compositor, CompositorConfig, VideoFrame};
use heliar::scene::lights::world_from_lamp;
use heliar::scene::{Light, LightKind, Scene, Schedule};
use heliar::geometry::raycast::RayScene;
use std::path::PathBuf;
use std::sync::Arc;

/// Timed renders per setting (the median is reported).
pub const TIMED_FRAMES: usize = 5;
/// Dim uniform ambient of the time-only sweeps (a night sky's order, scene units).
const NIGHT_PA: f32 = 1e-3;

/// The scene, the GPU and one footage frame to composite.
pub struct GpuBench {
    pub scene: Scene,
    pub ray: Arc<RayScene>,
    pub gpu: Arc<Gpu>,
    /// The last frame of the scene's first sequence.
    pub video: VideoFrame,
}

impl GpuBench {
    pub fn new(scene_dir: &std::path::Path) -> Result<Self> {
        let (scene, ray) = crate::common::load_scene(scene_dir)?;
        if scene.virtual_objects.is_empty() {
            bail!("{}: no [[virtual_objects]] for the lamps to light", scene.root.join(heliar::scene::MANIFEST_FILE).display());
        }
        let seq = scene.sequences.first().context("the scene has no [[sequences]]")?;
        let path = seq.files.last().context("the scene's first sequence has no frames")?;
        let frame = heliar::io::frames::Frame::load(path).with_context(|| format!("reading {}", path.display()))?;
        let video = VideoFrame::from_frame(&frame, &seq.photometry.linearizer());
        let gpu = Arc::new(Gpu::new(GpuOptions { samples: 4 })?);
        Ok(Self { scene, ray, gpu, video })
    }

    /// The scene's lamps as its manifest declares them.
    pub fn scene_lamps(&self) -> Result<Vec<Lamp>> {
        Ok(Lamp::load_all(&self.scene.root.join(heliar::scene::MANIFEST_FILE), &self.scene.lights)?)
    }

    /// The centre of the virtual objects' bounds.
    pub fn objects_centre(&self) -> Vec3 {
        let b = self.scene.virtual_objects.iter().filter_map(|o| o.mesh.bounds()).reduce(|(a, b), (c, d)| (a.min(c), b.max(d)));
        b.map_or(Vec3::ZERO, |(lo, hi)| 0.5 * (lo + hi))
    }

    /// A compositor for `scene` (this one's, or a variant), without lamps.
    pub fn compositor(&self, scene: &Scene) -> Result<Compositor> {
        let mut c = Compositor::for_scene(self.gpu.clone(), scene, self.ray.clone(), CompositorConfig::for_scene(scene)).with_context(|| format!("setting up the compositor for {}", scene.root.display()))?;
        c.set_lamps(&[], LampOptions::default())?;
        Ok(c)
    }
}

/// The night lighting of the time-only sweeps with `lamps` lamps at `k = 1`.
pub fn night(lamps: usize) -> Lighting {
    Lighting { sun_dir: Vec3::Y, above_horizon: false, pd: Vec3::ZERO, pa: Vec3::splat(NIGHT_PA), sky: heliar::lighting::FrameSky::Uniform, lamps: LampScales::from_slice(&vec![[1.0; 3]; lamps]) }
}

/// Median frame time (module docs), ms, and whether the lamp term ran.
pub fn frame_ms(comp: &mut Compositor, video: &VideoFrame, lighting: &Lighting) -> Result<(f64, bool)> {
    let (_, report) = comp.render(video, lighting)?;
    let mut ms = Vec::with_capacity(TIMED_FRAMES);
    for _ in 0..TIMED_FRAMES {
        comp.invalidate();
        let t = std::time::Instant::now();
        comp.render(video, lighting)?;
        ms.push(t.elapsed().as_secs_f64() * 1e3);
    }
    Ok((heliar::report::median(&ms), report.ran(pass::LAMP_TERM)))
}

/// A lamp at `position` aimed at `at`.
fn light(name: &str, kind: LightKind, position: Vec3, at: Vec3) -> Result<Light> {
    let world_from_lamp = world_from_lamp((at - position).as_dvec3(), 0.0).with_context(|| format!("{name}: the lamp sits on its target"))?;
    Ok(Light { name: name.into(), field: "bench".into(), kind, position: position.as_dvec3(), world_from_lamp, scale: 1.0, schedule: Schedule::Always })
}

/// A light-field lamp of `counts` filter positions and `texels`² constant images (the GPU's
/// cost does not depend on the images' values) 30 cm from its sampling plane, its 80 cm plane
/// spanning a ±53° beam, at `position` aimed at `at`.
pub fn light_field_lamp(counts: [usize; 2], texels: u32, position: Vec3, at: Vec3) -> Result<Lamp> {
    let grid = FilterGrid { counts, spacing_m: 0.02 };
    let images = (0..counts[0] * counts[1]).map(|_| LinearImage::from_fn(texels, texels, |_, _| [1.0, 0.9, 0.7])).collect();
    let origin = PathBuf::from(format!("<bench {}x{} light field>", counts[0], counts[1]));
    let lf = LightField::new(grid, 0.3, [0.8, 0.8], images, &origin)?;
    let light = light(&origin.to_string_lossy(), LightKind::LightField { dir: origin.clone() }, position, at)?;
    Ok(Lamp { light, model: Model::Field(Box::new(lf)) })
}

/// `n` copies of `lamp` on a ring of radius 2 m about `centre`, at the lamp's height, each aimed
/// as the original.
pub fn ring_of(lamp: &Lamp, n: usize, centre: Vec3) -> Vec<Lamp> {
    (0..n)
        .map(|i| {
            let a = std::f32::consts::TAU * i as f32 / n.max(1) as f32;
            let mut l = lamp.clone();
            l.light.position = glam::DVec3::new((centre.x + 2.0 * a.cos()) as f64, lamp.light.position.y, (centre.z + 2.0 * a.sin()) as f64);
            l.light.name = format!("{} {i}", lamp.light.name);
            l
        })
        .collect()
}

/// `scene` with its camera scaled to `width` × `height` (same field of view).
pub fn resized(scene: &Scene, width: u32, height: u32) -> Scene {
    let mut s = scene.clone();
    let k = &mut s.camera.intrinsics;
    let (sx, sy) = (width as f64 / k.width as f64, height as f64 / k.height as f64);
    k.fx *= sx;
    k.fy *= sy;
    k.cx *= sx;
    k.cy *= sy;
    k.width = width;
    k.height = height;
    s
}

/// `video` resampled (nearest texel) to `width` × `height`.
pub fn resized_video(video: &VideoFrame, width: u32, height: u32) -> VideoFrame {
    let rgba = (0..height)
        .flat_map(|y| (0..width).map(move |x| (x, y)))
        .map(|(x, y)| {
            let sx = ((x as u64 * video.width as u64) / width as u64) as u32;
            let sy = ((y as u64 * video.height as u64) / height as u64) as u32;
            video.rgba[(sy * video.width + sx) as usize]
        })
        .collect();
    VideoFrame { width, height, rgba }
}

/// `scene` with its objects replaced by one torus of about `triangles` triangles (major radius
/// 0.5 m, tube 0.2 m, standing 0.2 m above the ground at the objects' place).
pub fn with_torus(scene: &Scene, triangles: usize, centre: Vec3) -> Result<Scene> {
    let mut s = scene.clone();
    // 2 · rings · segments triangles, rings = 5/4 segments.
    let segments = ((triangles as f64 / 2.5).sqrt().round() as u32).max(3);
    let rings = (segments * 5 / 4).max(3);
    let mesh: Mesh = heliar::cuts::shapes::torus(Vec3::new(centre.x, 0.4, centre.z), 0.5, 0.2, rings, segments);
    let mut object = s.virtual_objects.first().context("no virtual object to replace")?.clone();
    object.mesh = mesh;
    object.motion = None;
    s.virtual_objects = vec![object];
    Ok(s)
}

/// Triangles of the scene's virtual objects.
pub fn triangles(scene: &Scene) -> usize {
    scene.virtual_objects.iter().map(|o| o.mesh.triangles.len()).sum()
}

/// A lamp named for the tables, with the GPU's lit spots.
pub struct NamedLamps {
    pub label: String,
    pub lamps: Vec<Lamp>,
}

/// The lamp sets of the frame-size sweep: none, the scene's lamps, and light fields of 5 × 5 and
/// 9 × 7 positions (the paper's Mag-Lite and bike light, Table 1) at the first lamp's place,
/// aimed at the objects.
pub fn table1_lamps(bench: &GpuBench, texels: u32) -> Result<Vec<NamedLamps>> {
    let scene_lamps = bench.scene_lamps()?;
    let at = bench.objects_centre();
    let place = scene_lamps.first().map_or(at + Vec3::new(1.0, 3.0, 1.0), |l| l.light.position.as_vec3());
    Ok(vec![
        NamedLamps { label: "none".into(), lamps: Vec::new() },
        NamedLamps { label: format!("scene ({} far-field)", scene_lamps.len()), lamps: scene_lamps },
        NamedLamps { label: "light field 5x5".into(), lamps: vec![light_field_lamp([5, 5], texels, place, at)?] },
        NamedLamps { label: "light field 9x7".into(), lamps: vec![light_field_lamp([9, 7], texels, place, at)?] },
    ])
}
