//! What the footage shows at each pixel, as far as the real proxy knows: the surface point, its
//! normal, albedo, weighted-ambient factor `c` and sun bounce `b`, and the same two factors with
//! the virtual objects standing in the scene (`c_v`, `b_v`). The composite pass needs them to
//! darken real pixels under a virtual shadow with the right ratio (Jensen §3.2 step 3 notes that
//! the surface normal is needed; §4.1 defines `c`), and, with the differential model, to darken
//! the sky light and bounce the virtual objects take from real surfaces near them.
//!
//! # How it works
//! One ray per footage pixel (through the lens model) against the proxy gives the point, the
//! normal facing the camera and the albedo; this is cheap and done once per camera. `c` and `b`
//! are path-traced integrals ([`crate::geometry::ambient::transport`], the same the estimator
//! uses), too costly for every pixel, so they are computed only for the pixels a virtual shadow
//! can reach or near the virtual objects (the caller passes them) and cached: `c` and `c_v` for
//! good, `b`, `b_v` and the real sun visibility `s` until the sun has moved more than the
//! estimator's `sun_rebuild_deg`. Pixels not computed hold `c = 1`, `b = 0` and no `c_v`.
//!
//! When the sun has moved that far and recomputing the pixels would take more than the per-frame
//! path budget, the recomputation for the new sun is done a slice per frame while the stored
//! values serve, and swapped in when complete ([`retrace`]); `c` does not depend on the sun (the
//! same random numbers whatever it is), so it comes out as stored. Under a shaped sky or with
//! terrain (`with_sky`, the scene's `[estimator.sky]`) `c` and `c_v` do follow the sun; every
//! computation for a sun gives them for that sun's sky, so they are recomputed with `b`.
//! Overcast frames, which the estimator fits under the uniform sky, switch the integrals to it
//! ([`Receivers::set_frame_sky`]; issue 13), and the next clear frame back. A turbidity fitted per
//! frame reshapes the sky: the values are recomputed under it as after a sun move (a slice per
//! frame within the budget, the stored values serving), not dropped.

mod cuts;
mod retrace;
mod sweep;

pub use sweep::{box_between, swept_box_contains};

use crate::geometry::ambient::{TransportQuality, transport_under};
use crate::lighting::FrameSky;
use crate::sky::radiance::SkyModel;
use crate::geometry::raycast::RayScene;
use crate::camera::Camera;
use glam::Vec3;
use rayon::prelude::*;

/// Per-pixel proxy data of the footage.
#[derive(Clone, Debug)]
pub struct Receivers {
    /// Footage width.
    pub width: u32,
    /// Footage height.
    pub height: u32,
    /// Surface point (world) per pixel; `None` where the pixel sees no proxy surface.
    pub point: Vec<Option<Vec3>>,
    /// Unit normal facing the camera, `w = 1` where there is a surface (texture layout).
    pub normal: Vec<[f32; 4]>,
    /// Diffuse albedo (texture layout).
    pub albedo: Vec<[f32; 4]>,
    /// Weighted-ambient factor `c`, and in `w` the real sun visibility `s` as the sunlit fraction
    /// of the pixel (texture layout).
    pub ambient: Vec<[f32; 4]>,
    /// Sun-bounce factor `b` for [`Receivers::bounce_sun`] (texture layout).
    pub bounce: Vec<[f32; 4]>,
    /// `c_v`: `c` with the virtual objects in the scene; `w` = 1 where computed.
    pub ambient_with: Vec<[f32; 4]>,
    /// `b_v`: `b` with the virtual objects in the scene.
    pub bounce_with: Vec<[f32; 4]>,
    /// Pixels whose `c` has been computed.
    have_ambient: Vec<bool>,
    /// `c_v`, `b_v` are known.
    have_with: Vec<bool>,
    /// `c_v`, `b_v` belong to the visibility cuts: a moved object can reach the pixel
    /// ([`Receivers::forget_objects_at`]); the others keep their traced values.
    by_cuts: Vec<bool>,
    /// The steps replayed frames decided on but did not do, in order (see [`Receivers::replay`]).
    owed: Vec<Owed>,
    /// Pixels whose `b` has been computed for `bounce_sun`.
    have_bounce: Vec<bool>,
    /// Sun direction the bounce values belong to.
    pub bounce_sun: Option<Vec3>,
    /// The sky the bounce values (and the `c` computed with them) were integrated under.
    bounce_sky: SkyModel,
    /// Seed of the integrals.
    seed: u64,
    /// The camera (for sub-pixel rays).
    camera: Camera,
    /// Paths per frame of a recomputation after a sun move (0: unbounded); see [`retrace`].
    budget_paths: u64,
    /// The recomputation for a new sun in progress.
    job: Option<retrace::BounceJob>,
    /// The sky the frame's integrals see (under a shaped sky `c` follows the sun with `b`): the
    /// scene's, or the variant the frame's estimate used ([`Receivers::set_frame_sky`]).
    sky_model: SkyModel,
    /// The scene's sky.
    scene_sky: SkyModel,
}

