//! The camera pose from 2D–3D pairs: pair files, checks, per-pair errors, the proxy's outline as
//! feedback, and the update of the scene's camera file.

use anyhow::{Context, Result, bail};
use glam::{DVec2, DVec3};
use heliar::opencv_calib::pose::PoseFit;
use heliar::geometry::Mesh;
use heliar::scene::Scene;
use heliar::camera::{Camera, Intrinsics};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// Above this RMS reprojection error (pixels) a pose is suspect (a swapped or misplaced point).
pub const RMS_WARN_PX: f64 = 3.0;
/// Two triangles sharing an edge with normals closer than this (cosine) are one face: the edge
/// between them is not drawn.
const COPLANAR_COS: f32 = 0.999;
/// Length of the straight pieces an edge is cut into before projection (distortion bends edges).
const OUTLINE_STEP_PX: f64 = 3.0;

/// Parses pairs `u,v,x,y,z` (pixel, world metres), one per line; a header line, blank lines and
/// `#` comments are skipped. `label` names the source in errors.
pub fn parse_pairs(text: &str, label: &str) -> Result<(Vec<DVec2>, Vec<DVec3>)> {
    let (mut px, mut world) = (Vec::new(), Vec::new());
    for (i, line) in text.lines().enumerate() {
        let l = line.trim();
        if l.is_empty() || l.starts_with('#') {
            continue;
        }
        let v: Result<Vec<f64>, _> = l.split(',').map(|s| s.trim().parse::<f64>()).collect();
        match v {
            Ok(v) if v.len() == 5 && v.iter().all(|x| x.is_finite()) => {
                px.push(DVec2::new(v[0], v[1]));
                world.push(DVec3::new(v[2], v[3], v[4]));
            }
            _ if i == 0 => continue, // header
            _ => bail!("{label}: line {}: expected u,v,x,y,z (five finite numbers)", i + 1),
        }
    }
    Ok((px, world))
}

/// Reads a pairs file (see [`parse_pairs`]).
pub fn read_pairs(path: &Path) -> Result<(Vec<DVec2>, Vec<DVec3>)> {
    let text = std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    parse_pairs(&text, &path.display().to_string())
}

/// Pairs as the CSV [`parse_pairs`] reads.
pub fn pairs_csv(px: &[DVec2], world: &[DVec3]) -> String {
    let mut s = String::from("u,v,x,y,z\n");
    for (p, w) in px.iter().zip(world) {
        s += &format!("{},{},{},{},{}\n", p.x, p.y, w.x, w.y, w.z);
    }
    s
}

/// Checks that every pixel lies on the `width × height` image; the error names the pair (1-based).
pub fn check_inside(k: &Intrinsics, px: &[DVec2], label: &str) -> Result<()> {
    if let Some((i, p)) = px.iter().enumerate().find(|(_, p)| !(p.x >= -0.5 && p.y >= -0.5 && p.x <= k.width as f64 - 0.5 && p.y <= k.height as f64 - 0.5)) {
        bail!("{label}: pair {}: pixel ({}, {}) is outside the {}×{} image", i + 1, p.x, p.y, k.width, k.height);
    }
    Ok(())
}

/// Fewest point pairs for a pose (six unknowns, two equations a pair, and P3P's ambiguity).
pub const MIN_PAIRS: usize = 4;
/// Two clicks closer than this (pixels) are the same image point.
pub const SAME_PIXEL_PX: f64 = 0.5;
/// Two world points closer than this (metres) are the same point.
pub const SAME_POINT_M: f64 = 1e-3;
/// World points within this fraction of their extent of one line are collinear: a rotation about
/// that line is not determined.
pub const COLLINEAR_FRACTION: f64 = 1e-3;

