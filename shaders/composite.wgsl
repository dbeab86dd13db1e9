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
//   differential: L_with / L_without of the estimator's model at the pixel, with
//                 L_without = c*Pa + (s*max(n.l,0) + b)*Pd and
//                 L_with    = c_v*Pa + (s*(1 - q)*max(n.l,0) + b_v)*Pd, with s the pixel's
//                 sunlit fraction (real shadows, traced on the CPU) and q the share of its
//                 sunlit real samples that the virtual shadow covers (masks r / (1 - a - g): the
//                 GPU's own samples, so q = 1 wherever the virtual shadow covers all of the
//                 pixel's sunlit part), where c_v, b_v are
//                 c and b with the virtual objects in the scene: the virtual shadow, and the sky
//                 and bounce light the objects take from surfaces near them (Debevec 1998's
//                 differential rendering, with the estimator's model as the local scene);
//                 with c_v = c, b_v = b it is the normal-aware ratio.
//                 With lamps (issue 16 §3; src/render/lamps/ground.rs), each lit spot j adds
//                 k*E_j*V_j^proxy to L_without and k*E_j*V_j^proxy*V_j^objects to L_with, the
//                 visibilities from the lamp shadow maps with and without the objects: where an
//                 object blocks only a lamp, video * E_rest / (E_rest + k*E*V). The lamps'
//                 light after a bounce, sum of k*B and of k*B_v (src/render/lamps/
//                 ground_bounce.rs), joins L_without and L_with in the same way, as b and b_v
//                 do for the sun.
// Clipped video pixels (true value unknown) get the model's radiance rho/pi*L instead.
// Paired with src/render/composite.rs.

#include "common/fullscreen.wgsl"
#include "common/lighting.wgsl"
#include "common/lamp_spots.wgsl"

// Linear radiance of the footage; alpha 1 for a usable pixel, 0 for a clipped or invalid one.
@group(0) @binding(0) var video: texture_2d<f32>;
// xyz: unit normal of the proxy surface seen by the pixel (facing the camera); w: 1 if any.
@group(0) @binding(1) var surface_normal: texture_2d<f32>;
// rgb: weighted-ambient factor c; w: the real sun visibility s of the surface point.
@group(0) @binding(2) var surface_ambient: texture_2d<f32>;
// rgb: sun-bounce factor b.
@group(0) @binding(3) var surface_bounce: texture_2d<f32>;
// rgb: the proxy's diffuse albedo.
@group(0) @binding(4) var surface_albedo: texture_2d<f32>;
// rgb: c_v (c with the virtual objects present); w: 1 where computed.
@group(0) @binding(5) var surface_ambient_with: texture_2d<f32>;
// rgb: b_v (b with the virtual objects present).
@group(0) @binding(6) var surface_bounce_with: texture_2d<f32>;
// xy: canvas pixel coordinates (OpenCV convention) of the output pixel's centre; negative x when
// the lens model has no inverse there. zw: the pixel's footprint on the canvas (canvas pixels
// per output pixel along x and y).
@group(0) @binding(7) var warp: texture_2d<f32>;
@group(0) @binding(8) var virtual_layer: texture_2d<f32>;
@group(0) @binding(9) var masks: texture_2d<f32>;
@group(0) @binding(10) var canvas_sampler: sampler;
// A storage buffer, not a uniform: lavapipe recompiles (and leaks) a shader whose branches read
// uniforms on every bind (issue 12; tests/suite/uniform_branches.rs).
@group(0) @binding(11) var<storage, read> lighting: Lighting;
// xyz: the proxy point seen by the pixel (world); w: 1 if any.
@group(0) @binding(12) var surface_point: texture_2d<f32>;
// rgb: the lamps' light after a bounce, sum of k*B (without the objects) and of k*B_v (with
// them) over the lamps (src/render/lamps/ground_bounce.rs); zero where not traced and without
// lamps.
@group(0) @binding(13) var surface_lamp_bounce: texture_2d<f32>;
@group(0) @binding(14) var surface_lamp_bounce_with: texture_2d<f32>;

@vertex
fn vs_main(@builtin(vertex_index) index: u32) -> FullscreenOut {
    return fullscreen_vertex(index, 0.0);
}

struct CanvasSample {
    virtual_rgba: vec4<f32>,
    masks: vec4<f32>,
}

