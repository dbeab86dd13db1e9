//! The weighted-ambient factor `c` and the sun-bounce factor `b` of a surface point, by path
//! tracing against the real proxy.
//!
//! Jensen §4.1 defines the weighted-ambient map as how much light each point receives from the
//! sky dome, computed "by a radiosity rendering of the scene with an all white skydome". heliar
//! uses the same quantity per pixel sample (estimator, Jensen §3.1) and per environment texel (the
//! bake), so it is written once, here.
//!
//! # How it works
//! Under Jensen's model ([`transport`]) the sky is a uniform dome of radiance `1/π` over the upper
//! hemisphere (directions with `y > 0`; below the horizon, where no proxy geometry is hit, there is
//! no light); [`transport_under`] takes the scene's sky instead (its shape and the terrain below
//! the horizon, [`Escape`]), with `c` still per unit `Pa`. Under the uniform sky an unoccluded
//! horizontal surface receives unit irradiance and an unoccluded vertical one ½. From the point `p` with normal `n`, `paths` cosine-weighted paths are traced
//! (stratified on the first bounce). With pdf `cos θ/π`, a path that escapes to the sky after
//! passing Lambertian surfaces of albedos `ρ₁ … ρ_k` contributes `ρ₁⋯ρ_k` to the estimate of `c`
//! (RGB, because coloured walls tint the light they pass on). Paths stop after `max_bounces`
//! surface hits; the energy lost there is below `ρ_max^max_bounces`.
//!
//! The sun-bounce factor `b` is the irradiance at `p` from sun light reflected by other proxy
//! surfaces, per unit `Pd`: at every vertex `y` of the same paths, next-event estimation toward the
//! sun adds `ρ₁⋯ρ_k · s(y) · max(n_y·l, 0)` (Jensen ignores this term; the estimator measures
//! whether it helps).

use super::raycast::{RAY_EPSILON_M, RayScene};
use super::sampling::{sample_cosine_around, sample_stratified_2d};
use glam::{Vec2, Vec3};
use rand::{Rng, SeedableRng, rngs::SmallRng};

/// Quality settings of the transport integrals.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct TransportQuality {
    /// Paths per point.
    pub paths: u32,
    /// Surface hits followed per path.
    pub max_bounces: u32,
}

impl Default for TransportQuality {
    fn default() -> Self {
        Self { paths: 256, max_bounces: 4 }
    }
}

/// `c` and `b` of a point (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transport {
    /// Weighted-ambient factor (RGB); 1 for an unoccluded horizontal surface.
    pub c: Vec3,
    /// Sun-bounce factor per unit `Pd` (RGB); zero when no sun direction was given.
    pub b: Vec3,
}

/// What a path that leaves the proxy in direction `d` brings back: `π` × the radiance per unit
/// `Pa` and per unit `Pd`, or `None` for nothing. The scene's sky (`crate::sky::radiance`) and
/// [`UniformSky`] implement it.
pub trait Escape: Sync {
    /// See the trait docs; `d` is a unit direction.
    fn escape(&self, d: Vec3) -> Option<(Vec3, Vec3)>;
}

/// Jensen's sky: uniform over the upper hemisphere (`π·L = 1` per unit `Pa`), nothing below.
#[derive(Clone, Copy, Debug, Default)]
pub struct UniformSky;

impl Escape for UniformSky {
    #[inline]
    fn escape(&self, d: Vec3) -> Option<(Vec3, Vec3)> {
        (d.y > 0.0).then_some((Vec3::ONE, Vec3::ZERO))
    }
}

/// [`transport_under`] Jensen's uniform sky.
pub fn transport(scene: &RayScene, p: Vec3, n: Vec3, sun: Option<Vec3>, quality: TransportQuality, seed: u64) -> Transport {
    transport_under(scene, p, n, sun, &UniformSky, quality, seed)
}

/// Traces the paths of point `p` with facing unit normal `n` under `sky`. `sun` is the unit
/// direction toward the sun, or `None` to compute `c` only (`sky`'s light per unit `Pd` from
/// the terrain is added to `b` either way). Deterministic for a given `seed`.
pub fn transport_under(scene: &RayScene, p: Vec3, n: Vec3, sun: Option<Vec3>, sky: &impl Escape, quality: TransportQuality, seed: u64) -> Transport {
    let mut c = Vec3::ZERO;
    let (k, b) = trace_paths(scene, p, n, sun, quality, seed, |_, throughput, dir| {
        let (pa, pd) = sky.escape(dir)?;
        c += throughput * pa;
        Some(throughput * pd)
    });
    Transport { c: c / k as f32, b: b / k as f32 }
}

