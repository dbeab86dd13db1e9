// Pass 1: the real proxy and the virtual objects into depth (and the virtual-surface stencil
// bit, set by the pipeline). Never drawn in colour. Paired with src/render/depth_prepass.rs.

#include "common/camera.wgsl"

@group(0) @binding(0) var<uniform> camera: Camera;

struct VertexOut {
    @invariant @builtin(position) position: vec4<f32>,
}

@vertex
fn vs_main(@location(0) position: vec3<f32>) -> VertexOut {
    var out: VertexOut;
    out.position = clip_from_world_point(camera, vec4<f32>(position, 1.0));
    return out;
}
