//! Ambient occlusion of the virtual objects by themselves, per canvas pixel.
//!
//! The probe grid knows the real scene only; a virtual object's own parts also hide sky and
//! surroundings from each other (a sphere resting on a pedestal darkens the pedestal's top). The
//! ambient term of the shading pass is multiplied by this factor.
//!
//! # How it works
//! For every canvas pixel, a ray through its centre (pinhole canvas) finds the first virtual
//! surface; there, `rays` cosine-weighted directions (stratified) are traced against the virtual
//! objects, and the unoccluded fraction is stored (1 where no virtual surface is seen). Camera and
//! objects are static, so this runs once; a moving camera or object would recompute it.

use crate::gpu::canvas::Canvas;
use crate::geometry::raycast::{RAY_EPSILON_M, RayScene};
use crate::geometry::sampling::sample_cosine_around;
use glam::Vec2;
use rand::{Rng, SeedableRng, rngs::SmallRng};
use rayon::prelude::*;

/// Default rays per pixel: ≈ 3% standard deviation of a half-occluded pixel after stratification.
pub const AO_RAYS: u32 = 128;

/// The unoccluded fraction per canvas pixel (row-major, canvas size).
pub fn virtual_occlusion(canvas: &Canvas, objects: &RayScene, rays: u32, seed: u64) -> Vec<f32> {
    let (w, h) = (canvas.intrinsics.width, canvas.intrinsics.height);
    let m = (rays.max(1) as f32).sqrt().ceil() as u32;
    (0..w * h)
        .into_par_iter()
        .map(|i| {
            let Some(hit) = objects.intersect_front(canvas.pose.translation.as_vec3(), canvas.pixel_dir(i)) else { return 1.0 };
            let mut rng = SmallRng::seed_from_u64(seed ^ (i as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15));
            let origin = hit.point + hit.normal * RAY_EPSILON_M;
            let n = m * m;
            let open = (0..n)
                .filter(|k| {
                    let s = Vec2::new(((k % m) as f32 + rng.random::<f32>()) / m as f32, ((k / m) as f32 + rng.random::<f32>()) / m as f32);
                    !objects.occluded(origin, sample_cosine_around(hit.normal, s.min(Vec2::splat(0.999_999))), f32::MAX)
                })
                .count();
            open as f32 / n as f32
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;
    use crate::geometry::{Material, Mesh};
    use crate::camera::{Camera, Intrinsics, Pose};

    #[test]
    fn a_convex_object_does_not_occlude_itself_and_a_corner_does() {
        let cam = Camera {
            intrinsics: Intrinsics::brown_conrady(64, 48, 50.0, 50.0, 32.0, 24.0, [0.0; 5]),
            pose: Pose::look_at(DVec3::new(3.0, 3.0, 3.0), DVec3::ZERO, DVec3::Y).unwrap(),
        };
        let canvas = Canvas::new(&cam, 1.0);
        let mut m = Mesh::default();
        let mat = m.add_material(Material::diffuse("g", [0.5; 3]));
        let n = m.add_node("box", false);
        m.push_box(glam::Vec3::splat(-0.5), glam::Vec3::splat(0.5), n, mat, false);
        let convex = virtual_occlusion(&canvas, &RayScene::new(m.clone()), 64, 1);
        let low: Vec<(usize, f32)> = convex.iter().copied().enumerate().filter(|(_, a)| *a < 1.0).collect();
        assert!(low.is_empty(), "{low:?}");
        // A floor under the box: the floor next to the box is partly occluded, the box's top not.
        m.push_quad(glam::Vec3::new(-3.0, -0.5, -3.0), glam::Vec3::Z * 6.0, glam::Vec3::X * 6.0, n, mat);
        let ao = virtual_occlusion(&canvas, &RayScene::new(m), 64, 1);
        assert!(ao.iter().any(|&a| a < 0.8), "no occluded pixel");
        assert!(ao.iter().all(|&a| (0.0..=1.0).contains(&a)));
    }
}
