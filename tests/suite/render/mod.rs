//! GPU compositor tests, headless on whatever adapter wgpu finds (Mesa's lavapipe through Vulkan,
//! or llvmpipe through GL). Every picture is compared with an independent CPU reference, never
//! with the compositor itself; the pass reports of `report_order` are compared with those the
//! compositor gave before its passes became units (the report is behaviour, see that module).

mod courtyard;
mod lamp_bounce;
mod lamp_ground;
mod lamp_penumbra;
mod lamps;
mod lens_filter;
mod night;
mod report_order;
mod robust;
mod shading;
mod shadows;
mod skip;
#[allow(dead_code)]
pub(crate) mod support;
mod transfer;
mod twilight;
mod winter;
