//! A lamp's light on a surface point, direct and interreflected, per unit lamp scale: the known
//! shape `E_i·V_i + B_i` of the lamp column `g_i = ρ/π·(E_i·V_i + B_i)` ([`super::lamps`]).
//!
//! Jensen §3.1 (`../shared/papers/jensen-outdoor-ar-ibl.txt`) models a sample's radiance as
//! `ρ/π` times the irradiance of each light source with a known shape and an unknown scale. For
//! the sun heliar adds the light the sun throws on other proxy surfaces (`b`,
//! [`crate::geometry::ambient`]); a near-field lamp (Granier §3, Eq. 14 for its irradiance;
//! `../shared/papers/granier-2003-complex-light-sources.txt`) needs the same term more: it lights
//! the paving below it hundreds of times more than the walls around, so the walls' lamp light is
//! nearly all bounce off the paving. On the dusk courtyard (`scenes/dusk`, 19:50) the north
//! building's samples show 2.9× the sky's prediction, an excess ≈ 130× their direct lamp
//! light; without `B` the fit gives that light to `Pa` and lowers `k` to keep the paving right.
//!
//! # How it works
//! - **Direct** ([`direct_irradiance`], in [`crate::lamps::visibility`] so that the renderer's
//!   lamp bounce shares it): the lamp model's irradiance `E(p, n)` when a shadow ray
//!   from `p` reaches the lamp (stopping [`LAMP_CLEARANCE_M`] short of it, so the luminaire's own
//!   housing in the proxy does not shadow it); zero behind the surface.
//! - **Bounce** ([`bounce_irradiance`], in [`crate::lamps::visibility`] as well: the renderer's
//!   lamp bounce on the real receivers, `render::lamps::ground_bounce`, shares it): the paths of the sun's `b` (cosine-weighted from `p`,
//!   stratified on the first bounce, up to `max_bounces` proxy hits, the proxy's albedo at each),
//!   with next-event estimation toward the lamp at every vertex `y`: a path adds
//!   `ρ₁⋯ρ_k · E(y, n_y)·V(y)`. With the pdf `cos θ/π` that is an unbiased estimate of the
//!   irradiance at `p` from the lamp light that Lambertian proxy surfaces reflect. Deterministic
//!   for a given seed. The proxy is all there is: the lamp light that unmodelled objects pass on
//!   is not in it.
//!
//! Both are linear in the lamp's scale, so `k_i` stays one NNLS column.

pub use crate::lamps::visibility::{LAMP_CLEARANCE_M, bounce_irradiance, direct_irradiance};

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::ambient::TransportQuality;
    use crate::geometry::raycast::RayScene;
    use crate::lamps::Lamp;
    use glam::Vec3;
    use crate::geometry::{Material, Mesh};
    use crate::scene::lights::world_from_lamp;
    use crate::scene::{Light, LightKind, Schedule};
    use glam::DVec3;
    use std::path::Path;

    fn point_lamp(at: Vec3, cd: f64) -> Lamp {
        let light = Light {
            name: "l".into(),
            field: "lights[0]".into(),
            kind: LightKind::Point { intensity_cd: cd },
            position: at.as_dvec3(),
            world_from_lamp: world_from_lamp(DVec3::NEG_Y, 0.0).unwrap(),
            scale: 1.0,
            schedule: Schedule::Always,
        };
        Lamp::load(Path::new("scene.toml"), &light).unwrap()
    }

    /// A large floor of albedo `rho` at `y = 0`.
    fn floor(rho: f32) -> RayScene {
        let mut mesh = Mesh::default();
        let m = mesh.add_material(Material::diffuse("floor", [rho; 3]));
        let node = mesh.add_node("floor", true);
        mesh.push_quad(Vec3::new(-500.0, 0.0, -500.0), Vec3::Z * 1000.0, Vec3::X * 1000.0, node, m);
        RayScene::new(mesh)
    }

    #[test]
    fn direct_light_is_the_inverse_square_law_and_nothing_behind() {
        let scene = floor(0.5);
        let lamp = point_lamp(Vec3::new(0.0, 2.0, 0.0), 10.0);
        // Below the lamp: I/h² = 2.5; 2 m aside: I·cos θ/r² = 10·(2/√8)/8.
        let e = direct_irradiance(&lamp, &scene, Vec3::ZERO, Vec3::Y);
        assert!((e[0] - 2.5).abs() < 1e-6, "{e:?}");
        let e = direct_irradiance(&lamp, &scene, Vec3::new(2.0, 0.0, 0.0), Vec3::Y);
        assert!((e[1] - 10.0 * (2.0 / 8f64.sqrt()) / 8.0).abs() < 1e-5, "{e:?}");
        // Under the floor, facing down: behind the floor's other side and shadowed.
        assert_eq!(direct_irradiance(&lamp, &scene, Vec3::new(0.0, -1.0, 0.0), Vec3::NEG_Y), [0.0; 3]);
    }

    #[test]
    fn a_wall_facing_a_lit_floor_receives_its_closed_form_bounce() {
        // A point 1 m above an infinite floor of albedo ρ, facing down, with an isotropic point
        // lamp of intensity I at height h above the floor (the lamp itself is behind the point's
        // surface, so it gets bounce only). The floor's irradiance is I·h/(h² + s²)^{3/2} at
        // horizontal distance s, its radiance ρ/π times that; the irradiance at the point from
        // the floor is ∫ ρ/π·E(s)·cos²θ/d² dA with d² = 1 + s², cos θ = 1/d:
        // B = ρ·I·h·2∫₀^∞ s/((h²+s²)^{3/2}(1+s²)²) ds, which for h = 2 is ρ·I·0.1598 (midpoint
        // rule below). One bounce: the floor is all there is.
        let (rho, cd, h) = (0.5f32, 10.0, 2.0f64);
        let scene = floor(rho);
        let lamp = point_lamp(Vec3::new(0.0, h as f32, 0.0), cd);
        let p = Vec3::new(0.0, 1.0, 0.0);
        let ds = 1e-4;
        let integral: f64 = (0..2_000_000).map(|i| (i as f64 + 0.5) * ds).map(|s| s / ((h * h + s * s).powf(1.5) * (1.0 + s * s).powi(2)) * ds).sum();
        let expect = rho as f64 * cd * h * 2.0 * integral;
        let q = TransportQuality { paths: 20_000, max_bounces: 3 };
        let b = bounce_irradiance(&lamp, &scene, p, Vec3::NEG_Y, q, 7);
        // Stratified cosine sampling of a smooth integrand: 2·10⁴ paths give well under 1%.
        assert!((b[0] - expect).abs() < 0.01 * expect, "{b:?} vs {expect}");
        assert_eq!(b, bounce_irradiance(&lamp, &scene, p, Vec3::NEG_Y, q, 7), "deterministic");
        // Facing up, on the floor: nothing to bounce off.
        assert_eq!(bounce_irradiance(&lamp, &scene, Vec3::new(1.0, 0.0, 0.0), Vec3::Y, q, 7), [0.0; 3]);
    }
}
