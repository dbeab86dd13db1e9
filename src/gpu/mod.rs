//! The GPU layer both renderers stand on: the device, textures, readback, shader loading with
//! `#include`, mesh upload and the undistorted canvas with its lens warp.
//!
//! | module | what it owns |
//! |---|---|
//! | [`device`] | the headless adapter (Vulkan/lavapipe or GL/llvmpipe), depth-stencil and output formats, MSAA support |
//! | [`texture`] | a texture with its view; MSAA colour layers with their resolves |
//! | [`readback`] | textures and buffers copied back to the CPU |
//! | [`shaders`] | the WGSL sources embedded in the binary, `#include` resolution, module creation |
//! | [`mesh`] | vertex and index buffers of the proxy and the virtual objects, per-material bind groups |
//! | [`cuts`] | the compute pass of the visibility cuts' per-vertex sum (arrays laid out by `cuts::flat`) |
//! | [`canvas`] | the undistorted pinhole canvas of a camera (reversed, infinite-far projection) and the lens warp back to the footage |
//!
//! Nothing here knows about lighting: the outdoor compositor (`render`) and the VEM renderer
//! (`render::vem`) build their passes on these pieces.

pub mod canvas;
pub mod cuts;
pub mod device;
pub mod mesh;
pub mod readback;
pub mod shaders;
pub mod texture;

pub use device::{Gpu, GpuOptions, LAYER_FORMAT, MASK_FORMAT, PREFERRED_SAMPLES, f32_from_f16};

/// Errors of the GPU layer.
#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    /// No GPU adapter (hardware or Mesa's software ones) could be opened.
    #[error("no GPU adapter: {0} (install Mesa: `apt-get install -y mesa-vulkan-drivers`, or set WGPU_BACKEND=gl)")]
    NoAdapter(String),
    /// The adapter refused to open a device.
    #[error("could not open the GPU device: {0}")]
    NoDevice(String),
    /// The device failed while working.
    #[error("GPU device error: {0}")]
    Device(String),
    /// A shader file is missing or its includes are broken.
    #[error("shaders/{name}: {message}")]
    Shader {
        /// The shader file under `shaders/`.
        name: String,
        /// What is wrong.
        message: String,
    },
    /// A buffer or texture would exceed the device's limit.
    #[error("{what} needs {bytes} bytes, more than the device allows ({limit})")]
    TooLarge {
        /// What.
        what: String,
        /// Bytes needed.
        bytes: u64,
        /// The limit.
        limit: u64,
    },
    /// A window surface problem.
    #[error("window surface: {0}")]
    Surface(String),
}
