//! Vertex and index buffers of the real proxy and the virtual objects, and the virtual objects'
//! materials (glTF metallic–roughness: base colour factor and texture, metallic, roughness).

use super::GpuError;
use crate::geometry::Mesh;
use crate::io::image::srgb_u8_from_linear;
use glam::{Vec2, Vec3};
use wgpu::util::DeviceExt;

/// One vertex of a virtual object. Mirrors `VertexIn` in `shaders/virtual_shading.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct VirtualVertex {
    /// World position.
    pub position: [f32; 3],
    /// Unit shading normal (the face normal when the file has no normals).
    pub normal: [f32; 3],
    /// Texture coordinates (glTF convention).
    pub uv: [f32; 2],
}

/// Mirrors `Material` in `shaders/virtual_shading.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct MaterialUniform {
    /// Linear base colour factor.
    pub base_color: [f32; 4],
    /// Metallic, roughness, 1 when textured, unused.
    pub params: [f32; 4],
}

/// The proxy's triangles for the depth prepass.
pub struct ProxyBuffers {
    /// Positions (`vec3<f32>`).
    pub vertices: wgpu::Buffer,
    /// Triangle indices.
    pub indices: wgpu::Buffer,
    /// Index count.
    pub index_count: u32,
}

impl ProxyBuffers {
    /// Uploads `mesh`.
    pub fn new(device: &wgpu::Device, mesh: &Mesh) -> Self {
        let positions: Vec<[f32; 3]> = mesh.positions.iter().map(|p| p.to_array()).collect();
        let vertices = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("proxy vertices"),
            contents: bytemuck::cast_slice(if positions.is_empty() { &[[0.0f32; 3]][..] } else { &positions }),
            usage: wgpu::BufferUsages::VERTEX,
        });
        let idx: Vec<u32> = mesh.triangles.iter().flatten().copied().collect();
        let indices = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("proxy indices"),
            contents: bytemuck::cast_slice(if idx.is_empty() { &[0u32; 3][..] } else { &idx }),
            usage: wgpu::BufferUsages::INDEX,
        });
        Self { vertices, indices, index_count: idx.len() as u32 }
    }
}

/// A run of indices drawn with one material.
pub struct MaterialDraw {
    /// Index range.
    pub indices: std::ops::Range<u32>,
    /// Material bind group (group 1 of the shading pass).
    pub bind_group: wgpu::BindGroup,
    /// The uniform it holds (for the CPU reference and reports).
    pub uniform: MaterialUniform,
    /// Its triangles belong to closed surfaces (drawn with back faces culled).
    pub closed: bool,
}

/// The virtual objects' buffers and materials.
pub struct VirtualBuffers {
    /// Vertices ([`VirtualVertex`]).
    pub vertices: wgpu::Buffer,
    /// Indices, grouped by material.
    pub indices: wgpu::Buffer,
    /// Total index count.
    pub index_count: u32,
    /// One draw per material in use.
    pub draws: Vec<MaterialDraw>,
}

/// Layout of a material bind group (group 1 of the shading pass).
pub fn material_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("material"),
        entries: &[
            super::canvas::storage_entry(0),
            wgpu::BindGroupLayoutEntry {
                binding: 1,
                visibility: wgpu::ShaderStages::FRAGMENT,
                ty: wgpu::BindingType::Texture {
                    sample_type: wgpu::TextureSampleType::Float { filterable: true },
                    view_dimension: wgpu::TextureViewDimension::D2,
                    multisampled: false,
                },
                count: None,
            },
            wgpu::BindGroupLayoutEntry {
                binding: 2,
                visibility: wgpu::ShaderStages::FRAGMENT,
                ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
                count: None,
            },
        ],
    })
}

/// Vertices of one object: shared when the mesh has normals, one per corner with the face
/// normal otherwise (faceted, as the geometry is).
pub fn object_vertices(mesh: &Mesh) -> (Vec<VirtualVertex>, Vec<[u32; 3]>) {
    let uv = |i: u32| mesh.uvs.get(i as usize).copied().unwrap_or(Vec2::ZERO).to_array();
    if mesh.normals.len() == mesh.positions.len() && !mesh.normals.is_empty() {
        let verts = (0..mesh.positions.len() as u32)
            .map(|i| VirtualVertex {
                position: mesh.positions[i as usize].to_array(),
                normal: mesh.normals[i as usize].normalize_or(Vec3::Y).to_array(),
                uv: uv(i),
            })
            .collect();
        (verts, mesh.triangles.clone())
    } else {
        let mut verts = Vec::with_capacity(mesh.triangles.len() * 3);
        let mut tris = Vec::with_capacity(mesh.triangles.len());
        for (t, tri) in mesh.triangles.iter().enumerate() {
            let n = mesh.face_normal(t as u32);
            let base = verts.len() as u32;
            for &i in tri {
                verts.push(VirtualVertex { position: mesh.positions[i as usize].to_array(), normal: n.to_array(), uv: uv(i) });
            }
            tris.push([base, base + 1, base + 2]);
        }
        (verts, tris)
    }
}

