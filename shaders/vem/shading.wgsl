// The VEM shading pass (Havran §4.1–4.2): the virtual objects lit by the frame's directional
// lights, and the real receivers (the proxy, or a ground plane) as shadow catchers.
//
// Objects: for the normal n, the LUT gives n's angular region and only that region's list of H
// is walked (every light that can face n is in it): diffuse lobe Σ E_i·f_d·max(n·l_i, 0)·V_i;
// specular lobe with the L/H split: lights of L inside the cone C around the mirror direction r
// (from the list of r's region of S_L) plus lights of H outside C, never both. V_i is the
// shadow-map visibility of the light's atlas slot.
// Receivers: the differential ratio Σ E_c·max(n·l_c,0)·V_c / Σ E_c·max(n·l_c,0) over the clustered
// lights c (one per shadow map) that darkens the background where the objects shadow it.
// Both passes write two targets: the objects' premultiplied radiance (alpha 1 where covered) and
// the ratio (1 where there is no receiver). Paired with src/render/vem/shading.rs.
// With the visibility cuts' light (--object-light cuts, src/run/vem_cuts.rs) the objects and the
// receivers are drawn by the *_cut_* entry points instead: no light loop, no shadow maps.

#include "common/object.wgsl"
#include "common/vem_lights.wgsl"

// Group 0, binding 0 is the camera (common/object.wgsl).
// A storage buffer, not a uniform: its counts steer loops and branches, and lavapipe recompiles
// (and leaks) a shader whose branches read uniforms on every bind (issue 12).
@group(0) @binding(1) var<storage, read> frame: VemFrame;
@group(0) @binding(2) var<storage, read> h_lights: array<VemLight>;
@group(0) @binding(3) var<storage, read> h_lists: array<u32>;
@group(0) @binding(4) var<storage, read> l_lights: array<VemLight>;
@group(0) @binding(5) var<storage, read> l_lists: array<u32>;
@group(0) @binding(6) var<storage, read> shadow_views: array<ShadowView>;
@group(0) @binding(7) var shadow_atlas: texture_depth_2d;
// One light per shadow map: the map's direction and the summed power of the lights of H that read
// it (the clustered lights of Havran §4.3).
@group(0) @binding(8) var<storage, read> shadow_lights: array<VemLight>;
// Nearest-texel comparison (LessEqual): a depth texture cannot be read with textureLoad on GL.
@group(0) @binding(9) var shadow_sampler: sampler_comparison;

// The visibility cuts' light (--object-light cuts; src/run/vem_cuts.rs over src/cuts/frame.rs):
// per object vertex (the order of the vertex buffer), two entries: the irradiance about the
// normal (w = 1 where the cuts serve the vertex) and about the reflected view direction; per
// canvas pixel (row-major, frame.l.w wide), the receivers' share of the captured sky that the
// objects leave. One zero entry each without the cuts.
@group(0) @binding(10) var<storage, read> cut_ambient: array<vec4<f32>>;
@group(0) @binding(11) var<storage, read> cut_ratio: array<f32>;

struct ReceiverOut {
    @invariant @builtin(position) position: vec4<f32>,
    @location(0) world: vec3<f32>,
}

struct FragOut {
    @location(0) virtual_layer: vec4<f32>,
    @location(1) ratio: vec4<f32>,
}

@vertex
fn vs_receiver(@location(0) position: vec3<f32>) -> ReceiverOut {
    var out: ReceiverOut;
    out.position = clip_from_world_point(camera, vec4<f32>(position, 1.0));
    out.world = position;
    return out;
}

// (first id in h_lists, count) of the list of n's region of H; (0, all) without culling.
fn h_list(n: vec3<f32>) -> vec2<u32> {
    if ((frame.h.w & VEM_CULLING) == 0u) {
        return vec2<u32>(0u, frame.h.x);
    }
    let size = frame.h.z;
    let lut_len = 6u * size * size;
    let r = lut_len + 2u * h_lists[cube_lut_texel(n, size)];
    return vec2<u32>(lut_len + 2u * frame.h.y + h_lists[r], h_lists[r + 1u]);
}

fn h_id(list: vec2<u32>, k: u32) -> u32 {
    if ((frame.h.w & VEM_CULLING) == 0u) {
        return k;
    }
    return h_lists[list.x + k];
}

