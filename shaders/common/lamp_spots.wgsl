// The lamps' spots as both the lamp term of the objects (lamps.wgsl) and the lamp shadows on real
// receivers (composite.wgsl) read them (issue 16 §2–3; Granier §3.2, §4): the spots, their
// texels and support taps, the shadow maps with the objects and the proxy, and the same maps
// with the proxy alone, all in bind group 2 (src/render/lamps/mod.rs, `data_layout`). A spot is
// a far-field lamp (E = I(ω) cos θ / r², analytic or a resampled table) or one filter position
// of a light field, the textured spot light of Eq. 14: f = cos θ_S cos θ_x / δ² from the filter
// centre times the support mean of E'_mn.

#include "common/constants.wgsl"
#include "common/vem_lights.wgsl"

struct LampHeader {
    // x: spots this frame, y: atlas tiles per side, z: tile size (texels), w: shadow maps drawn
    // (a slot at or past it reads no map).
    counts: vec4<u32>,
    // x: taps per axis of a light field's support mean (0: one lookup along the central ray);
    // y: 1 when the composite darkens real receivers by the objects' lamp shadows.
    taps: vec4<u32>,
}

// Mirrors `GpuSpot` in src/render/lamps/spots.rs.
struct LampSpot {
    // Rows of the luminaire frame from the world: x_lamp = (dot(row.xyz, p) + row.w) per axis.
    row_x: vec4<f32>,
    row_y: vec4<f32>,
    row_z: vec4<f32>,
    // The spot's centre in the luminaire frame (a light field's filter centre; 0 otherwise).
    centre: vec4<f32>,
    // The spot's centre in the world.
    world: vec4<f32>,
    // k times the lamp's unit, per channel.
    scale: vec4<f32>,
    // Analytic: cos of the inner and outer half-angles. Light field: d, plane width and height, h.
    params: vec4<f32>,
    // x: kind (LAMP_*), y: shadow slot, z: first texel, w: unused.
    index: vec4<u32>,
    // Image width and height in texels.
    dims: vec4<u32>,
}

const LAMP_ANALYTIC: u32 = 0u;
const LAMP_TABLE: u32 = 1u;
const LAMP_FIELD: u32 = 2u;

@group(2) @binding(0) var<storage, read> header: LampHeader;
@group(2) @binding(1) var<storage, read> spots: array<LampSpot>;
// Half-float RGB texels: r | g << 16, b (binary16 bits).
@group(2) @binding(2) var<storage, read> texels: array<vec2<u32>>;
// Support-mean taps per axis: x the offset in units of h, y the weight (they sum to 1).
@group(2) @binding(3) var<storage, read> taps: array<vec4<f32>>;
@group(2) @binding(4) var<storage, read> shadow_views: array<ShadowView>;
@group(2) @binding(5) var shadow_atlas: texture_depth_2d;
@group(2) @binding(6) var shadow_sampler: sampler_comparison;
// The same maps with the proxy alone (the real receivers' lamp visibility without the objects).
@group(2) @binding(7) var proxy_atlas: texture_depth_2d;

// A binary16 value (low 16 bits of `h`) as f32, exactly; decoded by hand because
// unpack2x16float needs a shader capability (SHADER_FLOAT16_IN_FLOAT32) not every adapter has.
// The stored values are at most 1 in magnitude, so infinities and NaN never occur.
fn half_to_f32(h: u32) -> f32 {
    let e = (h >> 10u) & 0x1fu;
    let m = h & 0x3ffu;
    var v = f32(m) * 5.9604645e-8;
    if (e != 0u) {
        v = bitcast<f32>(((e + 112u) << 23u) | (m << 13u));
    }
    return select(v, -v, ((h >> 15u) & 1u) == 1u);
}

fn texel(i: u32) -> vec3<f32> {
    let t = texels[i];
    return vec3<f32>(half_to_f32(t.x & 0xffffu), half_to_f32(t.x >> 16u), half_to_f32(t.y & 0xffffu));
}

