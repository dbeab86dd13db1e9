//! The generator's path tracer under a physically based sky (the winter scenes, `winter.rs`).
//!
//! Same transport as `render.rs` (cosine-weighted bounces, next-event estimation of the sun,
//! Russian roulette, the true albedo, glossy virtual objects), with two additions:
//!
//! - **The sky is a Hosek–Wilkie sky** ([`heliar::sky::hosek`]), scaled per channel to unit
//!   irradiance on an unoccluded horizontal surface (so the image is per unit `Pa`, as `Pa` is
//!   defined). It is importance sampled: at every surface vertex a direction is drawn from a
//!   table of the sky's luminance (cells of equal azimuth and zenith steps, mixed with
//!   [`UNIFORM_MIX`] of the uniform hemisphere so every direction can be drawn) and combined with
//!   the cosine-sampled continuation by multiple importance sampling (power heuristic; Veach
//!   1997, ch. 9), so the bright circumsolar sky of a low sun costs little noise.
//! - **Light from below the horizon**: a ray that leaves the world below the horizon sees flat
//!   terrain of albedo `ρ_t` beyond the world's terrain mesh, of radiance `ρ_t/π·(Pa + l_y·Pd)`.
//!
//! - **A lamp** (the dusk scene, `dusk.rs`), optional: a disc emitter ([`DiscLamp`]) sampled by
//!   next-event estimation at every surface vertex, with a shadow ray to the sampled point.
//!
//! Radiance stays linear in `Pa` (per channel), `Pd` and the lamp's scale, so a pixel is a
//! `(sky, sun, lamp)` triple that the caller scales.

use crate::render::TrueAlbedo;
use glam::{DVec2, Vec2, Vec3};
use heliar::geometry::raycast::{RAY_EPSILON_M, RayScene};
use heliar::geometry::sampling::sample_cosine_around;
use heliar::camera::Camera;
use heliar::sky::hosek::HosekSky;
use heliar::sky::quadrature::hemisphere_integral;
use rand::{Rng, SeedableRng, rngs::SmallRng};
use rayon::prelude::*;
use std::f32::consts::PI;

/// Azimuth cells of the sampling table.
const TABLE_PHI: usize = 256;
/// Zenith-angle cells of the sampling table (upper hemisphere).
const TABLE_THETA: usize = 64;
/// Fraction of sky samples drawn uniformly over the hemisphere.
const UNIFORM_MIX: f32 = 0.1;
/// Bounces followed per path (as `render.rs`).
const MAX_DEPTH: usize = 12;
/// Depth from which Russian roulette may end a path (as `render.rs`).
const ROULETTE_DEPTH: usize = 3;

/// The sky per unit `Pa` and its sampling table.
pub struct SkyLight {
    sky: HosekSky,
    /// `1 / E_h` per channel (`E_h` the sky's horizontal irradiance).
    inv_horizontal: Vec3,
    /// Cumulative cell probabilities (row-major: θ rows, φ columns), last = 1.
    cdf: Vec<f32>,
    /// Probability of every cell.
    prob: Vec<f32>,
}

fn luminance(c: Vec3) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

/// Solid angle of zenith row `j` cells.
fn cell_solid_angle(j: usize) -> f32 {
    let dt = std::f32::consts::FRAC_PI_2 / TABLE_THETA as f32;
    2.0 * PI / TABLE_PHI as f32 * ((j as f32 * dt).cos() - ((j + 1) as f32 * dt).cos())
}