// The same for the glossy set L and the mirror direction r.
fn l_list(r: vec3<f32>) -> vec2<u32> {
    if ((frame.h.w & VEM_CULLING) == 0u) {
        return vec2<u32>(0u, frame.l.x);
    }
    let size = frame.l.z;
    let lut_len = 6u * size * size;
    let q = lut_len + 2u * l_lists[cube_lut_texel(r, size)];
    return vec2<u32>(lut_len + 2u * frame.l.y + l_lists[q], l_lists[q + 1u]);
}

fn l_id(list: vec2<u32>, k: u32) -> u32 {
    if ((frame.h.w & VEM_CULLING) == 0u) {
        return k;
    }
    return l_lists[list.x + k];
}

// Visibility (0 or 1) of the light with atlas `slot` at `p` (normal `n`): one texel of its
// orthographic map, with the normal offset and depth bias of that map. Points outside the map's
// footprint see the light (no caster covers them); points beyond its far side compare with
// depth 1, so any caster in front shadows them.
fn shadow_visibility(slot: u32, p: vec3<f32>, n: vec3<f32>) -> f32 {
    if ((frame.h.w & VEM_SHADOWS) == 0u || slot >= frame.atlas.z) {
        return 1.0;
    }
    let view = shadow_views[slot];
    let q = view.light_from_world * vec4<f32>(p + n * view.bias.y, 1.0);
    let uv = vec2<f32>(0.5 * q.x + 0.5, 0.5 - 0.5 * q.y);
    if (uv.x < 0.0 || uv.y < 0.0 || uv.x >= 1.0 || uv.y >= 1.0) {
        return 1.0;
    }
    let tile = frame.atlas.y;
    let origin = vec2<u32>(slot % frame.atlas.x, slot / frame.atlas.x) * tile;
    let texel = min(vec2<u32>(uv * f32(tile)), vec2<u32>(tile - 1u));
    // The centre of that texel: the comparison reads exactly one texel, 1 when the point is not
    // farther from the light than the stored depth (within the bias).
    let at = (vec2<f32>(origin + texel) + vec2<f32>(0.5)) / f32(frame.atlas.x * tile);
    return textureSampleCompareLevel(shadow_atlas, shadow_sampler, at, min(q.z, 1.0) - view.bias.x);
}

@fragment
fn fs_object(in: VertexOut, @builtin(front_facing) front: bool) -> FragOut {
    let s = object_surface(in.uv);
    let n = facing_normal(in.normal, front);
    let v = normalize(camera.eye_world.xyz - in.world);
    let r = reflect(-v, n);
    let glossy = (frame.h.w & VEM_GLOSSY) != 0u;
    let cos_cone = frame.params.x;
    var radiance = vec3<f32>(0.0);
    // Lists are grouped by shadow slot (src/render/vem/frame.rs), so each map is read once per run.
    var slot = NO_SLOT;
    var vis = 1.0;
    let hl = h_list(n);
    for (var k = 0u; k < hl.y; k += 1u) {
        let light = h_lights[h_id(hl, k)];
        if (dot(n, light.dir) <= 0.0) {
            continue;
        }
        if (light.shadow != slot) {
            slot = light.shadow;
            vis = shadow_visibility(slot, in.world, n);
        }
        if (vis <= 0.0) {
            continue;
        }
        let parts = brdf_cos_parts(s, n, v, light.dir);
        var f = parts.diffuse;
        if (!glossy || dot(light.dir, r) < cos_cone) {
            f += parts.specular;
        }
        radiance += light.rgb * f * vis;
    }
    if (glossy) {
        slot = NO_SLOT;
        let ll = l_list(r);
        for (var k = 0u; k < ll.y; k += 1u) {
            let light = l_lights[l_id(ll, k)];
            if (dot(light.dir, r) < cos_cone || dot(n, light.dir) <= 0.0) {
                continue;
            }
            if (light.shadow != slot) {
                slot = light.shadow;
                vis = shadow_visibility(slot, in.world, n);
            }
            radiance += light.rgb * brdf_cos_parts(s, n, v, light.dir).specular * vis;
        }
    }
    var out: FragOut;
    out.virtual_layer = vec4<f32>(radiance, 1.0);
    out.ratio = vec4<f32>(1.0);
    return out;
}

