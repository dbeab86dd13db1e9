//! Shared pieces of the compositor tests: one GPU device per test binary, small synthetic scenes
//! and CPU ray-traced references that do not use any compositor code.

use glam::{DVec3, Vec2, Vec3};
use heliar::geometry::raycast::RayScene;
use heliar::geometry::{Material, Mesh};
use heliar::render::{Compositor, CompositorConfig, SceneParts};
use heliar::gpu::{Gpu, GpuOptions};
use heliar::camera::{Camera, Intrinsics, Pose};
use std::sync::{Arc, OnceLock};

/// The device shared by the tests of this binary.
pub fn gpu() -> Arc<Gpu> {
    static GPU: OnceLock<Arc<Gpu>> = OnceLock::new();
    GPU.get_or_init(|| {
        let g = Gpu::new(GpuOptions::default()).expect("a GPU adapter (Mesa lavapipe or llvmpipe)");
        eprintln!("GPU: {} (depth {:?}, {} samples)", g.describe(), g.depth_format, g.samples);
        Arc::new(g)
    })
    .clone()
}

/// A camera at `pos` looking at `at`.
pub fn camera(pos: [f64; 3], at: [f64; 3], w: u32, h: u32, distortion: [f64; 5]) -> Camera {
    let f = 0.8 * w as f64;
    Camera {
        intrinsics: Intrinsics::brown_conrady(w, h, f, f * 1.002, w as f64 / 2.0 + 0.7, h as f64 / 2.0 - 0.4, distortion),
        pose: Pose::look_at(DVec3::from(pos), DVec3::from(at), DVec3::Y).expect("valid pose"),
    }
}

/// The real proxy of a small yard: a ground quad and a free-standing wall (an open-bottom box,
/// as the bundled courtyard's proxy has).
pub fn yard_proxy() -> Mesh {
    let mut m = Mesh::default();
    let paving = m.add_material(Material::diffuse("paving", [0.32, 0.30, 0.27]));
    let concrete = m.add_material(Material::diffuse("concrete", [0.45, 0.45, 0.43]));
    let g = m.add_node("ground", true);
    let w = m.add_node("wall", false);
    m.push_quad(Vec3::new(-30.0, 0.0, -30.0), Vec3::Z * 60.0, Vec3::X * 60.0, g, paving);
    m.push_box(Vec3::new(-3.2, 0.0, -1.5), Vec3::new(-2.8, 2.4, 1.5), w, concrete, true);
    m
}

/// A closed icosphere (flat faces) of `radius` at `centre`, `subdiv` times subdivided.
pub fn icosphere(centre: Vec3, radius: f32, subdiv: u32, material: Material, name: &str) -> Mesh {
    let t = (1.0 + 5f32.sqrt()) / 2.0;
    let mut v: Vec<Vec3> = [
        [-1.0, t, 0.0], [1.0, t, 0.0], [-1.0, -t, 0.0], [1.0, -t, 0.0],
        [0.0, -1.0, t], [0.0, 1.0, t], [0.0, -1.0, -t], [0.0, 1.0, -t],
        [t, 0.0, -1.0], [t, 0.0, 1.0], [-t, 0.0, -1.0], [-t, 0.0, 1.0],
    ]
    .iter()
    .map(|p| Vec3::from(*p).normalize())
    .collect();
    let mut f: Vec<[u32; 3]> = vec![
        [0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4], [11, 10, 2], [10, 7, 6], [7, 1, 8],
        [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8], [3, 8, 9], [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1],
    ];
    for _ in 0..subdiv {
        let mut mid = std::collections::HashMap::new();
        let mut midpoint = |a: u32, b: u32, v: &mut Vec<Vec3>| {
            *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                v.push(((v[a as usize] + v[b as usize]) / 2.0).normalize());
                v.len() as u32 - 1
            })
        };
        let mut nf = Vec::with_capacity(f.len() * 4);
        for [a, b, c] in f {
            let (ab, bc, ca) = (midpoint(a, b, &mut v), midpoint(b, c, &mut v), midpoint(c, a, &mut v));
            nf.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        f = nf;
    }
    let mut m = Mesh::default();
    let mat = m.add_material(material);
    let node = m.add_node(name, false);
    m.positions = v.iter().map(|p| centre + *p * radius).collect();
    m.uvs = vec![Vec2::ZERO; m.positions.len()];
    m.tri_node = vec![node; f.len()];
    m.tri_material = vec![mat; f.len()];
    m.triangles = f;
    m
}

