//! The bake's per-texel steps (Jensen §3.2): the hit buffers of the capture centre's view of the
//! proxy, the lighting at capture, and the albedo inversion with the filling of flagged texels.

use super::{BakeConfig, BakeError, BakeInfo, MAX_ALBEDO, MIN_DENOMINATOR_REL, Progress, SKY};
use crate::camera::View;
use crate::estimate::{EstimateError, Estimator};
use crate::geometry::ambient::{transport, transport_under};
use crate::sky::radiance::{ShapeMinusUniform, SkyModel};
use crate::geometry::raycast::RayScene;
use crate::io::frames::{Frame, FrameData, Linearizer, Response};
use crate::io::image::LinearImage;
use crate::scene::Scene;
use glam::Vec3;
use rayon::prelude::*;
use std::f32::consts::PI;
use std::sync::atomic::{AtomicU64, Ordering};

/// Per texel of the map: the proxy node seen (or [`SKY`]), its point, normal and base colour.
pub(super) struct Hits {
    pub node: Vec<u32>,
    pub position: Vec<Vec3>,
    pub normal: Vec<Vec3>,
    pub base: Vec<Vec3>,
}

/// First hits of the `n` texel rays of `view` on the proxy (Jensen §3.2: the maps are baked
/// from the proxy as seen from the capture centre).
pub(super) fn hit_buffers(ray: &RayScene, view: &View, n: usize) -> Hits {
    let w = match view {
        View::Equirect { width, .. } => *width,
        _ => unreachable!("the bake's view is an equirect map"),
    };
    let hits: Vec<Option<crate::geometry::raycast::Hit>> = (0..n)
        .into_par_iter()
        .map(|i| {
            let (o, d) = view.ray(i as u32 % w, i as u32 / w)?;
            ray.intersect(o.as_vec3(), d.as_vec3(), f32::MAX)
        })
        .collect();
    let mesh = ray.mesh();
    Hits {
        node: hits.iter().map(|h| h.map_or(SKY, |h| mesh.tri_node[h.tri as usize])).collect(),
        position: hits.iter().map(|h| h.map_or(Vec3::ZERO, |h| h.point)).collect(),
        normal: hits.iter().map(|h| h.map_or(Vec3::ZERO, |h| h.normal)).collect(),
        base: hits.iter().map(|h| h.map_or(Vec3::ZERO, |h| ray.albedo(&h))).collect(),
    }
}

/// The weighted-ambient factor `c` per surface texel (Jensen §3.2; 0 for sky texels).
pub(super) fn weighted_ambient(ray: &RayScene, node: &[u32], position: &[Vec3], normal: &[Vec3], cfg: &BakeConfig, progress: Progress) -> Vec<Vec3> {
    let n = node.len();
    let done = AtomicU64::new(0);
    (0..n)
        .into_par_iter()
        .map(|i| {
            let r = if node[i] == SKY { Vec3::ZERO } else { transport(ray, position[i], normal[i], None, cfg.ambient, 0xa3b1_0000 + i as u64).c };
            let k = done.fetch_add(1, Ordering::Relaxed) + 1;
            if k % 1024 == 0 || k == n as u64 {
                progress("weighted ambient", k, n as u64);
            }
            r
        })
        .collect()
}

/// The lighting when the map was captured: the manifest's `capture_pd`/`capture_pa`, or the
/// estimator (with the settings `estimator`) run on the map itself. Returns `(Pd, Pa, sun
/// direction, sun above the horizon)`.
pub(super) fn capture_lighting(
    scene: &Scene,
    estimator: &crate::estimate::EstimatorConfig,
    ray: &std::sync::Arc<RayScene>,
    view: View,
    img: &LinearImage,
    path: &std::path::Path,
    info: &mut BakeInfo,
) -> Result<([f64; 3], [f64; 3], Vec3, bool), BakeError> {
    let mpath = scene.root.join(crate::scene::MANIFEST_FILE);
    let env = scene.manifest.envmap.as_ref().ok_or(BakeError::NoEnvMap { path: mpath.clone() })?;
    let time = crate::scene::parse_time(&mpath, "envmap.capture_time", &env.capture_time.to_string())
        .map_err(|e| BakeError::Info { path: mpath.clone(), message: e.to_string() })?;
    let sun_pos = crate::sun::sun_position(&scene.observer, &time).map_err(EstimateError::from)?;
    let (pd, pa, l, sun_above) = match (env.capture_pd, env.capture_pa) {
        (Some(pd), Some(pa)) => {
            info.capture_status = None;
            (pd, pa, scene.geo.sun_dir_in_world(&sun_pos), sun_pos.above_horizon())
        }
        _ => {
            let (w, h) = (img.width, img.height);
            let mut est = Estimator::with_view(estimator.clone(), scene.observer, scene.geo, view, ray.clone())?;
            let frame = Frame { width: w, height: h, data: FrameData::Hdr(img.clone()) };
            // An environment map is often 32-bit float with a bright sun: no clip level.
            let lin = Linearizer::new(&Response::Linear, 1.0, 1.0, Some(f32::INFINITY));
            let e = est.estimate(0, &time, &frame, &lin)?;
            let (Some(pd), Some(pa)) = (e.pd, e.pa) else {
                return Err(BakeError::CaptureLighting { path: path.to_path_buf(), status: e.status });
            };
            info.capture_status = Some(e.status);
            (pd, pa, Vec3::from(e.sun.dir_world), e.sun.above_horizon)
        }
    };
    info.capture_sun_dir = l.to_array();
    info.capture_pd = pd;
    info.capture_pa = pa;
    Ok((pd, pa, l, sun_above))
}

