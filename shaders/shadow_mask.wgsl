// Pass 4: stencil classes into a coverage mask (full-screen). Each pipeline tests one stencil
// class and writes 1 into one channel: r = virtual shadow on a real surface (no real shadow
// there, the composite darkens it), g = real shadow on a real surface (the composite's share of
// the sunlit real samples under the virtual shadow is r / (1 - a - g)), b = a virtual surface
// without sun and a = a virtual surface (a for the composite; the shading pass tests the stencil
// per sample for the sun's visibility).
// MSAA resolve turns the per-sample classes into coverage. Paired with src/render/shadow_mask.rs.

#include "common/fullscreen.wgsl"

@vertex
fn vs_main(@builtin(vertex_index) index: u32) -> @builtin(position) vec4<f32> {
    return fullscreen_vertex(index, 0.0).position;
}

@fragment
fn fs_main() -> @location(0) vec4<f32> {
    return vec4<f32>(1.0);
}