/// [`transport_under`] `sky`, and along the same paths what each sky of `bounced` brings back
/// through paths that left the proxy after at least one surface hit: its `c` and `b` parts per
/// unit `Pa` and `Pd` (the interreflected light of that sky), one [`Transport`] per sky. The
/// first [`Transport`] equals [`transport_under`]'s bit for bit; the other skies cost their
/// evaluations, no ray.
pub fn transport_with_bounced<E: Escape>(
    scene: &RayScene,
    p: Vec3,
    n: Vec3,
    sun: Option<Vec3>,
    sky: &impl Escape,
    bounced: &[E],
    quality: TransportQuality,
    seed: u64,
) -> (Transport, Vec<Transport>) {
    let mut c = Vec3::ZERO;
    let mut extra = vec![(Vec3::ZERO, Vec3::ZERO); bounced.len()];
    let (k, b) = trace_paths(scene, p, n, sun, quality, seed, |hits, throughput, dir| {
        if hits > 0 {
            for (sum, sky) in extra.iter_mut().zip(bounced) {
                if let Some((pa, pd)) = sky.escape(dir) {
                    sum.0 += throughput * pa;
                    sum.1 += throughput * pd;
                }
            }
        }
        let (pa, pd) = sky.escape(dir)?;
        c += throughput * pa;
        Some(throughput * pd)
    });
    let k = k as f32;
    (Transport { c: c / k, b: b / k }, extra.into_iter().map(|(c2, b2)| Transport { c: c2 / k, b: b2 / k }).collect())
}

