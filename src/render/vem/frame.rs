//! One VEM frame's lights as the passes take them: the plain values every pass plans from
//! ([`VemFrame`]), and their upload into buffers and bind groups ([`FrameBindings`]).
//!
//! # How it works
//! [`VemFrame::prepare`] decides whether the frame gets shadow maps (shadows on, objects, lights
//! with power), gives them to the clustered lights (the decomposer's clusters, else `H`
//! clustered here; Havran §4.3) and every light of `H` and `L` the map of its nearest cluster
//! ([`shadow_atlas::assign_slots`]), fits each map to the objects, fills the shading uniform and
//! the region-list buffers (Havran §4.1–4.2), and groups the lists by shadow slot so the shader
//! reads each map once per run ([`group_by_slot`]). Nothing here touches the GPU; the passes'
//! plans read it, and the renderer's `upload` turns it into the frame's buffers ([`FrameBindings`]).

use super::lists::{group_by_slot, light_bytes, list_words};
use super::shading::{FLAG_CULLING, FLAG_GLOSSY, FLAG_SHADOWS, VemFrameUniform};
use super::shadow_atlas::{self, ShadowView};
use super::{VemRenderConfig, VemRenderer};
use crate::io::image::LinearImage;
use crate::vem::Status;
use crate::vem::glossy::GlossyRegions;
use crate::vem::regions::{GpuLight, RegionLists, RegionSet};
use glam::Vec3;
use wgpu::util::DeviceExt;

/// One frame's lights as the renderer takes them.
#[derive(Clone, Debug)]
pub struct VemLights<'a> {
    /// The frame's status.
    pub status: Status,
    /// The set `H`: regions and this frame's lists.
    pub h: (&'a RegionSet, &'a RegionLists),
    /// The glossy set `L`, when configured.
    pub glossy: Option<(&'a GlossyRegions, &'a RegionLists)>,
    /// Directions of the clustered lights that get shadow maps (empty: `H` is clustered here).
    pub clusters: Vec<Vec3>,
}

impl<'a> VemLights<'a> {
    /// The lights of the decomposer's last frame.
    pub fn of(dec: &'a crate::vem::Decomposer, status: Status) -> Self {
        Self { status, h: dec.region_lists(), glossy: dec.glossy_lists(), clusters: dec.clusters().iter().map(|c| c.dir).collect() }
    }
}

/// The facts of one frame that the VEM passes decide on, and the data they draw with.
#[derive(Clone, Debug, PartialEq)]
pub struct VemFrame {
    /// Why the frame gets no shadow maps (`None`: it does).
    pub no_shadows: Option<String>,
    /// The scene has virtual objects.
    pub has_objects: bool,
    /// The objects and receivers take their light from the visibility cuts
    /// (`super::ObjectLight::Cuts`), not from the lights and shadow maps.
    pub cuts: bool,
    /// The lights of `H`, each with its shadow slot (grouped by slot when there are maps).
    pub h_lights: Vec<GpuLight>,
    /// The lights of `L`, likewise (empty without the glossy set).
    pub l_lights: Vec<GpuLight>,
    /// One orthographic view per shadow map.
    pub views: Vec<ShadowView>,
    /// One light per shadow map: its direction and the summed power of the lights of `H` that
    /// read it.
    pub shadow_lights: Vec<GpuLight>,
    /// The list buffer of `H`.
    pub h_words: Vec<u32>,
    /// The list buffer of `L` (one zero word without the glossy set).
    pub l_words: Vec<u32>,
    /// The shading pass's uniform.
    pub uniform: VemFrameUniform,
}

/// Why a frame gets no shadow maps, or `None`.
fn no_shadows(cfg: &VemRenderConfig, has_objects: bool, h: &[GpuLight], status: Status) -> Option<String> {
    let power: f32 = h.iter().map(|l| l.rgb.iter().sum::<f32>()).sum();
    if cfg.object_light == super::ObjectLight::Cuts {
        Some("the objects' light and shadows come from the visibility cuts (--object-light cuts)".to_owned())
    } else if !cfg.shadows {
        Some("shadows are off".to_owned())
    } else if !has_objects {
        Some("the scene has no virtual objects".to_owned())
    } else if power.is_nan() || power <= 0.0 {
        Some(format!("the lights carry no power (status {})", if status == Status::Dark { "dark" } else { "ok" }))
    } else {
        None
    }
}

