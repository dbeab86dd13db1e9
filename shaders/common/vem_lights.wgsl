// Lights of the captured-VEM mode (Havran 2005 §4.1–4.3) as the shaders read them.
// Mirrors `GpuLight` (src/vem/regions.rs), `VemFrameUniform` (src/render/vem/shading.rs) and
// `ShadowView` (src/render/vem/shadow_atlas.rs).
//
// A list buffer (one for the set H, one for the glossy set L) holds u32 values: the cube-map LUT
// (6·S·S region numbers, faces +X −X +Y −Y +Z −Z, row-major, row 0 at t = 0), then per region
// (offset, count) into the ids, then the ids (light indices, each region's in sequence order).

struct VemLight {
    // Unit direction toward the light (world).
    dir: vec3<f32>,
    // Shadow-map atlas slot (0xffffffff: none).
    shadow: u32,
    // Irradiance on a surface facing the light.
    rgb: vec3<f32>,
    // The light's sequence index.
    index: u32,
}

struct VemFrame {
    // x: lights in H, y: H regions, z: H LUT size per face, w: flags (VEM_*).
    h: vec4<u32>,
    // x: lights in L, y: L regions, z: L LUT size per face, w: canvas width in pixels with the
    // visibility cuts' light (the index of `cut_ratio`, shaders/vem/shading.wgsl), else 0.
    l: vec4<u32>,
    // x: atlas tiles per side, y: tile size in texels, z: shadow maps this frame, w: unused.
    atlas: vec4<u32>,
    // x: cos(γ/2), the glossy cone around the mirror direction; y: ground albedo; zw: unused.
    params: vec4<f32>,
}

// Per-region culling on (else every light is visited).
const VEM_CULLING: u32 = 1u;
// Shadow-map visibility on.
const VEM_SHADOWS: u32 = 2u;
// The glossy L/H split on.
const VEM_GLOSSY: u32 = 4u;

// A light without a shadow map (and the "no map read yet" state of the shading loops).
const NO_SLOT: u32 = 0xffffffffu;

// One shadow map of the atlas: orthographic (the VEM lights), or perspective from a point (the
// compositor's lamps, shaders/lamps.wgsl).
struct ShadowView {
    // World → clip: x, y in [-1, 1] over the tile, z in [0, 1] from the casters' side nearest
    // the light (after the division by w for a perspective map).
    light_from_world: mat4x4<f32>,
    // Orthographic (w = 0): x depth bias (clip z units), y normal offset (metres). Perspective
    // (w = 1): x, y the offsets toward the light and along the normal per metre of distance to
    // the light. z: unused.
    bias: vec4<f32>,
    // Perspective maps of a light with an area (`ShadowView::with_emitter`): x the emitter's
    // radius (m; 0 a point, one texel), y a texel's angular size on the axis, z the far plane (m).
    // Zero for orthographic maps.
    penumbra: vec4<f32>,
}

// The LUT texel of direction `d` on a `size`² per face cube map: `CubeLut::texel` in
// src/vem/regions.rs, written again (same face order and (s, t) convention).
fn cube_lut_texel(d: vec3<f32>, size: u32) -> u32 {
    let a = abs(d);
    var face = 0u;
    var sc = 0.0;
    var tc = 0.0;
    var ma = 0.0;
    if (a.x >= a.y && a.x >= a.z) {
        ma = a.x;
        if (d.x > 0.0) {
            face = 0u; sc = -d.z; tc = -d.y;
        } else {
            face = 1u; sc = d.z; tc = -d.y;
        }
    } else if (a.y >= a.z) {
        ma = a.y;
        if (d.y > 0.0) {
            face = 2u; sc = d.x; tc = d.z;
        } else {
            face = 3u; sc = d.x; tc = -d.z;
        }
    } else {
        ma = a.z;
        if (d.z > 0.0) {
            face = 4u; sc = d.x; tc = -d.y;
        } else {
            face = 5u; sc = -d.x; tc = -d.y;
        }
    }
    ma = max(ma, 1e-30);
    let n = f32(size);
    let s = 0.5 * (sc / ma + 1.0);
    let t = 0.5 * (tc / ma + 1.0);
    let col = min(u32(max(s * n, 0.0)), size - 1u);
    let row = min(u32(max(t * n, 0.0)), size - 1u);
    return (face * size + row) * size + col;
}
