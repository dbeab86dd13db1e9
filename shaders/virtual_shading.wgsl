// Pass 5: the virtual objects, shaded (Jensen §3.2 step 4 and §3.3): the glTF metallic-roughness
// response to the sun on the samples no shadow volume covers (two draws, `fs_lit` and
// `fs_shadowed`, split by the stencil per sample, so a fragment that covers part of a pixel gets
// its own samples' visibility, not the pixel's), plus ambient light: the per-pixel
// transfer R_a·Pa + R_d·Pd (+ the lamps' bounce Σ k_i·R_i) traced on the CPU (src/render/object_transfer.rs), reconstructed from the
// lattice entries around the pixel that lie on the fragment's surface, otherwise the probe grid
// evaluated per pixel times the objects' own ambient occlusion; for objects that moved, the
// per-vertex ambient of the visibility cuts instead (issue 15 §2). Depth-tested for equality against
// the prepass, so the real proxy hides them. Output is premultiplied linear radiance with alpha 1.
// Paired with src/render/virtual_shading.rs.

#include "common/object.wgsl"
#include "common/lighting.wgsl"
#include "common/sh.wgsl"

// Group 0, binding 0 is the camera (common/object.wgsl).
// Storage buffers, not a uniform: lavapipe recompiles (and leaks) a shader whose branches read
// uniforms on every bind (issue 12; tests/suite/uniform_branches.rs).
@group(0) @binding(1) var<storage, read> lighting: Lighting;
@group(0) @binding(2) var<storage, read> probe_grid: ProbeGridHeader;
// 9 coefficients per probe, rgb in xyz.
@group(0) @binding(3) var<storage, read> probe_coeffs: array<vec4<f32>>;
// 1 for a valid probe, 0 for one inside real geometry.
@group(0) @binding(4) var<storage, read> probe_valid: array<u32>;
// Per canvas pixel: the fraction of the hemisphere the virtual objects leave open (their own
// ambient occlusion, which the probes cannot know).
@group(0) @binding(5) var ambient_occlusion: texture_2d<f32>;

// The objects' ambient transfer per canvas pixel (src/render/object_transfer.rs): R_a (rgb, a = 1 where
// there is an entry), R_d, the entry's surface point (w: footprint radius, metres) and normal.
@group(0) @binding(7) var transfer_sky: texture_2d<f32>;
@group(0) @binding(8) var transfer_sun: texture_2d<f32>;
@group(0) @binding(9) var transfer_point: texture_2d<f32>;
@group(0) @binding(10) var transfer_normal: texture_2d<f32>;
// The lamps' light bounced off the proxy and the objects, Σ k_i·R_i, per canvas pixel of the same
// lattice (src/render/object_transfer/lamps.rs; zero without lamps or with none on).
@group(0) @binding(12) var transfer_lamp: texture_2d<f32>;

// Per vertex of the objects (the order of their vertex buffer), the ambient from the visibility
// cuts (src/cuts/frame.rs, issue 15 §2; mirrors `VertexAmbient` there), four entries per vertex:
// irradiance per unit Pa about the normal (w = 1 where the cuts serve the vertex), about the
// reflected view direction, and the same two per unit Pd. Written when an object has moved by
// translation; zero (unused) before.
@group(0) @binding(11) var<storage, read> cut_ambient: array<vec4<f32>>;

// VertexOut (common/object.wgsl) with the vertex's cut ambient, interpolated over the triangle.
struct ShadeVertex {
    @invariant @builtin(position) position: vec4<f32>,
    @location(0) @interpolate(perspective, centroid) world: vec3<f32>,
    @location(1) @interpolate(perspective, centroid) normal: vec3<f32>,
    @location(2) @interpolate(perspective, centroid) uv: vec2<f32>,
    @location(3) @interpolate(perspective, centroid) pa_n: vec4<f32>,
    @location(4) @interpolate(perspective, centroid) pa_r: vec3<f32>,
    @location(5) @interpolate(perspective, centroid) pd_n: vec3<f32>,
    @location(6) @interpolate(perspective, centroid) pd_r: vec3<f32>,
}

