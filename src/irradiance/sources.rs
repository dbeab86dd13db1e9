//! Where the probe grid comes from: the hook where "relight the environment map → update the
//! probes" (Jensen §3.4, §4.2) plugs into the frame loop. A [`ProbeSource`] is asked for a new
//! grid only on frames whose estimate says `relight` (the lighting moved enough), and on the
//! first frame.
//!
//! Two sources exist:
//! - [`VolumeProbes`], the product path: the scene's bake (albedo, normal and weighted-ambient
//!   environment maps) relit for the frame's sun and sky, folded into the probes through the
//!   precomputed transfer of [`super::probe_transfer`] (the linear path: one response per unit
//!   `Pa` and one per unit `Pd`, the latter rebuilt only when the sun has moved more than
//!   `[bake.relight] sun_rebuild_deg`).
//! - [`UniformSky`], for scenes without an `[envmap]`: every probe holds the closed form of an
//!   unoccluded uniform sky of the frame's `Pa` (`E(n) = Pa·(1 + n_y)/2`), so real surfaces
//!   neither hide sky nor bounce light.

use super::probe_transfer::{LinearBasis, ProbeTransfer, TransferStats};
use super::{ProbeGrid, sh};
use crate::envmap::bake::Baked;
use crate::envmap::relight::Relighter;
use crate::geometry::raycast::RayScene;
use crate::lighting::Lighting;
use crate::scene::Scene;
use glam::Vec3;
use std::sync::Arc;

/// Where the probe grid comes from.
pub trait ProbeSource {
    /// A grid for `lighting` (called only when the estimate says `relight`, and for the first
    /// frame). The grid is the source's own, updated in place (no copy per relight).
    fn relight(&mut self, lighting: &Lighting) -> &ProbeGrid;
    /// Short name for reports.
    fn name(&self) -> &'static str;
    /// The relighter whose map the probes come from, when there is one (the visibility cuts
    /// cluster its map, `crate::cuts::frame`).
    fn relighter(&self) -> Option<&Relighter> {
        None
    }
}

/// Every probe holds the irradiance of an unoccluded uniform sky of the frame's `Pa` (for
/// scenes without an `[envmap]`, or `--ambient uniform`).
#[derive(Clone, Debug)]
pub struct UniformSky {
    grid: ProbeGrid,
}

impl ProbeSource for UniformSky {
    fn relight(&mut self, lighting: &Lighting) -> &ProbeGrid {
        self.grid.coeffs.fill(sh::uniform_upper_sky(lighting.pa));
        &self.grid
    }
    fn name(&self) -> &'static str {
        "uniform_sky"
    }
}

/// Probe-grid bounds and spacing: the manifest's `[irradiance]`, else the virtual objects'
/// bounds grown by a metre at 1 m spacing (or a unit box at the origin without objects).
pub fn grid_bounds(scene: &Scene) -> (Vec3, Vec3, f32) {
    match &scene.manifest.irradiance {
        Some(g) => (glam::DVec3::from(g.min).as_vec3(), glam::DVec3::from(g.max).as_vec3(), g.spacing_m as f32),
        None => {
            let b = scene.virtual_objects.iter().filter_map(|o| o.mesh.bounds()).reduce(|(a, b), (c, d)| (a.min(c), b.max(d)));
            let (lo, hi) = b.unwrap_or((Vec3::ZERO, Vec3::ONE));
            (lo - Vec3::ONE, hi + Vec3::ONE, 1.0)
        }
    }
}

impl UniformSky {
    /// The stand-in over the scene's probe-grid bounds ([`grid_bounds`]).
    pub fn for_scene(scene: &Scene) -> Self {
        let (min, max, spacing) = grid_bounds(scene);
        Self::new(min, max, spacing)
    }

    /// The stand-in over `[min, max]` with probes `spacing` apart.
    pub fn new(min: Vec3, max: Vec3, spacing: f32) -> Self {
        Self { grid: ProbeGrid::filled(min, max, spacing, [[0.0; 3]; sh::N]) }
    }
}

/// The irradiance volume relit every time the estimate says the lighting moved (Jensen §3.3,
/// §4.2): relit environment map → probe SH by the linear path of the precomputed transfer.
pub struct VolumeProbes {
    relighter: Relighter,
    transfer: ProbeTransfer,
    basis: LinearBasis,
    grid: ProbeGrid,
    /// Sun-response rebuilds so far (sun visibility and bounce per texel, then the probes'
    /// per-unit-`Pd` response).
    pub sun_rebuilds: usize,
    /// Time of the last sun-response rebuild, ms (0 when the last update reused it).
    pub last_rebuild_ms: f64,
}

impl VolumeProbes {
    /// Builds the transfer from the probes over the scene's grid ([`grid_bounds`]) to the baked
    /// maps' texels (`[bake] probe_directions` rays per probe) and the ambient response.
    pub fn new(scene: &Scene, ray: Arc<RayScene>, baked: &Baked) -> Self {
        let (min, max, spacing) = grid_bounds(scene);
        let transfer = ProbeTransfer::build(min, max, spacing, baked, &ray, scene.bake.probe_directions);
        let relighter = Relighter::new(baked, ray, scene.bake.relight.clone()).with_sky(scene.estimator.sky.sky_model());
        let basis = LinearBasis { ambient: transfer.ambient_response(&relighter), direct: Vec::new() };
        let grid = transfer.grid();
        Self { relighter, transfer, basis, grid, sun_rebuilds: 0, last_rebuild_ms: 0.0 }
    }

    /// The transfer's counts (probes, invalid probes, directions, build time).
    pub fn stats(&self) -> TransferStats {
        self.transfer.stats
    }

    /// The grid for sun direction `sun` (toward the sun; `sun_up` false leaves the sun out), sun
    /// irradiance `pd` and sky irradiance `pa`.
    pub fn update(&mut self, sun: Vec3, sun_up: bool, pd: Vec3, pa: Vec3) -> &ProbeGrid {
        self.last_rebuild_ms = 0.0;
        let pd = if sun_up && pd.max_element() > 0.0 {
            let t = std::time::Instant::now();
            let u = self.relighter.update_sun(sun);
            if u.rebuilt || self.basis.direct.is_empty() {
                if u.rebuilt && !self.relighter.sky_model().is_uniform() {
                    // The sky's shape follows the sun.
                    self.basis.ambient = self.transfer.ambient_response(&self.relighter);
                }
                self.basis.direct = self.transfer.direct_response(&self.relighter);
                self.sun_rebuilds += 1;
                self.last_rebuild_ms = t.elapsed().as_secs_f64() * 1e3;
            }
            pd
        } else {
            Vec3::ZERO
        };
        self.transfer.linear_into(&self.basis, pd, pa, &mut self.grid);
        &self.grid
    }
}

impl ProbeSource for VolumeProbes {
    fn relight(&mut self, lighting: &Lighting) -> &ProbeGrid {
        if self.relighter.set_frame_sky(lighting.sky) {
            // An overcast frame's uniform sky, a fitted turbidity, or the scene's back: both
            // responses follow (the direct one with the next sun update).
            self.basis.ambient = self.transfer.ambient_response(&self.relighter);
            self.basis.direct.clear();
        }
        self.update(lighting.sun_dir, lighting.above_horizon, lighting.pd, lighting.pa)
    }
    fn name(&self) -> &'static str {
        "irradiance_volume"
    }
    fn relighter(&self) -> Option<&Relighter> {
        Some(&self.relighter)
    }
}
