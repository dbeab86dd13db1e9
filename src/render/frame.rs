//! Per-frame inputs and the per-frame report of the compositor.

use crate::io::frames::{Frame, Linearizer, PixelState};
use crate::io::image::LinearImage;
use glam::Vec3;
use serde::Serialize;

/// Rec. 709 luminance of an RGB value.
pub fn luma(v: Vec3) -> f32 {
    v.dot(Vec3::new(0.2126, 0.7152, 0.0722))
}

/// Mirrors `Lighting` in `shaders/common/lighting.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct LightingUniform {
    /// Toward the sun; `w` = 1 when the sun term is on.
    pub sun_dir: [f32; 4],
    /// `Pd`.
    pub pd: [f32; 4],
    /// `Pa`.
    pub pa: [f32; 4],
    /// Darkening model, bounce on, output scale, per-pixel transfer stride (0: off).
    pub params: [f32; 4],
}

/// How real pixels are darkened by the virtual objects.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Darkening {
    /// Where only a virtual shadow falls: `(c·Pa [+ b·Pd]) / (c·Pa + Pd·max(n·l,0) [+ b·Pd])`
    /// with the proxy's normal, weighted ambient and bounce at the pixel.
    Normal,
    /// Jensen's single ratio `Pa / (Pa + Pd)` for every pixel under a virtual shadow.
    Constant,
    /// The ratio of the model's radiance with and without the virtual objects: the normal-aware
    /// shadow, plus the sky and bounce light the objects take from real surfaces near them
    /// (contact shadows), with `c` and `b` computed both ways.
    #[default]
    Differential,
}

impl Darkening {
    /// Value of `Lighting.params.x` in the shaders.
    pub fn shader_code(self) -> f32 {
        match self {
            Darkening::Normal => 0.0,
            Darkening::Constant => 1.0,
            Darkening::Differential => 2.0,
        }
    }
}

/// A footage frame in linear radiance, with a usable flag per pixel (`a` = 1, or 0 when clipped
/// or invalid): the texture the composite reads.
#[derive(Clone, Debug, PartialEq)]
pub struct VideoFrame {
    /// Width.
    pub width: u32,
    /// Height.
    pub height: u32,
    /// Linear RGB and the usable flag, row-major.
    pub rgba: Vec<[f32; 4]>,
}

impl VideoFrame {
    /// Linearises a decoded frame.
    pub fn from_frame(frame: &Frame, lin: &Linearizer) -> Self {
        let rgba = (0..(frame.width * frame.height) as usize)
            .map(|i| {
                let (v, s) = lin.radiance(frame, i);
                match s {
                    PixelState::Ok => [v[0], v[1], v[2], 1.0],
                    PixelState::Clipped => [v[0], v[1], v[2], 0.0],
                    PixelState::Invalid => [0.0; 4],
                }
            })
            .collect();
        Self { width: frame.width, height: frame.height, rgba }
    }

    /// A frame from linear values, every pixel usable.
    pub fn from_linear(img: &LinearImage) -> Self {
        Self { width: img.width, height: img.height, rgba: img.data.iter().map(|p| [p[0], p[1], p[2], 1.0]).collect() }
    }
}

/// A pass or stage left out, and why.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Skipped {
    /// Pass name.
    pub pass: &'static str,
    /// Why.
    pub reason: String,
}

/// Shadow-volume numbers of a frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct VolumeStats {
    /// Triangles of the virtual occluders' volumes (`None` when built on the GPU and not read).
    pub virtual_triangles: Option<usize>,
    /// Triangles of the real occluders' volumes.
    pub real_triangles: usize,
    /// Parts of the real proxy that got a volume.
    pub real_parts: usize,
    /// Built by the compute pass instead of the CPU.
    pub compute: bool,
    /// Volumes and stencil results of an earlier frame reused.
    pub reused: bool,
}

/// Where the time of a frame went, ms.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct FrameTimings {
    /// Shadow-volume construction on the CPU (or recording the compute pass).
    pub volume_build_ms: f64,
    /// Per-pixel `c`/`b` of newly reached pixels.
    pub receivers_ms: f64,
    /// Tracing the virtual objects' ambient transfer (first frame, and when the sun moved).
    pub transfer_ms: f64,
    /// Finding the canvas region of the 3D passes (with the stencil).
    pub region_ms: f64,
    /// Uploads (footage, volumes, surface data, probes, uniforms).
    pub upload_ms: f64,
    /// Recording, submitting and waiting for the render passes.
    pub gpu_ms: f64,
    /// Copying the output to a buffer and mapping it.
    pub readback_ms: f64,
    /// The visibility cuts (issue 15 §2): the objects' per-vertex ambient and the receivers'
    /// sky visibility with the objects present.
    pub cuts_ms: f64,
    /// The receivers' part of `cuts_ms` (their sky visibility with the objects present).
    pub cut_receivers_ms: f64,
}

/// How many receivers a frame evaluated and how many kept their value (the report's
/// `cut_receivers`, `render::compositor`'s `cut_cache`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct CutReceiverCounts {
    /// Receivers whose visibility was evaluated.
    pub evaluated: usize,
    /// Receivers that kept the value stored at an earlier frame (no moved object reaches them).
    pub reused: usize,
}

