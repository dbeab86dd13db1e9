#include "common/constants.wgsl"

// Per-frame lighting of the compositor. Mirrors `LightingUniform` in src/render/frame.rs.
//
// Radiometry (crate docs): a Lambertian point of albedo rho has radiance
// rho/pi * (c*Pa + s*Pd*max(n.l, 0) [+ b*Pd]); Pd is the sun's irradiance on a surface facing the
// sun, Pa the sky's irradiance on an unoccluded horizontal surface.

struct Lighting {
    // Unit direction toward the sun (world); w = 1 when the sun term is on, 0 when skipped.
    sun_dir: vec4<f32>,
    // Pd (rgb).
    pd: vec4<f32>,
    // Pa (rgb).
    pa: vec4<f32>,
    // x: darkening model (0 = normal-aware, 1 = constant ratio, 2 = differential); y: 1 to add
    // the sun bounce b*Pd;
    // z: scale applied to the composite (1 for files, the exposure for a window); w: lattice
    // stride of the virtual objects' per-pixel ambient transfer, 0 when it is off.
    params: vec4<f32>,
}
