// Pass 3: turns a non-zero shadow-volume count into a flag bit (full-screen, stencil only; the
// comparison and the bits written are pipeline state). Paired with src/render/stencil.rs.

#include "common/fullscreen.wgsl"

@vertex
fn vs_main(@builtin(vertex_index) index: u32) -> @builtin(position) vec4<f32> {
    return fullscreen_vertex(index, 0.0).position;
}
