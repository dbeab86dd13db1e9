//! Test objects with known visibility for the cuts' tests, sweeps and benches.

use crate::geometry::{Material, Mesh};
use glam::{Vec2, Vec3};
use std::collections::HashMap;

/// A closed icosphere of `radius` at `centre`, `subdiv` times subdivided (`10·4^subdiv + 2`
/// vertices), with radial vertex normals: convex, so every vertex sees its whole upper
/// hemisphere.
pub fn icosphere(centre: Vec3, radius: f32, subdiv: u32) -> Mesh {
    let t = (1.0 + 5f32.sqrt()) / 2.0;
    let mut v: Vec<Vec3> = [
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ]
    .iter()
    .map(|p| Vec3::from(*p).normalize())
    .collect();
    let mut faces: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..subdiv {
        let mut mid: HashMap<(u32, u32), u32> = HashMap::new();
        let mut midpoint = |a: u32, b: u32, v: &mut Vec<Vec3>| {
            *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                v.push(((v[a as usize] + v[b as usize]) / 2.0).normalize());
                v.len() as u32 - 1
            })
        };
        let mut next = Vec::with_capacity(faces.len() * 4);
        for [a, b, c] in faces {
            let (ab, bc, ca) = (midpoint(a, b, &mut v), midpoint(b, c, &mut v), midpoint(c, a, &mut v));
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        faces = next;
    }
    let mut m = Mesh::default();
    let material = m.add_material(Material::diffuse("sphere", [0.5; 3]));
    let node = m.add_node("sphere", false);
    m.positions = v.iter().map(|p| centre + *p * radius).collect();
    m.normals = v;
    m.uvs = vec![Vec2::ZERO; m.positions.len()];
    m.tri_node = vec![node; faces.len()];
    m.tri_material = vec![material; faces.len()];
    m.triangles = faces;
    m
}

/// A closed torus around +Y at `centre` (tube radius `minor` at distance `major`): an object
/// whose inner side shadows itself.
pub fn torus(centre: Vec3, major: f32, minor: f32, rings: u32, segments: u32) -> Mesh {
    let mut m = Mesh::default();
    let material = m.add_material(Material::diffuse("torus", [0.5; 3]));
    let node = m.add_node("torus", false);
    m.push_torus(centre, major, minor, rings, segments, node, material);
    m
}

/// A vertical wall: the rectangle `x ∈ [x0, x1]`, `y ∈ [0, height]` in the plane `z = z`,
/// facing +Z (two-sided for rays).
pub fn wall(x0: f32, x1: f32, height: f32, z: f32) -> Mesh {
    let mut m = Mesh::default();
    let material = m.add_material(Material::diffuse("wall", [0.5; 3]));
    let node = m.add_node("wall", true);
    m.push_quad(Vec3::new(x0, 0.0, z), Vec3::X * (x1 - x0), Vec3::Y * height, node, material);
    m
}
