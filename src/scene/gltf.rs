//! glTF 2.0 (`.glb`/`.gltf`) into a world-space [`Mesh`].
//!
//! Every triangle primitive of every node of the default scene is flattened into world
//! coordinates with its node's global transform (and an extra placement transform for virtual
//! objects). A node is a diffuse estimation surface when its `extras` hold
//! `{"heliar": {"diffuse": true}}` (or an ancestor's do), or when the manifest names it.
//! Base-colour textures are sRGB-encoded per the glTF spec and decoded to linear here.

use super::SceneError;
use crate::geometry::{Material, Mesh, NodeInfo, Texture};
use crate::io::image::linear_from_srgb;
use glam::{Mat3, Mat4, Vec2, Vec3};
use std::path::Path;

/// What was loaded, besides the mesh.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LoadNotes {
    /// Primitives skipped because they are not triangles (points, lines).
    pub skipped_primitives: usize,
    /// Primitives whose base-colour texture uses a texture coordinate set other than 0 (set 0
    /// was used).
    pub other_texcoord_sets: usize,
}

fn node_marked_diffuse(node: &gltf::Node) -> bool {
    let Some(raw) = node.extras() else { return false };
    let Ok(v) = serde_json::from_str::<serde_json::Value>(raw.get()) else { return false };
    v.pointer("/heliar/diffuse").and_then(|d| d.as_bool()).unwrap_or(false)
}

fn texture_from_image(img: &gltf::image::Data) -> Option<Texture> {
    use gltf::image::Format;
    let (w, h) = (img.width, img.height);
    let n = (w * h) as usize;
    let px = &img.pixels;
    let srgb8 = |v: u8| linear_from_srgb(v as f32 / 255.0);
    let srgb16 = |i: usize| linear_from_srgb(u16::from_le_bytes([px[i], px[i + 1]]) as f32 / 65535.0);
    let data: Vec<[f32; 3]> = match img.format {
        Format::R8 => (0..n).map(|i| [srgb8(px[i]); 3]).collect(),
        Format::R8G8 => (0..n).map(|i| [srgb8(px[2 * i]); 3]).collect(),
        Format::R8G8B8 => (0..n).map(|i| [srgb8(px[3 * i]), srgb8(px[3 * i + 1]), srgb8(px[3 * i + 2])]).collect(),
        Format::R8G8B8A8 => (0..n).map(|i| [srgb8(px[4 * i]), srgb8(px[4 * i + 1]), srgb8(px[4 * i + 2])]).collect(),
        Format::R16G16B16 => (0..n).map(|i| [srgb16(6 * i), srgb16(6 * i + 2), srgb16(6 * i + 4)]).collect(),
        Format::R16G16B16A16 => (0..n).map(|i| [srgb16(8 * i), srgb16(8 * i + 2), srgb16(8 * i + 4)]).collect(),
        _ => return None,
    };
    (data.len() == n).then_some(Texture { width: w, height: h, data })
}

