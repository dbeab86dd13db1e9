//! The lighting of one frame as a plain value: what a lighting stage emits and a renderer
//! consumes (the arrow between them in the frame loop).
//!
//! The outdoor stage (estimator → relight → probes) fills the sun direction and the sun and sky
//! intensities (crate docs, "Radiometry": `Pd` is the sun's irradiance on a surface facing it,
//! `Pa` the sky's on an unoccluded horizontal surface). The environment relighting, the probe
//! update and the compositor all read this one type. With `[[lights]]` it also carries each
//! lamp's scale `k` (issue 16 §3), which the compositor's lamp term multiplies the lamp's model
//! by.

use glam::Vec3;

/// The sun and sky of one frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lighting {
    /// Unit direction toward the sun, world frame.
    pub sun_dir: Vec3,
    /// The sun is above the horizon (no direct light otherwise).
    pub above_horizon: bool,
    /// `Pd` (RGB); zero when unknown.
    pub pd: Vec3,
    /// `Pa` (RGB).
    pub pa: Vec3,
    /// The sky the frame's estimate used, which every renderer stage that traces paths (the
    /// relight, the probes, the objects' transfer, the receivers' `c`, `b`) takes for the frame
    /// ([`crate::sky::radiance::SkyModel::for_frame`]; issue 13, "they never disagree about the
    /// sky").
    pub sky: FrameSky,
    /// The scale of each lamp ([`LampScales::NONE`] without lamps).
    pub lamps: LampScales,
}

/// Which sky a frame's estimate used, relative to the scene's `[estimator.sky]`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum FrameSky {
    /// The scene's declared sky (a fixed turbidity, or Jensen's uniform sky).
    #[default]
    Declared,
    /// The uniform sky, the terrain kept: an overcast frame of a scene whose sky has a shape.
    Uniform,
    /// The declared shape with the turbidity the estimator chose for the frame by residual
    /// (`turbidity = "fit"`, `estimate::turbidity`). Without a shaped sky it changes nothing.
    Turbidity(f64),
}

impl FrameSky {
    /// `(uniform, turbidity)`: the form `crate::sky::radiance::SkyModel::for_frame` takes.
    pub fn parts(self) -> (bool, Option<f64>) {
        match self {
            FrameSky::Declared => (false, None),
            FrameSky::Uniform => (true, None),
            FrameSky::Turbidity(t) => (false, Some(t)),
        }
    }
}

/// Most lamps whose scales a frame's [`Lighting`] carries: as many as a scene may declare
/// (`crate::scene::lights::MAX_LIGHTS`, which refuses more at load; checked equal in
/// `run::outdoor`'s tests).
pub const MAX_LAMPS: usize = 64;

/// The scale `k` per channel of each of the scene's lamps (`[[lights]]`, in order) for one frame:
/// the estimator's fitted `k`, or the prior when the lamp was not fitted, and zero for a lamp
/// that is off (issue 16 §3). Empty when the scene has no lamps or the lighting says nothing of
/// them (then the lamps give no light).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LampScales {
    k: [[f32; 3]; MAX_LAMPS],
    len: usize,
}

impl Default for LampScales {
    /// No lamp.
    fn default() -> Self {
        Self::NONE
    }
}

impl LampScales {
    /// No lamp.
    pub const NONE: Self = Self { k: [[0.0; 3]; MAX_LAMPS], len: 0 };

    /// The scales of the first [`MAX_LAMPS`] lamps of `k`.
    pub fn from_slice(k: &[[f32; 3]]) -> Self {
        let mut out = Self::NONE;
        for (dst, src) in out.k.iter_mut().zip(k) {
            *dst = *src;
        }
        out.len = k.len().min(MAX_LAMPS);
        out
    }

    /// The scales, one per lamp.
    pub fn as_slice(&self) -> &[[f32; 3]] {
        &self.k[..self.len]
    }

    /// The scale of lamp `i` (zero past the end: a lamp the lighting says nothing of is dark).
    pub fn get(&self, i: usize) -> [f32; 3] {
        self.as_slice().get(i).copied().unwrap_or([0.0; 3])
    }

    /// True without lamps.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }
}
