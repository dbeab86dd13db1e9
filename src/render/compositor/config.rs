//! The compositor's settings and the plain values it takes and gives: the configuration, the
//! pass switches, what it draws ([`SceneParts`]) and a frame read back ([`RenderedFrame`]).

use super::Builder;
use crate::camera::Camera;
use crate::geometry::Mesh;
use crate::geometry::ambient::TransportQuality;
use crate::io::image::LinearImage;
use crate::render::frame::Darkening;
use crate::render::volume::OPEN_CAP_OFFSET_M;
use crate::scene::Scene;
use crate::scene::settings::EstimatorConfig;
use crate::sky::radiance::SkyModel;

/// Default largest sun motion (degrees) over which volumes and stencil are reused: the shadow of
/// an occluder 5 m from its receiver moves 4 mm, a fraction of a pixel at courtyard distances.
pub const REUSE_SUN_DEG: f64 = 0.05;

/// Default paths per frame of each sun-dependent re-trace (the receivers' `b`, the objects'
/// `R_d`) after a sun move. On this machine's two shared cores (dev build, load 5) 2¹⁴ paths
/// took a median 12 ms for the receivers and 23 ms for the transfer, but up to 78 ms for the
/// transfer, which put the slowest frame at 162 ms beside the software GPU's ~50 ms; 2¹³ keeps
/// every frame under 150 ms (`heliar bench render --knob moving-sun`, docs/measurements.md). A
/// re-trace of the bundled courtyard then takes 334 frames for the receivers (5344 pixels, 11 s
/// of 30 fps footage, in which the sun moves 0.05°) and 42 for the transfer.
pub const TRACE_PATHS_PER_FRAME: u64 = 1 << 13;

/// Relative error of a value stored as a half float (11 significant bits; conversion may
/// truncate, so one unit in the last place).
pub const HALF_PRECISION: f32 = 1.0 / 1024.0;

/// Compositor settings.
#[derive(Clone, Debug, PartialEq)]
pub struct CompositorConfig {
    /// Canvas pixels per footage pixel (≥ 1).
    pub supersample: f64,
    /// How real pixels under a virtual shadow are darkened.
    pub darkening: Darkening,
    /// Add the sun bounce `b·Pd` to the ambient of the darkening ratio.
    pub sun_bounce: bool,
    /// Virtual volume builder.
    pub builder: Builder,
    /// Sun motion (degrees) below which volumes and stencil are reused.
    pub reuse_sun_deg: f64,
    /// `Pd/Pa` (luminance) below which there is no sun term and no volume.
    pub no_sun_ratio: f64,
    /// Cap offset of per-triangle volumes, metres.
    pub cap_offset_m: f32,
    /// Also produce the warped debug masks (the 3D passes then cover the whole canvas, so the
    /// masks are complete).
    pub debug_masks: bool,
    /// Scissor the 3D passes to the canvas region the objects and their shadows can reach
    /// ([`crate::render::region`]); off, they cover the whole canvas (same picture, more time).
    pub scissor: bool,
    /// Quality of `c` (without bounce).
    pub ambient_quality: TransportQuality,
    /// Quality of `c` and `b` together.
    pub bounce_quality: TransportQuality,
    /// Sun motion (degrees) after which `b` is recomputed.
    pub bounce_rebuild_deg: f64,
    /// Rays per canvas pixel of the virtual objects' own ambient occlusion (0: none), the
    /// ambient's fallback where the per-pixel transfer has no entry.
    pub occlusion_rays: u32,
    /// Paths per canvas pixel of the virtual objects' ambient transfer ([`crate::render::object_transfer`]);
    /// 0 turns it off (ambient from the probe grid times ambient occlusion everywhere).
    pub transfer_paths: u32,
    /// Surface hits per path of the transfer.
    pub transfer_bounces: u32,
    /// Lattice spacing of the transfer's traced pixels (0: automatic, within
    /// [`crate::render::object_transfer::TRANSFER_PATH_BUDGET`]).
    pub transfer_stride: u32,
    /// Paths each of the receivers' `b` and the objects' `R_d` may trace per frame when they
    /// are re-traced after a sun move (0: unbounded, the whole re-trace in the frame that decides
    /// it). The re-trace is then done a slice per frame while the previous values serve.
    pub trace_paths_per_frame: u64,
    /// The sky the objects' transfer sees when its paths leave the proxy (the scene's
    /// `[estimator.sky]`, so that the estimator and the renderer agree on it).
    pub sky: SkyModel,
    /// Seed of the integrals.
    pub seed: u64,
}