/// One pixel's computed values: pixel, `c`, `b`, sunlit fraction, and (`c_v`, `b_v`).
type Row = (u32, Vec3, Vec3, f32, Option<(Vec3, Vec3)>);

/// Sub-pixel rays per axis for the sunlit fraction of a pixel (a pixel on a real shadow's edge is
/// partly lit in the footage; the differential model darkens exactly that part).
const LIT_SUBPIXELS: u32 = 4;

/// One step of a replayed frame, redone by [`Receivers::restore`] in the order it was decided:
/// the sun moved and the bounce values were dropped, or pixels computed for a bounce sun
/// (with or without the objects).
#[derive(Clone, Debug, PartialEq)]
enum Owed {
    Reset,
    /// The sky switched: every value dropped ([`Receivers::set_frame_sky`]).
    Drop,
    Compute { todo: Vec<u32>, bounce_sun: Option<Vec3>, with: bool, sky: SkyModel },
    /// `c_v`, `b_v` set from the sky visibility with the objects present (the visibility cuts
    /// at a replayed frame's poses): [`Receivers::set_with_from_visibility`].
    Visibility { pixels: Vec<u32>, visibility: Vec<crate::geometry::proxy_light::LightLeft> },
    /// The objects moved: `c_v`, `b_v` forgotten ([`Receivers::forget_objects`]).
    Forget,
    /// Some objects moved: `c_v`, `b_v` forgotten at these pixels ([`Receivers::forget_objects_at`]).
    ForgetAt(Vec<u32>),
}

/// The fraction of pixel `p` (footage grid) whose first proxy surface sees the sun `l`.
fn lit_fraction(camera: &Camera, proxy: &RayScene, p: u32, l: Vec3) -> f32 {
    let w = camera.intrinsics.width;
    let (col, row) = ((p % w) as f64, (p / w) as f64);
    let n = LIT_SUBPIXELS;
    let mut lit = 0;
    for k in 0..n * n {
        let uv = glam::DVec2::new(col + ((k % n) as f64 + 0.5) / n as f64 - 0.5, row + ((k / n) as f64 + 0.5) / n as f64 - 0.5);
        let Some((o, d)) = camera.ray_at(uv) else { continue };
        if let Some(hit) = proxy.intersect(o.as_vec3(), d.as_vec3(), f32::MAX)
            && hit.normal.dot(l) > 0.0
            && proxy.sees_direction(hit.point, hit.normal, l)
        {
            lit += 1;
        }
    }
    lit as f32 / (n * n) as f32
}

/// What one [`Receivers::ensure`] call computed.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct EnsureStats {
    /// Pixels whose `c` (and `b`) were computed now.
    pub computed: usize,
    /// True when the cached `b` was dropped because the sun moved.
    pub bounce_reset: bool,
    /// Time spent, ms.
    pub ms: f64,
}