/// The paths of [`transport_under`]: every path that leaves the proxy calls
/// `escape(hits, throughput, direction)`, `hits` the surfaces it passed, which returns what it
/// adds to `b`; next-event estimation toward `sun` adds to `b` too. Returns the number of paths
/// and the sum of `b` (not divided).
fn trace_paths(scene: &RayScene, p: Vec3, n: Vec3, sun: Option<Vec3>, quality: TransportQuality, seed: u64, mut escape: impl FnMut(u32, Vec3, Vec3) -> Option<Vec3>) -> (u32, Vec3) {
    let mut b = Vec3::ZERO;
    let mut rng = SmallRng::seed_from_u64(seed ^ 0x9e37_79b9_7f4a_7c15);
    let k = quality.paths.max(1);
    for i in 0..k {
        // First bounce: stratified.
        let mut dir = sample_cosine_around(n, sample_stratified_2d(i, k, &mut rng));
        let (mut origin, mut normal) = (p, n);
        let mut throughput = Vec3::ONE;
        for bounce in 0..=quality.max_bounces {
            let hit = scene.intersect(origin + normal * RAY_EPSILON_M, dir, f32::MAX);
            let Some(hit) = hit else {
                if let Some(add) = escape(bounce, throughput, dir) {
                    b += add;
                }
                break;
            };
            if bounce == quality.max_bounces {
                break;
            }
            let albedo = scene.albedo(&hit);
            throughput *= albedo;
            if let Some(l) = sun {
                let cos = hit.normal.dot(l);
                if cos > 0.0 && scene.sees_direction(hit.point, hit.normal, l) {
                    b += throughput * cos;
                }
            }
            if throughput.max_element() < 1e-4 {
                break;
            }
            origin = hit.point;
            normal = hit.normal;
            dir = sample_cosine_around(normal, Vec2::new(rng.random(), rng.random()));
        }
    }
    (k, b)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Material, Mesh, NodeInfo};

    fn scene_of(quads: &[(Vec3, Vec3, Vec3, [f32; 3])]) -> RayScene {
        // Each quad: corner, edge u, edge v, albedo.
        let mut m = Mesh::default();
        for (i, (o, eu, ev, a)) in quads.iter().enumerate() {
            let v0 = m.positions.len() as u32;
            m.positions.extend([*o, *o + *eu, *o + *eu + *ev, *o + *ev]);
            m.uvs.extend([Vec2::ZERO; 4]);
            m.triangles.extend([[v0, v0 + 1, v0 + 2], [v0, v0 + 2, v0 + 3]]);
            m.tri_node.extend([i as u32; 2]);
            m.tri_material.extend([i as u32; 2]);
            m.nodes.push(NodeInfo { name: format!("q{i}"), diffuse: true });
            m.materials.push(Material { base_color: [a[0], a[1], a[2], 1.0], ..Default::default() });
        }
        RayScene::new(m)
    }

    #[test]
    fn open_ground_has_unit_c_and_no_bounce() {
        let s = scene_of(&[(Vec3::new(-50.0, 0.0, -50.0), Vec3::Z * 100.0, Vec3::X * 100.0, [0.5; 3])]);
        let t = transport(&s, Vec3::ZERO, Vec3::Y, Some(Vec3::new(0.3, 0.8, 0.1).normalize()), TransportQuality::default(), 1);
        assert!((t.c - Vec3::ONE).abs().max_element() < 1e-6, "{:?}", t.c);
        assert_eq!(t.b, Vec3::ZERO);
    }

    #[test]
    fn vertical_surface_in_empty_space_sees_half_the_sky() {
        let s = RayScene::new(Mesh::default());
        let q = TransportQuality { paths: 4096, max_bounces: 1 };
        let t = transport(&s, Vec3::ZERO, Vec3::X, None, q, 5);
        assert!((t.c.x - 0.5).abs() < 0.01, "{:?}", t.c);
        let t = transport(&s, Vec3::ZERO, Vec3::NEG_Y, None, q, 5);
        assert_eq!(t.c, Vec3::ZERO);
    }

    #[test]
    fn vertical_wall_over_black_ground_sees_half_the_sky() {
        // A point on a wall above a black infinite floor: half of its hemisphere is sky.
        // Closed form: c = ½ exactly for a point at height h → ∞ above an infinite black plane;
        // at finite height over a 400 m floor it differs by < 1e-3.
        let s = scene_of(&[(Vec3::new(-200.0, 0.0, -200.0), Vec3::Z * 400.0, Vec3::X * 400.0, [0.0; 3])]);
        let q = TransportQuality { paths: 4096, max_bounces: 3 };
        let t = transport(&s, Vec3::new(0.0, 1.0, 0.0), Vec3::X, None, q, 7);
        // Cosine-weighted stratified estimate of a half-hemisphere: standard error ≈ 0.5/√4096 ≈ 0.008
        // before stratification, far less after.
        assert!((t.c.x - 0.5).abs() < 0.01, "{:?}", t.c);
    }

    #[test]
    fn interreflection_from_a_white_floor_adds_its_albedo() {
        // Wall point over a grey floor of albedo ρ that is itself unoccluded (c = 1): the lower
        // half of the hemisphere sends ρ·c_floor/π radiance, so c = ½ + ½·ρ·c_floor, and c_floor ≈ 1
        // (the wall is a single point, it does not occlude the floor).
        let rho = 0.6;
        let s = scene_of(&[(Vec3::new(-200.0, 0.0, -200.0), Vec3::Z * 400.0, Vec3::X * 400.0, [rho; 3])]);
        let q = TransportQuality { paths: 4096, max_bounces: 4 };
        let t = transport(&s, Vec3::new(0.0, 1.0, 0.0), Vec3::X, None, q, 3);
        let want = 0.5 + 0.5 * rho;
        assert!((t.c.x - want).abs() < 0.015, "{:?} vs {want}", t.c);
        // Sun straight overhead: the floor is lit with cos = 1, reflected to the wall: b = ½·ρ.
        let t = transport(&s, Vec3::new(0.0, 1.0, 0.0), Vec3::X, Some(Vec3::Y), q, 3);
        assert!((t.b.x - 0.5 * rho).abs() < 0.015, "{:?}", t.b);
    }

    /// A sky that is brighter toward +x above the horizon and has a bright terrain below (per
    /// unit `Pa` and `Pd`), for the split test.
    struct Lopsided;

    impl Escape for Lopsided {
        fn escape(&self, d: Vec3) -> Option<(Vec3, Vec3)> {
            Some(if d.y > 0.0 { (Vec3::splat(1.0 + d.x), Vec3::ZERO) } else { (Vec3::splat(0.7), Vec3::splat(0.3)) })
        }
    }

    #[test]
    fn the_bounced_split_keeps_the_transport_and_counts_only_paths_that_hit_a_surface() {
        let rho = 0.6;
        let s = scene_of(&[(Vec3::new(-200.0, 0.0, -200.0), Vec3::Z * 400.0, Vec3::X * 400.0, [rho; 3])]);
        let q = TransportQuality { paths: 4096, max_bounces: 4 };
        let (p, sun) = (Vec3::new(0.0, 1.0, 0.0), Some(Vec3::new(0.3, 0.8, 0.1).normalize()));
        for n in [Vec3::X, -Vec3::Y, Vec3::Y] {
            let (t, bounced) = transport_with_bounced(&s, p, n, sun, &UniformSky, &[Lopsided], q, 11);
            let bounced = bounced[0];
            // The first part is the plain transport, bit for bit.
            assert_eq!(t, transport_under(&s, p, n, sun, &UniformSky, q, 11));
            if n == Vec3::Y {
                // Facing up over the floor, nothing is hit: no bounced light at all.
                assert_eq!(bounced, Transport { c: Vec3::ZERO, b: Vec3::ZERO });
            }
            if n == -Vec3::Y {
                // Facing down, every path hits the floor once and leaves it upward (nothing above):
                // the bounced sky is ρ times the sky's cosine-weighted mean over the upper
                // hemisphere, ρ·(1 + E[d.x]) = ρ, since the cosine lobe is symmetric in x. The
                // second direction is random: d.x has a standard deviation of 0.5 over the lobe,
                // so over 4096 paths the mean's is 0.8% of ρ; 3% is nearly 4 of them. Nothing
                // reaches the terrain, so no `b`.
                assert!((bounced.c.x - rho).abs() < 0.03 * rho, "{:?}", bounced.c);
                assert_eq!(bounced.b, Vec3::ZERO);
            }
        }
    }
}
