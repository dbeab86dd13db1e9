#include "common/constants.wgsl"

// glTF 2.0 metallic-roughness BRDF (glTF specification, Appendix B): Lambert diffuse weighted by
// (1 - F), GGX distribution, height-correlated Smith visibility, Schlick Fresnel. Mirrored on the
// CPU by the shading reference of the tests (tests/render_support).

struct Surface {
    base_color: vec3<f32>,
    metallic: f32,
    roughness: f32,
}

const DIELECTRIC_F0: f32 = 0.04;
// Smallest GGX alpha: keeps a perfectly smooth material from producing an infinite peak.
const MIN_ALPHA: f32 = 0.002;

fn fresnel_f0(s: Surface) -> vec3<f32> {
    return mix(vec3<f32>(DIELECTRIC_F0), s.base_color, s.metallic);
}

// f(v, l) * max(n.l, 0) for unit n, v, l: the response to a directional light of unit irradiance
// on a surface facing it.
fn brdf_cos(s: Surface, n: vec3<f32>, v: vec3<f32>, l: vec3<f32>) -> vec3<f32> {
    let nl = dot(n, l);
    if (nl <= 0.0) {
        return vec3<f32>(0.0);
    }
    let nv = max(dot(n, v), 1e-4);
    let h = normalize(l + v);
    let nh = max(dot(n, h), 0.0);
    let vh = max(dot(v, h), 0.0);
    let alpha = max(s.roughness * s.roughness, MIN_ALPHA);
    let a2 = alpha * alpha;
    let f0 = fresnel_f0(s);
    let fresnel = f0 + (vec3<f32>(1.0) - f0) * pow(1.0 - vh, 5.0);
    let c_diff = mix(s.base_color, vec3<f32>(0.0), s.metallic);
    let diffuse = (vec3<f32>(1.0) - fresnel) * c_diff / PI;
    let t = nh * nh * (a2 - 1.0) + 1.0;
    let d = a2 / (PI * t * t);
    let vis = 0.5 / (nl * sqrt(nv * nv * (1.0 - a2) + a2) + nv * sqrt(nl * nl * (1.0 - a2) + a2));
    return (diffuse + fresnel * d * vis) * nl;
}

// Directional albedo of the specular lobe, (scale, bias) with F0*scale + bias: Karis' analytic fit
// of the split-sum environment BRDF ("Physically Based Shading on Mobile", 2014).
fn env_brdf(roughness: f32, nv: f32) -> vec2<f32> {
    let c0 = vec4<f32>(-1.0, -0.0275, -0.572, 0.022);
    let c1 = vec4<f32>(1.0, 0.0425, 1.04, -0.04);
    let r = roughness * c0 + c1;
    let a004 = min(r.x * r.x, exp2(-9.28 * nv)) * r.x + r.y;
    return vec2<f32>(-1.04, 1.04) * a004 + r.zw;
}

// Radiance from ambient light given irradiance e_n on the normal and e_r on the mirror direction:
// diffuse c_diff/pi * E(n) * (1 - specular albedo), and the specular albedo times E(r)/pi (the
// radiance of a smooth environment that gives the irradiance E(r); exact for a uniform one, an
// approximation for rough lobes otherwise).
fn ambient_radiance(s: Surface, nv: f32, e_n: vec3<f32>, e_r: vec3<f32>) -> vec3<f32> {
    let ab = env_brdf(s.roughness, max(nv, 1e-4));
    let spec_albedo = fresnel_f0(s) * ab.x + vec3<f32>(ab.y);
    let c_diff = mix(s.base_color, vec3<f32>(0.0), s.metallic);
    return c_diff / PI * e_n * (vec3<f32>(1.0) - spec_albedo) + spec_albedo * e_r / PI;
}

// brdf_cos split into its diffuse and specular lobes (their sum is brdf_cos): the VEM shading
// takes the diffuse lobe from the light set H and the specular one from the L/H split of
// Havran §4.2 (shaders/vem/shading.wgsl).
struct BrdfParts {
    diffuse: vec3<f32>,
    specular: vec3<f32>,
}

fn brdf_cos_parts(s: Surface, n: vec3<f32>, v: vec3<f32>, l: vec3<f32>) -> BrdfParts {
    var out: BrdfParts;
    out.diffuse = vec3<f32>(0.0);
    out.specular = vec3<f32>(0.0);
    let nl = dot(n, l);
    if (nl <= 0.0) {
        return out;
    }
    let nv = max(dot(n, v), 1e-4);
    let h = normalize(l + v);
    let nh = max(dot(n, h), 0.0);
    let vh = max(dot(v, h), 0.0);
    let alpha = max(s.roughness * s.roughness, MIN_ALPHA);
    let a2 = alpha * alpha;
    let f0 = fresnel_f0(s);
    // (1 - v.h)^5 by multiplication: pow is exp2(5 log2 x) in a software rasteriser, and this
    // function runs once per light and pixel.
    let m = 1.0 - vh;
    let m2 = m * m;
    let fresnel = f0 + (vec3<f32>(1.0) - f0) * (m2 * m2 * m);
    let c_diff = mix(s.base_color, vec3<f32>(0.0), s.metallic);
    let t = nh * nh * (a2 - 1.0) + 1.0;
    let d = a2 / (PI * t * t);
    let vis = 0.5 / (nl * sqrt(nv * nv * (1.0 - a2) + a2) + nv * sqrt(nl * nl * (1.0 - a2) + a2));
    out.diffuse = (vec3<f32>(1.0) - fresnel) * c_diff / PI * nl;
    out.specular = fresnel * d * vis * nl;
    return out;
}
