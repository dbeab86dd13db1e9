//! glTF 2.0 (`.glb`/`.gltf`) into a world-space [`Mesh`].
//!
//! Every triangle primitive of every node of the default scene is flattened into world
//! coordinates with its node's global transform (and an extra placement transform for virtual
//! objects). A node is a diffuse estimation surface when its `extras` hold
//! `{"heliar": {"diffuse": true}}` (or an ancestor's do), or when the manifest names it.
//! Base-colour textures are sRGB-encoded per the glTF spec and decoded to linear here.
//!
//! Buffer and image URIs are checked before anything is read: relative paths that stay inside
//! the folder they are confined to (the scene folder, or the glTF file's own folder), and
//! `data:` URIs of at most [`MAX_DATA_URI_BYTES`]; `file://`, other schemes and absolute paths
//! are refused.

use super::SceneError;
use crate::geometry::{Material, Mesh, NodeInfo, Texture};
use crate::io::image::linear_from_srgb;
use glam::{Mat3, Mat4, Vec2, Vec3};
use std::path::Path;

/// Largest `data:` URI (its text, base64) read from a glTF buffer or image.
pub const MAX_DATA_URI_BYTES: usize = 64 << 20;

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

/// `%XX` escapes decoded (as the glTF importer decodes relative URIs).
fn percent_decoded(uri: &str) -> String {
    let b = uri.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        let hex = b.get(i + 1..i + 3).and_then(|h| std::str::from_utf8(h).ok()).and_then(|h| u8::from_str_radix(h, 16).ok());
        match (b[i], hex) {
            (b'%', Some(v)) => {
                out.push(v);
                i += 3;
            }
            (c, _) => {
                out.push(c);
                i += 1;
            }
        }
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// Checks one buffer or image URI (`field`) of the glTF file `path`; `confine` is the resolved
/// folder relative URIs must stay in (`None`: anywhere).
fn check_uri(path: &Path, field: &str, uri: &str, confine: Option<&Path>) -> Result<(), SceneError> {
    let gerr = |message: String| SceneError::Gltf { path: path.to_owned(), message };
    if let Some(data) = uri.strip_prefix("data:") {
        if data.len() > MAX_DATA_URI_BYTES {
            return Err(gerr(format!("{field}: a data: URI of {} bytes is over the {MAX_DATA_URI_BYTES}-byte cap", data.len())));
        }
        return Ok(());
    }
    let scheme = uri.split_once(':').is_some_and(|(s, _)| !s.is_empty() && !s.contains('/'));
    let rel = percent_decoded(uri);
    if scheme || Path::new(&rel).is_absolute() {
        return Err(gerr(format!("{field}: '{uri}' is not a relative path or a data: URI (file://, other schemes and absolute paths are not read)")));
    }
    let Some(root) = confine else { return Ok(()) };
    let target = crate::io::guard::resolve(&path.parent().unwrap_or(Path::new(".")).join(&rel));
    if !target.starts_with(root) {
        return Err(gerr(format!(
            "{field}: '{uri}' resolves to {}, outside {} (--allow-outside-scene to read it anyway)",
            target.display(),
            root.display()
        )));
    }
    Ok(())
}

/// Loads `path`, applying `placement` after each node's own transform. `extra_diffuse` names
/// nodes to mark diffuse in addition to the file's extras. Buffers and images must lie in the
/// file's own folder (module docs).
pub fn load_gltf(path: &Path, placement: Mat4, extra_diffuse: &[String]) -> Result<(Mesh, LoadNotes), SceneError> {
    let own = crate::io::guard::resolve(path.parent().unwrap_or(Path::new(".")));
    load_gltf_with(path, placement, extra_diffuse, &[], Some(&own))
}

/// [`load_gltf`] with `not_diffuse`: nodes that are *not* diffuse even though the file's extras
/// (their own or an ancestor's) or `extra_diffuse` mark them (the manifest's
/// `proxy.not_diffuse_nodes`, which overrides the extras without editing the glTF). A node left
/// unmarked this way passes no mark on to its children.
pub fn load_gltf_marked(path: &Path, placement: Mat4, extra_diffuse: &[String], not_diffuse: &[String]) -> Result<(Mesh, LoadNotes), SceneError> {
    let own = crate::io::guard::resolve(path.parent().unwrap_or(Path::new(".")));
    load_gltf_with(path, placement, extra_diffuse, not_diffuse, Some(&own))
}

/// [`load_gltf`] with buffers and images confined to the resolved folder `confine` (a scene
/// folder), or anywhere with `None`.
pub fn load_gltf_within(path: &Path, placement: Mat4, extra_diffuse: &[String], confine: Option<&Path>) -> Result<(Mesh, LoadNotes), SceneError> {
    load_gltf_with(path, placement, extra_diffuse, &[], confine)
}

/// The loader behind the others: diffuse marks from the extras plus `extra_diffuse` minus
/// `not_diffuse`, buffers and images confined to `confine`.
pub fn load_gltf_with(
    path: &Path,
    placement: Mat4,
    extra_diffuse: &[String],
    not_diffuse: &[String],
    confine: Option<&Path>,
) -> Result<(Mesh, LoadNotes), SceneError> {
    let gerr = |message: String| SceneError::Gltf { path: path.to_owned(), message };
    if !path.exists() {
        return Err(SceneError::Missing { path: path.to_owned() });
    }
    let (doc, buffers, images) = import_checked(path, confine)?;
    let mut mesh = Mesh::default();
    let mut notes = LoadNotes::default();

    let default_material = push_materials(&doc, &images, &mut mesh, &mut notes);

    let scene = doc.default_scene().or_else(|| doc.scenes().next()).ok_or_else(|| gerr("the file has no scene".into()))?;
    let mut stack: Vec<(gltf::Node, Mat4, bool)> = scene.nodes().map(|n| (n, placement, false)).collect();
    while let Some((node, parent, parent_diffuse)) = stack.pop() {
        let world = parent * Mat4::from_cols_array_2d(&node.transform().matrix());
        let name = node.name().map(str::to_owned).unwrap_or_else(|| format!("node{}", node.index()));
        let diffuse = (parent_diffuse || node_marked_diffuse(&node) || extra_diffuse.contains(&name)) && !not_diffuse.contains(&name);
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
            let at = Placed { world, normal_matrix, flip, node_index, default_material };
            push_primitive(path, &name, &prim, &buffers, &at, &mut mesh, &mut notes)?;
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
    for name in not_diffuse {
        if !mesh.nodes.iter().any(|n| n.name == *name) {
            return Err(gerr(format!("node '{name}' (named in the manifest's not_diffuse_nodes) is not in the file")));
        }
    }
    Ok((mesh, notes))
}

/// What `gltf::import` does, with every buffer and image URI checked ([`check_uri`]) before any
/// is read.
#[allow(clippy::type_complexity)]
pub(super) fn import_checked(path: &Path, confine: Option<&Path>) -> Result<(gltf::Document, Vec<gltf::buffer::Data>, Vec<gltf::image::Data>), SceneError> {
    let gerr = |message: String| SceneError::Gltf { path: path.to_owned(), message };
    let gltf::Gltf { document: doc, blob } = gltf::Gltf::open(path).map_err(|e| gerr(e.to_string()))?;
    for b in doc.buffers() {
        if let gltf::buffer::Source::Uri(uri) = b.source() {
            check_uri(path, &format!("buffers[{}].uri", b.index()), uri, confine)?;
        }
    }
    for img in doc.images() {
        if let gltf::image::Source::Uri { uri, .. } = img.source() {
            check_uri(path, &format!("images[{}].uri", img.index()), uri, confine)?;
        }
    }
    let base = path.parent();
    let buffers = gltf::import_buffers(&doc, base, blob).map_err(|e| gerr(e.to_string()))?;
    let images = gltf::import_images(&doc, base, &buffers).map_err(|e| gerr(e.to_string()))?;
    Ok((doc, buffers, images))
}

/// The file's textures and materials (and a default material, whose index is returned).
fn push_materials(doc: &gltf::Document, images: &[gltf::image::Data], mesh: &mut Mesh, notes: &mut LoadNotes) -> u32 {
    for img in images {
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
    default_material
}

/// Where a node's primitives go: its world transform (and the normals' matrix, and whether it
/// mirrors), its node index and the material of primitives without one.
struct Placed {
    world: Mat4,
    normal_matrix: Mat3,
    flip: bool,
    node_index: u32,
    default_material: u32,
}

/// Appends one primitive of node `name` (triangles only; others are counted and skipped).
fn push_primitive(path: &Path, name: &str, prim: &gltf::Primitive, buffers: &[gltf::buffer::Data], at: &Placed, mesh: &mut Mesh, notes: &mut LoadNotes) -> Result<(), SceneError> {
    let gerr = |message: String| SceneError::Gltf { path: path.to_owned(), message };
    if prim.mode() != gltf::mesh::Mode::Triangles {
        notes.skipped_primitives += 1;
        return Ok(());
    }
    let reader = prim.reader(|b| buffers.get(b.index()).map(|d| &d.0[..]));
    let positions: Vec<Vec3> = reader
        .read_positions()
        .ok_or_else(|| gerr(format!("node '{name}': a primitive has no POSITION attribute")))?
        .map(|p| at.world.transform_point3(Vec3::from(p)))
        .collect();
    if positions.iter().any(|p| !p.is_finite()) {
        return Err(gerr(format!("node '{name}': non-finite vertex positions")));
    }
    let v0 = mesh.positions.len() as u32;
    let nv = positions.len() as u32;
    let normals: Option<Vec<Vec3>> =
        reader.read_normals().map(|it| it.map(|n| (at.normal_matrix * Vec3::from(n)).normalize_or_zero()).collect());
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
    let material = prim.material().index().map(|i| i as u32).unwrap_or(at.default_material);
    for t in indices.chunks_exact(3) {
        let tri = if at.flip { [t[0], t[2], t[1]] } else { [t[0], t[1], t[2]] };
        mesh.triangles.push(tri.map(|i| i + v0));
        mesh.tri_node.push(at.node_index);
        mesh.tri_material.push(material);
    }
    Ok(())
}

/// Writes `mesh` as a binary glTF: one node per [`NodeInfo`] (named, with
/// `extras.heliar.diffuse` set for diffuse nodes), its triangles in world coordinates, and one
/// material per [`Material`] (base colour factor, metallic, roughness; textures are not written).
pub fn save_glb(mesh: &Mesh, path: &Path) -> Result<(), SceneError> {
    use serde_json::json;
    let gerr = |message: String| SceneError::Gltf { path: path.to_owned(), message };
    let mut bin: Vec<u8> = Vec::new();
    let mut buffer_views = Vec::new();
    let mut accessors = Vec::new();
    let mut meshes = Vec::new();
    let mut nodes = Vec::new();
    for (ni, node) in mesh.nodes.iter().enumerate() {
        // Group this node's triangles by material.
        let mut by_material: std::collections::BTreeMap<u32, Vec<usize>> = Default::default();
        for (t, &n) in mesh.tri_node.iter().enumerate() {
            if n as usize == ni {
                by_material.entry(mesh.tri_material[t]).or_default().push(t);
            }
        }
        let mut primitives = Vec::new();
        for (material, tris) in by_material {
            // Unshared vertices per primitive: simple and exact.
            let mut pos: Vec<f32> = Vec::with_capacity(tris.len() * 9);
            let (mut lo, mut hi) = (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN));
            for &t in &tris {
                for v in mesh.triangles[t] {
                    let p = mesh.positions[v as usize];
                    lo = lo.min(p);
                    hi = hi.max(p);
                    pos.extend_from_slice(&p.to_array());
                }
            }
            let offset = bin.len();
            bin.extend(pos.iter().flat_map(|f| f.to_le_bytes()));
            while bin.len() % 4 != 0 {
                bin.push(0);
            }
            buffer_views.push(json!({"buffer": 0, "byteOffset": offset, "byteLength": pos.len() * 4, "target": 34962}));
            accessors.push(json!({
                "bufferView": buffer_views.len() - 1, "componentType": 5126, "count": tris.len() * 3,
                "type": "VEC3", "min": lo.to_array(), "max": hi.to_array()
            }));
            primitives.push(json!({"attributes": {"POSITION": accessors.len() - 1}, "material": material, "mode": 4}));
        }
        meshes.push(json!({"name": node.name, "primitives": primitives}));
        let mut n = json!({"name": node.name, "mesh": meshes.len() - 1});
        if node.diffuse {
            n["extras"] = json!({"heliar": {"diffuse": true}});
        }
        nodes.push(n);
    }
    let materials: Vec<_> = mesh
        .materials
        .iter()
        .map(|m| {
            json!({"name": m.name, "pbrMetallicRoughness": {
                "baseColorFactor": m.base_color, "metallicFactor": m.metallic, "roughnessFactor": m.roughness}})
        })
        .collect();
    let doc = json!({
        "asset": {"version": "2.0", "generator": concat!("heliar ", env!("CARGO_PKG_VERSION"))},
        "scene": 0,
        "scenes": [{"nodes": (0..nodes.len()).collect::<Vec<_>>()}],
        "nodes": nodes, "meshes": meshes, "materials": materials,
        "accessors": accessors, "bufferViews": buffer_views,
        "buffers": [{"byteLength": bin.len()}],
    });
    let mut json_bytes = serde_json::to_vec(&doc).map_err(|e| gerr(e.to_string()))?;
    while json_bytes.len() % 4 != 0 {
        json_bytes.push(b' ');
    }
    let glb = ::gltf::binary::Glb {
        header: ::gltf::binary::Header { magic: *b"glTF", version: 2, length: (12 + 8 + json_bytes.len() + 8 + bin.len()) as u32 },
        json: std::borrow::Cow::Owned(json_bytes),
        bin: Some(std::borrow::Cow::Owned(bin)),
    };
    let file = std::fs::File::create(path).map_err(|source| SceneError::Read { path: path.to_owned(), source })?;
    glb.to_writer(std::io::BufWriter::new(file)).map_err(|e| gerr(e.to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Material;

    #[test]
    fn glb_round_trip_keeps_geometry_materials_and_marks() {
        let mut mesh = Mesh {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::Z, Vec3::new(0.0, 2.0, 0.0)],
            uvs: vec![Vec2::ZERO; 4],
            triangles: vec![[0, 2, 1], [0, 1, 3]],
            tri_node: vec![0, 1],
            tri_material: vec![0, 1],
            nodes: vec![NodeInfo { name: "ground".into(), diffuse: true }, NodeInfo { name: "post".into(), diffuse: false }],
            materials: vec![
                Material { name: "paving".into(), base_color: [0.3, 0.2, 0.1, 1.0], ..Default::default() },
                Material { name: "metal".into(), base_color: [0.9, 0.9, 0.9, 1.0], metallic: 1.0, roughness: 0.3, ..Default::default() },
            ],
            ..Default::default()
        };
        mesh.normals.clear();
        let dir = std::env::temp_dir().join(format!("heliar-glb-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("m.glb");
        save_glb(&mesh, &p).unwrap();
        let (back, notes) = load_gltf(&p, Mat4::IDENTITY, &[]).unwrap();
        assert_eq!(notes, LoadNotes::default());
        assert_eq!(back.triangles.len(), 2);
        assert_eq!(back.nodes.iter().filter(|n| n.diffuse).map(|n| n.name.as_str()).collect::<Vec<_>>(), ["ground"]);
        for t in 0..2u32 {
            let node = &back.nodes[back.tri_node[t as usize] as usize].name;
            let orig = mesh.nodes.iter().position(|n| n.name == *node).unwrap() as u32;
            let ot = mesh.tri_node.iter().position(|&n| n == orig).unwrap() as u32;
            assert_eq!(back.corners(t), mesh.corners(ot));
            assert_eq!(back.albedo(t, Vec2::ZERO), mesh.albedo(ot, Vec2::ZERO));
        }
        // Extra marks from the manifest, and a name that is not there.
        let (marked, _) = load_gltf(&p, Mat4::IDENTITY, &["post".into()]).unwrap();
        assert!(marked.nodes.iter().all(|n| n.diffuse));
        let e = load_gltf(&p, Mat4::IDENTITY, &["nope".into()]).unwrap_err().to_string();
        assert!(e.contains("nope") && e.contains("m.glb"), "{e}");
        // A corrupt file names itself.
        std::fs::write(&p, b"glTF garbage").unwrap();
        let e = load_gltf(&p, Mat4::IDENTITY, &[]).unwrap_err().to_string();
        assert!(e.contains("m.glb"), "{e}");
        std::fs::remove_dir_all(&dir).ok();
    }
}
