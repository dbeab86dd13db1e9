//! The lamps' light that the real receivers get after a bounce (issue 16 §3, "virtual objects'
//! lamp shadows on real ground"): per footage pixel and lamp, the irradiance `B_i` per unit lamp
//! scale `k_i` that the lamp's light reaches the pixel's proxy point with after one or more
//! bounces off the proxy, and `B_{v,i}` the same with the virtual objects standing in the scene.
//! The composite adds `Σ k_i·B_i` to `L₀` and `Σ k_i·B_{v,i}` to `L₁` of the differential
//! darkening ([`super::ground`]).
//!
//! Jensen §3.1 and §4.2 (`../shared/papers/jensen-outdoor-ar-ibl.txt`) model a real pixel as `ρ/π`
//! times a sum of known shapes times the light sources' scales, with the sun's light after a
//! bounce as the shape `b` per unit `Pd` (the receivers' `b`, `b_v`, [`crate::render::receivers`]).
//! A lamp's light after a bounce is linear in its scale `k_i` in the same way, with the lamp's
//! irradiance from its model (Granier §3–4, Eq. 14 for a light field;
//! `../shared/papers/granier-2003-complex-light-sources.txt`). Without it `L₀`, `L₁` hold only
//! the lamp's direct light, so in a lamp shadow, where the bounce is all the lamp light left,
//! `video × L₁/L₀` came out too dark: on the dusk scene's night frame the statue's lamp shadow
//! was 13% below the path-traced reference (docs/measurements.md, "The lamp's bounced light on
//! the real ground").
//!
//! # How it works
//! - **The paths** are the estimator's lamp column's ([`bounce_irradiance`]: cosine-weighted from
//!   the receiver, stratified on the first bounce, next-event estimation toward the lamp with the
//!   lamp model's irradiance and a shadow ray at every vertex, the surfaces' albedo along the
//!   path, up to `max_bounces` hits), so the composite's model of the footage and the
//!   estimator's `k_i` agree. `B_i` is traced against the proxy, `B_{v,i}` against the proxy
//!   and the objects with the same seed: the objects block bounce paths and the lamp at their
//!   vertices, and pass on the lamp light they reflect (as diffuse surfaces of their base
//!   colour, as the receivers' `c_v`, `b_v` treat them). The lamp's direct light is not in
//!   them: that is the composite's spot term.
//! - **Where**: the pixels the differential model's region holds (near the objects) and those
//!   whose segment toward a lamp crosses an object's box (where its lamp shadow can fall), grown
//!   by two pixels ([`crate::render::receivers::Receivers::in_lamp_reach`]). Elsewhere both are
//!   zero, as before this term.
//! - **When**: lamps, proxy and objects are static, so it is traced once, on the first frame
//!   whose `lamp_ground` runs, with the receivers' bounce quality; a move of the objects drops
//!   it (traced again on the next such frame). A frame whose scales differ from those formed
//!   forms `Σ k_i·B_i`, `Σ k_i·B_{v,i}` on the CPU and uploads them. Scenes without lamps
//!   have none of it. While the visibility cuts serve the moved objects (`c_v`, `b_v` from
//!   them, no trace with the objects), the trace is kept and `B_{v,i} = B_i`
//!   ([`GroundBounce::without_objects`]): the objects' share of the bounce is left out there,
//!   and receivers outside the traced pixels get none, as before this term.

use crate::geometry::ambient::TransportQuality;
use crate::geometry::raycast::RayScene;
use crate::lamps::Lamp;
use crate::lamps::visibility::bounce_irradiance;
use crate::lighting::LampScales;
use glam::Vec3;
use rayon::prelude::*;

/// Mixed into the pixel seeds, so the lamp bounce's paths are not the receivers' `c`, `b` paths.
const SEED_SALT: u64 = 0x9a3f_16b0_0c5e_d016;

fn vec3(e: [f64; 3]) -> Vec3 {
    Vec3::new(e[0] as f32, e[1] as f32, e[2] as f32)
}

/// `(B_i, B_{v,i})` of `lamp` at the receiver `p` (unit normal `n` facing the camera): the
/// irradiance per unit scale after one or more bounces, against `proxy` and against `with` (the
/// proxy and the objects), the same paths (`seed`) for both.
pub fn receiver_bounce(lamp: &Lamp, proxy: &RayScene, with: &RayScene, p: Vec3, n: Vec3, quality: TransportQuality, seed: u64) -> (Vec3, Vec3) {
    let b = bounce_irradiance(lamp, proxy, p, n, quality, seed);
    let b_v = bounce_irradiance(lamp, with, p, n, quality, seed);
    (vec3(b), vec3(b_v))
}

