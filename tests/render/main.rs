//! GPU compositor tests, headless on whatever adapter wgpu finds (Mesa's lavapipe through Vulkan,
//! or llvmpipe through GL). Every comparison is against an independent CPU reference, never
//! against the compositor itself.

mod courtyard;
mod report_order;
mod robust;
mod shading;
mod shadows;
mod skip;
mod support;
mod transfer;
