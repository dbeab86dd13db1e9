//! Runtime relighting of the environment map (Jensen §4.2).
//!
//! # How it works
//! Given `Lighting { l, Pd, Pa }`, every surface texel gets
//! `P = ρ/π · (c·Pa + (s·max(n·l,0) + b)·Pd)` and every sky texel the sky's radiance `Pa/π` (a
//! uniform upper-hemisphere sky of horizontal irradiance `Pa`); the sun itself is left out, so the
//! map holds ambient light only and the compositor shades the sun directly.
//!
//! The map is stored as three channel planes (structure of arrays) and relit as
//! `P[c][i] = A[c][i]·Pa[c] + D[c][i]·Pd[c] + S[i]·Pa[c]`, with `A = ρ·c/π` fixed, `S = 1/π` on sky
//! texels, and `D = ρ·(s·max(n·l,0) + b)/π` rebuilt only when the sun has moved more than
//! `sun_rebuild_deg` since the last build (default 0.5°: the sun moves 0.25° per minute, and at the
//! bundled map's 1.4° texels a half-degree shift moves shadow edges by a third of a texel). The
//! per-texel sun visibility `s` is a shadow ray against the proxy (the binary shadow map of the
//! paper) and `b` the sun bounce of [`crate::geometry::ambient`]. The relight loop is two
//! multiply-adds per channel and texel over contiguous slices, split into chunks across threads
//! with rayon.

use super::bake::{Baked, SKY};
pub use crate::scene::settings::RelightConfig;
use crate::lighting::Lighting;
use crate::geometry::ambient::{TransportQuality, transport, transport_under};
use crate::geometry::equirect::dir_from_texel_centre;
use crate::geometry::proxy_light::ProxyLight;
use crate::sky::radiance::{ShapeMinusUniform, SkyModel, SkyRadiance};
use crate::geometry::raycast::RayScene;
use crate::io::image::LinearImage;
use glam::Vec3;
use rayon::prelude::*;
use std::f32::consts::FRAC_1_PI;
use std::sync::Arc;

/// Texels per parallel chunk of the relight loop.
const CHUNK: usize = 8192;

/// A relit map as three channel planes.
#[derive(Clone, Debug, PartialEq)]
pub struct RelitMap {
    /// Width.
    pub width: u32,
    /// Height.
    pub height: u32,
    /// Radiance per channel and texel.
    pub rgb: [Vec<f32>; 3],
}

impl RelitMap {
    /// A black map.
    pub fn new(width: u32, height: u32) -> Self {
        let n = (width * height) as usize;
        Self { width, height, rgb: [vec![0.0; n], vec![0.0; n], vec![0.0; n]] }
    }

    /// Radiance of texel `i`.
    #[inline]
    pub fn get(&self, i: usize) -> Vec3 {
        Vec3::new(self.rgb[0][i], self.rgb[1][i], self.rgb[2][i])
    }

    /// As an interleaved image (for files).
    pub fn to_image(&self) -> LinearImage {
        LinearImage { width: self.width, height: self.height, data: (0..self.rgb[0].len()).map(|i| self.get(i).to_array()).collect() }
    }
}

/// A relit map split by what it is linear in ([`Relighter::unit_maps`]).
#[derive(Clone, Debug, PartialEq)]
pub struct UnitMaps {
    /// Sky texels' radiance per unit `Pa` (zero on surfaces).
    pub sky_pa: LinearImage,
    /// Surface texels' radiance per unit `Pa` (zero on sky).
    pub surface_pa: LinearImage,
    /// Surface texels' radiance per unit `Pd`, once a sun is built.
    pub surface_pd: Option<LinearImage>,
}

/// The sun-dependent planes.
#[derive(Clone, Debug)]
struct SunPlanes {
    dir: Vec3,
    direct: [Vec<f32>; 3],
    /// Under a shaped sky or with terrain: the ambient plane for this sun, sky texels included
    /// (replaces the fixed ambient and sky planes).
    ambient: Option<[Vec<f32>; 3]>,
    lit_texels: usize,
}



/// Relights a baked environment map.
pub struct Relighter {
    width: u32,
    height: u32,
    surface: Vec<u32>,
    position: Vec<Vec3>,
    normal: Vec<Vec3>,
    albedo: Vec<Vec3>,
    ambient: [Vec<f32>; 3],
    sky: Vec<f32>,
    sun: Option<SunPlanes>,
    config: RelightConfig,
    ray: Arc<RayScene>,
    /// The bake's capture centre.
    centre: Vec3,
    /// The bake's weighted-ambient factor `c` per texel (Jensen's uniform sky).
    c_uniform: Vec<Vec3>,
    /// The scene's sky.
    scene_sky: SkyModel,
    /// The sky of the current frame: the scene's, or the variant the frame's estimate used
    /// ([`Relighter::set_frame_sky`]).
    sky_model: SkyModel,
}