// Bilinear between the texel centres of the image at `first` (`dims` texels) at continuous
// texel coordinates `f` (0 at the first centre), clamped; `wrap` wraps columns (azimuth).
fn bilinear(first: u32, dims: vec2<u32>, f: vec2<f32>, wrap: bool) -> vec3<f32> {
    let fl = floor(f);
    let t = f - fl;
    let w = dims.x;
    var x0 = u32(max(fl.x, 0.0));
    var x1 = min(x0 + 1u, w - 1u);
    if (wrap) {
        x0 = x0 % w;
        x1 = (x0 + 1u) % w;
    }
    let y0 = min(u32(max(fl.y, 0.0)), dims.y - 1u);
    let y1 = min(y0 + 1u, dims.y - 1u);
    let a = texel(first + y0 * w + x0);
    let b = texel(first + y0 * w + x1);
    let c = texel(first + y1 * w + x0);
    let d = texel(first + y1 * w + x1);
    return mix(mix(a, b, t.x), mix(c, d, t.x), t.y);
}

fn lamp_point(s: LampSpot, p: vec3<f32>) -> vec3<f32> {
    let q = vec4<f32>(p, 1.0);
    return vec3<f32>(dot(s.row_x, q), dot(s.row_y, q), dot(s.row_z, q));
}

// The analytic spot's smoothstep falloff about −Z (src/lamps/analytic.rs) for the unit
// direction `dir` from the lamp.
fn analytic_intensity(s: LampSpot, dir: vec3<f32>) -> f32 {
    let mu = -dir.z;
    let ci = s.params.x;
    let co = s.params.y;
    if (mu >= ci) {
        return 1.0;
    }
    if (mu <= co) {
        return 0.0;
    }
    let x = (mu - co) / (ci - co);
    return x * x * (3.0 - 2.0 * x);
}

// A resampled table (src/render/lamps/spots.rs): rows by the angle from −Z, columns by azimuth.
fn table_intensity(s: LampSpot, dir: vec3<f32>) -> f32 {
    let gamma = acos(clamp(-dir.z, -1.0, 1.0));
    var phi = atan2(dir.y, dir.x);
    if (phi < 0.0) {
        phi += 2.0 * PI;
    }
    let dims = s.dims.xy;
    let f = vec2<f32>(phi / (2.0 * PI) * f32(dims.x), gamma / PI * f32(dims.y - 1u));
    return bilinear(s.index.z, dims, f, true).x;
}

// E'_mn at (s, t) on the measurement plane (LightField::sample): zero outside the plane.
fn field_sample(s: LampSpot, st: vec2<f32>) -> vec3<f32> {
    let size = s.params.yz;
    let half_size = 0.5 * size;
    if (abs(st.x) > half_size.x || abs(st.y) > half_size.y) {
        return vec3<f32>(0.0);
    }
    let dims = vec2<f32>(s.dims.xy);
    let f = clamp((st + half_size) / size * dims - vec2<f32>(0.5), vec2<f32>(0.0), dims - vec2<f32>(1.0));
    return bilinear(s.index.z, s.dims.xy, f, false);
}

// Eq. 14 without the cos θ_x of the receiver: (z'/δ) / δ² times the support mean of E'_mn, for
// the point `x` of the luminaire frame at squared distance `delta2` from the filter centre.
fn field_irradiance(s: LampSpot, x: vec3<f32>, delta2: f32) -> vec3<f32> {
    let z = -x.z;
    if (z <= 0.0) {
        return vec3<f32>(0.0);
    }
    let d = s.params.x;
    let c = s.centre.xy;
    let st_c = c + (x.xy - c) * (d / z);
    var mean = vec3<f32>(0.0);
    let n = header.taps.x;
    if (n == 0u) {
        mean = field_sample(s, st_c);
    } else {
        let step = s.params.w * (1.0 - d / z);
        for (var j = 0u; j < n; j += 1u) {
            let tj = taps[j];
            for (var i = 0u; i < n; i += 1u) {
                let ti = taps[i];
                mean += (ti.y * tj.y) * field_sample(s, st_c + step * vec2<f32>(ti.x, tj.x));
            }
        }
    }
    return (z * inverseSqrt(delta2)) / delta2 * mean;
}