impl Receivers {
    /// Casts the primary rays of `camera` against `proxy`.
    pub fn new(camera: &Camera, proxy: &RayScene, seed: u64) -> Self {
        let (w, h) = (camera.intrinsics.width, camera.intrinsics.height);
        let hits: Vec<Option<(Vec3, Vec3, Vec3)>> = (0..w * h)
            .into_par_iter()
            .map(|i| {
                let (o, d) = camera.pixel_ray(i % w, i / w)?;
                let hit = proxy.intersect(o.as_vec3(), d.as_vec3(), f32::MAX)?;
                Some((hit.point, hit.normal, proxy.albedo(&hit)))
            })
            .collect();
        let n = hits.len();
        Self {
            width: w,
            height: h,
            point: hits.iter().map(|h| h.map(|h| h.0)).collect(),
            normal: hits.iter().map(|h| h.map_or([0.0; 4], |h| [h.1.x, h.1.y, h.1.z, 1.0])).collect(),
            albedo: hits.iter().map(|h| h.map_or([0.0; 4], |h| [h.2.x, h.2.y, h.2.z, 1.0])).collect(),
            ambient: vec![[1.0, 1.0, 1.0, 1.0]; n],
            bounce: vec![[0.0; 4]; n],
            ambient_with: vec![[1.0, 1.0, 1.0, 0.0]; n],
            bounce_with: vec![[0.0; 4]; n],
            have_ambient: vec![false; n],
            have_with: vec![false; n],
            by_cuts: vec![false; n],
            owed: Vec::new(),
            have_bounce: vec![false; n],
            bounce_sun: None,
            bounce_sky: SkyModel::uniform(),
            seed,
            camera: camera.clone(),
            budget_paths: 0,
            job: None,
            sky_model: SkyModel::uniform(),
            scene_sky: SkyModel::uniform(),
        }
    }

    /// Recomputes after a sun move in slices of about `paths_per_frame` paths, one per frame,
    /// serving the stored values until the last slice is done (0: all in the frame that decides
    /// it). See [`retrace`].
    pub fn with_budget(mut self, paths_per_frame: u64) -> Self {
        self.budget_paths = paths_per_frame;
        self
    }

    /// Integrates under `sky` instead of Jensen's uniform sky. Every computation with a sun
    /// gives `c` for that sun's sky, so `c` follows the sun wherever `b` does.
    pub fn with_sky(mut self, sky: SkyModel) -> Self {
        self.scene_sky = sky.clone();
        self.bounce_sky = sky.clone();
        self.sky_model = sky;
        self
    }

    /// Integrates under the sky the frame's estimate used from now on. A switch between the
    /// uniform sky (an overcast frame) and the scene's shape drops every computed value
    /// (integrated under the other sky) and any recomputation in progress, so the pixels the
    /// next [`Self::ensure`] needs are computed again; while `replaying` ([`Self::replay`]) the
    /// drop of the values is owed in order, so [`Self::restore`] redoes it where the
    /// uninterrupted run did. A change of the shape's turbidity alone
    /// ([`SkyModel::reshapes_to`]) keeps the values: the next [`Self::ensure`] with a sun
    /// recomputes them as after a sun move ([`retrace`]). Returns true on a change.
    pub fn set_frame_sky(&mut self, sky: FrameSky, replaying: bool) -> bool {
        let model = self.scene_sky.for_frame(sky.parts());
        if model == self.sky_model {
            return false;
        }
        let reshape = self.sky_model.reshapes_to(&model);
        self.sky_model = model;
        if reshape {
            return true;
        }
        self.bounce_sky = self.sky_model.clone();
        self.have_ambient.fill(false);
        self.have_bounce.fill(false);
        self.have_with.fill(false);
        self.bounce_sun = None;
        self.job = None;
        match replaying {
            true => self.owed.push(Owed::Drop),
            false => self.drop_values(),
        }
        true
    }

    /// True when [`Self::set_frame_sky`] with `sky` would change the sky.
    pub fn sky_switch_pending(&self, sky: FrameSky) -> bool {
        self.scene_sky.for_frame(sky.parts()) != self.sky_model
    }

    /// The sky the frame's integrals see.
    pub fn sky_model(&self) -> &SkyModel {
        &self.sky_model
    }

    /// The sky the stored bounce values were integrated under.
    pub fn bounce_sky(&self) -> &SkyModel {
        &self.bounce_sky
    }

