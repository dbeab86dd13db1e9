//! The frame's background and receivers when the scene lacks them: the VEM seen through the
//! camera (the environment at infinity, Havran §5's display of the captured map) and a ground
//! plane under the objects that catches their shadows.

use crate::geometry::{Material, Mesh};
use crate::io::image::LinearImage;
use crate::camera::Camera;
use crate::vem::polar::{PolarMap, polar_from_dir};
use crate::vem::regions::GpuLight;
use glam::Vec3;

/// Half side of the ground plane, metres.
const GROUND_HALF_SIDE_M: f32 = 200.0;

/// A ground quad at height `y` around `centre` (the receiver when the scene has no proxy).
pub fn ground_plane(centre: Vec3, y: f32, albedo: f32) -> Mesh {
    let mut m = Mesh::default();
    let mat = m.add_material(Material::diffuse("ground", [albedo; 3]));
    let node = m.add_node("ground", true);
    let s = GROUND_HALF_SIDE_M;
    m.push_quad(Vec3::new(centre.x - s, y, centre.z - s), Vec3::Z * (2.0 * s), Vec3::X * (2.0 * s), node, mat);
    m
}

/// Radiance of a horizontal Lambertian ground of `albedo` lit by `lights` (no shadows):
/// `ρ/π · Σ rgb·max(l_y, 0)`.
pub fn ground_radiance(lights: &[GpuLight], albedo: f32) -> [f32; 3] {
    let mut e = [0.0f32; 3];
    for l in lights {
        let c = l.dir[1].max(0.0);
        for (e, rgb) in e.iter_mut().zip(l.rgb) {
            *e += rgb * c;
        }
    }
    e.map(|v| albedo / std::f32::consts::PI * v)
}

/// The VEM seen through `camera` (nearest texel of the polar map), `below` for rays under the
/// horizon and black where the lens model has no ray.
pub fn environment_background(map: &PolarMap, camera: &Camera, below: [f32; 3]) -> LinearImage {
    let (w, h) = (camera.intrinsics.width, camera.intrinsics.height);
    LinearImage::from_fn(w, h, |x, y| match camera.pixel_ray(x, y) {
        Some((_, d)) => match polar_from_dir(d.as_vec3(), map.width, map.height) {
            Some((px, py)) => map.get((px.max(0.0) as u32).min(map.width - 1), (py.max(0.0) as u32).min(map.height - 1)),
            None => below,
        },
        None => [0.0; 3],
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ground_radiance_closed_form() {
        // One light straight above of irradiance 2, one below the horizon: ρ/π·2.
        let up = GpuLight { dir: [0.0, 1.0, 0.0], shadow: u32::MAX, rgb: [2.0; 3], index: 0 };
        let down = GpuLight { dir: [0.0, -1.0, 0.0], ..up };
        let e = ground_radiance(&[up, down], 0.3);
        assert!((e[0] - 0.6 / std::f32::consts::PI).abs() < 1e-6);
    }
}
