//! The bundled virtual object (the statue) and the reference frames with it physically present.

use crate::render::{self, Glossy, TrueAlbedo};
use crate::{Args, Courtyard, PA0, PD0, REFERENCE_FRAMES, REFERENCE_MARGIN_PX, STATUE_FILE, cloud, write};
use anyhow::{Context, Result};
use glam::{Vec2, Vec3};
use heliar::camera::Camera;
use heliar::geometry::raycast::RayScene;
use heliar::geometry::{Material, Mesh};
use heliar::io::image::{ExrPrecision, LinearImage};
use heliar::sun::{GeoFrame, Observer, sun_position};
use std::path::Path;

/// The statue in its own frame (base centred on the origin, metres): a stone pedestal and a
/// red-painted sphere, flat faceted, glTF metallic–roughness materials.
pub(crate) fn statue_local() -> Mesh {
    let mut m = Mesh::default();
    let stone = m.add_material(Material { name: "stone".into(), base_color: [0.62, 0.60, 0.56, 1.0], base_color_texture: None, metallic: 0.0, roughness: 0.9 });
    let paint = m.add_material(Material { name: "paint".into(), base_color: [0.55, 0.10, 0.07, 1.0], base_color_texture: None, metallic: 0.0, roughness: 0.45 });
    let pedestal = m.add_node("pedestal", false);
    m.push_box(Vec3::new(-0.35, 0.0, -0.35), Vec3::new(0.35, 0.6, 0.35), pedestal, stone, false);
    let sphere = m.add_node("sphere", false);
    // Icosphere, 3 subdivisions (1280 faces), radius 0.45 m, on top of the pedestal.
    let (centre, radius) = (Vec3::new(0.0, 1.05, 0.0), 0.45);
    let t = (1.0 + 5f32.sqrt()) / 2.0;
    let mut v: Vec<Vec3> = [
        [-1.0, t, 0.0], [1.0, t, 0.0], [-1.0, -t, 0.0], [1.0, -t, 0.0], [0.0, -1.0, t], [0.0, 1.0, t],
        [0.0, -1.0, -t], [0.0, 1.0, -t], [t, 0.0, -1.0], [t, 0.0, 1.0], [-t, 0.0, -1.0], [-t, 0.0, 1.0],
    ]
    .iter()
    .map(|p| Vec3::from(*p).normalize())
    .collect();
    let mut f: Vec<[u32; 3]> = vec![
        [0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4], [11, 10, 2], [10, 7, 6], [7, 1, 8],
        [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8], [3, 8, 9], [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1],
    ];
    for _ in 0..3 {
        let mut mid = std::collections::BTreeMap::new();
        let mut nf = Vec::with_capacity(f.len() * 4);
        for [a, b, c] in f {
            let mut m_of = |x: u32, y: u32| {
                *mid.entry((x.min(y), x.max(y))).or_insert_with(|| {
                    v.push(((v[x as usize] + v[y as usize]) / 2.0).normalize());
                    v.len() as u32 - 1
                })
            };
            let (ab, bc, ca) = (m_of(a, b), m_of(b, c), m_of(c, a));
            nf.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        f = nf;
    }
    let v0 = m.positions.len() as u32;
    m.positions.extend(v.iter().map(|p| centre + *p * radius));
    m.uvs.extend(std::iter::repeat_n(Vec2::ZERO, v.len()));
    for tri in f {
        m.triangles.push(tri.map(|i| i + v0));
        m.tri_node.push(sphere);
        m.tri_material.push(paint);
    }
    m
}

/// Reference-frame surfaces: the courtyard's true albedo for real triangles (the first
/// `real_tris`), the statue's glTF materials for the rest.
pub(crate) struct WithStatue<'a> {
    pub(crate) real: &'a Courtyard,
    pub(crate) real_tris: usize,
    pub(crate) statue: &'a Mesh,
}

impl TrueAlbedo for WithStatue<'_> {
    fn albedo(&self, tri: u32, p: Vec3, base: Vec3) -> Vec3 {
        self.real.albedo(tri, p, base)
    }
    fn glossy(&self, tri: u32) -> Option<Glossy> {
        let t = (tri as usize).checked_sub(self.real_tris)?;
        let m = &self.statue.materials[*self.statue.tri_material.get(t)? as usize];
        Some(Glossy { base: Vec3::new(m.base_color[0], m.base_color[1], m.base_color[2]), metallic: m.metallic, roughness: m.roughness })
    }
}

