//! The bundled courtyard's second virtual object: a small delivery robot that crosses the yard
//! (issue 15 §5), placed and moved by the manifest's keyframes ([`ROBOT_KEYS`]).

use glam::Vec3;
use heliar::geometry::{Material, Mesh};

/// The robot's file, beside the statue's.
pub(crate) const ROBOT_FILE: &str = "objects/robot.glb";

/// Where the robot is at the sequence's start and at its end (seconds, translation, turn about
/// the vertical in degrees, facing its way across the yard). It crosses the right side of the
/// view toward the camera, more than 5 m from the statue's box, so that its visibility cut field
/// (about 10 bounding radii, 4.6 m) never reaches the statue, which keeps its traced transfer bit
/// for bit (`render::compositor`'s `kept`); it never enters the statue's reference crops, and
/// its shadow at 15:30 (sun in the south-west) falls away from them.
pub(crate) const ROBOT_KEYS: [(f64, [f64; 3], f64); 2] = [(0.0, [5.0, 0.0, -3.0], -9.5), (110.0, [4.0, 0.0, 3.0], -9.5)];

/// Faces per box side along each edge: the cuts light an object per vertex, so the body's sides
/// get a grid of vertices (their lower rows take the ground's occlusion).
const GRID: u32 = 4;

/// An axis-aligned box `lo..hi` whose six sides are `GRID`² quads each.
fn push_grid_box(m: &mut Mesh, lo: Vec3, hi: Vec3, node: u32, material: u32) {
    let d = hi - lo;
    let (x, y, z) = (Vec3::X * d.x, Vec3::Y * d.y, Vec3::Z * d.z);
    // Each side: a corner and two edges whose cross product points outward (as `push_box`).
    let sides = [
        (Vec3::new(hi.x, lo.y, lo.z), y, z),
        (lo, z, y),
        (Vec3::new(lo.x, hi.y, lo.z), z, x),
        (lo, x, z),
        (Vec3::new(lo.x, lo.y, hi.z), x, y),
        (lo, y, x),
    ];
    let n = GRID as f32;
    for (o, u, v) in sides {
        for i in 0..GRID {
            for j in 0..GRID {
                m.push_quad(o + u * (i as f32 / n) + v * (j as f32 / n), u / n, v / n, node, material);
            }
        }
    }
}

/// The robot in its own frame (base centred on the origin, metres, long side along z): a dark
/// chassis on the ground, a light body on it and an orange lamp on the lid; glTF
/// metallic–roughness materials. 0.48 × 0.52 × 0.60 m.
pub(crate) fn robot_local() -> Mesh {
    let mut m = Mesh::default();
    let rubber = m.add_material(Material { name: "rubber".into(), base_color: [0.06, 0.06, 0.06, 1.0], base_color_texture: None, metallic: 0.0, roughness: 0.9 });
    let shell = m.add_material(Material { name: "shell".into(), base_color: [0.80, 0.80, 0.76, 1.0], base_color_texture: None, metallic: 0.0, roughness: 0.5 });
    let lamp = m.add_material(Material { name: "lamp".into(), base_color: [0.90, 0.35, 0.05, 1.0], base_color_texture: None, metallic: 0.0, roughness: 0.4 });
    let chassis = m.add_node("chassis", false);
    push_grid_box(&mut m, Vec3::new(-0.24, 0.0, -0.26), Vec3::new(0.24, 0.12, 0.26), chassis, rubber);
    let body = m.add_node("body", false);
    push_grid_box(&mut m, Vec3::new(-0.22, 0.12, -0.30), Vec3::new(0.22, 0.46, 0.30), body, shell);
    let top = m.add_node("lamp", false);
    m.push_box(Vec3::new(-0.05, 0.46, -0.05), Vec3::new(0.05, 0.52, 0.05), top, lamp, false);
    m
}

/// The manifest's `[[virtual_objects]]` entry of the robot, with its keyframes.
pub(crate) fn robot_manifest() -> String {
    let mut s = format!("[[virtual_objects]]\n# A delivery robot crossing the yard (issue 15 §5): the visibility cuts light it and its\n# contact shadow; the statue keeps its traced transfer.\nfile = \"{ROBOT_FILE}\"\nscale = 1.0\n");
    for (t, [x, y, z], turn) in ROBOT_KEYS {
        s += &format!("[[virtual_objects.motion.keyframes]]\ntime = {t:.1}\ntranslation = [{x:.1}, {y:.1}, {z:.1}]\nrotation_y_deg = {turn}\n");
    }
    s
}