/// The mesh vertex each vertex of [`object_vertices`] comes from (the identity when the mesh
/// has normals, the triangle corners otherwise), so per-mesh-vertex data can follow the GPU
/// vertex order.
pub fn vertex_sources(mesh: &Mesh) -> Vec<u32> {
    if mesh.normals.len() == mesh.positions.len() && !mesh.normals.is_empty() {
        (0..mesh.positions.len() as u32).collect()
    } else {
        mesh.triangles.iter().flatten().copied().collect()
    }
}

fn texture_rgba8(mesh: &Mesh, t: u32) -> Option<(u32, u32, Vec<u8>)> {
    let tex = mesh.textures.get(t as usize)?;
    let mut data = Vec::with_capacity(tex.data.len() * 4);
    for p in &tex.data {
        data.extend(p.map(srgb_u8_from_linear));
        data.push(255);
    }
    Some((tex.width, tex.height, data))
}

impl VirtualBuffers {
    /// Uploads the objects (world coordinates) and builds one bind group per material and
    /// closedness. `closed[k][t]` says whether triangle `t` of object `k` is part of a closed
    /// surface (missing entries: not).
    pub fn new(device: &wgpu::Device, queue: &wgpu::Queue, layout: &wgpu::BindGroupLayout, objects: &[&Mesh], closed: &[Vec<bool>]) -> Result<Self, GpuError> {
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("base colour"),
            address_mode_u: wgpu::AddressMode::Repeat,
            address_mode_v: wgpu::AddressMode::Repeat,
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            ..Default::default()
        });
        let make_texture = |w: u32, h: u32, data: &[u8]| {
            device.create_texture_with_data(
                queue,
                &wgpu::TextureDescriptor {
                    label: Some("base colour"),
                    size: wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 },
                    mip_level_count: 1,
                    sample_count: 1,
                    dimension: wgpu::TextureDimension::D2,
                    format: wgpu::TextureFormat::Rgba8UnormSrgb,
                    usage: wgpu::TextureUsages::TEXTURE_BINDING,
                    view_formats: &[],
                },
                wgpu::util::TextureDataOrder::LayerMajor,
                data,
            )
        };
        let white = make_texture(1, 1, &[255; 4]).create_view(&Default::default());
        let mut vertices: Vec<VirtualVertex> = Vec::new();
        // Per material: its uniform, texture, and indices of closed and of open triangles.
        let mut runs: Vec<(MaterialUniform, Option<wgpu::TextureView>, [Vec<u32>; 2])> = Vec::new();
        for (k, mesh) in objects.iter().enumerate() {
            let (verts, tris) = object_vertices(mesh);
            let base = vertices.len() as u32;
            vertices.extend(verts);
            let first_run = runs.len();
            for mat in &mesh.materials {
                let view = mat.base_color_texture.and_then(|t| texture_rgba8(mesh, t)).map(|(w, h, d)| make_texture(w, h, &d).create_view(&Default::default()));
                let uniform = MaterialUniform {
                    base_color: mat.base_color,
                    params: [mat.metallic.clamp(0.0, 1.0), mat.roughness.clamp(0.0, 1.0), if view.is_some() { 1.0 } else { 0.0 }, 0.0],
                };
                runs.push((uniform, view, [Vec::new(), Vec::new()]));
            }
            for (t, tri) in tris.iter().enumerate() {
                let m = mesh.tri_material.get(t).copied().unwrap_or(0) as usize;
                let is_closed = closed.get(k).and_then(|c| c.get(t)).copied().unwrap_or(false);
                if let Some(run) = runs.get_mut(first_run + m) {
                    run.2[usize::from(!is_closed)].extend(tri.iter().map(|i| i + base));
                }
            }
        }
        let mut indices: Vec<u32> = Vec::new();
        let mut draws = Vec::new();
        for (uniform, view, groups) in runs {
            if groups.iter().all(Vec::is_empty) {
                continue;
            }
            let buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("material"),
                contents: bytemuck::bytes_of(&uniform),
                usage: wgpu::BufferUsages::STORAGE,
            });
            let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("material"),
                layout,
                entries: &[
                    wgpu::BindGroupEntry { binding: 0, resource: buffer.as_entire_binding() },
                    wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::TextureView(view.as_ref().unwrap_or(&white)) },
                    wgpu::BindGroupEntry { binding: 2, resource: wgpu::BindingResource::Sampler(&sampler) },
                ],
            });
            for (g, idx) in groups.into_iter().enumerate() {
                if idx.is_empty() {
                    continue;
                }
                let start = indices.len() as u32;
                indices.extend(idx);
                draws.push(MaterialDraw { indices: start..indices.len() as u32, bind_group: bind_group.clone(), uniform, closed: g == 0 });
            }
        }
        let vertex_bytes: &[u8] = if vertices.is_empty() { &[0u8; 32] } else { bytemuck::cast_slice(&vertices) };
        let index_bytes: &[u8] = if indices.is_empty() { &[0u8; 12] } else { bytemuck::cast_slice(&indices) };
        Ok(Self {
            vertices: device.create_buffer_init(&wgpu::util::BufferInitDescriptor { label: Some("virtual vertices"), contents: vertex_bytes, usage: wgpu::BufferUsages::VERTEX }),
            indices: device.create_buffer_init(&wgpu::util::BufferInitDescriptor { label: Some("virtual indices"), contents: index_bytes, usage: wgpu::BufferUsages::INDEX }),
            index_count: indices.len() as u32,
            draws,
        })
    }
}
