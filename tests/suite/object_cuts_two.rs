//! Two objects moving and turning differently through the visibility cuts (issue 15 §2, "the
//! other objects' fields"): the courtyard's statue moves 0.92 m and turns +90° while a second,
//! smaller statue beside its path turns −50° where it stands. On the frame where both changed,
//! each object's ambient is its own self-visibility times the other's field remapped through the
//! other's turn, and the ground's contact shadows come from both fields, nothing traced. Checked
//! against both objects placed and turned there from the start, traced (per-pixel transfer and
//! `c_v`, `b_v`), as `object_cuts_turned` does for one object. Each statue also gets the light
//! the other reflects onto it (`cuts::bounce`) and the light it reflects onto itself
//! (`cuts::self_bounce`, its long edges split at load), which the traced reference has.

use crate::common::*;
use crate::object_cuts::{augment3, block, edit, lum, object_hits, object_pixels, rel_rmse};
use heliar::scene::Scene;

/// Statue A: still for two frames at the manifest's placement (25°), then moved and turned by
/// 90°. Statue B (0.6 scale): still at `B_AT`, then turned −50° in place (frames 10 s apart).
const A_KEYS: &str = "[[virtual_objects.motion.keyframes]]\ntime = 0.0\ntranslation = [-1.9, 0, 0]\nrotation_y_deg = 25\n\
                      [[virtual_objects.motion.keyframes]]\ntime = 10.0\ntranslation = [-1.9, 0, 0]\nrotation_y_deg = 25\n\
                      [[virtual_objects.motion.keyframes]]\ntime = 20.0\ntranslation = [-1.2, 0, 0.6]\nrotation_y_deg = 115\n";
const B_AT: &str = "[-0.2, 0, 1.3]";

fn second(rotation: f64, keys: bool) -> String {
    let mut b = format!("[[virtual_objects]]\nfile = \"objects/statue.glb\"\ntranslation = {B_AT}\nrotation_y_deg = {rotation}\nscale = 0.6\n");
    if keys {
        b += &format!(
            "[[virtual_objects.motion.keyframes]]\ntime = 0.0\ntranslation = {B_AT}\nrotation_y_deg = 0\n\
             [[virtual_objects.motion.keyframes]]\ntime = 10.0\ntranslation = {B_AT}\nrotation_y_deg = 0\n\
             [[virtual_objects.motion.keyframes]]\ntime = 20.0\ntranslation = {B_AT}\nrotation_y_deg = -50\n"
        );
    }
    b
}

const STATUE: &str = "[[virtual_objects]]\nfile = \"objects/statue.glb\"\ntranslation = [-1.9, 0, 0]\nrotation_y_deg = 25\nscale = 1.0\n";