/// Checks pairs before they reach OpenCV (whose assertions would be the only message): at least
/// [`MIN_PAIRS`], no image point or world point given twice, and world points not all on one
/// line. Errors name the pairs (1-based, in file order) and `label` (the pairs' source).
pub fn check_pairs(px: &[DVec2], world: &[DVec3], label: &str) -> Result<()> {
    if px.len() < MIN_PAIRS {
        bail!("{label}: {} point pairs; at least {MIN_PAIRS} are needed", px.len());
    }
    for i in 0..px.len() {
        for j in i + 1..px.len() {
            if (px[i] - px[j]).length() < SAME_PIXEL_PX {
                bail!("{label}: pairs {} and {} click the same pixel ({:.1}, {:.1}); each pair needs its own image point", i + 1, j + 1, px[j].x, px[j].y);
            }
            if (world[i] - world[j]).length() < SAME_POINT_M {
                bail!("{label}: pairs {} and {} name the same world point ({}, {}, {}); each pair needs its own proxy point", i + 1, j + 1, world[j].x, world[j].y, world[j].z);
            }
        }
    }
    // The line through the two points farthest apart; every point's distance from it.
    let (mut a, mut b, mut extent) = (0, 0, 0.0);
    for i in 0..world.len() {
        for j in i + 1..world.len() {
            let l = (world[i] - world[j]).length();
            if l > extent {
                (a, b, extent) = (i, j, l);
            }
        }
    }
    let dir = (world[b] - world[a]) / extent;
    let off = world.iter().map(|p| (*p - world[a]).reject_from_normalized(dir).length()).fold(0.0, f64::max);
    if off <= COLLINEAR_FRACTION * extent {
        bail!("{label}: all {} world points lie on one line (from pair {} to pair {}); add points off that line (a corner of another edge)", world.len(), a + 1, b + 1);
    }
    Ok(())
}

/// What is doubtful about a pose, in words.
pub fn warnings(fit: &PoseFit) -> Vec<String> {
    if fit.rms_px > RMS_WARN_PX {
        vec![format!("RMS reprojection error {:.1} px: check the pairs (a swapped point?)", fit.rms_px)]
    } else {
        Vec::new()
    }
}

/// Reprojection error of each pair, pixels (infinite for a point behind the camera).
pub fn pair_errors_px(camera: &Camera, px: &[DVec2], world: &[DVec3]) -> Vec<f64> {
    px.iter().zip(world).map(|(p, w)| camera.project_world(*w).map_or(f64::INFINITY, |q| (q - *p).length())).collect()
}

/// The camera file `text` with its pose replaced by the solved one (other fields and comments
/// kept). `path` is only for the error message.
pub fn camera_toml_with_pose(text: &str, path: &Path, fit: &PoseFit) -> Result<String> {
    let mut doc: toml_edit::DocumentMut = text.parse().with_context(|| format!("{}: not valid TOML", path.display()))?;
    let mut pose = toml_edit::Table::new();
    pose["rvec_camera_from_world"] = super::toml_array(fit.rvec_camera_from_world);
    pose["tvec_camera_from_world"] = super::toml_array(fit.tvec_camera_from_world);
    doc["pose"] = toml_edit::Item::Table(pose);
    Ok(doc.to_string())
}

/// Stores the pose in the scene's camera file (validated, atomic); returns the reloaded scene and
/// the camera file's path. The camera file (`camera.file` of the manifest, resolved against the
/// scene folder with symlinks and `..`) must lie inside the scene folder unless `allow_outside`
/// (`--allow-outside-scene`).
pub fn save_pose(scene_dir: &Path, scene: &Scene, fit: &PoseFit, allow_outside: bool) -> Result<(Scene, PathBuf)> {
    let rel = PathBuf::from(&scene.manifest.camera.file);
    let path = scene_dir.join(&rel);
    let text = std::fs::read_to_string(&path).with_context(|| format!("reading {}", path.display()))?;
    let new = camera_toml_with_pose(&text, &path, fit)?;
    let s = match check_camera_inside(scene_dir, scene, allow_outside)? {
        Some(inside) => crate::edit::edit_scene(scene_dir, &[(inside, new.into_bytes())])?,
        None => crate::edit::edit_camera_outside(scene_dir, &heliar::io::guard::resolve(&path), new.as_bytes())?,
    };
    Ok((s, path))
}