/// A closed box (shared-position faces as `Mesh::push_box` makes them).
pub fn cube(lo: Vec3, hi: Vec3, material: Material, name: &str) -> Mesh {
    let mut m = Mesh::default();
    let mat = m.add_material(material);
    let node = m.add_node(name, false);
    m.push_box(lo, hi, node, mat, false);
    m
}

/// The sun of the bundled courtyard at 15:30 (toward the sun, world frame).
pub fn courtyard_sun() -> Vec3 {
    Vec3::new(-0.486, 0.756, 0.437).normalize()
}

/// A synthetic set-up: camera, proxy, virtual objects.
pub struct Setup {
    /// Camera.
    pub camera: Camera,
    /// Real proxy.
    pub proxy: Mesh,
    /// Virtual objects.
    pub objects: Vec<(String, Mesh)>,
}

impl Setup {
    /// A compositor for this set-up.
    ///
    /// The CPU references of these tests light the scene with Jensen's uniform sky and no
    /// terrain, so the compositor is given the same sky whatever `config` says (the library's
    /// default `[estimator.sky]` is the Hošek–Wilkie shape).
    pub fn compositor(&self, config: CompositorConfig) -> Compositor {
        let config = CompositorConfig { sky: heliar::sky::radiance::SkyModel::uniform(), ..config };
        let objs: Vec<(String, &Mesh)> = self.objects.iter().map(|(n, m)| (n.clone(), m)).collect();
        let parts = SceneParts { camera: &self.camera, proxy: &self.proxy, proxy_name: "yard", objects: &objs };
        Compositor::new(gpu(), &parts, Arc::new(RayScene::new(self.proxy.clone())), config).expect("compositor")
    }
}

/// What the CPU ray tracer sees through one pixel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RefPixel {
    /// 0 nothing, 1 real surface, 2 virtual surface.
    pub kind: u8,
    /// The surface point is in a real occluder's shadow.
    pub real_shadow: bool,
    /// The surface point is in a virtual occluder's shadow.
    pub virtual_shadow: bool,
    /// Geometric normal (facing the camera) dotted with the sun.
    pub n_dot_l: f32,
    /// Triangle id (proxy triangles, then virtual ones offset by 1e6).
    pub tri: u32,
    /// The hit point.
    pub point: Vec3,
    /// Facing geometric normal.
    pub normal: Vec3,
    /// Object index for virtual hits.
    pub object: usize,
}

/// Ray-traces every pixel centre of `setup.camera` (through the lens model): first hit against
/// the proxy and the virtual objects, then shadow rays toward `sun` against each.
pub fn reference(setup: &Setup, sun: Vec3) -> Vec<RefPixel> {
    use rayon::prelude::*;
    let proxy = RayScene::new(setup.proxy.clone());
    let objects: Vec<RayScene> = setup.objects.iter().map(|(_, m)| RayScene::new(m.clone())).collect();
    let (w, h) = (setup.camera.intrinsics.width, setup.camera.intrinsics.height);
    (0..w * h)
        .into_par_iter()
        .map(|i| {
            let none = RefPixel { kind: 0, real_shadow: false, virtual_shadow: false, n_dot_l: 0.0, tri: u32::MAX, point: Vec3::ZERO, normal: Vec3::ZERO, object: 0 };
            let Some((o, d)) = setup.camera.pixel_ray(i % w, i / w) else { return none };
            // Start at the near plane, as the rasteriser clips there.
            let forward = setup.camera.pose.rotation.z_axis;
            let t0 = heliar::gpu::canvas::NEAR_M / d.dot(forward).max(1e-9);
            let (o, d) = ((o + d * t0).as_vec3(), d.as_vec3());
            let mut best = proxy.intersect(o, d, f32::MAX).map(|hit| (hit, 1u8, usize::MAX));
            for (k, s) in objects.iter().enumerate() {
                if let Some(hit) = s.intersect(o, d, f32::MAX)
                    && best.as_ref().is_none_or(|b| hit.t < b.0.t)
                {
                    best = Some((hit, 2, k));
                }
            }
            let Some((hit, kind, object)) = best else { return none };
            let real_shadow = !proxy.sees_direction(hit.point, hit.normal, sun);
            let virtual_shadow = objects.iter().any(|s| !s.sees_direction(hit.point, hit.normal, sun));
            RefPixel {
                kind,
                real_shadow,
                virtual_shadow,
                n_dot_l: hit.normal.dot(sun),
                tri: if kind == 1 { hit.tri } else { 1_000_000 * (object as u32 + 1) + hit.tri },
                point: hit.point,
                normal: hit.normal,
                object: if kind == 2 { object } else { 0 },
            }
        })
        .collect()
}

