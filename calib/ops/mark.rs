//! Diffuse estimation surfaces: which proxy node a pixel (or a direction of the environment map)
//! sees, and the manifest's `proxy.diffuse_nodes` list, edited with `toml_edit` so the user's
//! comments and layout survive.

use anyhow::{Context, Result, bail};
use glam::{DVec2, DVec3};
use heliar::geometry::raycast::RayScene;
use heliar::scene::{MANIFEST_FILE, Scene};
use std::path::{Path, PathBuf};

/// Why a node counts as a diffuse estimation surface.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Marked {
    /// Not marked.
    No,
    /// Listed in the manifest's `proxy.diffuse_nodes` (can be unmarked here).
    Manifest,
    /// Marked by the glTF node's extras (unmarking records the override in the manifest's
    /// `proxy.not_diffuse_nodes`).
    Extras,
}

/// How node `index` of the scene's proxy is marked.
pub fn marked(scene: &Scene, index: usize) -> Marked {
    let Some(n) = scene.proxy.nodes.get(index) else { return Marked::No };
    if scene.manifest.proxy.diffuse_nodes.contains(&n.name) {
        Marked::Manifest
    } else if n.diffuse {
        Marked::Extras
    } else {
        Marked::No
    }
}

/// The proxy node hit first along a ray, `None` when the ray sees no proxy geometry.
pub fn node_along(scene: &Scene, rays: &RayScene, origin: DVec3, dir: DVec3) -> Option<usize> {
    let hit = rays.intersect(origin.as_vec3(), dir.as_vec3(), f32::MAX)?;
    scene.proxy.tri_node.get(hit.tri as usize).map(|&n| n as usize)
}

/// The proxy node seen at camera pixel `uv`.
pub fn node_at_pixel(scene: &Scene, rays: &RayScene, uv: DVec2) -> Result<usize> {
    let k = &scene.camera.intrinsics;
    if !(uv.x >= -0.5 && uv.y >= -0.5 && uv.x <= k.width as f64 - 0.5 && uv.y <= k.height as f64 - 0.5) {
        bail!("pixel {:.1},{:.1} is outside the {}×{} image", uv.x, uv.y, k.width, k.height);
    }
    let (o, d) = scene.camera.ray_at(uv).with_context(|| format!("pixel {:.1},{:.1}: outside the lens model", uv.x, uv.y))?;
    node_along(scene, rays, o, d).with_context(|| format!("pixel {:.1},{:.1} sees no proxy geometry", uv.x, uv.y))
}

/// The index of the node called `name`; the error lists the nodes there are.
pub fn node_index(scene: &Scene, name: &str) -> Result<usize> {
    scene.proxy.nodes.iter().position(|n| n.name == name).with_context(|| {
        format!(
            "{}: no node named '{name}' (have: {})",
            scene.manifest.proxy.file,
            scene.proxy.nodes.iter().map(|x| x.name.as_str()).collect::<Vec<_>>().join(", ")
        )
    })
}

/// The manifest's list with `names` added (or removed, when `unmark`).
pub fn updated_list(current: &[String], names: &[String], unmark: bool) -> Vec<String> {
    let mut list = current.to_vec();
    for n in names {
        if unmark {
            list.retain(|x| x != n);
        } else if !list.contains(n) {
            list.push(n.clone());
        }
    }
    list
}

/// The manifest's two lists after marking (or unmarking) `names`: `(proxy.diffuse_nodes,
/// proxy.not_diffuse_nodes)`. `by_extras` says whether the proxy's glTF extras mark a node.
///
/// Unmarking removes the name from `diffuse_nodes` and, when the extras mark the node, records it
/// in `not_diffuse_nodes` (the override: the proxy file is left alone). Marking removes the name
/// from `not_diffuse_nodes`, and lists it in `diffuse_nodes` unless that removal alone marks it
/// again (the extras do).
pub fn updated_lists(scene: &Scene, names: &[String], unmark: bool, by_extras: impl Fn(&str) -> bool) -> (Vec<String>, Vec<String>) {
    let p = &scene.manifest.proxy;
    let mut not = p.not_diffuse_nodes.clone();
    let mut marked_again = Vec::new();
    for n in names {
        if unmark {
            if by_extras(n) && !not.contains(n) {
                not.push(n.clone());
            }
        } else if not.contains(n) {
            not.retain(|x| x != n);
            if by_extras(n) {
                marked_again.push(n.clone());
            }
        }
    }
    let to_list: Vec<String> = names.iter().filter(|n| !marked_again.contains(n)).cloned().collect();
    (updated_list(&p.diffuse_nodes, &to_list, unmark), not)
}