    /// Every pixel back to its value before any computation (`c = 1`, `b = 0`, no `c_v`).
    fn drop_values(&mut self) {
        self.ambient.fill([1.0; 4]);
        self.bounce.fill([0.0; 4]);
        self.ambient_with.fill([1.0, 1.0, 1.0, 0.0]);
        self.bounce_with.fill([0.0; 4]);
    }

    /// Makes sure `c` (and, with `sun` given, `b` and `s` for that sun) is known at `pixels`,
    /// and, when `with` (the proxy and the virtual objects together) is given, `c_v` and `b_v`
    /// too. The cached sun-dependent values are dropped when the sun moved by more than
    /// `rebuild_deg`.
    #[allow(clippy::too_many_arguments)]
    pub fn ensure(
        &mut self,
        proxy: &RayScene,
        with: Option<&RayScene>,
        pixels: &[u32],
        sun: Option<Vec3>,
        ambient_quality: TransportQuality,
        bounce_quality: TransportQuality,
        rebuild_deg: f64,
    ) -> EnsureStats {
        let t = std::time::Instant::now();
        if let Some(mut stats) = self.job_slice(proxy, with, pixels, sun, bounce_quality, rebuild_deg) {
            stats.ms = t.elapsed().as_secs_f64() * 1e3;
            return stats;
        }
        let (todo, bounce_sun, bounce_reset) = self.advance(pixels, sun, rebuild_deg, with.is_some());
        let q = if bounce_sun.is_some() { bounce_quality } else { ambient_quality };
        let sky = self.sky_model.clone();
        self.compute(proxy, with, &todo, bounce_sun, q, &sky);
        EnsureStats { computed: todo.len(), bounce_reset, ms: t.elapsed().as_secs_f64() * 1e3 }
    }

    /// What [`Self::ensure`] decides, without computing: the cached state moves on as if it had
    /// computed, and each pixel's computation is owed with the sun it would have used (a run
    /// resumed after an interruption replays its earlier frames this way). [`Self::restore`]
    /// pays what is owed, so the values end up as the uninterrupted run's.
    pub fn replay(&mut self, pixels: &[u32], sun: Option<Vec3>, rebuild_deg: f64, with: bool, bounce_paths: u32) -> EnsureStats {
        if let Some(stats) = self.replay_job_slice(pixels, sun, rebuild_deg, with, bounce_paths) {
            return stats;
        }
        let (todo, bounce_sun, bounce_reset) = self.advance(pixels, sun, rebuild_deg, with);
        if bounce_reset {
            self.owed.push(Owed::Reset);
        }
        let computed = todo.len();
        if computed > 0 {
            self.owed.push(Owed::Compute { todo, bounce_sun, with, sky: self.sky_model.clone() });
        }
        EnsureStats { computed, bounce_reset, ms: 0.0 }
    }

    /// Forgets `c_v` and `b_v` (the virtual objects moved); the next [`Self::ensure`] with the
    /// objects computes them again where they are needed.
    /// Computations owed by replayed frames before the move are forgotten after them, in order.
    pub fn forget_objects(&mut self) {
        self.by_cuts.fill(false);
        self.clear_with();
        if !self.owed.is_empty() {
            self.owed.push(Owed::Forget);
        }
    }

    fn clear_with(&mut self) {
        self.have_with.fill(false);
        self.ambient_with.fill([1.0, 1.0, 1.0, 0.0]);
        self.bounce_with.fill([0.0; 4]);
    }

    /// The surface point and normal of pixel `p`, where it sees the proxy.
    pub fn surface(&self, p: u32) -> Option<(Vec3, Vec3)> {
        let i = p as usize;
        let point = (*self.point.get(i)?)?;
        let n = self.normal[i];
        Some((point, Vec3::new(n[0], n[1], n[2])))
    }

    /// True when replayed frames owe computations.
    pub fn owes(&self) -> bool {
        !self.owed.is_empty() || self.job_owes()
    }