/// What [`Relighter::update_sun`] did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SunUpdate {
    /// True when the sun planes were rebuilt.
    pub rebuilt: bool,
    /// Rebuild time, ms (0 when not rebuilt).
    pub build_ms: f64,
    /// Surface texels that see the sun.
    pub lit_texels: usize,
}

impl Relighter {
    /// Prepares the fixed planes of a bake.
    pub fn new(baked: &Baked, ray: Arc<RayScene>, config: RelightConfig) -> Self {
        let n = baked.node.len();
        let surface: Vec<u32> = (0..n as u32).filter(|&i| baked.node[i as usize] != SKY).collect();
        let ambient: [Vec<f32>; 3] = std::array::from_fn(|c| {
            (0..n).map(|i| if baked.node[i] == SKY { 0.0 } else { baked.albedo[i][c] * baked.ambient[i][c] * FRAC_1_PI }).collect()
        });
        let sky = baked.node.iter().map(|&k| if k == SKY { FRAC_1_PI } else { 0.0 }).collect();
        Self {
            width: baked.width,
            height: baked.height,
            surface,
            position: baked.position.clone(),
            normal: baked.normal.clone(),
            albedo: baked.albedo.clone(),
            ambient,
            sky,
            sun: None,
            config,
            ray,
            centre: baked.centre,
            c_uniform: baked.ambient.clone(),
            scene_sky: SkyModel::uniform(),
            sky_model: SkyModel::uniform(),
        }
    }

    /// Relights under `sky` instead of Jensen's uniform sky: the sky texels take its radiance for
    /// the current sun (the terrain below the horizon included) and the surface texels' `c` its
    /// shape, both rebuilt with the sun planes.
    pub fn with_sky(mut self, sky: SkyModel) -> Self {
        self.scene_sky = sky.clone();
        self.sky_model = sky;
        self
    }

    /// Relights the next frames under the sky the frame's estimate used (the scene's, the
    /// uniform sky of an overcast frame, or the scene's shape with a fitted turbidity). Returns
    /// true when that changed the sky, which drops the sun planes, so the next
    /// [`Self::update_sun`] rebuilds them under the new sky.
    pub fn set_frame_sky(&mut self, sky: crate::lighting::FrameSky) -> bool {
        let model = self.scene_sky.for_frame(sky.parts());
        if model == self.sky_model {
            return false;
        }
        self.sky_model = model;
        self.sun = None;
        true
    }

    /// The sky model of the current frame.
    pub fn sky_model(&self) -> &SkyModel {
        &self.sky_model
    }

    /// The sky of the current sun planes (`None` before the first: the sky without a sun).
    pub fn sky_for_current_sun(&self) -> SkyRadiance {
        self.sky_model.for_sun(self.sun.as_ref().map(|s| s.dir))
    }

    /// Map size.
    pub fn size(&self) -> (u32, u32) {
        (self.width, self.height)
    }

    /// The ambient plane `ρ·c/π` per channel (zero on sky), fixed under the uniform sky; under
    /// a shaped one, the current sun's, with the sky texels' radiance per unit `Pa`.
    pub fn ambient_plane(&self) -> &[Vec<f32>; 3] {
        self.sun.as_ref().and_then(|s| s.ambient.as_ref()).unwrap_or(&self.ambient)
    }

    /// The uniform sky plane (`1/π` on sky texels, zero elsewhere); `None` when the current
    /// ambient plane holds the sky already (a shaped sky).
    pub fn sky_plane(&self) -> Option<&[f32]> {
        match self.sun.as_ref().and_then(|s| s.ambient.as_ref()) {
            Some(_) => None,
            None => Some(&self.sky),
        }
    }

    /// The direct plane `ρ·(s·cos + b)/π` for the current sun, if built.
    pub fn direct_plane(&self) -> Option<&[Vec<f32>; 3]> {
        self.sun.as_ref().map(|s| &s.direct)
    }