// Near plane of the perspective maps, metres (mirrors SPOT_NEAR_M in
// src/render/vem/shadow_atlas.rs).
const SPOT_NEAR_M: f32 = 0.02;
// The penumbra of a source with an area (PCSS; `ShadowView::with_emitter`): taps per axis of
// the blocker search and of the filter, and the widest search and filter radius in texels (a
// wider penumbra, from a blocker closer to the light than half the receiver's distance, is cut
// to it).
const PCSS_SEARCH_TAPS: i32 = 5;
const PCSS_FILTER_TAPS: i32 = 6;
const PCSS_MAX_RADIUS_TEXELS: f32 = 16.0;
// Largest tan θ of the receiver-plane bias of the wide lookups (θ ≈ 80°).
const PCSS_MAX_SLOPE: f32 = 5.67;

// A perspective map's stored depth as metres along its axis (`spot_linear_depth` in
// src/render/vem/shadow_atlas.rs), and back.
fn spot_linear_depth(z: f32, far: f32) -> f32 {
    return SPOT_NEAR_M * far / max(far - z * (far - SPOT_NEAR_M), 1e-6);
}

fn spot_stored_depth(d: f32, far: f32) -> f32 {
    return far * (d - SPOT_NEAR_M) / (max(d, 1e-6) * (far - SPOT_NEAR_M));
}

// Where point `p` (normal `n`, unit direction `l` to the light at `light`) falls in `view`: xy
// continuous texel coordinates in its tile, z the depth to compare, w 1 when inside the map. The
// point is moved toward the light and along its normal by the view's offsets per metre of
// distance.
fn spot_tile_coords(view: ShadowView, light: vec3<f32>, p: vec3<f32>, n: vec3<f32>, l: vec3<f32>) -> vec4<f32> {
    let dist = length(light - p);
    let q = view.light_from_world * vec4<f32>(p + n * (view.bias.y * dist) + l * (view.bias.x * dist), 1.0);
    if (q.w <= 1e-6) {
        return vec4<f32>(0.0);
    }
    let ndc = q.xyz / q.w;
    let uv = vec2<f32>(0.5 * ndc.x + 0.5, 0.5 - 0.5 * ndc.y);
    if (uv.x < 0.0 || uv.y < 0.0 || uv.x >= 1.0 || uv.y >= 1.0) {
        return vec4<f32>(0.0);
    }
    return vec4<f32>(uv * f32(header.counts.z), min(ndc.z, 1.0), 1.0);
}

// The atlas texel (integer coordinates) of texel `t` of map `slot`'s tile, clamped to the tile.
fn spot_atlas_texel(slot: u32, t: vec2<i32>) -> vec2<i32> {
    let tiles = header.counts.y;
    let tile = header.counts.z;
    let origin = vec2<i32>(vec2<u32>(slot % tiles, slot / tiles) * tile);
    return origin + clamp(t, vec2<i32>(0), vec2<i32>(i32(tile) - 1));
}

// The atlas coordinates of that texel's centre.
fn spot_atlas_uv(slot: u32, t: vec2<i32>) -> vec2<f32> {
    let size = f32(header.counts.y * header.counts.z);
    return (vec2<f32>(spot_atlas_texel(slot, t)) + vec2<f32>(0.5)) / size;
}

// The visibility of the light at `light` from `p` in map `slot` of `atlas` (the objects and the
// proxy, or the proxy alone). A point source (the view's emitter radius 0) reads one texel. A
// source of radius R reads the penumbra it casts (PCSS, Fernando 2005): a blocker at distance
// d_b from the light hides part of the disc from a receiver at d_r when its direction lies within
// R·(d_r − d_b)/(d_r·d_b) of the receiver's; so the mean depth of the blockers found within the
// widest such angle sets the filter, a box of that half-width whose depth tests are biased by the
// receiver's own slope across it.
fn spot_soft_visibility(atlas: texture_depth_2d, slot: u32, light: vec3<f32>, p: vec3<f32>, n: vec3<f32>, l: vec3<f32>) -> f32 {
    if (slot >= header.counts.w) {
        return 1.0;
    }
    return spot_soft_visibility_at(atlas, slot, spot_tile_coords(shadow_views[slot], light, p, n, l), n, l);
}

