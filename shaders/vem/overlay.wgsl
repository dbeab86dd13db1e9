// The VEM composite, in the footage's own (distorted) pixel grid: the canvas layers of the
// shading pass are sampled through the lens warp (as in shaders/composite.wgsl) and
//   out = objects + (1 − alpha) · background · ratio,
// with the background the footage frame or the VEM seen through the camera (linear radiance),
// and ratio the receivers' differential darkening. Paired with src/render/vem/overlay.rs.

#include "common/fullscreen.wgsl"

@group(0) @binding(0) var background: texture_2d<f32>;
// xy: canvas pixel coordinates of the output pixel's centre; negative x where the lens model has
// no inverse.
@group(0) @binding(1) var warp: texture_2d<f32>;
@group(0) @binding(2) var virtual_layer: texture_2d<f32>;
@group(0) @binding(3) var ratio_layer: texture_2d<f32>;
@group(0) @binding(4) var canvas_sampler: sampler;

@vertex
fn vs_main(@builtin(vertex_index) index: u32) -> FullscreenOut {
    return fullscreen_vertex(index, 0.0);
}

@fragment
fn fs_main(in: FullscreenOut) -> @location(0) vec4<f32> {
    let px = vec2<i32>(floor(in.position.xy));
    let bg = textureLoad(background, px, 0).rgb;
    let w = textureLoad(warp, px, 0).xy;
    if (w.x < -0.5) {
        return vec4<f32>(bg, 1.0);
    }
    let uv = (w + vec2<f32>(0.5)) / vec2<f32>(textureDimensions(virtual_layer));
    let v = textureSampleLevel(virtual_layer, canvas_sampler, uv, 0.0);
    let ratio = textureSampleLevel(ratio_layer, canvas_sampler, uv, 0.0).rgb;
    return vec4<f32>(v.rgb + (1.0 - v.a) * bg * ratio, 1.0);
}