/// The lamps' bounce at the receivers, and the texels of a frame's `Σ k_i·B_i`, `Σ k_i·B_{v,i}`.
pub struct GroundBounce {
    /// Footage pixel of each traced receiver.
    pixels: Vec<u32>,
    /// `(B_i, B_{v,i})` per traced receiver and lamp (`values[receiver][lamp]`).
    values: Vec<Vec<(Vec3, Vec3)>>,
    /// `Σ k_i·B_i` per footage pixel (texture layout; `w` = 1 where traced).
    pub without: Vec<[f32; 4]>,
    /// `Σ k_i·B_{v,i}` per footage pixel.
    pub with: Vec<[f32; 4]>,
    /// The scales the texels were formed with (`None`: not yet formed).
    applied: Option<LampScales>,
    /// Time the trace took, ms.
    pub trace_ms: f64,
}

impl GroundBounce {
    /// Traces the bounce of `lamps` at `pixels` of a footage of `footage_pixels` pixels, the
    /// receiver of pixel `p` being `surface(p)` (point, normal; `None`: no proxy there, left at
    /// zero), against `proxy` and `with` (module docs). Deterministic for a given `seed`.
    #[allow(clippy::too_many_arguments)]
    pub fn trace(
        surface: impl Fn(u32) -> Option<(Vec3, Vec3)> + Sync,
        pixels: &[u32],
        footage_pixels: usize,
        proxy: &RayScene,
        with: &RayScene,
        lamps: &[Lamp],
        quality: TransportQuality,
        seed: u64,
    ) -> Self {
        let t = std::time::Instant::now();
        let traced: Vec<(u32, Vec<(Vec3, Vec3)>)> = pixels
            .par_iter()
            .filter(|&&p| (p as usize) < footage_pixels)
            .filter_map(|&p| {
                let (point, n) = surface(p)?;
                let s = seed ^ SEED_SALT ^ (p as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15);
                Some((p, lamps.iter().map(|lamp| receiver_bounce(lamp, proxy, with, point, n, quality, s)).collect()))
            })
            .collect();
        let (pixels, values) = traced.into_iter().unzip();
        Self { pixels, values, without: vec![[0.0; 4]; footage_pixels], with: vec![[0.0; 4]; footage_pixels], applied: None, trace_ms: t.elapsed().as_secs_f64() * 1e3 }
    }

    /// The traced receivers' pixels, in the order of [`Self::value`].
    pub fn pixels(&self) -> &[u32] {
        &self.pixels
    }

    /// `(B_i, B_{v,i})` of lamp `lamp` at traced receiver `index` (zero past the end).
    pub fn value(&self, index: usize, lamp: usize) -> (Vec3, Vec3) {
        self.values.get(index).and_then(|v| v.get(lamp)).copied().unwrap_or((Vec3::ZERO, Vec3::ZERO))
    }

    /// Forgets the objects' effect: `B_{v,i} = B_i` everywhere (the objects moved where no
    /// trace follows them, see the module docs); the next [`Self::apply`] forms the texels again.
    pub fn without_objects(&mut self) {
        for v in &mut self.values {
            for (b, b_v) in v.iter_mut() {
                *b_v = *b;
            }
        }
        self.applied = None;
    }

    /// The scales the texels hold (`None` before the first [`Self::apply`]).
    pub fn applied(&self) -> Option<&LampScales> {
        self.applied.as_ref()
    }

    /// Forms the texels for the scales `k` (a lamp past `k`'s end gives no light).
    pub fn apply(&mut self, k: &LampScales) {
        for (pixel, v) in self.pixels.iter().zip(&self.values) {
            let (mut b, mut b_v) = (Vec3::ZERO, Vec3::ZERO);
            for (i, (bi, bvi)) in v.iter().enumerate() {
                let ki = Vec3::from(k.get(i));
                b += ki * *bi;
                b_v += ki * *bvi;
            }
            self.without[*pixel as usize] = [b.x, b.y, b.z, 1.0];
            self.with[*pixel as usize] = [b_v.x, b_v.y, b_v.z, 1.0];
        }
        self.applied = Some(*k);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Material, Mesh};
    use crate::scene::lights::world_from_lamp;
    use crate::scene::{Light, LightKind, Schedule};
    use glam::DVec3;
    use std::path::Path;

    /// An isotropic point lamp of `cd` candela at `at`.
    fn point_lamp(at: Vec3, cd: f64) -> Lamp {
        let light = Light {
            name: "l".into(),
            field: "lights[0]".into(),
            kind: LightKind::Point { intensity_cd: cd },
            position: at.as_dvec3(),
            world_from_lamp: world_from_lamp(DVec3::NEG_Y, 0.0).expect("pose"),
            scale: 1.0,
            schedule: Schedule::Always,
        };
        Lamp::load(Path::new("scene.toml"), &light).expect("lamp")
    }