impl SkyLight {
    /// The normalised sky of `sky` and its table.
    pub fn new(sky: HosekSky) -> Self {
        let eh: [f64; 3] = std::array::from_fn(|c| hemisphere_integral(|d| sky.radiance_rgb(d.as_vec3())[c] as f64));
        let inv_horizontal = Vec3::new((1.0 / eh[0]) as f32, (1.0 / eh[1]) as f32, (1.0 / eh[2]) as f32);
        let dt = std::f32::consts::FRAC_PI_2 / TABLE_THETA as f32;
        let dp = 2.0 * PI / TABLE_PHI as f32;
        let mut weight = Vec::with_capacity(TABLE_PHI * TABLE_THETA);
        for j in 0..TABLE_THETA {
            let omega = cell_solid_angle(j);
            let theta = (j as f32 + 0.5) * dt;
            for i in 0..TABLE_PHI {
                let phi = (i as f32 + 0.5) * dp - PI;
                let d = Vec3::new(theta.sin() * phi.sin(), theta.cos(), -theta.sin() * phi.cos());
                weight.push(luminance(Vec3::from(sky.radiance_rgb(d)) * inv_horizontal) * omega);
            }
        }
        let total: f32 = weight.iter().sum();
        let prob: Vec<f32> = weight
            .iter()
            .enumerate()
            .map(|(k, w)| (1.0 - UNIFORM_MIX) * w / total + UNIFORM_MIX * cell_solid_angle(k / TABLE_PHI) / (2.0 * PI))
            .collect();
        let mut acc = 0.0;
        let mut cdf: Vec<f32> = prob.iter().map(|p| { acc += p; acc }).collect();
        if let Some(last) = cdf.last_mut() {
            *last = 1.0;
        }
        Self { sky, inv_horizontal, cdf, prob }
    }

    /// The Hosek sky's own horizontal irradiance per channel (the model's units).
    pub fn horizontal_irradiance(&self) -> Vec3 {
        Vec3::ONE / self.inv_horizontal
    }

    /// Sky radiance per unit `Pa` (per channel) along unit `d`; 0 below the horizon.
    pub fn radiance(&self, d: Vec3) -> Vec3 {
        Vec3::from(self.sky.radiance_rgb(d)) * self.inv_horizontal
    }

    /// The cell of unit direction `d` (`d.y ≥ 0`).
    fn cell(d: Vec3) -> usize {
        let theta = d.y.clamp(0.0, 1.0).acos();
        let phi = d.x.atan2(-d.z) + PI;
        let j = ((theta / std::f32::consts::FRAC_PI_2 * TABLE_THETA as f32) as usize).min(TABLE_THETA - 1);
        let i = ((phi / (2.0 * PI) * TABLE_PHI as f32) as usize).min(TABLE_PHI - 1);
        j * TABLE_PHI + i
    }

    /// Density (per steradian) of [`Self::sample`] at unit `d`.
    pub fn pdf(&self, d: Vec3) -> f32 {
        if d.y < 0.0 {
            return 0.0;
        }
        let k = Self::cell(d);
        self.prob[k] / cell_solid_angle(k / TABLE_PHI)
    }

    /// A direction drawn from the table: a cell by its probability, then uniform in solid angle
    /// within it. Returns the direction and its density.
    pub fn sample(&self, u: Vec2, v: Vec2) -> (Vec3, f32) {
        let k = self.cdf.partition_point(|c| *c < u.x).min(self.cdf.len() - 1);
        let (j, i) = (k / TABLE_PHI, k % TABLE_PHI);
        let dt = std::f32::consts::FRAC_PI_2 / TABLE_THETA as f32;
        let (c0, c1) = ((j as f32 * dt).cos(), ((j + 1) as f32 * dt).cos());
        let cos_t = c0 + (c1 - c0) * v.x;
        let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
        let phi = (i as f32 + v.y) * 2.0 * PI / TABLE_PHI as f32 - PI;
        let d = Vec3::new(sin_t * phi.sin(), cos_t, -sin_t * phi.cos());
        (d, self.prob[k] / cell_solid_angle(j))
    }
}

/// A street lamp's emitter: a horizontal disc facing down (`−Y`) whose radiance falls off as
/// `L(θ) = L₀ cos² θ` from its axis. Its far-field intensity is `I(θ) = L₀ π R² cos³ θ` — what a
/// goniophotometer several metres away records, and what the dusk scene's IES file holds; close
/// to the lamp the disc's size makes the true irradiance depart from `I cos θ_x / r²`.
#[derive(Clone, Copy, Debug)]
pub struct DiscLamp {
    /// Centre of the disc (world metres).
    pub centre: Vec3,
    /// Radius (m).
    pub radius: f32,
    /// Intensity on the axis, `I₀ = L₀ π R²` (frame units per unit lamp scale).
    pub intensity: f32,
}

impl DiscLamp {
    /// Far-field intensity at angle `cos θ` from the axis (`I₀ cos³ θ`; 0 above the disc).
    pub fn far_field(&self, cos_theta: f32) -> f32 {
        self.intensity * cos_theta.max(0.0).powi(3)
    }

