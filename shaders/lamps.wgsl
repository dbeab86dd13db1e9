// The lamp term of the virtual objects (issue 16 §2; Granier §3.2, §4): every lit spot's
// irradiance times its shadow-map visibility times the glTF BRDF, summed in one draw of the
// objects and added (blend One + One, alpha kept) onto the shading pass's float layer. The spots,
// their images and maps are common/lamp_spots.wgsl (group 2). Paired with src/render/lamps/.

#include "common/object.wgsl"
#include "common/lamp_spots.wgsl"

@fragment
fn fs_lamps(in: VertexOut, @builtin(front_facing) front: bool) -> @location(0) vec4<f32> {
    let n = facing_normal(in.normal, front);
    let v = normalize(camera.eye_world.xyz - in.world);
    let s = object_surface(in.uv);
    var radiance = vec3<f32>(0.0);
    for (var k = 0u; k < header.counts.x; k += 1u) {
        let spot = spots[k];
        let to_light = spot.world.xyz - in.world;
        let dist2 = dot(to_light, to_light);
        if (dist2 <= 1e-12) {
            continue;
        }
        let l = to_light * inverseSqrt(dist2);
        if (dot(n, l) <= 0.0) {
            continue;
        }
        let e = spot_irradiance(spot, in.world, dist2);
        if (all(e == vec3<f32>(0.0))) {
            continue;
        }
        let vis = spot_visibility(spot.index.y, spot.world.xyz, in.world, n, l);
        radiance += vis * spot.scale.rgb * e * brdf_cos(s, n, v, l);
    }
    return vec4<f32>(radiance, 0.0);
}
