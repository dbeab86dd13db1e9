// Pass 2: shadow volumes into the stencil (z-fail, Carmack's reverse). Vertices are homogeneous:
// w = 1 on the occluder, w = 0 for the end of an edge extruded to infinity away from the sun.
// The stencil operations (virtual occluders count up on back faces that fail the depth test,
// real occluders count down) are pipeline state. Paired with src/render/shadow_volume.rs.

#include "common/camera.wgsl"

@group(0) @binding(0) var<uniform> camera: Camera;

@vertex
fn vs_main(@location(0) position: vec4<f32>) -> @builtin(position) vec4<f32> {
    return clip_from_world_point(camera, position);
}