    // The set-up of the quadrature test: a floor (y = 0) and a wall (the plane x = 0, facing +x,
    // z in [−WALL_HALF, WALL_HALF], y in [0, WALL_H]); a point lamp at (LAMP_X, LAMP_H, 0); the
    // receiver on the floor at (P_X, 0, 0); the virtual object a horizontal plate of half-size
    // PLATE_HALF at height PLATE_Y right above the receiver, which puts it in the plate's lamp
    // shadow (the ray toward the lamp crosses the plate's plane (LAMP_X − P_X)·PLATE_Y/LAMP_H =
    // 0.2 m from its centre) and hides the wall's upper middle from it.
    const RHO_WALL: f32 = 0.6;
    const WALL_HALF: f32 = 3.0;
    const WALL_H: f32 = 3.0;
    const LAMP_X: f32 = 2.0;
    const LAMP_H: f32 = 3.0;
    const CD: f64 = 10.0;
    const P_X: f32 = 1.0;
    const PLATE_Y: f32 = 0.6;
    const PLATE_HALF: f32 = 0.3;

    fn scenes() -> (RayScene, RayScene) {
        let mut mesh = Mesh::default();
        let floor = mesh.add_material(Material::diffuse("floor", [0.3; 3]));
        let wall = mesh.add_material(Material::diffuse("wall", [RHO_WALL; 3]));
        let node = mesh.add_node("proxy", true);
        mesh.push_quad(Vec3::new(-50.0, 0.0, -50.0), Vec3::Z * 100.0, Vec3::X * 100.0, node, floor);
        mesh.push_quad(Vec3::new(0.0, 0.0, -WALL_HALF), Vec3::Y * WALL_H, Vec3::Z * 2.0 * WALL_HALF, node, wall);
        let mut with = mesh.clone();
        let plate = with.add_material(Material::diffuse("plate", [0.8; 3]));
        let obj = with.add_node("plate", false);
        with.push_quad(Vec3::new(P_X - PLATE_HALF, PLATE_Y, -PLATE_HALF), Vec3::Z * 2.0 * PLATE_HALF, Vec3::X * 2.0 * PLATE_HALF, obj, plate);
        (RayScene::new(mesh), RayScene::new(with))
    }

    /// The segment from `a` to `b` crosses the plate.
    fn through_plate(a: Vec3, b: Vec3) -> bool {
        if (a.y - PLATE_Y) * (b.y - PLATE_Y) >= 0.0 {
            return false;
        }
        let x = a + (b - a) * ((PLATE_Y - a.y) / (b.y - a.y));
        (x.x - P_X).abs() < PLATE_HALF && x.z.abs() < PLATE_HALF
    }

    /// The one-bounce irradiance at the receiver from the wall, by the midpoint rule over the
    /// wall: `∫ ρ/π · E(q) · cos θ_p cos θ_q / |q − p|² dA` with the wall's irradiance
    /// `E(q) = I·cos/r² = I·LAMP_X/|L − q|³` (the floor reflects too, but the receiver on the
    /// floor does not see it). With `plate`, wall points hidden from the receiver or from the
    /// lamp by the plate are left out (the plate's underside, all the receiver sees of it, is
    /// unlit).
    fn quadrature(plate: bool) -> f64 {
        let (p, l) = (Vec3::new(P_X, 0.0, 0.0), Vec3::new(LAMP_X, LAMP_H, 0.0));
        let n = (1200, 600);
        let (dz, dy) = (2.0 * WALL_HALF as f64 / n.0 as f64, WALL_H as f64 / n.1 as f64);
        let mut sum = 0.0f64;
        for i in 0..n.0 {
            for j in 0..n.1 {
                let q = Vec3::new(0.0, ((j as f64 + 0.5) * dy) as f32, (-(WALL_HALF as f64) + (i as f64 + 0.5) * dz) as f32);
                if plate && (through_plate(p, q) || through_plate(q, l)) {
                    continue;
                }
                let (to_l, to_p) = ((l - q).as_dvec3(), (p - q).as_dvec3());
                let e = CD * LAMP_X as f64 / to_l.length().powi(3);
                let r2 = to_p.length_squared();
                let (cos_p, cos_q) = (q.y as f64 / r2.sqrt(), P_X as f64 / r2.sqrt());
                sum += RHO_WALL as f64 / std::f64::consts::PI * e * cos_p * cos_q / r2 * dz * dy;
            }
        }
        sum
    }