    /// Rebuilds the sun planes when the sun moved more than the threshold (or on first use).
    pub fn update_sun(&mut self, dir: Vec3) -> SunUpdate {
        if let Some(s) = &self.sun {
            let moved = s.dir.dot(dir).clamp(-1.0, 1.0).acos().to_degrees() as f64;
            if moved <= self.config.sun_rebuild_deg {
                return SunUpdate { rebuilt: false, build_ms: 0.0, lit_texels: s.lit_texels };
            }
        }
        let t0 = std::time::Instant::now();
        if !self.sky_model.is_uniform() {
            return self.update_sun_shaped(dir, t0);
        }
        let n = self.sky.len();
        let cfg = &self.config;
        let vals: Vec<(u32, Vec3, bool)> = self
            .surface
            .par_iter()
            .map(|&i| {
                let i = i as usize;
                let (p, nn) = (self.position[i], self.normal[i]);
                let cos = nn.dot(dir).max(0.0);
                let s = cos > 0.0 && self.ray.sees_direction(p, nn, dir);
                let b = if cfg.sun_bounce { transport(&self.ray, p, nn, Some(dir), cfg.bounce, 0x5e1f_0000 + i as u64).b } else { Vec3::ZERO };
                let d = self.albedo[i] * (Vec3::splat(if s { cos } else { 0.0 }) + b) * FRAC_1_PI;
                (i as u32, d, s)
            })
            .collect();
        let mut direct: [Vec<f32>; 3] = [vec![0.0; n], vec![0.0; n], vec![0.0; n]];
        let mut lit = 0;
        for (i, d, s) in vals {
            for c in 0..3 {
                direct[c][i as usize] = d[c];
            }
            lit += s as usize;
        }
        let build_ms = t0.elapsed().as_secs_f64() * 1e3;
        self.sun = Some(SunPlanes { dir, direct, ambient: None, lit_texels: lit });
        SunUpdate { rebuilt: true, build_ms, lit_texels: lit }
    }

    /// [`Self::update_sun`] under a shaped sky or with terrain: per surface texel the sun
    /// bounce and the change of `c` along the same paths ([`ShapeMinusUniform`]); per sky texel
    /// the sky's (or the terrain's) radiance per unit `Pa` and `Pd`.
    fn update_sun_shaped(&mut self, dir: Vec3, t0: std::time::Instant) -> SunUpdate {
        let n = self.sky.len();
        let cfg = &self.config;
        let sky = self.sky_model.for_sun(Some(dir));
        let delta = ShapeMinusUniform(&sky);
        let q = if cfg.sun_bounce { cfg.bounce } else { TransportQuality { paths: cfg.bounce.paths.max(1), max_bounces: 0 } };
        let (w, h) = (self.width, self.height);
        let texels: Vec<(Vec3, Vec3, bool)> = (0..n)
            .into_par_iter()
            .map(|i| {
                if self.sky[i] != 0.0 {
                    let d = dir_from_texel_centre(i as u32 % w, i as u32 / w, w, h);
                    let (pa, pd) = sky.escape(d).unwrap_or((Vec3::ZERO, Vec3::ZERO));
                    return (pa * FRAC_1_PI, pd * FRAC_1_PI, false);
                }
                let (p, nn) = (self.position[i], self.normal[i]);
                let cos = nn.dot(dir).max(0.0);
                let s = cos > 0.0 && self.ray.sees_direction(p, nn, dir);
                let sun = cfg.sun_bounce.then_some(dir);
                let t = transport_under(&self.ray, p, nn, sun, &delta, q, 0x5e1f_0000 + i as u64);
                let rho = self.albedo[i] * FRAC_1_PI;
                let c = (self.c_uniform[i] + t.c).max(Vec3::ZERO);
                (rho * c, rho * (Vec3::splat(if s { cos } else { 0.0 }) + t.b), s)
            })
            .collect();
        let mut direct: [Vec<f32>; 3] = [vec![0.0; n], vec![0.0; n], vec![0.0; n]];
        let mut ambient: [Vec<f32>; 3] = [vec![0.0; n], vec![0.0; n], vec![0.0; n]];
        let mut lit = 0;
        for (i, (a, d, s)) in texels.into_iter().enumerate() {
            for c in 0..3 {
                ambient[c][i] = a[c];
                direct[c][i] = d[c];
            }
            lit += s as usize;
        }
        let build_ms = t0.elapsed().as_secs_f64() * 1e3;
        self.sun = Some(SunPlanes { dir, direct, ambient: Some(ambient), lit_texels: lit });
        SunUpdate { rebuilt: true, build_ms, lit_texels: lit }
    }

    /// The sun direction of the current sun planes (`None` before the first).
    pub fn sun_dir(&self) -> Option<Vec3> {
        self.sun.as_ref().map(|s| s.dir)
    }

