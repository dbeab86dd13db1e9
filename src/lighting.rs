//! The lighting of one frame as a plain value: what a lighting stage emits and a renderer
//! consumes (the arrow between them in the frame loop).
//!
//! The outdoor stage (estimator → relight → probes) fills the sun direction and the sun and sky
//! intensities (crate docs, "Radiometry": `Pd` is the sun's irradiance on a surface facing it,
//! `Pa` the sky's on an unoccluded horizontal surface). The environment relighting, the probe
//! update and the compositor all read this one type.

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
    /// The frame's model took the sky as uniform (an overcast frame of a scene whose
    /// `[estimator.sky]` has a shape; issue 13): the renderer's paths then see the uniform sky,
    /// the terrain kept, instead of the shaped one ([`crate::sky::radiance::SkyModel::for_frame`]).
    /// Without a shaped sky in the scene it changes nothing.
    pub uniform_sky: bool,
}