    /// Irradiance-weighted light from one uniformly drawn point of the disc at the surface point
    /// `p` with normal `n`: `(direction, L(θ_e) cos θ_e A / r², distance)`, or `None` when the
    /// point is behind the surface or above the disc.
    fn sample(&self, p: Vec3, n: Vec3, u: Vec2) -> Option<(Vec3, f32, f32)> {
        let (r, phi) = (self.radius * u.x.sqrt(), 2.0 * PI * u.y);
        let q = self.centre + Vec3::new(r * phi.cos(), 0.0, r * phi.sin());
        let to = q - p;
        let dist = to.length();
        let wi = to / dist;
        let cos_e = wi.y; // the emitter faces −Y: cos θ_e = (−Y)·(p − q)/|p − q|
        if n.dot(wi) <= 0.0 || cos_e <= 0.0 {
            return None;
        }
        let area = PI * self.radius * self.radius;
        let radiance = self.intensity / area * cos_e * cos_e;
        Some((wi, radiance * cos_e * area / (dist * dist), dist))
    }
}

/// Everything that lights the winter world.
pub struct Lighting<'a> {
    /// Unit direction toward the sun.
    pub sun: Vec3,
    /// The sky.
    pub sky: &'a SkyLight,
    /// Albedo of the terrain beyond the world's meshes (rays that leave below the horizon).
    pub terrain_albedo: Vec3,
    /// A lamp, per unit of its scale (the dusk scene), or none.
    pub lamp: Option<DiscLamp>,
}

/// Power-heuristic weight of a strategy with density `a` against one with density `b`.
fn power(a: f32, b: f32) -> f32 {
    if a <= 0.0 { 0.0 } else { a * a / (a * a + b * b) }
}

/// Radiance basis along one ray: `(sky, sun)` per unit `Pa` (per channel) and unit `Pd`.
pub fn trace(scene: &RayScene, albedo: &dyn TrueAlbedo, origin: Vec3, dir: Vec3, light: &Lighting, rng: &mut SmallRng) -> (Vec3, Vec3) {
    let (sky, sun, _) = trace_with_lamp(scene, albedo, origin, dir, light, rng);
    (sky, sun)
}

/// [`trace`] with the lamp's basis as well: `(sky, sun, lamp)`, the last per unit lamp scale. The
/// lamp draws random numbers only when there is one, so the winter renders are unchanged.
pub fn trace_with_lamp(scene: &RayScene, albedo: &dyn TrueAlbedo, origin: Vec3, dir: Vec3, light: &Lighting, rng: &mut SmallRng) -> (Vec3, Vec3, Vec3) {
    let [sky, sun, lamp, _] = trace_split(scene, albedo, origin, dir, light, rng);
    (sky, sun, lamp)
}