// Footprints up to this many canvas pixels are sampled with one bilinear tap (no supersampling:
// the lens's own local scale stays near 1); larger ones (a supersampled canvas) with four taps
// at ±1/4 of the footprint, a box filter over the output pixel (exact for a 2× canvas, whose
// four taps land on the four canvas texels under the pixel where the lens is near identity:
// src/gpu/canvas.rs puts the canvas grid on the footage's phase at the lens's centre).
const ONE_TAP_FOOTPRINT: f32 = 1.25;

fn canvas_sample(px: vec2<i32>) -> CanvasSample {
    var out: CanvasSample;
    out.virtual_rgba = vec4<f32>(0.0);
    out.masks = vec4<f32>(0.0);
    let w = textureLoad(warp, px, 0);
    if (w.x < -0.5) {
        return out;
    }
    let size = vec2<f32>(textureDimensions(virtual_layer));
    if (max(w.z, w.w) <= ONE_TAP_FOOTPRINT) {
        let uv = (w.xy + vec2<f32>(0.5)) / size;
        out.virtual_rgba = textureSampleLevel(virtual_layer, canvas_sampler, uv, 0.0);
        out.masks = textureSampleLevel(masks, canvas_sampler, uv, 0.0);
        return out;
    }
    let q = 0.25 * w.zw;
    for (var k = 0u; k < 4u; k += 1u) {
        let o = vec2<f32>(select(-q.x, q.x, (k & 1u) != 0u), select(-q.y, q.y, (k & 2u) != 0u));
        let uv = (w.xy + o + vec2<f32>(0.5)) / size;
        out.virtual_rgba += 0.25 * textureSampleLevel(virtual_layer, canvas_sampler, uv, 0.0);
        out.masks += 0.25 * textureSampleLevel(masks, canvas_sampler, uv, 0.0);
    }
    return out;
}

// Below this share of sunlit real samples a pixel is taken as all in real shadow.
const MIN_LIT_SAMPLES: f32 = 1e-3;

// The share of a pixel's sunlit real samples in virtual shadow, from the warped masks.
fn lit_share_covered(m: vec4<f32>) -> f32 {
    let lit = 1.0 - m.a - m.g;
    if (lit <= MIN_LIT_SAMPLES) {
        return 0.0;
    }
    return clamp(m.r / lit, 0.0, 1.0);
}

// The lamps' light at a real pixel: Σ k·E·V^proxy without the objects, Σ k·E·V^proxy·V^objects
// with them (the file's head), and whether the objects block any of it.
struct LampShare {
    without: vec3<f32>,
    with_objects: vec3<f32>,
    shadowed: bool,
}

// The composite darkens by the objects' lamp shadows this frame (header.taps.y, lamp_ground).
fn lamps_on() -> bool {
    return header.taps.y != 0u && header.counts.x > 0u;
}

// The lamps' share at pixel `px` (proxy normal `n`); with `irradiance` false only `shadowed`
// is found (two map lookups per spot, no lamp model).
fn lamp_share(px: vec2<i32>, n: vec3<f32>, irradiance: bool) -> LampShare {
    var out: LampShare;
    out.without = vec3<f32>(0.0);
    out.with_objects = vec3<f32>(0.0);
    out.shadowed = false;
    if (!lamps_on()) {
        return out;
    }
    let point = textureLoad(surface_point, px, 0);
    if (point.w < 0.5) {
        return out;
    }
    let p = point.xyz;
    for (var k = 0u; k < header.counts.x; k += 1u) {
        let spot = spots[k];
        let to_light = spot.world.xyz - p;
        let dist2 = dot(to_light, to_light);
        if (dist2 <= 1e-12) {
            continue;
        }
        let l = to_light * inverseSqrt(dist2);
        let cos_l = dot(n, l);
        if (cos_l <= 0.0) {
            continue;
        }
        // The proxy-alone and the objects-and-proxy atlases hold the same views.
        let slot = spot.index.y;
        var c = vec4<f32>(0.0);
        if (slot < header.counts.w) {
            c = spot_tile_coords(shadow_views[slot], spot.world.xyz, p, n, l);
        }
        let v_proxy = spot_soft_visibility_at(proxy_atlas, slot, c, n, l);
        var v_both = 0.0;
        if (v_proxy > 0.0) {
            v_both = spot_soft_visibility_at(shadow_atlas, slot, c, n, l);
        }
        if (v_proxy <= 0.0) {
            continue;
        }
        out.shadowed = out.shadowed || v_both < v_proxy;
        if (irradiance) {
            let e = spot.scale.rgb * spot_irradiance(spot, p, dist2) * cos_l;
            out.without += v_proxy * e;
            out.with_objects += v_both * e;
        }
    }
    return out;
}

