//! The proxy's surface light as a lat-long map's texels: what arrives at the surface point each
//! texel shows. `envmap::relight::Relighter::local_light` fills it; `cuts::local_sun` reads it to
//! light a proxy point seen from elsewhere than the capture centre. It lives here, below both, so
//! the two share one type.

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