    #[test]
    fn a_shadowed_floor_point_gets_the_lit_walls_bounce_with_and_without_the_object() {
        let (proxy, with) = scenes();
        let lamp = point_lamp(Vec3::new(LAMP_X, LAMP_H, 0.0), CD);
        let p = Vec3::new(P_X, 0.0, 0.0);
        // One bounce, where the quadrature is exact: the receiver sees the wall (and the plate's
        // unlit underside) only.
        let q = TransportQuality { paths: 40_000, max_bounces: 1 };
        let (b, b_v) = receiver_bounce(&lamp, &proxy, &with, p, Vec3::Y, q, 11);
        let (want, want_v) = (quadrature(false), quadrature(true));
        eprintln!("B {} against {want}, B_v {} against {want_v}", b.x, b_v.x);
        // The plate hides a clear share of the wall's light, or the test would not tell
        // B from B_v.
        assert!(want_v < 0.9 * want, "{want_v} vs {want}");
        // 4·10⁴ cosine-weighted paths, stratified on the first bounce, over an integrand that is
        // smooth on B's side and cut by the plate's outline on B_v's: the standard error is
        // about 0.5%; 2% is four of them. The quadrature's 5 mm cells are far finer.
        assert!((b.x as f64 - want).abs() < 0.02 * want, "B {} vs {want}", b.x);
        assert!((b_v.x as f64 - want_v).abs() < 0.02 * want_v, "B_v {} vs {want_v}", b_v.x);
        assert_eq!(b.x, b.z, "grey surfaces, grey bounce");
        // The receiver is in the plate's lamp shadow: its direct light is not in B_v (nor in B).
        assert!(with.occluded(p + Vec3::Y * 1e-3, (lamp.light.position.as_vec3() - p).normalize(), 3.0));
        // More bounces add the floor's light off the wall (floor → wall → receiver).
        let (b2, b2_v) = receiver_bounce(&lamp, &proxy, &with, p, Vec3::Y, TransportQuality { paths: 40_000, max_bounces: 4 }, 11);
        assert!(b2.x > b.x && b2_v.x > b_v.x, "{b2} {b2_v}");
    }

    #[test]
    fn the_texels_are_linear_in_each_lamps_scale_and_zero_where_not_traced() {
        let (proxy, with) = scenes();
        let lamps = [point_lamp(Vec3::new(LAMP_X, LAMP_H, 0.0), CD), point_lamp(Vec3::new(LAMP_X, LAMP_H, 1.5), 2.0 * CD)];
        // A 4-pixel footage; pixel 2 sees no proxy, pixel 3 is not asked for.
        let surface = |p: u32| match p {
            0 => Some((Vec3::new(P_X, 0.0, 0.0), Vec3::Y)),
            1 => Some((Vec3::new(0.5, 0.0, 1.0), Vec3::Y)),
            _ => None,
        };
        let q = TransportQuality { paths: 256, max_bounces: 2 };
        let mut g = GroundBounce::trace(surface, &[0, 1, 2], 4, &proxy, &with, &lamps, q, 3);
        assert_eq!(g.pixels(), &[0, 1]);
        let k = LampScales::from_slice(&[[0.5, 1.0, 2.0], [3.0, 0.0, 1.0]]);
        g.apply(&k);
        assert_eq!(g.applied(), Some(&k));
        for (index, &pixel) in g.pixels().iter().enumerate() {
            let ((b0, bv0), (b1, bv1)) = (g.value(index, 0), g.value(index, 1));
            let want = Vec3::from(k.get(0)) * b0 + Vec3::from(k.get(1)) * b1;
            let want_v = Vec3::from(k.get(0)) * bv0 + Vec3::from(k.get(1)) * bv1;
            assert!((Vec3::from_slice(&g.without[pixel as usize][..3]) - want).abs().max_element() <= 1e-6 * want.max_element(), "{pixel}");
            assert!((Vec3::from_slice(&g.with[pixel as usize][..3]) - want_v).abs().max_element() <= 1e-6 * want_v.max_element(), "{pixel}");
            assert!(b0.x > 0.0 && b1.x > 0.0, "both lamps light the wall that the receiver sees");
        }
        assert_eq!(g.without[2], [0.0; 4]);
        assert_eq!(g.with[3], [0.0; 4]);
        // Deterministic.
        let again = GroundBounce::trace(surface, &[0, 1, 2], 4, &proxy, &with, &lamps, q, 3);
        assert_eq!(again.value(1, 1), g.value(1, 1));
        // Without the objects' effect (moved by the cuts): B_v = B, formed again.
        g.without_objects();
        assert_eq!(g.applied(), None);
        g.apply(&k);
        assert_eq!(g.value(0, 1).1, g.value(0, 1).0);
        assert_eq!(g.with[0], g.without[0]);
    }
}