#[test]
fn two_objects_turned_differently_take_ambient_and_contact_shadows_from_the_cuts() {
    let outs = std::env::temp_dir().join(format!("heliar-cuts-two-out-{}", std::process::id()));
    let bare = scratch_courtyard("cuts-two-bare");
    edit(&bare, STATUE, "");
    let (n, _) = augment3(&bare, &outs.join("bare"));
    let moving = scratch_courtyard("cuts-two-moving");
    edit(&moving, "scale = 1.0\n", &format!("scale = 1.0\n{A_KEYS}{}\n", second(0.0, true)));
    let placed = scratch_courtyard("cuts-two-placed");
    edit(&placed, "translation = [-1.9, 0, 0]\nrotation_y_deg = 25\nscale = 1.0\n", &format!("translation = [-1.2, 0, 0.6]\nrotation_y_deg = 115\nscale = 1.0\n{}\n", second(-50.0, false)));
    let (a, lines) = augment3(&moving, &outs.join("moving"));
    let (b, _) = augment3(&placed, &outs.join("placed"));
    let passes = &lines[2]["passes"];
    // Both objects changed on frame 2, which ran the cuts and traced nothing.
    let moved: Vec<&str> = passes["moved"].as_array().unwrap().iter().filter_map(|m| m.as_str()).collect();
    assert_eq!(moved.len(), 2, "frame 2 moved: {passes}");
    assert!(passes["ran"].as_array().unwrap().iter().any(|p| p == "visibility_cuts"), "{passes}");
    assert_eq!(passes["receivers_computed"].as_u64(), Some(0), "{passes}");
    assert_eq!(passes["transfer_traced"].as_u64(), Some(0), "{passes}");

    let scene_b = Scene::load(&placed).unwrap();
    assert_eq!(scene_b.virtual_objects.len(), 2);
    let w = scene_b.camera.intrinsics.width;
    // Each statue shows: the small one's interior alone (the placed scene without statue A).
    let only_b = {
        let mut s = Scene::load(&placed).unwrap();
        s.virtual_objects.remove(0);
        object_pixels(&s)
    };
    let only_a = {
        let mut s = Scene::load(&placed).unwrap();
        s.virtual_objects.truncate(1);
        object_pixels(&s)
    };
    let pixels = object_pixels(&scene_b);
    let mean_over = |img: &heliar::io::image::LinearImage, px: &[usize]| px.iter().map(|&i| lum(img.data[i])).sum::<f64>() / px.len().max(1) as f64;
    eprintln!(
        "statue A alone {} px: relative RMSE {:.4}, mean cuts {:.5} traced {:.5}; statue B: mean cuts {:.5} traced {:.5}",
        only_a.len(),
        rel_rmse(&a[2], &b[2], &only_a),
        mean_over(&a[2], &only_a),
        mean_over(&b[2], &only_a),
        mean_over(&a[2], &only_b),
        mean_over(&b[2], &only_b)
    );
    assert!(only_b.len() > 60 && pixels.len() > only_b.len() + 300, "{} object pixels, {} of statue B", pixels.len(), only_b.len());
    let err = rel_rmse(&a[2], &b[2], &pixels);
    let err_b = rel_rmse(&a[2], &b[2], &only_b);
    let objects_b = block(&object_hits(&scene_b), w, false);
    let darker = |img: &heliar::io::image::LinearImage, i: usize| 1.0 - lum(img.data[i]) / lum(n[2].data[i]).max(1e-9);
    let contact: Vec<usize> = (0..n[2].data.len()).filter(|&i| !objects_b[i] && darker(&b[2], i) > 0.01).collect();
    let contact_err = rel_rmse(&a[2], &b[2], &contact);
    eprintln!(
        "two statues, +90° and −50°: object pixels {} relative RMSE {err:.4} (statue B's {}: {err_b:.4}); contact region {} pixels, relative RMSE {contact_err:.4}; composite {:.0} ms of which cuts {:.0} ms",
        pixels.len(),
        only_b.len(),
        contact.len(),
        lines[2]["composite_ms"].as_f64().unwrap(),
        passes["timings"]["cuts_ms"].as_f64().unwrap()
    );
    assert!(contact.len() > 100, "{} contact pixels", contact.len());
    let err_a = rel_rmse(&a[2], &b[2], &only_a);
    assert!(err_a <= STATUE_A_TOLERANCE, "relative RMSE {err_a:.4} over statue A's pixels");
    assert!(err <= TWO_OBJECTS_TOLERANCE, "relative RMSE {err:.4} over the objects' pixels");
    assert!(err_b <= OBJECT_TOLERANCE, "relative RMSE {err_b:.4} over statue B's pixels");
    assert!(contact_err <= CONTACT_TOLERANCE, "relative RMSE {contact_err:.4} over the contact region");
    for d in [&bare, &moving, &placed, &outs] {
        std::fs::remove_dir_all(d).ok();
    }
}