/// The scene's camera file relative to the scene folder (symlinks and `..` resolved), or `None`
/// when it lies outside and `allow_outside`; an error naming the manifest's `camera.file` when it
/// lies outside and not `allow_outside`.
pub fn check_camera_inside(scene_dir: &Path, scene: &Scene, allow_outside: bool) -> Result<Option<PathBuf>> {
    let file = &scene.manifest.camera.file;
    match crate::edit::rel_inside(scene_dir, Path::new(file)) {
        Some(inside) => Ok(Some(inside)),
        None if allow_outside => Ok(None),
        None => bail!(
            "{}: camera.file = \"{file}\" is {}, outside the scene folder {}; the pose was not written (move the camera file into the scene, or --allow-outside-scene)",
            scene_dir.join(heliar::scene::MANIFEST_FILE).display(),
            heliar::io::guard::resolve(&scene_dir.join(file)).display(),
            scene_dir.display()
        ),
    }
}

/// The proxy's visible outline: its border and crease edges (edges inside a flat face, such as
/// the diagonal of a quad, are left out).
pub fn outline_edges(mesh: &Mesh) -> Vec<[DVec3; 2]> {
    // Vertices are matched by position, since glTF splits them where normals differ.
    let key = |p: glam::Vec3| (p * 1e4).round().as_ivec3().to_array();
    let mut ids: HashMap<[i32; 3], u32> = HashMap::new();
    let mut edges: HashMap<(u32, u32), (usize, Vec<glam::Vec3>)> = HashMap::new();
    for (t, tri) in mesh.triangles.iter().enumerate() {
        if mesh.double_area(t as u32) <= 1e-10 {
            continue;
        }
        let n = mesh.face_normal(t as u32);
        let v: Vec<u32> = tri.iter().map(|&i| {
            let next = ids.len() as u32;
            *ids.entry(key(mesh.positions[i as usize])).or_insert(next)
        }).collect();
        for e in 0..3 {
            let (a, b) = (v[e], v[(e + 1) % 3]);
            let k = (a.min(b), a.max(b));
            let entry = edges.entry(k).or_insert_with(|| (t * 3 + e, Vec::new()));
            entry.1.push(n);
        }
    }
    let mut out: Vec<(usize, [DVec3; 2])> = edges
        .into_values()
        .filter(|(_, normals)| normals.len() != 2 || normals[0].dot(normals[1]).abs() < COPLANAR_COS)
        .map(|(first, _)| {
            let tri = mesh.triangles[first / 3];
            let (a, b) = (tri[first % 3], tri[(first % 3 + 1) % 3]);
            (first, [mesh.positions[a as usize].as_dvec3(), mesh.positions[b as usize].as_dvec3()])
        })
        .collect();
    out.sort_by_key(|(first, _)| *first);
    out.into_iter().map(|(_, e)| e).collect()
}

/// The outline edges projected through `camera` as polylines in pixel coordinates (each edge is
/// cut into short pieces, so lens distortion bends it as it bends the real edge; pieces behind the
/// camera are left out).
pub fn project_outline(camera: &Camera, edges: &[[DVec3; 2]]) -> Vec<Vec<DVec2>> {
    let mut lines = Vec::new();
    for [a, b] in edges {
        let (pa, pb) = (camera.project_world(*a), camera.project_world(*b));
        let n = match (pa, pb) {
            (Some(p), Some(q)) => (((q - p).length() / OUTLINE_STEP_PX).ceil() as usize).clamp(1, 400),
            _ => 200,
        };
        let mut line = Vec::new();
        for s in 0..=n {
            match camera.project_world(*a + (*b - *a) * (s as f64 / n as f64)) {
                Some(uv) if uv.is_finite() => line.push(uv),
                _ => {
                    if line.len() > 1 {
                        lines.push(std::mem::take(&mut line));
                    }
                    line.clear();
                }
            }
        }
        if line.len() > 1 {
            lines.push(line);
        }
    }
    lines
}