/// The shadow maps of the casters' box `lo..hi`: their views and clustered lights; every light of
/// `h` and `l` gets the slot of its nearest map.
fn shadow_maps(h: &mut [GpuLight], l: &mut [GpuLight], clusters: &[Vec3], (lo, hi): (Vec3, Vec3), cfg: &VemRenderConfig) -> (Vec<ShadowView>, Vec<GpuLight>) {
    let dirs = shadow_atlas::shadow_directions(h, clusters, cfg.shadow_slots);
    shadow_atlas::assign_slots(h, &dirs);
    shadow_atlas::assign_slots(l, &dirs);
    let mut clustered: Vec<GpuLight> = dirs.iter().enumerate().map(|(k, d)| GpuLight { dir: d.to_array(), shadow: k as u32, rgb: [0.0; 3], index: k as u32 }).collect();
    for light in h.iter() {
        if let Some(c) = clustered.get_mut(light.shadow as usize) {
            for k in 0..3 {
                c.rgb[k] += light.rgb[k];
            }
        }
    }
    (dirs.iter().map(|d| shadow_atlas::fit_view(*d, lo, hi, cfg.tile)).collect(), clustered)
}

/// The shading uniform of `h` lights of `h_set`, the glossy set with `l` lights, and `maps`
/// shadow maps.
fn frame_uniform(cfg: &VemRenderConfig, (h, h_set): (usize, &RegionSet), glossy: Option<(&GlossyRegions, usize)>, maps: usize) -> VemFrameUniform {
    let mut flags = 0;
    if cfg.culling {
        flags |= FLAG_CULLING;
    }
    if maps > 0 {
        flags |= FLAG_SHADOWS;
    }
    if glossy.is_some() {
        flags |= FLAG_GLOSSY;
    }
    VemFrameUniform {
        h: [h as u32, h_set.len() as u32, h_set.lut.size, flags],
        l: glossy.map_or([0; 4], |(g, l)| [l as u32, g.regions.len() as u32, g.regions.lut.size, 0]),
        atlas: [shadow_atlas::tiles_per_side(cfg.shadow_slots), cfg.tile, maps as u32, 0],
        params: [glossy.map_or(2.0, |(g, _)| g.cos_cone), cfg.ground_albedo, 0.0, 0.0],
    }
}

impl VemFrame {
    /// The frame of `lights` for a renderer with settings `cfg`, objects or not, and the objects'
    /// bounds (the shadow maps' casters).
    pub fn prepare(lights: &VemLights<'_>, cfg: &VemRenderConfig, has_objects: bool, bounds: Option<(Vec3, Vec3)>) -> Self {
        let (h_set, h_lists) = lights.h;
        let mut h_lights = h_lists.lights.clone();
        let mut l_lights = lights.glossy.map(|(_, l)| l.lights.clone()).unwrap_or_default();
        let no_shadows = no_shadows(cfg, has_objects, &h_lights, lights.status);
        let (views, shadow_lights) = match (&no_shadows, bounds) {
            (None, Some(b)) => shadow_maps(&mut h_lights, &mut l_lights, &lights.clusters, b, cfg),
            _ => (Vec::new(), Vec::new()),
        };
        let glossy = lights.glossy.filter(|_| !l_lights.is_empty());
        let uniform = frame_uniform(cfg, (h_lights.len(), h_set), glossy.map(|(g, _)| (g, l_lights.len())), views.len());
        let mut h_words = list_words(h_set, h_lists);
        let mut l_words = glossy.map_or_else(|| vec![0u32], |(g, l)| list_words(&g.regions, l));
        if !views.is_empty() {
            group_by_slot(&mut h_lights, &mut h_words, h_set.lut.texels.len(), h_set.len());
            if let Some((g, _)) = glossy {
                group_by_slot(&mut l_lights, &mut l_words, g.regions.lut.texels.len(), g.regions.len());
            }
        }
        let cuts = cfg.object_light == super::ObjectLight::Cuts;
        Self { no_shadows, has_objects, cuts, h_lights, l_lights, views, shadow_lights, h_words, l_words, uniform }
    }
}

/// A frame's GPU inputs.
pub struct FrameBindings {
    /// Group 0 of the shading pass.
    pub shading: wgpu::BindGroup,
    /// The shadow maps' views (the atlas pass binds them).
    pub views: wgpu::Buffer,
    /// Group 0 of the composite.
    pub composite: wgpu::BindGroup,
}

