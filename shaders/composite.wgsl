// Pass 6: the output frame, drawn in the footage's own (distorted) pixel grid (Jensen §3.2
// step 3, with the surface normal the paper left out).
//
// For each output pixel, `warp` gives the point of the undistorted pinhole canvas that the lens
// maps there (precomputed from the Brown–Conrady model); the canvas layers (virtual objects,
// premultiplied, and the shadow coverage) are sampled there. Real pixels under a virtual shadow
// are darkened by the ratio of the radiance without and with the sun:
//   normal-aware: (c*Pa [+ b*Pd]) / (c*Pa + Pd*max(n.l, 0) [+ b*Pd]), with the proxy's normal n,
//                 weighted-ambient factor c and sun bounce b of that pixel;
//   constant:     Pa / (Pa + Pd), Jensen's one ratio for every pixel.
// Clipped video pixels (true value unknown) get the model's shadowed radiance rho/pi*(c*Pa [+ b*Pd])
// instead. Paired with src/render/composite.rs.

#include "common/fullscreen.wgsl"
#include "common/lighting.wgsl"

// Linear radiance of the footage; alpha 1 for a usable pixel, 0 for a clipped or invalid one.
@group(0) @binding(0) var video: texture_2d<f32>;
// xyz: unit normal of the proxy surface seen by the pixel (facing the camera); w: 1 if any.
@group(0) @binding(1) var surface_normal: texture_2d<f32>;
// rgb: weighted-ambient factor c.
@group(0) @binding(2) var surface_ambient: texture_2d<f32>;
// rgb: sun-bounce factor b.
@group(0) @binding(3) var surface_bounce: texture_2d<f32>;
// rgb: the proxy's diffuse albedo.
@group(0) @binding(4) var surface_albedo: texture_2d<f32>;
// xy: canvas pixel coordinates (OpenCV convention) of the output pixel's centre; negative x when
// the lens model has no inverse there.
@group(0) @binding(5) var warp: texture_2d<f32>;
@group(0) @binding(6) var virtual_layer: texture_2d<f32>;
@group(0) @binding(7) var masks: texture_2d<f32>;
@group(0) @binding(8) var canvas_sampler: sampler;
@group(0) @binding(9) var<uniform> lighting: Lighting;

@vertex
fn vs_main(@builtin(vertex_index) index: u32) -> FullscreenOut {
    return fullscreen_vertex(index, 0.0);
}

struct CanvasSample {
    virtual_rgba: vec4<f32>,
    masks: vec4<f32>,
}

fn canvas_sample(px: vec2<i32>) -> CanvasSample {
    var out: CanvasSample;
    out.virtual_rgba = vec4<f32>(0.0);
    out.masks = vec4<f32>(0.0);
    let w = textureLoad(warp, px, 0).xy;
    if (w.x < -0.5) {
        return out;
    }
    let size = vec2<f32>(textureDimensions(virtual_layer));
    let uv = (w + vec2<f32>(0.5)) / size;
    out.virtual_rgba = textureSampleLevel(virtual_layer, canvas_sampler, uv, 0.0);
    out.masks = textureSampleLevel(masks, canvas_sampler, uv, 0.0);
    return out;
}

// Radiance of a real pixel after the virtual shadow covering `coverage` of it.
fn real_radiance(px: vec2<i32>, coverage: f32) -> vec3<f32> {
    let v = textureLoad(video, px, 0);
    let s = textureLoad(surface_normal, px, 0);
    if (coverage <= 0.0 || s.w < 0.5 || lighting.sun_dir.w < 0.5) {
        return v.rgb;
    }
    let pd = lighting.pd.rgb;
    let pa = lighting.pa.rgb;
    var ambient = textureLoad(surface_ambient, px, 0).rgb * pa;
    if (lighting.params.y > 0.5) {
        ambient += textureLoad(surface_bounce, px, 0).rgb * pd;
    }
    var shadowed: vec3<f32>;
    if (lighting.params.x > 0.5) {
        shadowed = v.rgb * pa / max(pa + pd, vec3<f32>(1e-20));
    } else if (v.a > 0.5) {
        let lit = ambient + pd * max(dot(s.xyz, lighting.sun_dir.xyz), 0.0);
        shadowed = select(v.rgb, v.rgb * ambient / lit, lit > vec3<f32>(0.0));
    } else {
        shadowed = textureLoad(surface_albedo, px, 0).rgb / PI * ambient;
    }
    return mix(v.rgb, shadowed, coverage);
}

@fragment
fn fs_composite(in: FullscreenOut) -> @location(0) vec4<f32> {
    let px = vec2<i32>(floor(in.position.xy));
    let c = canvas_sample(px);
    let real = real_radiance(px, c.masks.r);
    let out = c.virtual_rgba.rgb + (1.0 - c.virtual_rgba.a) * real;
    return vec4<f32>(out * lighting.params.z, 1.0);
}

// The canvas masks warped to the output grid (tests and debugging).
@fragment
fn fs_masks(in: FullscreenOut) -> @location(0) vec4<f32> {
    let px = vec2<i32>(floor(in.position.xy));
    return canvas_sample(px).masks;
}
