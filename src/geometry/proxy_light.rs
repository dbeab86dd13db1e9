//! The proxy's surface light as a lat-long map's texels: what arrives at the surface point each
//! texel shows. `envmap::relight::Relighter::local_light` fills it; `cuts::local_sun` reads it to
//! light a proxy point seen from elsewhere than the capture centre. It lives here, below both, so
//! the two share one type. So does [`LightLeft`], what a real proxy point keeps of its light with
//! the virtual objects present: `cuts::receiver_light` computes it, `render::compositor` applies
//! it to the receivers' `c` and `b`.

use super::raycast::RayScene;
use glam::Vec3;
use std::sync::Arc;

/// The relit map's surface texels as irradiance arriving at their points.
#[derive(Clone)]
pub struct ProxyLight {
    /// Map width.
    pub width: u32,
    /// Map height.
    pub height: u32,
    /// The map's capture centre.
    pub centre: Vec3,
    /// Toward the sun, unit, world frame.
    pub sun: Vec3,
    /// Per texel, irradiance per unit `Pa` at its surface point (`c`; zero on sky).
    pub pa: Vec<Vec3>,
    /// Per texel, the sun's bounce per unit `Pd` at its surface point (`b`; zero on sky).
    pub pd: Vec<Vec3>,
    /// The proxy.
    pub ray: Arc<RayScene>,
}

/// What a receiver has with the objects present: the share it keeps of its `c` (sky and the
/// proxy's interreflected sky) and of its `b` (the sun's bounce off the proxy), each in
/// `[0, 1]`, and the light the objects reflect onto it instead, per unit `Pa` and `Pd`:
/// `c_v = c·ambient + ambient_add`, `b_v = b·bounce + bounce_add`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightLeft {
    /// Share of `c` left.
    pub ambient: f32,
    /// Share of `b` left.
    pub bounce: f32,
    /// Irradiance per unit `Pa` the objects reflect onto the receiver (RGB).
    pub ambient_add: Vec3,
    /// Irradiance per unit `Pd` the objects reflect onto the receiver (RGB).
    pub bounce_add: Vec3,
}

impl LightLeft {
    /// Nothing hidden.
    pub const ALL: Self = Self::both(1.0);

    /// The same share of both and nothing reflected (a receiver weighed by the sky alone).
    pub const fn both(v: f32) -> Self {
        Self { ambient: v, bounce: v, ambient_add: Vec3::ZERO, bounce_add: Vec3::ZERO }
    }
}