/// [`trace_with_lamp`] with the lamp's basis split as well: `[sky, sun, lamp, lamp_first]`, where
/// `lamp_first` is the lamp's light at the first surface the ray meets (its direct light there,
/// part of `lamp`); `lamp − lamp_first` is the lamp's light after one or more bounces. The same
/// random numbers as [`trace_with_lamp`].
pub fn trace_split(scene: &RayScene, albedo: &dyn TrueAlbedo, origin: Vec3, dir: Vec3, light: &Lighting, rng: &mut SmallRng) -> [Vec3; 4] {
    let (mut sky, mut sun_l, mut lamp_l, mut lamp_first) = (Vec3::ZERO, Vec3::ZERO, Vec3::ZERO, Vec3::ZERO);
    let mut throughput = Vec3::ONE;
    let (mut o, mut d) = (origin, dir);
    let mut offset = Vec3::ZERO;
    // Density of the cosine sampling that produced `d` (None for the camera ray).
    let mut bsdf_pdf: Option<f32> = None;
    for depth in 0..MAX_DEPTH {
        let Some(hit) = scene.intersect(o + offset, d, f32::MAX) else {
            if d.y > 0.0 {
                let w = bsdf_pdf.map_or(1.0, |p| power(p, light.sky.pdf(d)));
                sky += throughput * light.sky.radiance(d) * w;
            } else {
                let t = throughput * light.terrain_albedo / PI;
                sky += t;
                sun_l += t * light.sun.y.max(0.0);
            }
            break;
        };
        let n = hit.normal;
        let v = -d;
        // f(ω) for the sky and sun estimates, and the continuation weight f·cos/pdf = π·f.
        let glossy = albedo.glossy(hit.tri);
        let rho = if glossy.is_none() { albedo.albedo(hit.tri, hit.point, scene.albedo(&hit)) } else { Vec3::ZERO };
        let brdf = |l: Vec3| match &glossy {
            Some(g) => g.brdf(n, v, l),
            None => rho / PI,
        };
        let cos = n.dot(light.sun);
        if cos > 0.0 && scene.sees_direction(hit.point, n, light.sun) {
            sun_l += throughput * brdf(light.sun) * cos;
        }
        if let Some(lamp) = &light.lamp
            && let Some((wi, e, dist)) = lamp.sample(hit.point, n, Vec2::new(rng.random(), rng.random()))
        {
            let o = hit.point + n * RAY_EPSILON_M;
            if !scene.occluded(o, wi, dist - 2.0 * RAY_EPSILON_M) {
                let add = throughput * brdf(wi) * e * n.dot(wi);
                lamp_l += add;
                if depth == 0 {
                    lamp_first += add;
                }
            }
        }
        let (ls, ps) = light.sky.sample(Vec2::new(rng.random(), rng.random()), Vec2::new(rng.random(), rng.random()));
        let cos_s = n.dot(ls);
        if cos_s > 0.0 && ps > 0.0 && scene.sees_direction(hit.point, n, ls) {
            let w = power(ps, cos_s / PI);
            sky += throughput * brdf(ls) * cos_s * light.sky.radiance(ls) * (w / ps);
        }
        let next = sample_cosine_around(n, Vec2::new(rng.random(), rng.random()));
        throughput *= brdf(next) * PI;
        if depth >= ROULETTE_DEPTH {
            let q = throughput.max_element().min(0.95);
            if rng.random::<f32>() >= q {
                break;
            }
            throughput /= q;
        }
        bsdf_pdf = Some(n.dot(next).max(0.0) / PI);
        o = hit.point;
        offset = n * RAY_EPSILON_M;
        d = next;
    }
    [sky, sun_l, lamp_l, lamp_first]
}

/// `(sky, sun)` basis images of `camera` over the pixels `(x0, y0, width, height)` with `spp`
/// jittered samples per pixel (row-major within the region).
pub fn render_region(
    scene: &RayScene,
    albedo: &dyn TrueAlbedo,
    camera: &Camera,
    light: &Lighting,
    spp: u32,
    seed: u64,
    region: (u32, u32, u32, u32),
) -> (Vec<Vec3>, Vec<Vec3>) {
    let px = render_region_with_lamp(scene, albedo, camera, light, spp, seed, region);
    px.into_iter().map(|(a, b, _)| (a, b)).unzip()
}

/// [`render_region`] with the lamp's basis: `(sky, sun, lamp)` per pixel.
pub fn render_region_with_lamp(
    scene: &RayScene,
    albedo: &dyn TrueAlbedo,
    camera: &Camera,
    light: &Lighting,
    spp: u32,
    seed: u64,
    region: (u32, u32, u32, u32),
) -> Vec<(Vec3, Vec3, Vec3)> {
    render_region_split(scene, albedo, camera, light, spp, seed, region).into_iter().map(|[a, b, c, _]| (a, b, c)).collect()
}

/// [`render_region_with_lamp`] with the lamp's first-surface light as well ([`trace_split`]):
/// `[sky, sun, lamp, lamp_first]` per pixel, the same samples.
pub fn render_region_split(
    scene: &RayScene,
    albedo: &dyn TrueAlbedo,
    camera: &Camera,
    light: &Lighting,
    spp: u32,
    seed: u64,
    (x0, y0, w, h): (u32, u32, u32, u32),
) -> Vec<[Vec3; 4]> {
    let rows: Vec<Vec<[Vec3; 4]>> = (y0..y0 + h)
        .into_par_iter()
        .map(|y| {
            (x0..x0 + w)
                .map(|x| {
                    let mut rng = SmallRng::seed_from_u64(seed ^ ((y as u64) << 32 | x as u64).wrapping_mul(0x2545_f491_4f6c_dd1d));
                    let mut sum = [Vec3::ZERO; 4];
                    for _ in 0..spp {
                        let uv = DVec2::new(x as f64 + rng.random::<f64>() - 0.5, y as f64 + rng.random::<f64>() - 0.5);
                        if let Some((o, d)) = camera.ray_at(uv) {
                            let t = trace_split(scene, albedo, o.as_vec3(), d.as_vec3(), light, &mut rng);
                            for (s, v) in sum.iter_mut().zip(t) {
                                *s += v;
                            }
                        }
                    }
                    let k = 1.0 / spp as f32;
                    sum.map(|s| s * k)
                })
                .collect()
        })
        .collect();
    rows.into_iter().flatten().collect()
}

