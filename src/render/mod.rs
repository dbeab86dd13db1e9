//! The GPU compositor: virtual objects merged into outdoor footage, lit by the estimated sun and
//! sky, shadowed by real things and casting shadows onto the real ground (Jensen §3.2–3.4, §5).
//!
//! # How it works
//! Per frame, [`Compositor::render`] takes the footage (linear radiance), the sun direction and
//! the estimated `Pd`, `Pa`; a [`ProbeGrid`](crate::irradiance::ProbeGrid) holds the ambient
//! light ([`probes`]). The passes, each a `src/render/<pass>.rs` beside `shaders/<pass>.wgsl`:
//!
//! | pass | what it does |
//! |---|---|
//! | [`depth_prepass`] | real proxy and virtual objects into depth (never in colour) |
//! | [`shadow_volume`] + [`stencil`] | z-fail shadow volumes of the directional sun, real parts down, virtual up, each resolved to a flag |
//! | [`shadow_mask`] | samples in virtual but not real shadow, real surfaces in real shadow, and virtual-surface samples in any shadow, as MSAA coverage |
//! | [`virtual_shading`] | glTF metallic–roughness sun term on the samples no shadow volume covers (two stencil-split draws); ambient from the per-pixel [`object_transfer`] (`R_a·Pa + R_d·Pd`), or SH ambient per pixel times self-occlusion where it has no entry |
//! | [`lamps`] | the scene's lamps on the virtual objects (Granier §3.2, §4): one additive draw over every lit spot (far-field lamps, light-field filter positions) inside the shading pass, with perspective shadow maps in the VEM atlas |
//! | [`composite`] | in the footage's own pixel grid: lens warp of the canvas layers, footage darkened with the proxy's normal and `c` (and `c_v`, `b_v` with the objects present: contact shadows) |
//!
//! Volumes come from [`occluder`] (welded adjacency, closed or not) and [`volume`] (rayon) or
//! [`volume_compute`] (a compute pass); [`reach`] decides which real parts need one;
//! [`receivers`] holds the proxy's per-pixel normal, `c` and `b`; [`object_transfer`] the objects'
//! per-pixel ambient light, path-traced on the CPU; [`occlusion`] the objects' own ambient
//! occlusion (the fallback's); [`crate::gpu::canvas`] the undistorted canvas and the lens warp; [`output`]
//! writes frames with the camera's response; [`target`] the window surface that shares all of
//! the above; [`reference`] measures composites against reference frames rendered with the
//! objects present; [`vem`] is the VEM mode's renderer, on the same GPU layer.
//!
//! Every pass is a unit ([`plan`]): it says whether it runs for a frame, and why not, before it
//! records its own commands, and what it keeps between frames lives with it. Each renderer's
//! frame is a list of its units read top to bottom ([`compositor`]'s `encode`, [`vem`]'s
//! `render`), and the report's `ran` and `skipped` follow the list.
//!
//! Conventions are the crate's: world +Y up, metres; OpenCV camera; linear scene radiance with
//! `L = ρ/π·(c·Pa + s·Pd·max(n·l,0) [+ b·Pd])`.

pub mod composite;
pub mod compositor;
pub mod depth_prepass;
pub mod frame;
pub mod lamps;
pub mod object_transfer;
pub mod occluder;
pub mod occlusion;
pub mod output;
pub mod plan;
pub mod probes;
pub mod reach;
pub mod receivers;
pub mod reference;
pub mod region;
pub mod shadow_mask;
pub mod shadow_volume;
pub mod stencil;
pub mod target;
pub mod vem;
pub mod virtual_shading;
pub mod volume;
pub mod volume_compute;

pub use compositor::{Builder, Compositor, CompositorConfig, PassSwitches, RenderedFrame, SceneParts, TRACE_PATHS_PER_FRAME};
pub use frame::{Darkening, FrameTimings, PassReport, VideoFrame};

/// Errors of the renderers.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// The GPU layer failed (adapter, device, shaders, limits, surface).
    #[error(transparent)]
    Gpu(#[from] crate::gpu::GpuError),
    /// A frame does not have the camera's size.
    #[error("frame is {}×{} but the camera is {}×{}", got.0, got.1, want.0, want.1)]
    FrameSize {
        /// Frame size.
        got: (u32, u32),
        /// Camera size.
        want: (u32, u32),
    },
    /// An output file could not be written.
    #[error(transparent)]
    Io(#[from] crate::io::IoError),
    /// A lamp's model could not be built (the message names `scene.toml` and the field).
    #[error(transparent)]
    Lamp(#[from] crate::lamps::LampError),
}