    /// Redoes what [`Self::replay`] left owed, step by step as the frames that decided on it
    /// would have (a pixel computed twice is computed twice, a reset drops the bounce values
    /// computed before it); returns the pixels computed.
    pub fn restore(&mut self, proxy: &RayScene, with: Option<&RayScene>, ambient_quality: TransportQuality, bounce_quality: TransportQuality) -> usize {
        let mut computed = 0;
        for step in std::mem::take(&mut self.owed) {
            match step {
                Owed::Drop => self.drop_values(),
                Owed::Reset => {
                    self.bounce.iter_mut().for_each(|b| *b = [0.0; 4]);
                    self.bounce_with.iter_mut().for_each(|b| *b = [0.0; 4]);
                }
                Owed::Forget => self.clear_with(),
                Owed::ForgetAt(pixels) => self.clear_with_at(&pixels),
                Owed::Visibility { pixels, visibility } => self.set_with_from_visibility(&pixels, &visibility),
                Owed::Compute { todo, bounce_sun, with: with_on, sky } => {
                    let q = if bounce_sun.is_some() { bounce_quality } else { ambient_quality };
                    self.compute(proxy, with.filter(|_| with_on), &todo, bounce_sun, q, &sky);
                    computed += todo.len();
                }
            }
        }
        computed + self.restore_job(proxy, with, bounce_quality)
    }

    /// The bookkeeping of [`Self::ensure`]: drops the sun-dependent values when the sun moved,
    /// marks the pixels to compute as known, and returns them with the bounce sun they use and
    /// whether the bounce was reset.
    fn advance(&mut self, pixels: &[u32], sun: Option<Vec3>, rebuild_deg: f64, with: bool) -> (Vec<u32>, Option<Vec3>, bool) {
        let mut reset = false;
        if let Some(l) = sun {
            let moved = self.bounce_sky != self.sky_model || self.bounce_sun.is_none_or(|s| (s.dot(l).clamp(-1.0, 1.0).acos().to_degrees() as f64) > rebuild_deg);
            if moved {
                self.reset_bounce(l, self.sky_model.clone());
                reset = true;
            }
        }
        let bounce_sun = sun.and(self.bounce_sun);
        let todo: Vec<u32> = pixels
            .iter()
            .copied()
            .filter(|&p| {
                let i = p as usize;
                i < self.point.len()
                    && self.point[i].is_some()
                    && (!self.have_ambient[i] || (with && !self.have_with[i]) || (bounce_sun.is_some() && !self.have_bounce[i]))
            })
            .collect();
        self.mark(&todo, bounce_sun.is_some(), with);
        (todo, bounce_sun, reset)
    }

    /// Drops every pixel's `b`, `b_v` (the bounce now belongs to the sun `l` under `sky`).
    fn reset_bounce(&mut self, l: Vec3, sky: SkyModel) {
        self.bounce_sky = sky;
        self.have_bounce.iter_mut().for_each(|b| *b = false);
        self.bounce.iter_mut().for_each(|b| *b = [0.0; 4]);
        self.bounce_with.iter_mut().for_each(|b| *b = [0.0; 4]);
        self.bounce_sun = Some(l);
    }

    /// Marks `todo` as computed (`b` with `bounce`, `c_v`, `b_v` with `with`).
    fn mark(&mut self, todo: &[u32], bounce: bool, with: bool) {
        for &p in todo {
            let i = p as usize;
            self.have_ambient[i] = true;
            self.have_bounce[i] |= bounce;
            self.have_with[i] |= with;
        }
    }

    /// Path-traces `c`, `b`, the sunlit fraction (and with `with`, `c_v`, `b_v`) at `todo` for
    /// `bounce_sun` under `sky` with quality `q`, into the stored values.
    fn compute(&mut self, proxy: &RayScene, with: Option<&RayScene>, todo: &[u32], bounce_sun: Option<Vec3>, q: TransportQuality, sky: &SkyModel) {
        let rows = self.trace_rows(proxy, with, todo, bounce_sun, q, sky);
        self.apply_rows(rows, bounce_sun.is_some());
    }