// spot_soft_visibility at the coordinates `c` of spot_tile_coords in map `slot` (`slot` below
// the maps drawn), so that two atlases of the same views share one projection.
fn spot_soft_visibility_at(atlas: texture_depth_2d, slot: u32, c: vec4<f32>, n: vec3<f32>, l: vec3<f32>) -> f32 {
    if (c.w < 0.5) {
        return 1.0;
    }
    let view = shadow_views[slot];
    let base = vec2<i32>(floor(c.xy));
    let radius = view.penumbra.x;
    if (radius <= 0.0) {
        return textureSampleCompareLevel(atlas, shadow_sampler, spot_atlas_uv(slot, base), c.z);
    }
    let texel = view.penumbra.y;
    let far = view.penumbra.z;
    let d_r = spot_linear_depth(c.z, far);
    let cos_t = max(dot(n, l), 0.1);
    let slope = min(sqrt(max(1.0 - cos_t * cos_t, 0.0)) / cos_t, PCSS_MAX_SLOPE);
    // Metres of the receiver plane's depth per texel of offset, and a texel of margin.
    let per_texel = texel * d_r * slope;
    let search = min(radius / (d_r * texel), PCSS_MAX_RADIUS_TEXELS);
    var blockers = 0.0;
    var depth_sum = 0.0;
    for (var j = 0; j < PCSS_SEARCH_TAPS; j += 1) {
        for (var i = 0; i < PCSS_SEARCH_TAPS; i += 1) {
            let o = (vec2<f32>(f32(i), f32(j)) + 0.5) / f32(PCSS_SEARCH_TAPS) * 2.0 - 1.0;
            let off = o * search;
            let d = spot_linear_depth(textureLoad(atlas, spot_atlas_texel(slot, vec2<i32>(floor(c.xy + off))), 0), far);
            if (d < d_r - per_texel * (length(off) + 1.0)) {
                blockers += 1.0;
                depth_sum += d;
            }
        }
    }
    if (blockers < 0.5) {
        return 1.0;
    }
    let d_b = depth_sum / blockers;
    let width = clamp(radius * (d_r - d_b) / (d_r * d_b * texel), 0.5, PCSS_MAX_RADIUS_TEXELS);
    var lit = 0.0;
    for (var j = 0; j < PCSS_FILTER_TAPS; j += 1) {
        for (var i = 0; i < PCSS_FILTER_TAPS; i += 1) {
            let o = (vec2<f32>(f32(i), f32(j)) + 0.5) / f32(PCSS_FILTER_TAPS) * 2.0 - 1.0;
            let off = o * width;
            let z = spot_stored_depth(d_r - per_texel * length(off), far);
            lit += textureSampleCompareLevel(atlas, shadow_sampler, spot_atlas_uv(slot, vec2<i32>(floor(c.xy + off))), min(z, c.z));
        }
    }
    return lit / f32(PCSS_FILTER_TAPS * PCSS_FILTER_TAPS);
}

// 1 when no caster of map `slot` (the objects and the proxy) lies between the light at `light`
// and `p`, with the penumbra of the light's area (spot_soft_visibility).
fn spot_visibility(slot: u32, light: vec3<f32>, p: vec3<f32>, n: vec3<f32>, l: vec3<f32>) -> f32 {
    return spot_soft_visibility(shadow_atlas, slot, light, p, n, l);
}

// The unscaled irradiance of `spot` at the world point `p` on a surface facing the spot
// (without the receiver's cos θ), `dist2` the squared distance to the spot's centre.
fn spot_irradiance(spot: LampSpot, p: vec3<f32>, dist2: f32) -> vec3<f32> {
    let x = lamp_point(spot, p);
    let kind = spot.index.x;
    if (kind == LAMP_FIELD) {
        return field_irradiance(spot, x, dist2);
    }
    if (kind == LAMP_TABLE) {
        return vec3<f32>(table_intensity(spot, normalize(x)) / dist2);
    }
    return vec3<f32>(analytic_intensity(spot, normalize(x)) / dist2);
}