/// Renders the frames of [`REFERENCE_FRAMES`] again with the statue in the world, over a crop
/// around the statue and its shadow, without sensor noise, into `reference/`.
#[allow(clippy::too_many_arguments)]
pub(crate) fn render_references(
    out: &Path,
    args: &Args,
    cam: &Camera,
    proxy: &Mesh,
    extra: &Mesh,
    statue: &Mesh,
    real_albedo: &Courtyard,
    times: &[chrono::DateTime<chrono::FixedOffset>],
    observer: &Observer,
    geo: &GeoFrame,
) -> Result<()> {
    std::fs::create_dir_all(out.join("reference"))?;
    let mut world = proxy.clone();
    world.append(extra);
    let real_tris = world.triangles.len();
    world.append(statue);
    let scene = RayScene::new(world);
    let surfaces = WithStatue { real: real_albedo, real_tris, statue };
    let frames: Vec<usize> = REFERENCE_FRAMES.iter().copied().filter(|&i| i < times.len()).collect();
    let suns = frames.iter().map(|&i| Ok(geo.sun_dir_in_world(&sun_position(observer, &times[i])?))).collect::<Result<Vec<_>>>()?;
    let region = reference_crop(cam, statue, &suns)?;
    let sky_spp = args.reference_spp;
    eprintln!("rendering references: crop {region:?}, {sky_spp} + {} spp", sky_spp / 2);
    let (sky, _) = render::render_basis_region(&scene, &surfaces, cam, Vec3::Y, sky_spp, 7001, region);
    let mut names = Vec::new();
    for &i in &frames {
        let l = geo.sun_dir_in_world(&sun_position(observer, &times[i])?);
        let (_, sun) = render::render_basis_region(&scene, &surfaces, cam, l, (sky_spp / 2).max(1), 7100 + i as u64, region);
        let m = cloud(i, args.frames);
        let pd = Vec3::from(PD0) * m;
        let pa = Vec3::from(PA0) * (1.0 + 0.25 * (1.0 - m)) + Vec3::splat(0.08 * (1.0 - m));
        let img = LinearImage { width: region.2, height: region.3, data: sky.iter().zip(&sun).map(|(s, d)| (*s * pa + *d * pd).to_array()).collect() };
        let name = format!("frame_{i:03}.exr");
        img.write_exr(&out.join("reference").join(&name), ExrPrecision::Half)?;
        names.push(name);
        eprintln!("reference frame {i}");
    }
    write(
        &out.join("reference/reference.toml"),
        &format!(
            "# Reference frames of the courtyard with the statue ({STATUE_FILE}) physically present, written by\n\
             # gen-courtyard: the same camera (lens distortion included), true albedo and lighting as frames/hdr,\n\
             # path traced by the generator's own renderer, without sensor noise. Each EXR covers the crop\n\
             # below, in pixel coordinates of the full frame.\n\
             frames = {frames:?}\n\
             files = {names:?}\n\
             crop = {{ x = {}, y = {}, width = {}, height = {} }}\n\
             sky_spp = {sky_spp}\n\
             sun_spp = {}\n",
            region.0,
            region.1,
            region.2,
            region.3,
            (sky_spp / 2).max(1)
        ),
    )
}

/// Crop `(x, y, width, height)` of the references: the statue's box and its shadow on the ground
/// for every sun of `suns`, plus a margin, clamped to the frame.
pub(crate) fn reference_crop(cam: &Camera, statue: &Mesh, suns: &[Vec3]) -> Result<(u32, u32, u32, u32)> {
    let (lo, hi) = statue.bounds().context("the statue has no triangles")?;
    let (mut a, mut b) = (glam::DVec2::splat(f64::MAX), glam::DVec2::splat(f64::MIN));
    for &l in suns {
        for k in 0..8 {
            let c = Vec3::new([lo.x, hi.x][k & 1], [lo.y, hi.y][(k >> 1) & 1], [lo.z, hi.z][(k >> 2) & 1]);
            let ground = c - l * (c.y / l.y.max(1e-3));
            for p in [c, ground] {
                if let Some(uv) = cam.project_world(p.as_dvec3()) {
                    a = a.min(uv);
                    b = b.max(uv);
                }
            }
        }
    }
    let (w, h) = (cam.intrinsics.width as f64, cam.intrinsics.height as f64);
    let x0 = (a.x - REFERENCE_MARGIN_PX).floor().clamp(0.0, w - 1.0) as u32;
    let y0 = (a.y - REFERENCE_MARGIN_PX).floor().clamp(0.0, h - 1.0) as u32;
    let x1 = (b.x + REFERENCE_MARGIN_PX).ceil().clamp(x0 as f64 + 1.0, w) as u32;
    let y1 = (b.y + REFERENCE_MARGIN_PX).ceil().clamp(y0 as f64 + 1.0, h) as u32;
    Ok((x0, y0, x1 - x0, y1 - y0))
}