    /// The relit map split by what it is linear in (for the visibility cuts, `crate::cuts::frame`):
    /// sky texels per unit `Pa`, surface texels per unit `Pa`, and surface texels per unit `Pd`
    /// (the current sun's direct plane; `None` before the first sun). `relight_into` is
    /// `(sky + surface_pa)·Pa + surface_pd·Pd` texel for texel.
    pub fn unit_maps(&self) -> UnitMaps {
        let n = self.sky.len();
        let mut surface = vec![false; n];
        for &i in &self.surface {
            surface[i as usize] = true;
        }
        let (amb, sky) = (self.ambient_plane(), self.sky_plane());
        let image = |keep_surface: bool| LinearImage {
            width: self.width,
            height: self.height,
            data: (0..n).map(|i| if surface[i] == keep_surface { std::array::from_fn(|c| amb[c][i] + sky.map_or(0.0, |s| s[i])) } else { [0.0; 3] }).collect(),
        };
        let surface_pd = self.direct_plane().map(|d| LinearImage { width: self.width, height: self.height, data: (0..n).map(|i| std::array::from_fn(|c| d[c][i])).collect() });
        UnitMaps { sky_pa: image(false), surface_pa: image(true), surface_pd }
    }

    /// The map's surface texels as light *arriving* at the surface point each shows, per unit
    /// `Pa` and per unit `Pd` with the direct sun left out (the sun's bounce `b` only), for
    /// relighting a point of the proxy seen from elsewhere than the capture centre
    /// (`crate::cuts::local_sun`): `None` before the first sun.
    pub fn local_light(&self) -> Option<ProxyLight> {
        let sun = self.sun.as_ref()?;
        let n = self.sky.len();
        let amb = self.ambient_plane();
        let (mut pa, mut pd) = (vec![Vec3::ZERO; n], vec![Vec3::ZERO; n]);
        let vals: Vec<(usize, Vec3, Vec3)> = self
            .surface
            .par_iter()
            .map(|&i| {
                let i = i as usize;
                let (p, nn, rho) = (self.position[i], self.normal[i], self.albedo[i]);
                let cos = nn.dot(sun.dir).max(0.0);
                let s = if cos > 0.0 && self.ray.sees_direction(p, nn, sun.dir) { cos } else { 0.0 };
                let per = |plane: &[Vec<f32>; 3], minus: f32| Vec3::from_array(std::array::from_fn(|c| if rho[c] > 0.0 { (plane[c][i] * std::f32::consts::PI / rho[c] - minus).max(0.0) } else { 0.0 }));
                (i, per(amb, 0.0), per(&sun.direct, s))
            })
            .collect();
        for (i, a, d) in vals {
            pa[i] = a;
            pd[i] = d;
        }
        Some(ProxyLight { width: self.width, height: self.height, centre: self.centre, sun: sun.dir, pa, pd, ray: self.ray.clone() })
    }

    /// Relights into `out` (resized as needed). Without a built sun (or with the sun down), the
    /// direct term is left out.
    pub fn relight_into(&self, lighting: &Lighting, out: &mut RelitMap) {
        let n = self.sky.len();
        if out.rgb[0].len() != n {
            *out = RelitMap::new(self.width, self.height);
        }
        let direct = self.sun.as_ref().filter(|_| lighting.above_horizon).map(|s| &s.direct);
        // A shaped sky's ambient plane holds the sky texels: there is no uniform sky plane to add.
        let sky_plane = self.sky_plane();
        let ambient = self.ambient_plane();
        for c in 0..3 {
            let (pa, pd) = (lighting.pa[c], if direct.is_some() { lighting.pd[c] } else { 0.0 });
            let amb = &ambient[c];
            let dir_plane = direct.map(|d| &d[c]);
            out.rgb[c].par_chunks_mut(CHUNK).enumerate().for_each(|(k, dst)| {
                let s = k * CHUNK;
                let e = s + dst.len();
                let a = &amb[s..e];
                match (dir_plane, sky_plane) {
                    (Some(d), Some(sky)) => {
                        let (d, sky) = (&d[s..e], &sky[s..e]);
                        for j in 0..dst.len() {
                            dst[j] = a[j] * pa + d[j] * pd + sky[j] * pa;
                        }
                    }
                    (None, Some(sky)) => {
                        let sky = &sky[s..e];
                        for j in 0..dst.len() {
                            dst[j] = (a[j] + sky[j]) * pa;
                        }
                    }
                    (Some(d), None) => {
                        let d = &d[s..e];
                        for j in 0..dst.len() {
                            dst[j] = a[j] * pa + d[j] * pd;
                        }
                    }
                    (None, None) => {
                        for j in 0..dst.len() {
                            dst[j] = a[j] * pa;
                        }
                    }
                }
            });
        }
    }

    /// Relights into a new map.
    pub fn relight(&self, lighting: &Lighting) -> RelitMap {
        let mut out = RelitMap::new(self.width, self.height);
        self.relight_into(lighting, &mut out);
        out
    }
}