/// The albedo inversion (Jensen §3.2, eq. 4 solved for `ρ`): per surface texel,
/// `ρ = π·L / (c·Pa + (s·cos + b)·Pd)`, with the texels whose denominator is too small or whose
/// `ρ` is out of `[0, MAX_ALBEDO]` flagged for filling.
pub(super) struct Inversion<'a> {
    pub ray: &'a RayScene,
    pub hits: &'a Hits,
    pub ambient: &'a [Vec3],
    pub cfg: &'a BakeConfig,
    /// The scene's sky: under a shaped one or with terrain, `c` at capture is the bake's (uniform)
    /// `c` plus the change along the bounce paths ([`ShapeMinusUniform`]).
    pub sky: &'a SkyModel,
    pub progress: Progress<'a>,
}

impl Inversion<'_> {
    pub fn run(&self, img: &LinearImage, pd: [f64; 3], pa: [f64; 3], l: Vec3, sun_above: bool) -> (Vec<Vec3>, Vec<bool>) {
        let (ray, cfg, progress) = (self.ray, self.cfg, self.progress);
        let Hits { node, position, normal, .. } = self.hits;
        let n = node.len();
        let (pd, pa) = (Vec3::new(pd[0] as f32, pd[1] as f32, pd[2] as f32), Vec3::new(pa[0] as f32, pa[1] as f32, pa[2] as f32));
        let sun_up = sun_above && pd.max_element() > 0.0;
        let model = self.sky;
        let shaped = (!model.is_uniform()).then(|| model.for_sun(Some(l)));
        let done = AtomicU64::new(0);
        let inverted: Vec<(Vec3, bool)> = (0..n)
            .into_par_iter()
            .map(|i| {
                if node[i] == SKY {
                    return (Vec3::ZERO, true);
                }
                let (p, nn) = (position[i], normal[i]);
                if let Some(sky) = &shaped {
                    // The scene's sky at capture: `c` for its shape and the terrain (module docs).
                    let cos = nn.dot(l).max(0.0);
                    let s = sun_up && cos > 0.0 && ray.sees_direction(p, nn, l);
                    let t = transport_under(ray, p, nn, sun_up.then_some(l), &ShapeMinusUniform(sky), cfg.bounce, 0xb0c0_0000 + i as u64);
                    let c = (self.ambient[i] + t.c).max(Vec3::ZERO);
                    let denom = c * pa + (Vec3::splat(if s { cos } else { 0.0 }) + t.b) * pd;
                    return invert(img.data[i], denom, pa);
                }
                let (direct, bounce) = if sun_up {
                    let cos = nn.dot(l).max(0.0);
                    let s = cos > 0.0 && ray.sees_direction(p, nn, l);
                    let b = transport(ray, p, nn, Some(l), cfg.bounce, 0xb0c0_0000 + i as u64).b;
                    (if s { cos } else { 0.0 }, b)
                } else {
                    (0.0, Vec3::ZERO)
                };
                let k = done.fetch_add(1, Ordering::Relaxed) + 1;
                if k % 1024 == 0 || k == n as u64 {
                    progress("albedo inversion", k, n as u64);
                }
                let denom = self.ambient[i] * pa + (Vec3::splat(direct) + bounce) * pd;
                invert(img.data[i], denom, pa)
            })
            .collect();
        inverted.into_iter().unzip()
    }
}

/// `ρ = π·L / denom`, flagged (zero, false) when the texel received too little light or the result
/// is implausible.
fn invert(radiance: [f32; 3], denom: Vec3, pa: Vec3) -> (Vec3, bool) {
    let rho = Vec3::from(radiance) * PI / denom;
    let ok = denom.cmpge(pa * MIN_DENOMINATOR_REL).all() && rho.is_finite() && rho.cmpge(Vec3::ZERO).all() && rho.cmple(Vec3::splat(MAX_ALBEDO)).all();
    (if ok { rho } else { Vec3::ZERO }, ok)
}

/// Fills flagged texels from valid 8-neighbours of the same node (repeated averaging, wrapping in
/// x), then from the base colour. Returns the two counts.
pub(super) fn fill_flagged(rho: &mut [Vec3], valid: &[bool], node: &[u32], base: &[Vec3], w: u32, h: u32) -> (usize, usize) {
    let (w, h) = (w as i64, h as i64);
    let mut ok = valid.to_vec();
    let flagged = ok.iter().zip(node).filter(|(v, k)| !**v && **k != SKY).count();
    loop {
        let mut changes = Vec::new();
        for i in 0..(w * h) as usize {
            if ok[i] || node[i] == SKY {
                continue;
            }
            let (x, y) = (i as i64 % w, i as i64 / w);
            let (mut sum, mut cnt) = (Vec3::ZERO, 0);
            for dy in -1..=1 {
                for dx in -1..=1 {
                    let (nx, ny) = ((x + dx).rem_euclid(w), y + dy);
                    if ny < 0 || ny >= h || (dx == 0 && dy == 0) {
                        continue;
                    }
                    let j = (ny * w + nx) as usize;
                    if ok[j] && node[j] == node[i] {
                        sum += rho[j];
                        cnt += 1;
                    }
                }
            }
            if cnt > 0 {
                changes.push((i, sum / cnt as f32));
            }
        }
        if changes.is_empty() {
            break;
        }
        for (i, v) in changes {
            rho[i] = v;
            ok[i] = true;
        }
    }
    let mut from_base = 0;
    for i in 0..rho.len() {
        if !ok[i] && node[i] != SKY {
            rho[i] = base[i];
            from_base += 1;
        }
    }
    (flagged - from_base, from_base)
}