/// The names of the proxy's nodes its glTF extras mark (their own or an ancestor's), whatever the
/// manifest says.
pub fn marked_by_extras(scene: &Scene) -> Result<Vec<String>> {
    let path = scene.root.join(&scene.manifest.proxy.file);
    let (mesh, _) = heliar::scene::gltf::load_gltf(&path, glam::Mat4::IDENTITY, &[]).with_context(|| format!("reading {}", path.display()))?;
    Ok(mesh.nodes.into_iter().filter(|n| n.diffuse).map(|n| n.name).collect())
}

/// The manifest `text` with `proxy.diffuse_nodes = list` and, when given,
/// `proxy.not_diffuse_nodes = not` (left out when empty and not there yet); everything else,
/// comments included, is kept. `path` is only for the error message.
pub fn manifest_with_lists(text: &str, path: &Path, list: &[String], not: Option<&[String]>) -> Result<String> {
    let mut doc: toml_edit::DocumentMut = text.parse().with_context(|| format!("{}: not valid TOML", path.display()))?;
    let Some(proxy) = doc.get_mut("proxy").and_then(|p| p.as_table_like_mut()) else {
        bail!("{}: no [proxy] table", path.display());
    };
    set_array(proxy, "diffuse_nodes", list, true);
    if let Some(not) = not {
        set_array(proxy, "not_diffuse_nodes", not, false);
    }
    Ok(doc.to_string())
}

fn set_array(table: &mut dyn toml_edit::TableLike, key: &str, list: &[String], insert_empty: bool) {
    match table.get_mut(key).and_then(|v| v.as_array_mut()) {
        // Edit the array in place so the decoration around it (comments after it) stays.
        Some(arr) => {
            arr.clear();
            for n in list {
                arr.push(n.as_str());
            }
        }
        None if list.is_empty() && !insert_empty => {}
        None => {
            table.insert(key, super::toml_array(list.iter().map(String::as_str)));
        }
    }
}

/// Writes `proxy.diffuse_nodes = list` (and `proxy.not_diffuse_nodes = not`, when given) into
/// the scene's manifest (validated on a copy first, then replaced atomically); returns the
/// reloaded scene. Removing the last marked node fails, since a scene needs at least one
/// estimation surface.
pub fn set_marks(scene_dir: &Path, list: &[String], not: Option<&[String]>) -> Result<Scene> {
    let mpath = scene_dir.join(MANIFEST_FILE);
    let text = std::fs::read_to_string(&mpath).with_context(|| format!("reading {}", mpath.display()))?;
    let new = manifest_with_lists(&text, &mpath, list, not)?;
    crate::edit::edit_scene(scene_dir, &[(PathBuf::from(MANIFEST_FILE), new.into_bytes())])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_list_is_edited_and_comments_survive() {
        let text = "name = \"x\" # the name\n\n[proxy]\nfile = \"proxy.glb\" # ours\ndiffuse_nodes = [\"ground\"] # paving\n\n[camera]\nfile = \"c.toml\"\n";
        let list = updated_list(&["ground".into()], &["wall".into(), "ground".into()], false);
        assert_eq!(list, ["ground", "wall"]);
        let new = manifest_with_lists(text, Path::new("scene.toml"), &list, None).unwrap();
        assert!(new.contains("# the name") && new.contains("# ours") && new.contains("# paving"), "{new}");
        assert!(new.contains("diffuse_nodes = [\"ground\", \"wall\"]"), "{new}");
        let without = manifest_with_lists("[proxy]\nfile = \"p.glb\"\n", Path::new("scene.toml"), &list, None).unwrap();
        assert!(without.contains("diffuse_nodes = [\"ground\", \"wall\"]"), "{without}");
        assert_eq!(updated_list(&list, &["ground".into()], true), ["wall"]);
        assert!(manifest_with_lists("name = 1\n", Path::new("scene.toml"), &list, None).unwrap_err().to_string().contains("[proxy]"));
    }
}