    /// The values of [`Self::compute`] at `todo`, not stored.
    fn trace_rows(&self, proxy: &RayScene, with: Option<&RayScene>, todo: &[u32], bounce_sun: Option<Vec3>, q: TransportQuality, sky: &SkyModel) -> Vec<Row> {
        let seed = self.seed;
        let sky = sky.for_sun(bounce_sun);
        todo
            .par_iter()
            .filter_map(|&p| {
                let i = p as usize;
                let point = self.point[i]?;
                let n = Vec3::new(self.normal[i][0], self.normal[i][1], self.normal[i][2]);
                let pixel_seed = seed ^ (p as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15);
                let tr = transport_under(proxy, point, n, bounce_sun, &sky, q, pixel_seed);
                let lit = bounce_sun.map_or(0.0, |l| lit_fraction(&self.camera, proxy, p, l));
                // Same seed with and without the objects: the difference is then mostly the
                // objects', not Monte Carlo noise.
                let tv = with.map(|w| {
                    let t = transport_under(w, point, n, bounce_sun, &sky, q, pixel_seed);
                    (t.c, t.b)
                });
                Some((p, tr.c, tr.b, lit, tv))
            })
            .collect()
    }

    /// Stores computed values (`b` too when they were computed with a sun).
    fn apply_rows(&mut self, rows: Vec<Row>, with_bounce: bool) {
        for (p, c, b, lit, tv) in rows {
            let i = p as usize;
            self.ambient[i] = [c.x, c.y, c.z, lit];
            if with_bounce {
                self.bounce[i] = [b.x, b.y, b.z, 1.0];
            }
            if let Some((cv, bv)) = tv {
                self.ambient_with[i] = [cv.x, cv.y, cv.z, 1.0];
                self.bounce_with[i] = [bv.x, bv.y, bv.z, 1.0];
            }
        }
    }

    /// Pixels whose surface point lies within `radius_m` of one of the boxes `bounds`, where a
    /// virtual object takes a noticeable part of the sky and bounce light.
    pub fn near(&self, bounds: &[(Vec3, Vec3)], radius_m: f32) -> Vec<u32> {
        (0..self.point.len() as u32)
            .into_par_iter()
            .filter(|&i| self.point[i as usize].is_some_and(|p| bounds.iter().any(|(lo, hi)| (p.clamp(*lo, *hi) - p).length() <= radius_m)))
            .collect()
    }

    /// Pixels whose surface point lies in the region swept from the boxes `bounds` away from
    /// the sun `l` (where their shadows can fall), grown by `grow_px` pixels.
    pub fn in_shadow_reach(&self, bounds: &[(Vec3, Vec3)], l: Vec3, grow_px: u32) -> Vec<u32> {
        let hit: Vec<bool> = self.point.par_iter().map(|p| p.is_some_and(|p| bounds.iter().any(|b| swept_box_contains(*b, l, p)))).collect();
        self.grown(&hit, grow_px)
    }

    /// Pixels whose surface point lies where the boxes `bounds` can shadow one of the point
    /// lamps at `lamps` (the segment toward the lamp crosses a box), grown by `grow_px` pixels.
    pub fn in_lamp_reach(&self, bounds: &[(Vec3, Vec3)], lamps: &[Vec3], grow_px: u32) -> Vec<u32> {
        let hit: Vec<bool> = self.point.par_iter().map(|p| p.is_some_and(|p| bounds.iter().any(|b| lamps.iter().any(|&at| box_between(*b, at, p))))).collect();
        self.grown(&hit, grow_px)
    }

    /// The pixels within `grow_px` pixels (a square) of one where `hit` holds.
    fn grown(&self, hit: &[bool], grow_px: u32) -> Vec<u32> {
        let (w, h, g) = (self.width as i64, self.height as i64, grow_px as i64);
        let at = |x: i64, y: i64| (0..w).contains(&x) && (0..h).contains(&y) && hit[(y * w + x) as usize];
        let near = |x: i64, y: i64| (-g..=g).any(|dy| (-g..=g).any(|dx| at(x + dx, y + dy)));
        (0..(w * h) as u32).into_par_iter().filter(|&i| near(i as i64 % w, i as i64 / w)).collect()
    }
}
