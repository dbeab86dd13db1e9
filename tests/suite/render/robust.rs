//! Robustness of the shadow volumes: open and non-manifold meshes (per-triangle fallback with a
//! warning naming the mesh), degenerate triangles, a sun exactly parallel to faces, and the
//! compute-pass builder producing the CPU builder's triangles.

use super::shadows::{check, check_with, statue};
use super::support::*;
use glam::{Vec2, Vec3};
use heliar::geometry::{Material, Mesh};
use heliar::render::occluder::Occluder;
use heliar::render::volume::{HVertex, OPEN_CAP_OFFSET_M, Parts, build};
use heliar::render::{Builder, CompositorConfig};

fn view() -> heliar::camera::Camera {
    camera([1.5, 1.6, 5.0], [-1.2, 0.4, 0.2], 240, 180, [-0.08, 0.012, 0.0, 0.0, 0.0])
}

/// An open-bottom crate and a one-sided sign (a single quad on a post).
fn open_objects() -> Vec<(String, Mesh)> {
    let mut crate_ = Mesh::default();
    let m = crate_.add_material(Material::diffuse("wood", [0.5, 0.4, 0.3]));
    let n = crate_.add_node("crate", false);
    crate_.push_box(Vec3::new(0.2, 0.0, 1.4), Vec3::new(0.8, 0.7, 2.0), n, m, true);
    let mut sign = Mesh::default();
    let m = sign.add_material(Material::diffuse("sign", [0.8, 0.8, 0.2]));
    let n = sign.add_node("board", false);
    sign.push_quad(Vec3::new(-1.0, 1.0, 2.5), Vec3::X * 0.8, Vec3::Y * 0.5, n, m);
    vec![("crate.glb".into(), crate_), ("sign.glb".into(), sign)]
}

#[test]
fn open_meshes_fall_back_to_per_triangle_volumes_with_a_named_warning() {
    let setup = Setup { camera: view(), proxy: yard_proxy(), objects: open_objects() };
    let comp = setup.compositor(CompositorConfig::from_estimator_settings(&Default::default()));
    let w = comp.warnings().join("\n");
    assert!(w.contains("crate.glb") && w.contains("sign.glb") && w.contains("per triangle"), "{w}");
    check("open meshes", &setup, courtyard_sun(), [300, 0, 0, 1000]);
}

#[test]
fn degenerate_triangles_are_harmless() {
    let mut objects = statue();
    objects.push(("crate".into(), cube(Vec3::new(0.2, 0.0, 1.4), Vec3::new(0.8, 0.7, 2.0), Material::diffuse("c", [0.5; 3]), "crate")));
    for (_, m) in &mut objects {
        // A zero-area sliver with three distinct corners (collinear), and a collapsed triangle.
        let [a, b, _] = m.triangles[0];
        let (pa, pb) = (m.positions[a as usize], m.positions[b as usize]);
        let mid = m.positions.len() as u32;
        m.positions.push((pa + pb) / 2.0);
        m.uvs.push(Vec2::ZERO);
        m.triangles.extend([[a, b, mid], [a, a, b]]);
        m.tri_node.extend([0, 0]);
        m.tri_material.extend([0, 0]);
    }
    let occ = Occluder::new(&objects[0].1, "sphere");
    assert_eq!(occ.dropped_degenerate, 1);
    let setup = Setup { camera: view(), proxy: yard_proxy(), objects };
    check("degenerate triangles", &setup, courtyard_sun(), [300, 1000, 0, 1000]);
}

#[test]
fn sun_exactly_parallel_to_faces() {
    // The sun in the x–y plane: exactly parallel to the ±z faces of the boxes and the wall.
    let sun = Vec3::new(-0.6, 0.8, 0.0);
    assert_eq!(sun.length(), 1.0);
    let mut objects = statue();
    objects.push(("crate".into(), cube(Vec3::new(0.2, 0.0, 1.4), Vec3::new(0.8, 0.7, 2.0), Material::diffuse("c", [0.5; 3]), "crate")));
    let setup = Setup { camera: view(), proxy: yard_proxy(), objects };
    check("sun parallel to faces", &setup, sun, [300, 1000, 0, 1000]);
}

fn sorted(mut tris: Vec<[HVertex; 3]>) -> Vec<[HVertex; 3]> {
    // Rotate each triangle to start at its smallest vertex (same winding), then sort.
    for t in &mut tris {
        let k = (0..3).min_by(|&i, &j| t[i].partial_cmp(&t[j]).unwrap()).unwrap();
        t.rotate_left(k);
    }
    tris.sort_by(|a, b| a.partial_cmp(b).unwrap());
    tris
}

#[test]
fn compute_builder_makes_the_cpu_builders_triangles_and_the_same_masks() {
    let mut objects = statue();
    objects.extend(open_objects());
    let setup = Setup { camera: view(), proxy: yard_proxy(), objects };
    let sun = courtyard_sun();
    let mut config = CompositorConfig::from_estimator_settings(&Default::default());
    config.builder = Builder::Compute;
    // Same masks as ray tracing with the compute builder.
    check_with("compute builder", &setup, sun, [300, 0, 0, 1000], config.clone());
    // And the same triangles as the CPU builder, object by object.
    let mut comp = setup.compositor(config);
    let (w, h) = (240, 180);
    let video = heliar::render::VideoFrame { width: w, height: h, rgba: vec![[0.5; 4]; (w * h) as usize] };
    comp.render(&video, &heliar::lighting::Lighting { sun_dir: sun, above_horizon: true, pd: Vec3::splat(3.0), pa: Vec3::splat(0.6), sky: heliar::lighting::FrameSky::Declared, lamps: heliar::lighting::LampScales::NONE }).unwrap();
    let gpu = gpu();
    let bufs = comp.volumes().compute_buffers().expect("compute buffers");
    for ((name, mesh), b) in setup.objects.iter().zip(bufs) {
        let args = heliar::gpu::readback::read_buffer_bytes(&gpu, &b.draw_args, 16).unwrap();
        let count = u32::from_le_bytes([args[0], args[1], args[2], args[3]]) as usize;
        let bytes = heliar::gpu::readback::read_buffer_bytes(&gpu, &b.vertices, (count * 16) as u64).unwrap();
        let gpu_v: &[HVertex] = bytemuck::cast_slice(&bytes);
        let mut cpu_v = Vec::new();
        build(&Occluder::new(mesh, name), sun, OPEN_CAP_OFFSET_M, Parts::All, &mut cpu_v);
        assert_eq!(gpu_v.len(), cpu_v.len(), "{name}: vertex count");
        let g = sorted(gpu_v.chunks(3).map(|t| [t[0], t[1], t[2]]).collect());
        let c = sorted(cpu_v.chunks(3).map(|t| [t[0], t[1], t[2]]).collect());
        for (a, b) in g.iter().zip(&c) {
            for k in 0..3 {
                for j in 0..4 {
                    assert!((a[k][j] - b[k][j]).abs() <= 1e-5, "{name}: {a:?} vs {b:?}");
                }
            }
        }
    }
}
