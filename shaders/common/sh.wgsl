// Order-2 real spherical harmonics and the irradiance-probe grid.
// Basis and order mirror `heliar::irradiance::sh::basis`; the grid and its trilinear
// interpolation with invalid probes left out mirror `ProbeGrid::coeffs_at` (src/irradiance).
// Probe data mirrors `ProbeGridHeader` / the coefficient buffer in src/render/probes.rs.

struct ProbeGridHeader {
    // xyz: world position of probe (0, 0, 0); w: spacing in metres.
    origin: vec4<f32>,
    // xyz: probes per axis; w: total probes.
    dims: vec4<u32>,
}

fn sh_basis(d: vec3<f32>) -> array<f32, 9> {
    return array<f32, 9>(
        0.282095,
        0.488603 * d.y,
        0.488603 * d.z,
        0.488603 * d.x,
        1.092548 * d.x * d.y,
        1.092548 * d.y * d.z,
        0.315392 * (3.0 * d.z * d.z - 1.0),
        1.092548 * d.x * d.z,
        0.546274 * (d.x * d.x - d.y * d.y),
    );
}