impl CompositorConfig {
    /// Defaults that follow the scene's estimator settings (same `c`, `b` quality, bounce on or
    /// off, no-sun threshold).
    pub fn for_scene(scene: &Scene) -> Self {
        Self::from_estimator_settings(&scene.estimator)
    }

    /// Defaults that follow the scene's `[estimator]` settings (plain data from
    /// [`crate::scene::settings`]): the same `c`, `b` quality, bounce on or off, no-sun threshold.
    pub fn from_estimator_settings(e: &EstimatorConfig) -> Self {
        Self {
            supersample: 1.0,
            darkening: Darkening::default(),
            sun_bounce: e.sun_bounce,
            builder: Builder::Cpu,
            reuse_sun_deg: REUSE_SUN_DEG,
            no_sun_ratio: e.no_sun_ratio,
            cap_offset_m: OPEN_CAP_OFFSET_M,
            debug_masks: false,
            scissor: true,
            ambient_quality: e.ambient,
            bounce_quality: e.bounce,
            bounce_rebuild_deg: e.sun_rebuild_deg,
            occlusion_rays: crate::render::occlusion::AO_RAYS,
            transfer_paths: crate::render::object_transfer::TRANSFER_PATHS,
            transfer_bounces: crate::render::object_transfer::TRANSFER_BOUNCES,
            transfer_stride: 0,
            trace_paths_per_frame: TRACE_PATHS_PER_FRAME,
            sky: e.sky.sky_model(),
            seed: e.seed,
        }
    }
}

/// Passes a viewer can switch off (all on by default). A pass switched off is listed in the
/// frame's [`crate::render::PassReport::skipped`] with the reason given to [`super::Compositor::set_switches`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PassSwitches {
    /// The virtual objects and everything they need (off: the footage passes through).
    pub virtual_objects: bool,
    /// The virtual objects' shadow volumes: their shadows on real surfaces and on themselves.
    pub virtual_volumes: bool,
    /// The real proxy's shadow volumes: real shadows on the virtual objects (and real shadow
    /// that keeps a virtual shadow from darkening twice).
    pub real_volumes: bool,
    /// The objects' per-pixel ambient transfer (off: the probe grid times ambient occlusion
    /// everywhere). Without effect when the compositor was built with `transfer_paths = 0`.
    pub transfer: bool,
}

impl Default for PassSwitches {
    fn default() -> Self {
        Self { virtual_objects: true, virtual_volumes: true, real_volumes: true, transfer: true }
    }
}

/// A composited frame read back to the CPU.
#[derive(Clone, Debug)]
pub struct RenderedFrame {
    /// Linear radiance of the output.
    pub image: LinearImage,
    /// Warped masks per pixel (`r` virtual shadow on real, `g` real shadow, `b` virtual surface
    /// without sun, `a` virtual surface), when debug masks are on.
    pub masks: Option<Vec<[u8; 4]>>,
    /// Relative precision of `image`: 0 for a 32-bit float output, 2⁻¹⁰ for a half-float one
    /// (GL cannot render to 32-bit float). Pixels the composite left alone equal the footage
    /// within it.
    pub precision: f32,
}

/// What the compositor draws: the camera, the real proxy and the virtual objects (world
/// coordinates), with names for warnings.
#[derive(Clone, Copy, Debug)]
pub struct SceneParts<'a> {
    /// The calibrated camera.
    pub camera: &'a Camera,
    /// The real proxy.
    pub proxy: &'a Mesh,
    /// Name of the proxy (its file).
    pub proxy_name: &'a str,
    /// Virtual objects and their names.
    pub objects: &'a [(String, &'a Mesh)],
}

impl<'a> SceneParts<'a> {
    /// The names of a scene's virtual objects (their file names), for [`SceneParts::objects`].
    pub fn object_list(scene: &'a Scene) -> Vec<(String, &'a Mesh)> {
        scene.virtual_objects.iter().map(|o| (file_name(&o.path), &o.mesh)).collect()
    }

    /// The parts of a loaded scene; `objects` from [`SceneParts::object_list`].
    pub fn of(scene: &'a Scene, objects: &'a [(String, &'a Mesh)]) -> Self {
        Self { camera: &scene.camera, proxy: &scene.proxy, proxy_name: &scene.manifest.proxy.file, objects }
    }
}

fn file_name(p: &std::path::Path) -> String {
    p.file_name().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| p.display().to_string())
}