/// Relative RMSE allowed over one object's pixels (statue B's 176). Measured 3.5% (debug build)
/// with the light each statue reflects onto itself (`cuts::self_bounce`) and the objects' long
/// edges split at load (`geometry::subdivide`); before them 6.2%. One point of margin: the
/// self-bounce's 64 rays per vertex and the fields' sampling, not the load, set the error.
const OBJECT_TOLERANCE: f64 = 0.045;
/// Relative RMSE allowed over statue A's pixels. The cuts alone (cyberworlds Eqs. 3–4) took the
/// sunlit statue B as a black occluder of A's sky: 7.8% (A without B: 4.9%). With the light B
/// reflects onto A (`cuts::bounce`, an extension of Eq. 3): 5.3%; with the light A reflects onto
/// itself and the split edges as well: measured 3.0%. One point of margin as above.
const STATUE_A_TOLERANCE: f64 = 0.04;
/// Relative RMSE allowed over both objects' pixels (711; A's 496 and B's 176 interior pixels
/// are counted each without the other, and the statues meet on screen). Measured 3.7% with the
/// other's and each one's own reflected light and the split edges (6.3% with the other's only,
/// 8.1% with neither; docs/measurements.md, "Self-bounce and split edges on by default"):
/// issue 15's 5% is met, with 0.8 point of margin.
const TWO_OBJECTS_TOLERANCE: f64 = 0.045;
/// Relative RMSE allowed over the contact region (issue 15 §3 asks ≤ 8%). Measured 6.3% (5.1% with
/// the finer fields above) with `c·V`, `b·V`; 1.82% with the receivers' own light by direction,
/// the nearer statue's reflected light and the near field traced (`cuts::receiver_light`).
const CONTACT_TOLERANCE: f64 = 0.04;

/// The loader splits every virtual object's long edges (`geometry::subdivide`, for the cuts'
/// per-vertex shading and the light an object reflects onto itself), static and moving alike:
/// the surface (area per material) is the glTF's, no edge is longer than the limit, and a
/// moving object's rest mesh has the placed mesh's triangles.
#[test]
fn the_courtyards_objects_are_split_at_load_and_keep_their_surface() {
    use heliar::geometry::subdivide::{CUTS_EDGE_FRACTION, bounding_radius};
    let scene = Scene::load(&std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/courtyard")).unwrap();
    assert!(!scene.virtual_objects.is_empty());
    for (o, spec) in scene.virtual_objects.iter().zip(&scene.manifest.virtual_objects) {
        let name = o.path.display();
        let (glb, _) = heliar::scene::gltf::load_gltf(&o.path, glam::Mat4::IDENTITY, &[]).unwrap();
        // The split mesh and its scale against the glTF's frame (a moving object's rest mesh is
        // in that frame; a static one is placed with the manifest's scale).
        let (split, scale) = match &o.motion {
            Some(m) => (&m.rest, 1.0),
            None => (&o.mesh, spec.scale as f32),
        };
        let limit = CUTS_EDGE_FRACTION * bounding_radius(&glb);
        eprintln!("{name}: {} → {} triangles, {} → {} vertices (edges ≤ {limit:.3} m before scaling)", glb.triangles.len(), o.mesh.triangles.len(), glb.positions.len(), o.mesh.positions.len());
        assert!(o.mesh.triangles.len() >= glb.triangles.len() && o.mesh.tri_material.len() == o.mesh.triangles.len(), "{name}");
        if let Some(m) = &o.motion {
            assert_eq!(m.rest.triangles, o.mesh.triangles, "{name}: rest and placed meshes");
        }
        for t in 0..split.triangles.len() as u32 {
            let [a, b, c] = split.corners(t);
            let longest = (b - a).length().max((c - b).length()).max((a - c).length()) / scale;
            // Relative slack for the f32 rounding of placement and midpoints.
            assert!(longest <= limit * (1.0 + 1e-4), "{name}: triangle {t} has an edge of {longest} m");
        }
        // The surface per material is kept (to f32 rounding summed over the triangles).
        for mat in 0..glb.materials.len().max(1) as u32 {
            let area = |m: &heliar::geometry::Mesh| (0..m.triangles.len() as u32).filter(|&t| m.tri_material[t as usize] == mat).map(|t| m.double_area(t) as f64).sum::<f64>();
            let (want, got) = (area(&glb) * (scale as f64).powi(2), area(split));
            assert!((got - want).abs() <= 1e-4 * want.max(1e-6), "{name}: material {mat}: area {got} against {want}");
        }
    }
}