// The differential model (see the file's head); `coverage` is the masks' r, `q` the share of
// the sunlit real samples it covers.
fn differential(px: vec2<i32>, v: vec4<f32>, n: vec3<f32>, coverage: f32, q: f32) -> vec3<f32> {
    let present = textureLoad(surface_ambient_with, px, 0);
    let lamps = lamp_share(px, n, true);
    if (present.w < 0.5 && coverage <= 0.0 && !lamps.shadowed) {
        return v.rgb;
    }
    let a = textureLoad(surface_ambient, px, 0);
    let b = textureLoad(surface_bounce, px, 0).rgb;
    var c_v = a.rgb;
    var b_v = b;
    if (present.w > 0.5) {
        c_v = present.rgb;
        b_v = textureLoad(surface_bounce_with, px, 0).rgb;
    }
    let use_b = lighting.params.y;
    var pd = vec3<f32>(0.0);
    if (lighting.sun_dir.w > 0.5) {
        pd = lighting.pd.rgb;
    }
    // a.w: the pixel's sunlit fraction (real shadows only); the virtual shadow takes `q` of it.
    let cos_l = max(dot(n, lighting.sun_dir.xyz), 0.0);
    var l0 = a.rgb * lighting.pa.rgb + (a.w * cos_l + use_b * b) * pd;
    var l1 = c_v * lighting.pa.rgb + (a.w * (1.0 - q) * cos_l + use_b * b_v) * pd;
    if (lamps_on()) {
        l0 += lamps.without + textureLoad(surface_lamp_bounce, px, 0).rgb;
        l1 += lamps.with_objects + textureLoad(surface_lamp_bounce_with, px, 0).rgb;
    }
    if (v.a > 0.5) {
        return select(v.rgb, v.rgb * l1 / l0, l0 > vec3<f32>(0.0));
    }
    return textureLoad(surface_albedo, px, 0).rgb / PI * l1;
}

// Radiance of a real pixel after the virtual shadow covering `coverage` of it (`q` of its
// sunlit real samples).
fn real_radiance(px: vec2<i32>, coverage: f32, q: f32) -> vec3<f32> {
    let v = textureLoad(video, px, 0);
    let s = textureLoad(surface_normal, px, 0);
    if (s.w < 0.5) {
        return v.rgb;
    }
    if (lighting.params.x > 1.5) {
        return differential(px, v, s.xyz, coverage, q);
    }
    if (coverage <= 0.0 || lighting.sun_dir.w < 0.5) {
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

// The objects block a lamp from the real pixel `px` (never without lamps).
fn lamp_shadowed(px: vec2<i32>) -> bool {
    if (!lamps_on()) {
        return false;
    }
    let s = textureLoad(surface_normal, px, 0);
    return s.w > 0.5 && lamp_share(px, s.xyz, false).shadowed;
}

@fragment
fn fs_composite(in: FullscreenOut) -> @location(0) vec4<f32> {
    let px = vec2<i32>(floor(in.position.xy));
    let c = canvas_sample(px);
    // Most pixels are untouched: no virtual surface, no virtual shadow, outside the region where
    // the differential model has data. They are the footage, read once.
    if (c.virtual_rgba.a <= 0.0 && c.masks.r <= 0.0 && (lighting.params.x < 1.5 || textureLoad(surface_ambient_with, px, 0).w < 0.5) && !lamp_shadowed(px)) {
        return vec4<f32>(textureLoad(video, px, 0).rgb * lighting.params.z, 1.0);
    }
    let real = real_radiance(px, c.masks.r, lit_share_covered(c.masks));
    let out = c.virtual_rgba.rgb + (1.0 - c.virtual_rgba.a) * real;
    return vec4<f32>(out * lighting.params.z, 1.0);
}

// The canvas masks warped to the output grid (tests and debugging).
@fragment
fn fs_masks(in: FullscreenOut) -> @location(0) vec4<f32> {
    let px = vec2<i32>(floor(in.position.xy));
    return canvas_sample(px).masks;
}