/// Pixels within one pixel of a change of `f` (the 1-px edges excluded from comparisons).
pub use heliar::render::reference::edges;

/// The glTF 2.0 metallic–roughness BRDF (specification, Appendix B), written again on the CPU:
/// `f(v, l)·max(n·l, 0)` for unit vectors.
pub fn brdf_cos(base: Vec3, metallic: f32, roughness: f32, n: Vec3, v: Vec3, l: Vec3) -> Vec3 {
    let nl = n.dot(l);
    if nl <= 0.0 {
        return Vec3::ZERO;
    }
    let nv = n.dot(v).max(1e-4);
    let h = (l + v).normalize();
    let (nh, vh) = (n.dot(h).max(0.0), v.dot(h).max(0.0));
    let alpha = (roughness * roughness).max(0.002);
    let a2 = alpha * alpha;
    let f0 = Vec3::splat(0.04).lerp(base, metallic);
    let fresnel = f0 + (Vec3::ONE - f0) * (1.0 - vh).powi(5);
    let c_diff = base.lerp(Vec3::ZERO, metallic);
    let diffuse = (Vec3::ONE - fresnel) * c_diff / std::f32::consts::PI;
    let t = nh * nh * (a2 - 1.0) + 1.0;
    let d = a2 / (std::f32::consts::PI * t * t);
    let vis = 0.5 / (nl * (nv * nv * (1.0 - a2) + a2).sqrt() + nv * (nl * nl * (1.0 - a2) + a2).sqrt());
    (diffuse + fresnel * d * vis) * nl
}

/// Ambient radiance from irradiance `e_n` (normal) and `e_r` (mirror direction), with Karis'
/// fit of the specular albedo, as documented in `shaders/common/brdf.wgsl`.
pub fn ambient_radiance(base: Vec3, metallic: f32, roughness: f32, nv: f32, e_n: Vec3, e_r: Vec3) -> Vec3 {
    let nv = nv.max(1e-4);
    let c0 = [-1.0f32, -0.0275, -0.572, 0.022];
    let c1 = [1.0f32, 0.0425, 1.04, -0.04];
    let r: Vec<f32> = (0..4).map(|i| roughness * c0[i] + c1[i]).collect();
    let a004 = (r[0] * r[0]).min((-9.28 * nv).exp2()) * r[0] + r[1];
    let (a, b) = (-1.04 * a004 + r[2], 1.04 * a004 + r[3]);
    let f0 = Vec3::splat(0.04).lerp(base, metallic);
    let spec = f0 * a + Vec3::splat(b);
    let c_diff = base.lerp(Vec3::ZERO, metallic);
    c_diff / std::f32::consts::PI * e_n * (Vec3::ONE - spec) + spec * e_r / std::f32::consts::PI
}

/// What an end-to-end test against a bundled scene's reference frames starts from: the reference
/// frames, their sequence and its linearizer, the proxy's and the first object's ray scenes, and
/// the scene's estimator.
pub struct ReferenceRun {
    /// The reference frames (`reference/reference.toml`).
    pub refs: heliar::render::reference::References,
    /// The sequence they belong to.
    pub seq: heliar::scene::Sequence,
    /// Its photometry's linearizer.
    pub lin: heliar::io::frames::Linearizer,
    /// The real proxy.
    pub ray: Arc<RayScene>,
    /// The first virtual object alone (for the reference's pixel classes).
    pub statue: RayScene,
    /// The scene's estimator.
    pub est: heliar::estimate::Estimator,
}

