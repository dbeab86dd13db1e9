// The VEM shadow-map atlas (Havran §4.3: shadows for the clustered lights): the virtual objects
// into one 256² (configurable) tile per shadow map, depth only, orthographic along each light.
// The tile is the draw's viewport; the instance index is the map's slot.
// Paired with src/render/vem/shadow_atlas.rs.

#include "common/vem_lights.wgsl"

@group(0) @binding(0) var<storage, read> shadow_views: array<ShadowView>;

@vertex
fn vs_main(@location(0) position: vec3<f32>, @builtin(instance_index) slot: u32) -> @builtin(position) vec4<f32> {
    return shadow_views[slot].light_from_world * vec4<f32>(position, 1.0);
}