@fragment
fn fs_receiver(in: ReceiverOut) -> FragOut {
    // The proxy's buffers hold positions only: the face normal from the screen derivatives,
    // turned toward the camera.
    let c = cross(dpdx(in.world), dpdy(in.world));
    var n = vec3<f32>(0.0, 1.0, 0.0);
    if (dot(c, c) > 1e-24) {
        n = normalize(c);
    }
    if (dot(n, camera.eye_world.xyz - in.world) < 0.0) {
        n = -n;
    }
    var lit = vec3<f32>(0.0);
    var total = vec3<f32>(0.0);
    // The clustered lights, one per shadow map: visibility is per map anyway, and the ratio
    // needs no more directional detail than the clusters carry.
    for (var k = 0u; k < frame.atlas.z; k += 1u) {
        let light = shadow_lights[k];
        let nl = dot(n, light.dir);
        if (nl <= 0.0) {
            continue;
        }
        let e = light.rgb * nl;
        total += e;
        lit += e * shadow_visibility(k, in.world, n);
    }
    var out: FragOut;
    out.virtual_layer = vec4<f32>(0.0);
    out.ratio = vec4<f32>(select(vec3<f32>(1.0), lit / total, total > vec3<f32>(0.0)), 1.0);
    return out;
}

// VertexOut (common/object.wgsl) with the vertex's light from the cuts, interpolated over the
// triangle.
struct CutVertex {
    @invariant @builtin(position) position: vec4<f32>,
    @location(0) @interpolate(perspective, centroid) world: vec3<f32>,
    @location(1) @interpolate(perspective, centroid) normal: vec3<f32>,
    @location(2) @interpolate(perspective, centroid) uv: vec2<f32>,
    @location(3) @interpolate(perspective, centroid) e_n: vec4<f32>,
    @location(4) @interpolate(perspective, centroid) e_r: vec3<f32>,
}

// vs_object's invariant position arithmetic, plus the vertex's light from the cuts.
@vertex
fn vs_cut_object(v: VertexIn, @builtin(vertex_index) index: u32) -> CutVertex {
    var out: CutVertex;
    out.position = clip_from_world_point(camera, vec4<f32>(v.position, 1.0));
    out.world = v.position;
    out.normal = v.normal;
    out.uv = v.uv;
    out.e_n = vec4<f32>(0.0);
    out.e_r = vec3<f32>(0.0);
    let i = index * 2u;
    if (i + 1u < arrayLength(&cut_ambient)) {
        out.e_n = cut_ambient[i];
        out.e_r = cut_ambient[i + 1u].xyz;
    }
    return out;
}

// The objects under the cuts' light: B = Σ_k l_k v_k f_r as the glTF BRDF's split sum of the
// irradiance about the normal and about the mirror direction (ambient_radiance,
// common/brdf.wgsl; the outdoor mode's cut_ambient path in virtual_shading.wgsl).
@fragment
fn fs_cut_object(in: CutVertex, @builtin(front_facing) front: bool) -> FragOut {
    let s = object_surface(in.uv);
    let n = facing_normal(in.normal, front);
    let v = normalize(camera.eye_world.xyz - in.world);
    var out: FragOut;
    out.virtual_layer = vec4<f32>(ambient_radiance(s, dot(n, v), in.e_n.xyz, in.e_r), 1.0);
    out.ratio = vec4<f32>(1.0);
    return out;
}

// The receivers under the cuts' light: the ratio of the fragment's canvas pixel.
@fragment
fn fs_cut_receiver(in: ReceiverOut) -> FragOut {
    let px = vec2<u32>(max(in.position.xy, vec2<f32>(0.0)));
    let i = px.y * frame.l.w + px.x;
    var r = 1.0;
    if (frame.l.w > 0u && px.x < frame.l.w && i < arrayLength(&cut_ratio)) {
        r = cut_ratio[i];
    }
    var out: FragOut;
    out.virtual_layer = vec4<f32>(0.0);
    out.ratio = vec4<f32>(vec3<f32>(r), 1.0);
    return out;
}