/// Draws the outline (yellow) and the clicked points (red crosses) into `img`.
pub fn draw_overlay(img: &mut image::RgbImage, outline: &[Vec<DVec2>], clicks: &[DVec2]) {
    let (w, h) = (img.width() as i64, img.height() as i64);
    let mut plot = |x: f64, y: f64, c: [u8; 3]| {
        let (x, y) = (x.round() as i64, y.round() as i64);
        if x >= 0 && y >= 0 && x < w && y < h {
            img.put_pixel(x as u32, y as u32, image::Rgb(c));
        }
    };
    for line in outline {
        for seg in line.windows(2) {
            let (a, b) = (seg[0], seg[1]);
            let steps = ((b - a).length().ceil() as usize).clamp(1, 10_000);
            for s in 0..=steps {
                let p = a + (b - a) * (s as f64 / steps as f64);
                plot(p.x, p.y, [255, 220, 0]);
            }
        }
    }
    for c in clicks {
        for d in -3..=3 {
            plot(c.x + d as f64, c.y, [255, 0, 0]);
            plot(c.x, c.y + d as f64, [255, 0, 0]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use heliar::geometry::Material;

    #[test]
    fn pairs_round_trip_and_bad_lines_are_named() {
        let px = vec![DVec2::new(1.5, 2.0), DVec2::new(3.0, 4.25)];
        let world = vec![DVec3::new(0.0, 1.0, -2.0), DVec3::new(5.0, 0.0, 1.0)];
        let (p2, w2) = parse_pairs(&pairs_csv(&px, &world), "pairs.csv").unwrap();
        assert_eq!((p2, w2), (px, world));
        let e = parse_pairs("u,v,x,y,z\n1,2,3,4,5\n1,2,3\n", "pairs.csv").unwrap_err().to_string();
        assert!(e.contains("pairs.csv: line 3"), "{e}");
        let k = Intrinsics::brown_conrady(10, 8, 10.0, 10.0, 5.0, 4.0, [0.0; 5]);
        assert!(check_inside(&k, &[DVec2::new(9.4, 7.4)], "x").is_ok());
        assert!(check_inside(&k, &[DVec2::new(1.0, 1.0), DVec2::new(10.0, 1.0)], "x").unwrap_err().to_string().contains("pair 2"));
        assert!(check_inside(&k, &[DVec2::new(f64::NAN, 1.0)], "x").is_err());
    }

    #[test]
    fn pairs_opencv_cannot_use_are_named() {
        let px: Vec<DVec2> = (0..5).map(|i| DVec2::new(10.0 * i as f64, 3.0 * (i * i) as f64)).collect();
        let world = vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z, DVec3::ONE];
        assert!(check_pairs(&px, &world, "p.csv").is_ok());
        assert!(check_pairs(&px[..3], &world[..3], "p.csv").unwrap_err().to_string().contains("at least 4"));
        let mut dup = px.clone();
        dup[3] = dup[1] + DVec2::splat(0.1);
        assert!(check_pairs(&dup, &world, "p.csv").unwrap_err().to_string().contains("pairs 2 and 4 click the same pixel"));
        let mut same = world.clone();
        same[4] = same[0];
        assert!(check_pairs(&px, &same, "p.csv").unwrap_err().to_string().contains("pairs 1 and 5 name the same world point"));
        let line: Vec<DVec3> = (0..5).map(|i| DVec3::new(i as f64, 2.0 * i as f64, 0.5)).collect();
        let e = check_pairs(&px, &line, "p.csv").unwrap_err().to_string();
        assert!(e.contains("p.csv") && e.contains("one line"), "{e}");
    }

    #[test]
    fn a_box_outline_has_its_twelve_edges() {
        let mut m = Mesh::default();
        let (n, mat) = (m.add_node("box", true), m.add_material(Material::diffuse("m", [0.5; 3])));
        m.push_box(glam::Vec3::ZERO, glam::Vec3::ONE, n, mat, false);
        assert_eq!(m.triangles.len(), 12);
        assert_eq!(outline_edges(&m).len(), 12);
    }
}