/// `(sky, sun)` basis of an equirect environment map seen from `centre`.
#[allow(clippy::too_many_arguments)]
pub fn render_env(scene: &RayScene, albedo: &dyn TrueAlbedo, centre: Vec3, width: u32, height: u32, light: &Lighting, spp: u32, seed: u64) -> (Vec<Vec3>, Vec<Vec3>) {
    let rows: Vec<Vec<(Vec3, Vec3)>> = (0..height)
        .into_par_iter()
        .map(|y| {
            (0..width)
                .map(|x| {
                    let mut rng = SmallRng::seed_from_u64(seed ^ ((y as u64) << 32 | x as u64).wrapping_mul(0x9e37_79b9));
                    let (mut a, mut b) = (Vec3::ZERO, Vec3::ZERO);
                    for _ in 0..spp {
                        let d = heliar::geometry::equirect::dir_from_texel(x as f32 + rng.random::<f32>(), y as f32 + rng.random::<f32>(), width, height);
                        let (s, l) = trace(scene, albedo, centre, d, light, &mut rng);
                        a += s;
                        b += l;
                    }
                    (a / spp as f32, b / spp as f32)
                })
                .collect()
        })
        .collect();
    rows.into_iter().flatten().unzip()
}

#[cfg(test)]
mod tests {
    use super::*;
    use heliar::geometry::{Material, Mesh};

    struct Plain;
    impl TrueAlbedo for Plain {
        fn albedo(&self, _tri: u32, _point: Vec3, base: Vec3) -> Vec3 {
            base
        }
    }

    #[test]
    fn open_ground_receives_unit_sky_irradiance() {
        // A Lambertian plane under the normalised sky receives irradiance 1 per unit Pa, so it
        // shows radiance ρ/π; the sun adds ρ/π·l_y per unit Pd. Whatever the sky's shape, the MIS
        // of the table and the cosine sampling must reproduce that without bias.
        let mut mesh = Mesh::default();
        let m = mesh.add_material(Material::diffuse("ground", [0.5, 0.5, 0.5]));
        let node = mesh.add_node("ground", true);
        mesh.push_quad(Vec3::new(-1e3, 0.0, -1e3), Vec3::Z * 2e3, Vec3::X * 2e3, node, m);
        let scene = RayScene::new(mesh);
        let sun = Vec3::new(0.3, 0.1, 0.95).normalize();
        let sky = SkyLight::new(HosekSky::new(sun, 3.0, [0.8; 3]).unwrap());
        let light = Lighting { sun, sky: &sky, terrain_albedo: Vec3::splat(0.8), lamp: None };
        let mut rng = SmallRng::seed_from_u64(5);
        let n = 40_000;
        let (mut s, mut l) = (Vec3::ZERO, Vec3::ZERO);
        for _ in 0..n {
            let (a, b) = trace(&scene, &Plain, Vec3::new(0.0, 1.0, 0.0), Vec3::NEG_Y, &light, &mut rng);
            s += a;
            l += b;
        }
        let (s, l) = (s / n as f32, l / n as f32);
        let expect = 0.5 / PI;
        // Standard error of the mean of 4·10⁴ paths of a smooth sky: well under 1%.
        for c in 0..3 {
            assert!((s[c] - expect).abs() < 0.01 * expect, "sky {s} vs {expect}");
            assert!((l[c] - expect * sun.y).abs() < 1e-5, "sun {l}");
        }
        // Looking down where no geometry is: the distant terrain, ρ_t/π·(Pa + l_y·Pd).
        let (a, b) = trace(&RayScene::new(Mesh::default()), &Plain, Vec3::Y, Vec3::NEG_Y, &light, &mut rng);
        assert!((a - Vec3::splat(0.8 / PI)).length() < 1e-6 && (b - Vec3::splat(0.8 / PI * sun.y)).length() < 1e-6);
    }