/// Loads `path`, applying `placement` after each node's own transform. `extra_diffuse` names
/// nodes to mark diffuse in addition to the file's extras.
pub fn load_gltf(path: &Path, placement: Mat4, extra_diffuse: &[String]) -> Result<(Mesh, LoadNotes), SceneError> {
    let gerr = |message: String| SceneError::Gltf { path: path.to_owned(), message };
    if !path.exists() {
        return Err(SceneError::Missing { path: path.to_owned() });
    }
    let (doc, buffers, images) = gltf::import(path).map_err(|e| gerr(e.to_string()))?;
    let mut mesh = Mesh::default();
    let mut notes = LoadNotes::default();

    for img in &images {
        // Unsupported pixel formats become a white texture so indices stay aligned.
        mesh.textures.push(texture_from_image(img).unwrap_or(Texture { width: 1, height: 1, data: vec![[1.0; 3]] }));
    }
    for m in doc.materials() {
        let pbr = m.pbr_metallic_roughness();
        let tex = pbr.base_color_texture();
        if tex.as_ref().is_some_and(|t| t.tex_coord() != 0) {
            notes.other_texcoord_sets += 1;
        }
        mesh.materials.push(Material {
            name: m.name().unwrap_or_default().to_owned(),
            base_color: pbr.base_color_factor(),
            base_color_texture: tex.map(|t| t.texture().source().index() as u32),
            metallic: pbr.metallic_factor(),
            roughness: pbr.roughness_factor(),
        });
    }
    let default_material = mesh.materials.len() as u32;
    mesh.materials.push(Material::default());

    let scene = doc.default_scene().or_else(|| doc.scenes().next()).ok_or_else(|| gerr("the file has no scene".into()))?;
    let mut stack: Vec<(gltf::Node, Mat4, bool)> = scene.nodes().map(|n| (n, placement, false)).collect();
    while let Some((node, parent, parent_diffuse)) = stack.pop() {
        let world = parent * Mat4::from_cols_array_2d(&node.transform().matrix());
        let name = node.name().map(str::to_owned).unwrap_or_else(|| format!("node{}", node.index()));
        let diffuse = parent_diffuse || node_marked_diffuse(&node) || extra_diffuse.iter().any(|n| *n == name);
        for child in node.children() {
            stack.push((child, world, diffuse));
        }
        let Some(gmesh) = node.mesh() else { continue };
        if !world.is_finite() {
            return Err(gerr(format!("node '{name}' has a non-finite transform")));
        }
        let normal_matrix = Mat3::from_mat4(world).inverse().transpose();
        let flip = Mat3::from_mat4(world).determinant() < 0.0;
        let node_index = mesh.nodes.len() as u32;
        mesh.nodes.push(NodeInfo { name: name.clone(), diffuse });
        for prim in gmesh.primitives() {
            if prim.mode() != gltf::mesh::Mode::Triangles {
                notes.skipped_primitives += 1;
                continue;
            }
            let reader = prim.reader(|b| buffers.get(b.index()).map(|d| &d.0[..]));
            let positions: Vec<Vec3> = reader
                .read_positions()
                .ok_or_else(|| gerr(format!("node '{name}': a primitive has no POSITION attribute")))?
                .map(|p| world.transform_point3(Vec3::from(p)))
                .collect();
            if positions.iter().any(|p| !p.is_finite()) {
                return Err(gerr(format!("node '{name}': non-finite vertex positions")));
            }
            let v0 = mesh.positions.len() as u32;
            let nv = positions.len() as u32;
            let normals: Option<Vec<Vec3>> =
                reader.read_normals().map(|it| it.map(|n| (normal_matrix * Vec3::from(n)).normalize_or_zero()).collect());
            let uvs: Vec<Vec2> = match reader.read_tex_coords(0) {
                Some(t) => t.into_f32().map(Vec2::from).collect(),
                None => vec![Vec2::ZERO; positions.len()],
            };
            let indices: Vec<u32> = match reader.read_indices() {
                Some(i) => i.into_u32().collect(),
                None => (0..nv).collect(),
            };
            if indices.len() % 3 != 0 || indices.iter().any(|&i| i >= nv) || uvs.len() != positions.len() {
                return Err(gerr(format!("node '{name}': malformed index or attribute data")));
            }
            match normals {
                Some(n) if n.len() == positions.len() && (mesh.normals.len() == mesh.positions.len()) => mesh.normals.extend(n),
                _ => mesh.normals.clear(),
            }
            mesh.positions.extend(positions);
            mesh.uvs.extend(uvs);
            let material = prim.material().index().map(|i| i as u32).unwrap_or(default_material);
            for t in indices.chunks_exact(3) {
                let tri = if flip { [t[0], t[2], t[1]] } else { [t[0], t[1], t[2]] };
                mesh.triangles.push(tri.map(|i| i + v0));
                mesh.tri_node.push(node_index);
                mesh.tri_material.push(material);
            }
        }
    }
    if mesh.triangles.is_empty() {
        return Err(gerr("the file has no triangles".into()));
    }
    for name in extra_diffuse {
        if !mesh.nodes.iter().any(|n| n.name == *name) {
            return Err(gerr(format!("node '{name}' (named in the manifest's diffuse_nodes) is not in the file")));
        }
    }
    Ok((mesh, notes))
}