/// The bundled scene under `scenes/<name>` as the command line opens it: `terrain_albedo = "map"`
/// measured on the environment map (`envmap::bake::terrain::resolve_scene`; `Scene::load`
/// alone leaves the fallback albedo 0.2, which on the winter snow scene moves frame 0's
/// estimated `Pd` by +1 to +4.5% per channel against the map's 0.79).
pub fn scene_as_cli(name: &str) -> heliar::scene::Scene {
    let mut scene = heliar::scene::Scene::load(&std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes").join(name)).expect("bundled scene");
    let ray = Arc::new(RayScene::new(scene.proxy.clone()));
    heliar::envmap::bake::terrain::resolve_scene(&mut scene, &ray).expect("the terrain albedo from the environment map");
    scene
}

impl ReferenceRun {
    /// The pieces for `scene`, which must have reference frames.
    pub fn new(scene: &heliar::scene::Scene) -> Self {
        let refs = heliar::render::reference::References::load(scene).expect("reference.toml").expect("the scene has reference frames");
        let seq = scene.sequence(refs.sequence.as_deref()).expect("reference sequence").clone();
        let ray = Arc::new(RayScene::new(scene.proxy.clone()));
        let statue = RayScene::new(scene.virtual_objects[0].mesh.clone());
        let est = heliar::estimate::Estimator::new(scene, ray.clone()).expect("estimator");
        let lin = seq.photometry.linearizer();
        Self { refs, seq, lin, ray, statue, est }
    }

    /// Estimates the sequence's frames `0..=index` in order (the smoothing needs the frames
    /// before) and returns frame `index` with its estimate.
    pub fn estimate_through(&mut self, index: usize) -> (heliar::io::frames::Frame, heliar::estimate::FrameEstimate) {
        let mut last = None;
        for i in 0..=index {
            let f = heliar::io::frames::Frame::load(&self.seq.files[i]).unwrap();
            let e = self.est.estimate(i, &self.seq.times[i], &f, &self.lin).unwrap();
            last = Some((f, e));
        }
        last.expect("at least one frame")
    }
}

/// A 1 m stone block on the yard proxy seen from (3, 1.6, 2.4) at 160×120 through `lens`, lit by
/// the sun `sun` alone (`Pd` 3, `Pa` 0, no transfer or occlusion rays) over black footage, so
/// that each pixel is the block's sunlit radiance times the share of the pixel it covers; canvas
/// supersampling `supersample`. Returns the set-up, the block and the rendered frame (for the
/// shading and lens-filter tests' CPU box filters).
pub fn sunlit_block(sun: Vec3, base: Vec3, lens: [f64; 5], supersample: Option<f64>) -> (Setup, Mesh, heliar::render::RenderedFrame) {
    use heliar::irradiance::{ProbeGrid, sh};
    use heliar::lighting::{FrameSky, LampScales, Lighting};
    use heliar::render::VideoFrame;
    let mat = Material { name: "stone".into(), base_color: [base.x, base.y, base.z, 1.0], base_color_texture: None, metallic: 0.0, roughness: 0.9 };
    let block = cube(Vec3::new(-0.5, 0.0, -0.5), Vec3::new(0.5, 1.0, 0.5), mat, "block");
    let (w, h) = (160u32, 120u32);
    let setup = Setup { camera: camera([3.0, 1.6, 2.4], [0.0, 0.5, 0.0], w, h, lens), proxy: yard_proxy(), objects: vec![("block".into(), block.clone())] };
    let mut config = CompositorConfig::from_estimator_settings(&Default::default());
    config.occlusion_rays = 0;
    config.transfer_paths = 0;
    if let Some(s) = supersample {
        config.supersample = s;
    }
    let mut comp = setup.compositor(config);
    comp.set_probes(&ProbeGrid::filled(Vec3::new(-6.0, 0.1, -6.0), Vec3::new(6.0, 3.0, 6.0), 1.0, sh::uniform_upper_sky(Vec3::ZERO)));
    let video = VideoFrame { width: w, height: h, rgba: vec![[0.0, 0.0, 0.0, 1.0]; (w * h) as usize] };
    let lighting = Lighting { sun_dir: sun, above_horizon: true, pd: Vec3::splat(3.0), pa: Vec3::ZERO, sky: FrameSky::Declared, lamps: LampScales::NONE };
    let (frame, _) = comp.render(&video, &lighting).expect("render");
    (setup, block, frame)
}