/// The compositor's report of one frame (part of the per-frame JSON line).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct PassReport {
    /// Passes that ran, in order.
    pub ran: Vec<&'static str>,
    /// Passes left out, with the reason.
    pub skipped: Vec<Skipped>,
    /// Sun term and shadow volumes on.
    pub sun: bool,
    /// Volume numbers.
    pub volumes: VolumeStats,
    /// Pixels whose `c`/`b` were computed this frame.
    pub receivers_computed: usize,
    /// Canvas pixels whose ambient transfer was traced this frame.
    pub transfer_traced: usize,
    /// Receivers whose sky visibility the visibility cuts evaluated this frame, and those that
    /// kept their last value because no object that moved reaches them at its old or new pose
    /// (`render::compositor`'s `cut_cache`); absent when the cuts did not set the receivers.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cut_receivers: Option<CutReceiverCounts>,
    /// Work earlier frames decided on that this frame did instead: a run resumed after an
    /// interruption replays its written frames without their work, and the first new frame
    /// pays what they owe (absent in uninterrupted runs).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub restored: Vec<&'static str>,
    /// Virtual objects that moved this frame (their motion, `scene::motion`), by name; absent
    /// when none did.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub moved: Vec<String>,
    /// The sky the renderer's stages took for this frame (as the estimator names it, e.g.
    /// `"hosek_wilkie T=6"`), when the frame's lighting asked for another than the scene's
    /// declared one: a turbidity fitted per frame, or the uniform sky of an overcast frame
    /// ([`crate::lighting::FrameSky`]); absent otherwise. The objects' transfer and the
    /// receivers' `c`, `b` follow it, re-traced as after a sun move.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sky: Option<String>,
    /// Warnings of this frame (an object outside the irradiance-volume box); absent when none.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub warnings: Vec<String>,
    /// The canvas rectangle the 3D passes drew (`None`: the whole canvas).
    pub canvas_region: Option<crate::render::region::Rect>,
    /// Timings.
    pub timings: FrameTimings,
}

impl PassReport {
    /// Records a skipped pass.
    pub fn skip(&mut self, pass: &'static str, reason: impl Into<String>) {
        self.skipped.push(Skipped { pass, reason: reason.into() });
    }
    /// True when `pass` ran.
    pub fn ran(&self, pass: &str) -> bool {
        self.ran.contains(&pass)
    }
    /// The reason `pass` was skipped, if it was.
    pub fn skip_reason(&self, pass: &str) -> Option<&str> {
        self.skipped.iter().find(|s| s.pass == pass).map(|s| s.reason.as_str())
    }
}

/// Pass names used in reports.
pub mod pass {
    /// Bringing moved virtual objects to their place for the frame (`run::motion`); objects
    /// that did not move are reported skipped under this name.
    pub const OBJECT_MOTION: &str = "object_motion";
    /// The visibility cuts evaluated for the objects' translations (`crate::cuts::frame`):
    /// their ambient per vertex and the receivers' sky visibility; reported, ran or skipped with
    /// its reason, in scenes with moving objects.
    pub const VISIBILITY_CUTS: &str = "visibility_cuts";
    /// One object's part of the visibility cuts, its per-vertex ambient: reported skipped, per
    /// object with its reason, when it was not evaluated or some of its vertices reused their
    /// last value (`crate::cuts::reuse`).
    pub const OBJECT_CUTS: &str = "object_cuts";
    /// CPU (or compute) shadow-volume construction.
    pub const VOLUME_BUILD: &str = "volume_build";
    /// Depth prepass.
    pub const DEPTH_PREPASS: &str = "depth_prepass";
    /// Real occluders' volumes and their resolve.
    pub const REAL_VOLUMES: &str = "real_volumes";
    /// Virtual occluders' volumes and their resolve.
    pub const VIRTUAL_VOLUMES: &str = "virtual_volumes";
    /// Tracing the virtual objects' per-pixel ambient transfer (CPU).
    pub const OBJECT_TRANSFER: &str = "object_transfer";
    /// Virtual object shading.
    pub const VIRTUAL_SHADING: &str = "virtual_shading";
    /// Stencil classes into the coverage mask.
    pub const SHADOW_MASK: &str = "shadow_mask";
    /// The sun term of the virtual objects and the darkening of real pixels.
    pub const SUN_TERM: &str = "sun_term";
    /// The lamps' shadow maps (`render::lamps`).
    pub const LAMP_SHADOWS: &str = "lamp_shadows";
    /// The lamps' light on the virtual objects (`render::lamps`).
    pub const LAMP_TERM: &str = "lamp_term";
    /// The objects' lamp shadows on the real receivers (`render::lamps::ground`).
    pub const LAMP_GROUND: &str = "lamp_ground";
    /// The lamps' light bounced onto the objects off the proxy and the objects
    /// (`render::object_transfer::lamps`), added to their per-pixel ambient.
    pub const LAMP_BOUNCE: &str = "lamp_bounce";
    /// One lamp left out of the lamp term (the reason names it).
    pub const LAMP: &str = "lamp";
    /// The output frame.
    pub const COMPOSITE: &str = "composite";
    /// Copy to the CPU.
    pub const READBACK: &str = "readback";
}
