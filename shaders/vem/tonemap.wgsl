// Global Reinhard tone mapping with the temporally smoothed parameters of src/vem/reinhard.rs
// (Havran §5.1; Reinhard et al. 2002): L = a·L_w/L̄, L_d = L·(1 + L/L_white²)/(1 + L), colour
// ratios kept. The target is an sRGB format, so the hardware applies the sRGB transfer.
// `ToneParams::apply` is the CPU reference. Paired with src/render/vem/tonemap.rs.

#include "common/fullscreen.wgsl"

struct Tone {
    // x: a / L̄ (the scale); y: L_white times the scale; zw: unused.
    params: vec4<f32>,
}

@group(0) @binding(0) var hdr: texture_2d<f32>;
@group(0) @binding(1) var<uniform> tone: Tone;

// Rec. 709 luminance (vem::polar::LUMA_F32).
const LUMA: vec3<f32> = vec3<f32>(0.2126, 0.7152, 0.0722);

@vertex
fn vs_main(@builtin(vertex_index) index: u32) -> FullscreenOut {
    return fullscreen_vertex(index, 0.0);
}

@fragment
fn fs_main(in: FullscreenOut) -> @location(0) vec4<f32> {
    let c = textureLoad(hdr, vec2<i32>(floor(in.position.xy)), 0).rgb;
    let l = dot(c, LUMA);
    if (!(l > 0.0)) {
        return vec4<f32>(0.0, 0.0, 0.0, 1.0);
    }
    let x = l * tone.params.x;
    let w = tone.params.y;
    let d = min(x * (1.0 + x / (w * w)) / (1.0 + x), 1.0);
    return vec4<f32>(max(c * (d / l), vec3<f32>(0.0)), 1.0);
}