    #[test]
    fn lamp_gives_the_discs_closed_form_irradiance_below_it() {
        // On the axis of a disc of radius R at height h with radiance L₀cos²θ, the irradiance is
        // E = π L₀/2 · (1 − (h²/(h² + R²))²) = I₀/(2R²) · (1 − (h²/(h² + R²))²): here 0.2284·I₀,
        // against the far field's I₀/h² = 0.25·I₀ (the disc's size matters this close).
        let mut mesh = Mesh::default();
        let m = mesh.add_material(Material::diffuse("ground", [0.5, 0.5, 0.5]));
        let node = mesh.add_node("ground", true);
        mesh.push_quad(Vec3::new(-50.0, 0.0, -50.0), Vec3::Z * 100.0, Vec3::X * 100.0, node, m);
        let scene = RayScene::new(mesh);
        let sun = Vec3::new(0.3, 0.5, 0.8).normalize();
        let sky = SkyLight::new(HosekSky::new(sun, 3.0, [0.2; 3]).unwrap());
        let (h, r, i0) = (2.0f32, 0.5f32, 0.8f32);
        let lamp = DiscLamp { centre: Vec3::new(0.0, h, 0.0), radius: r, intensity: i0 };
        let light = Lighting { sun, sky: &sky, terrain_albedo: Vec3::ZERO, lamp: Some(lamp) };
        let mut rng = SmallRng::seed_from_u64(9);
        let n = 40_000;
        let mut sum = Vec3::ZERO;
        for _ in 0..n {
            sum += trace_with_lamp(&scene, &Plain, Vec3::new(0.0, 1.0, 0.0), Vec3::NEG_Y, &light, &mut rng).2;
        }
        let q = (h * h / (h * h + r * r)).powi(2);
        let expect = 0.5 / PI * i0 / (2.0 * r * r) * (1.0 - q);
        // The estimator's spread over the disc is ±12% per sample: 4·10⁴ samples give ≈ 0.06%.
        for c in 0..3 {
            assert!((sum[c] / n as f32 - expect).abs() < 3e-3 * expect, "{} vs {expect}", sum[c] / n as f32);
        }
        assert!((lamp.far_field(1.0) / (h * h) - 0.25 * i0).abs() < 1e-6 && lamp.far_field(0.5) == i0 * 0.125);
    }

    #[test]
    fn table_density_integrates_to_one_and_matches_sampling() {
        let sun = Vec3::new(0.3, 0.12, 0.95).normalize();
        let light = SkyLight::new(HosekSky::new(sun, 3.0, [0.8; 3]).unwrap());
        assert!((light.prob.iter().sum::<f32>() - 1.0).abs() < 1e-4);
        // ∫ pdf dω over the hemisphere = 1 (midpoint rule on a finer grid than the table).
        let (nt, np) = (256, 1024);
        let mut total = 0.0f64;
        for j in 0..nt {
            let t = (j as f32 + 0.5) / nt as f32 * std::f32::consts::FRAC_PI_2;
            for i in 0..np {
                let p = (i as f32 + 0.5) / np as f32 * 2.0 * PI - PI;
                let d = Vec3::new(t.sin() * p.sin(), t.cos(), -t.sin() * p.cos());
                total += (light.pdf(d) * t.sin()) as f64 * (std::f64::consts::FRAC_PI_2 / nt as f64) * (2.0 * std::f64::consts::PI / np as f64);
            }
        }
        assert!((total - 1.0).abs() < 5e-3, "{total}");
        // A sample's density is its cell's; f32 rounding can put a sample drawn at a cell's very
        // edge into the neighbour (a few in 10⁴).
        let mut rng = SmallRng::seed_from_u64(3);
        let mut mismatched = 0;
        for _ in 0..10_000 {
            let (d, p) = light.sample(Vec2::new(rng.random(), rng.random()), Vec2::new(rng.random(), rng.random()));
            assert!(d.y >= 0.0 && (d.length() - 1.0).abs() < 1e-4);
            mismatched += usize::from((light.pdf(d) - p).abs() > 1e-3 * p);
        }
        assert!(mismatched < 20, "{mismatched}");
        // Normalised: unit horizontal irradiance per channel.
        for c in 0..3 {
            let e = hemisphere_integral(|d| light.radiance(d.as_vec3())[c] as f64);
            assert!((e - 1.0).abs() < 1e-4, "{e}");
        }
    }
}
