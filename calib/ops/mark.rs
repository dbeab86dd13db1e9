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
    /// Marked by the glTF node's extras (edit the proxy file to change it).
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

/// The manifest `text` with `proxy.diffuse_nodes = list` (everything else, comments included,
/// kept). `path` is only for the error message.
pub fn manifest_with_diffuse_nodes(text: &str, path: &Path, list: &[String]) -> Result<String> {
    let mut doc: toml_edit::DocumentMut = text.parse().with_context(|| format!("{}: not valid TOML", path.display()))?;
    let Some(proxy) = doc.get_mut("proxy").and_then(|p| p.as_table_like_mut()) else {
        bail!("{}: no [proxy] table", path.display());
    };
    match proxy.get_mut("diffuse_nodes").and_then(|v| v.as_array_mut()) {
        // Edit the array in place so the decoration around it (comments after it) stays.
        Some(arr) => {
            arr.clear();
            for n in list {
                arr.push(n.as_str());
            }
        }
        None => {
            proxy.insert("diffuse_nodes", super::toml_array(list.iter().map(String::as_str)));
        }
    }
    Ok(doc.to_string())
}

/// Writes `proxy.diffuse_nodes = list` into the scene's manifest (validated on a copy first, then
/// replaced atomically); returns the reloaded scene. Removing the last marked node fails, since
/// a scene needs at least one estimation surface.
pub fn set_diffuse_nodes(scene_dir: &Path, list: &[String]) -> Result<Scene> {
    let mpath = scene_dir.join(MANIFEST_FILE);
    let text = std::fs::read_to_string(&mpath).with_context(|| format!("reading {}", mpath.display()))?;
    let new = manifest_with_diffuse_nodes(&text, &mpath, list)?;
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
        let new = manifest_with_diffuse_nodes(text, Path::new("scene.toml"), &list).unwrap();
        assert!(new.contains("# the name") && new.contains("# ours") && new.contains("# paving"), "{new}");
        assert!(new.contains("diffuse_nodes = [\"ground\", \"wall\"]"), "{new}");
        let without = manifest_with_diffuse_nodes("[proxy]\nfile = \"p.glb\"\n", Path::new("scene.toml"), &list).unwrap();
        assert!(without.contains("diffuse_nodes = [\"ground\", \"wall\"]"), "{without}");
        assert_eq!(updated_list(&list, &["ground".into()], true), ["wall"]);
        assert!(manifest_with_diffuse_nodes("name = 1\n", Path::new("scene.toml"), &list).unwrap_err().to_string().contains("[proxy]"));
    }
}