impl VemRenderer {
    /// Uploads `frame` and the `background` (linear radiance in the camera's pixel grid).
    pub(super) fn upload(&self, frame: &VemFrame, background: &LinearImage) -> FrameBindings {
        let device = &self.gpu.device;
        let storage = |label: &str, bytes: &[u8]| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor { label: Some(label), contents: bytes, usage: wgpu::BufferUsages::STORAGE })
        };
        // Read-only storage like the rest: the shader branches on these values (issue 12).
        let uniform = storage("vem frame", bytemuck::bytes_of(&frame.uniform));
        let h_lights = storage("vem H lights", &light_bytes(&frame.h_lights));
        let h_lists = storage("vem H lists", bytemuck::cast_slice(&frame.h_words));
        let l_lights = storage("vem L lights", &light_bytes(&frame.l_lights));
        let l_lists = storage("vem L lists", bytemuck::cast_slice(&frame.l_words));
        // A storage buffer may not be empty: one zero view without maps (the shader reads none).
        let views_bytes: Vec<u8> = if frame.views.is_empty() { vec![0u8; std::mem::size_of::<ShadowView>()] } else { bytemuck::cast_slice(&frame.views).to_vec() };
        let views = storage("vem shadow views", &views_bytes);
        let shadow_lights = storage("vem shadow lights", &light_bytes(&frame.shadow_lights));
        fn buffer(binding: u32, b: &wgpu::Buffer) -> wgpu::BindGroupEntry<'_> {
            wgpu::BindGroupEntry { binding, resource: b.as_entire_binding() }
        }
        let shading = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("vem shading frame"),
            layout: &self.shading.frame_layout,
            entries: &[
                buffer(0, &self.camera_buffer),
                buffer(1, &uniform),
                buffer(2, &h_lights),
                buffer(3, &h_lists),
                buffer(4, &l_lights),
                buffer(5, &l_lists),
                buffer(6, &views),
                wgpu::BindGroupEntry { binding: 7, resource: wgpu::BindingResource::TextureView(&self.targets.atlas.view) },
                buffer(8, &shadow_lights),
                wgpu::BindGroupEntry { binding: 9, resource: wgpu::BindingResource::Sampler(&self.targets.shadow_sampler) },
                buffer(10, &self.cut_light.0),
                buffer(11, &self.cut_light.1),
            ],
        });
        let bg: Vec<[f32; 4]> = background.data.iter().map(|p| [p[0], p[1], p[2], 1.0]).collect();
        self.targets.background.write(&self.gpu.queue, &bg);
        let composite = self.composite.bind_group(device, &self.targets);
        FrameBindings { shading, views, composite }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn light(dir: Vec3, rgb: f32, index: u32) -> GpuLight {
        GpuLight { dir: dir.normalize().to_array(), shadow: u32::MAX, rgb: [rgb; 3], index }
    }

    #[test]
    fn shadows_are_left_out_for_the_first_reason_that_holds() {
        let cfg = VemRenderConfig::default();
        let lit = [light(Vec3::Y, 1.0, 0)];
        let dark = [light(Vec3::Y, 0.0, 0)];
        let nan = [light(Vec3::Y, f32::NAN, 0)];
        let off = VemRenderConfig { shadows: false, ..cfg.clone() };
        assert_eq!(no_shadows(&off, false, &dark, Status::Dark).as_deref(), Some("shadows are off"));
        assert_eq!(no_shadows(&cfg, false, &dark, Status::Dark).as_deref(), Some("the scene has no virtual objects"));
        assert_eq!(no_shadows(&cfg, true, &dark, Status::Dark).as_deref(), Some("the lights carry no power (status dark)"));
        assert_eq!(no_shadows(&cfg, true, &nan, Status::Ok).as_deref(), Some("the lights carry no power (status ok)"));
        assert_eq!(no_shadows(&cfg, true, &lit, Status::Ok), None);
    }

    #[test]
    fn each_map_carries_the_power_of_the_lights_that_read_it() {
        let cfg = VemRenderConfig::default();
        let mut h: Vec<GpuLight> = (0..12).map(|k| light(Vec3::new((k as f32 * 0.7).cos(), 1.0, (k as f32 * 0.7).sin()), 0.5 + k as f32, k)).collect();
        let mut l = h.clone();
        let clusters = [Vec3::new(1.0, 1.0, 0.0).normalize(), Vec3::new(-1.0, 1.0, 0.0).normalize(), Vec3::new(0.0, 1.0, 1.0).normalize()];
        let (views, maps) = shadow_maps(&mut h, &mut l, &clusters, (Vec3::splat(-0.5), Vec3::splat(0.5)), &cfg);
        assert_eq!((views.len(), maps.len()), (3, 3));
        // Every light reads a map, and the maps' power is the lights' (sums of at most 12
        // values of ~10: exact to f32 rounding, 1e-4 relative).
        assert!(h.iter().chain(&l).all(|x| (x.shadow as usize) < maps.len()));
        let total: f32 = h.iter().map(|x| x.rgb[0]).sum();
        let mapped: f32 = maps.iter().map(|m| m.rgb[0]).sum();
        assert!((total - mapped).abs() <= 1e-4 * total, "{total} vs {mapped}");
        for (k, m) in maps.iter().enumerate() {
            let own: f32 = h.iter().filter(|x| x.shadow == k as u32).map(|x| x.rgb[0]).sum();
            assert!((own - m.rgb[0]).abs() <= 1e-4 * total && Vec3::from_array(m.dir) == clusters[k]);
        }
    }
}