// vs_object's invariant position arithmetic (the depth test against the prepass passes exactly
// on the visible surface), plus the vertex's cut ambient.
@vertex
fn vs_shade(v: VertexIn, @builtin(vertex_index) index: u32) -> ShadeVertex {
    var out: ShadeVertex;
    out.position = clip_from_world_point(camera, vec4<f32>(v.position, 1.0));
    out.world = v.position;
    out.normal = v.normal;
    out.uv = v.uv;
    out.pa_n = vec4<f32>(0.0);
    out.pa_r = vec3<f32>(0.0);
    out.pd_n = vec3<f32>(0.0);
    out.pd_r = vec3<f32>(0.0);
    let i = index * 4u;
    if (i + 3u < arrayLength(&cut_ambient)) {
        out.pa_n = cut_ambient[i];
        out.pa_r = cut_ambient[i + 1u].xyz;
        out.pd_n = cut_ambient[i + 2u].xyz;
        out.pd_r = cut_ambient[i + 3u].xyz;
    }
    return out;
}

// An entry takes part in a fragment's value when its normal is within ~25° of the fragment's
// and its point lies within this many lattice footprints (footprint radius times the stride; a
// neighbouring lattice point on the same face is 1–1.5 of them away).
const TRANSFER_MIN_NORMAL_DOT: f32 = 0.9;
const TRANSFER_MAX_FOOTPRINTS: f32 = 2.5;
// Each entry's weight: exp(-(distance / (stride * footprint))^2), times the normals' agreement
// above TRANSFER_MIN_NORMAL_DOT.

struct TransferHit {
    found: bool,
    sky: vec3<f32>,
    sun: vec3<f32>,
    lamp: vec3<f32>,
}

// The fragment's transfer from the 3×3 lattice entries around canvas pixel `px` (lattice spacing
// `stride`), for a surface point `p` with normal `n`: the weighted mean of the matching entries.
fn transfer_lookup(px: vec2<i32>, stride: i32, p: vec3<f32>, n: vec3<f32>) -> TransferHit {
    var out: TransferHit;
    out.found = false;
    out.sky = vec3<f32>(0.0);
    out.sun = vec3<f32>(0.0);
    out.lamp = vec3<f32>(0.0);
    let size = vec2<i32>(textureDimensions(transfer_sky));
    let base = (px / stride) * stride;
    var wsum = 0.0;
    for (var j = -1; j <= 1; j += 1) {
        for (var i = -1; i <= 1; i += 1) {
            let q = base + vec2<i32>(i, j) * stride;
            if (any(q < vec2<i32>(0)) || any(q >= size)) {
                continue;
            }
            let sky = textureLoad(transfer_sky, q, 0);
            if (sky.a < 0.5) {
                continue;
            }
            let e = textureLoad(transfer_point, q, 0);
            let nd = dot(textureLoad(transfer_normal, q, 0).xyz, n);
            let dist = length(e.xyz - p) / max(e.w * f32(stride), 1e-6);
            if (nd < TRANSFER_MIN_NORMAL_DOT || dist > TRANSFER_MAX_FOOTPRINTS) {
                continue;
            }
            let w = exp(-dist * dist) * (nd - TRANSFER_MIN_NORMAL_DOT) / (1.0 - TRANSFER_MIN_NORMAL_DOT + 1e-6);
            if (w <= 0.0) {
                continue;
            }
            wsum += w;
            out.sky += w * sky.rgb;
            out.sun += w * textureLoad(transfer_sun, q, 0).rgb;
            out.lamp += w * textureLoad(transfer_lamp, q, 0).rgb;
        }
    }
    if (wsum > 0.0) {
        out.found = true;
        out.sky /= wsum;
        out.sun /= wsum;
        out.lamp /= wsum;
    }
    return out;
}

fn probe_sh_eval(probe: u32, d: vec3<f32>) -> vec3<f32> {
    let y = sh_basis(d);
    var e = vec3<f32>(0.0);
    for (var k = 0u; k < 9u; k += 1u) {
        e += probe_coeffs[probe * 9u + k].xyz * y[k];
    }
    return e;
}

