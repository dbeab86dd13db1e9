// The virtual objects as the shading passes draw them (shaders/virtual_shading.wgsl and
// shaders/vem/shading.wgsl): the canvas camera (group 0, binding 0), a draw's glTF material
// (group 1), the vertex layout of `VirtualVertex` (src/gpu/mesh.rs), the vertex stage, and the
// surface a fragment shades with. Mirrors `MaterialUniform` and `material_layout` in
// src/gpu/mesh.rs.

#include "common/camera.wgsl"
#include "common/brdf.wgsl"

struct Material {
    // Linear base colour factor.
    base_color: vec4<f32>,
    // x: metallic, y: roughness, z: 1 when the base-colour texture is used, w: unused.
    params: vec4<f32>,
}

@group(0) @binding(0) var<uniform> camera: Camera;

// A storage buffer, not a uniform: lavapipe recompiles (and leaks) a shader whose branches read
// uniforms on every bind (issue 12; tests/suite/uniform_branches.rs).
@group(1) @binding(0) var<storage, read> material: Material;
@group(1) @binding(1) var base_color_texture: texture_2d<f32>;
@group(1) @binding(2) var base_color_sampler: sampler;

struct VertexIn {
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) uv: vec2<f32>,
}

// Centroid interpolation: with MSAA a fragment is shaded once per pixel, at the pixel's centre
// unless told otherwise, even when the triangle covers only some of its samples. A face seen at a
// grazing angle (the statue's pedestal top, one pixel row high) then takes its position, normal
// and texture coordinate extrapolated far past its covered samples: at night the pedestal top's
// pixels looked up the lamp's shadow map under the sphere and came out 3–4× too dark (dusk scene,
// frame 4: object 7.1% → 3.4% relative RMSE against the path-traced reference; docs/measurements.md,
// "Centroid interpolation"). Every struct that carries a surface's attributes to a shading
// fragment shader uses it (`ShadeVertex` in virtual_shading.wgsl, `CutVertex` in vem/shading.wgsl).
struct VertexOut {
    @invariant @builtin(position) position: vec4<f32>,
    @location(0) @interpolate(perspective, centroid) world: vec3<f32>,
    @location(1) @interpolate(perspective, centroid) normal: vec3<f32>,
    @location(2) @interpolate(perspective, centroid) uv: vec2<f32>,
}

// The same invariant position arithmetic as the depth prepass, so the shading pass's depth test
// against it (GreaterEqual) passes exactly on the visible surface.
@vertex
fn vs_object(v: VertexIn) -> VertexOut {
    var out: VertexOut;
    out.position = clip_from_world_point(camera, vec4<f32>(v.position, 1.0));
    out.world = v.position;
    out.normal = v.normal;
    out.uv = v.uv;
    return out;
}

// The material at texture coordinate `uv`: base colour (times the texture when there is one),
// metallic, roughness. Call from uniform control flow (it samples with derivatives).
fn object_surface(uv: vec2<f32>) -> Surface {
    var base = material.base_color.rgb;
    if (material.params.z > 0.5) {
        base *= textureSample(base_color_texture, base_color_sampler, uv).rgb;
    }
    return Surface(base, material.params.x, material.params.y);
}

// The unit shading normal on the side the camera sees: an open mesh seen from behind shades its
// back face.
fn facing_normal(normal: vec3<f32>, front: bool) -> vec3<f32> {
    var n = normalize(normal);
    if (!front) {
        n = -n;
    }
    return n;
}