// Irradiance at `p` on a surface of normal `n`: trilinear interpolation of the valid probes of the
// surrounding cell, weights renormalised, clamped to be non-negative (ProbeGrid::irradiance).
fn probe_irradiance(p: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    let dims = probe_grid.dims.xyz;
    let maxc = max(vec3<f32>(dims) - vec3<f32>(1.0), vec3<f32>(0.0));
    let g = min(max((p - probe_grid.origin.xyz) / probe_grid.origin.w, vec3<f32>(0.0)), maxc);
    let base = min(floor(g), max(maxc - vec3<f32>(1.0), vec3<f32>(0.0)));
    let f = g - base;
    let b = vec3<u32>(base);
    var e = vec3<f32>(0.0);
    var wsum = 0.0;
    for (var corner = 0u; corner < 8u; corner += 1u) {
        let o = vec3<u32>(corner & 1u, (corner >> 1u) & 1u, (corner >> 2u) & 1u);
        let q = min(b + o, dims - vec3<u32>(1u));
        let i = q.x + dims.x * (q.y + dims.y * q.z);
        if (probe_valid[i] == 0u) {
            continue;
        }
        let wv = select(vec3<f32>(1.0) - f, f, o == vec3<u32>(1u));
        let w = wv.x * wv.y * wv.z;
        if (w <= 0.0) {
            continue;
        }
        wsum += w;
        e += w * probe_sh_eval(i, n);
    }
    if (wsum <= 0.0) {
        return vec3<f32>(0.0);
    }
    return max(e / wsum, vec3<f32>(0.0));
}

// Ambient occlusion `visibility` raised to account for light the occluding parts reflect, for a
// surface of `albedo` surrounded by similar ones: Jimenez et al. 2016, "Practical real-time
// strategies for accurate indirect occlusion", cubic fit of the multi-bounce visibility.
fn multi_bounce_ao(visibility: f32, albedo: vec3<f32>) -> vec3<f32> {
    let a = 2.0404 * albedo - vec3<f32>(0.3324);
    let b = -4.7951 * albedo + vec3<f32>(0.6417);
    let c = 2.7552 * albedo + vec3<f32>(0.6903);
    let x = vec3<f32>(visibility);
    return max(x, ((x * a + b) * x + c) * x);
}

// The samples of the fragment that no shadow volume covers (stencil: exactly the
// virtual-surface bit): the sun at full strength.
@fragment
fn fs_lit(in: ShadeVertex, @builtin(front_facing) front: bool) -> @location(0) vec4<f32> {
    return shade(in, front, 1.0);
}

// The samples of the fragment inside a real or virtual shadow volume: no direct sun.
@fragment
fn fs_shadowed(in: ShadeVertex, @builtin(front_facing) front: bool) -> @location(0) vec4<f32> {
    return shade(in, front, 0.0);
}

// The fragment's radiance with the sun's visibility `visible` (0 or 1) on its samples.
fn shade(in: ShadeVertex, front: bool, visible: f32) -> vec4<f32> {
    let n = facing_normal(in.normal, front);
    let v = normalize(camera.eye_world.xyz - in.world);
    let s = object_surface(in.uv);
    let nv = dot(n, v);
    let r = reflect(-v, n);
    let px = vec2<i32>(floor(in.position.xy));
    let sun_on = lighting.sun_dir.w > 0.5;
    var radiance: vec3<f32>;
    var transfer: TransferHit;
    transfer.found = false;
    if (lighting.params.w > 0.5) {
        transfer = transfer_lookup(px, i32(lighting.params.w + 0.5), in.world, n);
    }
    if (in.pa_n.w > 0.5) {
        // The visibility cuts: the objects' and the proxy's visibility are in the irradiances
        // already, so no ambient occlusion on top.
        var e_n = in.pa_n.rgb * lighting.pa.rgb;
        var e_r = in.pa_r * lighting.pa.rgb;
        if (sun_on) {
            e_n += in.pd_n * lighting.pd.rgb;
            e_r += in.pd_r * lighting.pd.rgb;
        }
        radiance = ambient_radiance(s, nv, max(e_n, vec3<f32>(0.0)), max(e_r, vec3<f32>(0.0)));
    } else if (transfer.found) {
        radiance = transfer.sky * lighting.pa.rgb;
        if (sun_on) {
            radiance += transfer.sun * lighting.pd.rgb;
        }
        // Zero without lamps: the sum is then the one above, bit for bit.
        radiance += transfer.lamp;
    } else {
        let ao = multi_bounce_ao(textureLoad(ambient_occlusion, px, 0).r, s.base_color);
        radiance = ao * ambient_radiance(s, nv, probe_irradiance(in.world, n), probe_irradiance(in.world, r));
    }
    if (sun_on && visible > 0.0) {
        radiance += visible * lighting.pd.rgb * brdf_cos(s, n, v, lighting.sun_dir.xyz);
    }
    return vec4<f32>(radiance, 1.0);
}
