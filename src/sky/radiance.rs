//! The light a path that leaves the proxy brings back: the scene's one sky, shared by every
//! stage that traces paths (issue 13, "one sky model is used everywhere").
//!
//! A direction above the horizon sees the sky: uniform (Jensen §3.1, radiance `Pa/π`) or the
//! Hošek–Wilkie shape for the frame's sun ([`ShapedSky`], normalised per channel to unit
//! irradiance on an open horizontal surface, so its weight stays `Pa`, the crate's definition). A
//! direction below it sees the distant terrain of [`super::terrain`]: Lambertian of albedo `ρ_t`,
//! radiance `ρ_t/π·(Pa + max(l_y, 0)·Pd)`. Both stay linear in `Pa` and `Pd`, so every integral
//! keeps its two coefficients per channel.
//!
//! [`SkyRadiance::escape`] returns `π` times the radiance per unit `Pa` and per unit `Pd`, the form
//! a cosine-sampled estimator adds directly: exactly `(1, 0)` for the uniform sky above the
//! horizon and `(0, 0)` below it without terrain, so paths traced under Jensen's model give the
//! same bits as before this module existed.

use super::SkyError;
use super::hosek::HosekSky;
use super::quadrature::hemisphere_integral_rgb;
use glam::Vec3;
use std::f32::consts::PI;

/// The Hošek–Wilkie sky for one sun, normalised to unit horizontal irradiance per channel.
#[derive(Clone, Debug)]
pub struct ShapedSky {
    sky: HosekSky,
    norm: [f32; 3],
}

impl ShapedSky {
    /// The sky of turbidity `turbidity` over ground of albedo `ground` (the model's own input)
    /// for the sun toward `sun_dir_world` (a sun below the horizon is lifted onto it,
    /// [`super::ShapeSun`]). `field` names the setting in errors.
    pub fn hosek(sun_dir_world: Vec3, turbidity: f64, ground: [f32; 3], field: &'static str) -> Result<Self, SkyError> {
        let ground = ground.map(|v| v.clamp(0.0, 1.0) as f64);
        let sky = HosekSky::new(sun_dir_world, turbidity, ground)?;
        let integral = hemisphere_integral_rgb(|d| sky.radiance_rgb(d.as_vec3()).map(f64::from));
        let norm: [f32; 3] = integral.map(|v| (1.0 / v) as f32);
        if norm.iter().any(|v| !v.is_finite() || *v <= 0.0) {
            return Err(SkyError::Parameter { field, reason: "gives a sky without light", value: turbidity });
        }
        Ok(Self { sky, norm })
    }

    /// Radiance toward `d` per unit `Pa`, per channel (0 below the horizon).
    #[inline]
    pub fn eval(&self, d: Vec3) -> [f32; 3] {
        let r = self.sky.radiance_rgb(d);
        [r[0] * self.norm[0], r[1] * self.norm[1], r[2] * self.norm[2]]
    }
}

/// The scene's sky as a function of the sun: what builds each frame's [`SkyRadiance`].
#[derive(Clone, Debug, PartialEq)]
pub struct SkyModel {
    /// Turbidity of the Hošek–Wilkie shape; `None` for the uniform sky.
    pub hosek_turbidity: Option<f64>,
    /// Albedo of the terrain below the horizon (zero: none).
    pub terrain_albedo: [f32; 3],
}

impl SkyModel {
    /// Jensen's model.
    pub fn uniform() -> Self {
        Self { hosek_turbidity: None, terrain_albedo: [0.0; 3] }
    }

    /// True for Jensen's model: nothing traced under it depends on the sun.
    pub fn is_uniform(&self) -> bool {
        self.hosek_turbidity.is_none() && self.terrain_albedo == [0.0; 3]
    }

    /// The model of one frame (`FrameSky`, what the frame's estimate used): the scene's; under
    /// an overcast frame (which the estimator fits with the uniform sky; issue 13) the uniform
    /// sky with the same terrain; under a turbidity chosen by residual the scene's shape with
    /// that turbidity (a scene without a shape stays as it is).
    ///
    /// `(uniform, turbidity)` is the frame's `crate::lighting::FrameSky` as plain values
    /// (`FrameSky::parts`), so that this leaf does not import the lighting value.
    pub fn for_frame(&self, (uniform, turbidity): (bool, Option<f64>)) -> SkyModel {
        match (uniform, turbidity) {
            (true, _) => Self { hosek_turbidity: None, terrain_albedo: self.terrain_albedo },
            (false, Some(t)) => Self { hosek_turbidity: self.hosek_turbidity.map(|_| t), terrain_albedo: self.terrain_albedo },
            (false, None) => self.clone(),
        }
    }

    /// True when the change from `self` to `to` is a change of the shape's turbidity alone
    /// (both shaped, the same terrain): the stages then re-trace as after a sun move, a slice
    /// per frame while the values traced under `self` serve, instead of dropping them as on a
    /// switch between the uniform sky and a shaped one.
    pub fn reshapes_to(&self, to: &SkyModel) -> bool {
        self.hosek_turbidity.is_some() && to.hosek_turbidity.is_some() && self.terrain_albedo == to.terrain_albedo
    }

    /// True when the sky's shape depends on the sun's direction (a Hošek–Wilkie shape), so
    /// paths traced under it must know where the sun is even on a frame without sun light.
    pub fn follows_sun(&self) -> bool {
        self.hosek_turbidity.is_some()
    }

    /// How the reports name the model (as the estimator's `sky_model`).
    pub fn name(&self) -> String {
        match self.hosek_turbidity {
            Some(t) => format!("hosek_wilkie T={t}"),
            None => "uniform".to_owned(),
        }
    }

    /// The sky for the sun toward `sun` (`None`: no sun, so the uniform shape and an unlit
    /// terrain). A shape the model cannot build (an invalid direction) falls back to uniform.
    pub fn for_sun(&self, sun: Option<Vec3>) -> SkyRadiance {
        let shape = match (self.hosek_turbidity, sun) {
            (Some(t), Some(l)) => ShapedSky::hosek(l, t, self.terrain_albedo, "sky").ok(),
            _ => None,
        };
        SkyRadiance::new(shape, self.terrain_albedo, sun.map_or(0.0, |l| l.y))
    }
}

/// The sky and terrain one frame's paths see (module docs).
#[derive(Clone, Debug)]
pub struct SkyRadiance {
    shape: Option<ShapedSky>,
    /// `ρ_t`: `π` × the terrain's radiance per unit `Pa`.
    terrain: Vec3,
    /// `ρ_t·max(l_y, 0)`: the same per unit `Pd`.
    terrain_sun: Vec3,
}

impl SkyRadiance {
    /// Jensen's model: the uniform sky, nothing below the horizon.
    pub fn uniform() -> Self {
        Self { shape: None, terrain: Vec3::ZERO, terrain_sun: Vec3::ZERO }
    }

    /// `shape` (`None`: uniform) above the horizon, and terrain of albedo `terrain_albedo` lit
    /// by a sun of elevation sine `sun_y` (0 when the sun is below the horizon or absent).
    pub fn new(shape: Option<ShapedSky>, terrain_albedo: [f32; 3], sun_y: f32) -> Self {
        let terrain = Vec3::from(terrain_albedo);
        Self { shape, terrain, terrain_sun: terrain * sun_y.max(0.0) }
    }

    /// True for Jensen's model (uniform, no terrain): the paths' results do not depend on the sun.
    pub fn is_uniform(&self) -> bool {
        self.shape.is_none() && self.terrain == Vec3::ZERO
    }

    /// The sky's shape, `None` for the uniform sky.
    pub fn shape(&self) -> Option<&ShapedSky> {
        self.shape.as_ref()
    }

    /// `π` × the radiance toward `d` (unit) per unit `Pa` and per unit `Pd`, or `None` where
    /// nothing comes back (below the horizon without terrain).
    #[inline]
    pub fn escape(&self, d: Vec3) -> Option<(Vec3, Vec3)> {
        if d.y > 0.0 {
            return Some(match &self.shape {
                None => (Vec3::ONE, Vec3::ZERO),
                Some(s) => (Vec3::from(s.eval(d)) * PI, Vec3::ZERO),
            });
        }
        (self.terrain != Vec3::ZERO).then_some((self.terrain, self.terrain_sun))
    }
}

impl crate::geometry::ambient::Escape for SkyRadiance {
    #[inline]
    fn escape(&self, d: Vec3) -> Option<(Vec3, Vec3)> {
        SkyRadiance::escape(self, d)
    }
}

/// A sky minus Jensen's uniform one (its terrain kept): traced along the same paths as a sun
/// bounce, its `c` is the change of the weighted-ambient factor that the sky's shape and the
/// terrain bring, so a `c` traced once under the uniform sky (the bake's, with more paths) serves
/// as control variate: `c_sky = c_uniform + Δc`, at no extra trace.
pub struct ShapeMinusUniform<'a>(pub &'a SkyRadiance);

impl crate::geometry::ambient::Escape for ShapeMinusUniform<'_> {
    #[inline]
    fn escape(&self, d: Vec3) -> Option<(Vec3, Vec3)> {
        let (pa, pd) = self.0.escape(d)?;
        Some(if d.y > 0.0 { (pa - Vec3::ONE, pd) } else { (pa, pd) })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lighting::FrameSky;
    use crate::sky::quadrature::hemisphere_integral_rgb;

    #[test]
    fn the_uniform_sky_gives_exactly_one_above_and_nothing_below() {
        let s = SkyRadiance::uniform();
        assert!(s.is_uniform());
        assert_eq!(s.escape(Vec3::new(0.3, 0.1, 0.9).normalize()), Some((Vec3::ONE, Vec3::ZERO)));
        assert_eq!(s.escape(Vec3::new(0.3, -0.1, 0.9).normalize()), None);
    }

    #[test]
    fn a_shaped_sky_gives_unit_horizontal_irradiance_per_channel() {
        // ∫ escape/π · cos over the upper hemisphere = 1 (the definition of `Pa`).
        let shape = ShapedSky::hosek(Vec3::new(0.8, 0.1, -0.2), 3.0, [0.8; 3], "test").unwrap();
        let s = SkyRadiance::new(Some(shape), [0.0; 3], 0.1);
        let e = hemisphere_integral_rgb(|d| s.escape(d.as_vec3()).map_or([0.0; 3], |(a, _)| (a / PI).to_array().map(f64::from)));
        for c in e {
            assert!((c - 1.0).abs() < 1e-3, "{e:?}");
        }
        // Brighter toward the low sun than away from it at the same elevation.
        let toward = s.escape(Vec3::new(0.8, 0.15, -0.2).normalize()).unwrap().0;
        let away = s.escape(Vec3::new(-0.8, 0.15, 0.2).normalize()).unwrap().0;
        assert!(toward.x > 2.0 * away.x, "{toward} {away}");
    }

    #[test]
    fn an_overcast_frame_keeps_the_terrain_and_drops_the_shape() {
        let m = SkyModel { hosek_turbidity: Some(3.0), terrain_albedo: [0.8, 0.8, 0.82] };
        assert_eq!(m.for_frame(FrameSky::Declared.parts()), m);
        assert_eq!(m.for_frame(FrameSky::Uniform.parts()), SkyModel { hosek_turbidity: None, terrain_albedo: [0.8, 0.8, 0.82] });
        assert_eq!(SkyModel::uniform().for_frame(FrameSky::Uniform.parts()), SkyModel::uniform());
        // The overcast sky above the horizon is exactly the uniform one.
        let s = m.for_frame(FrameSky::Uniform.parts()).for_sun(Some(Vec3::new(0.5, 0.3, 0.1)));
        assert_eq!(s.escape(Vec3::new(0.2, 0.5, 0.1).normalize()), Some((Vec3::ONE, Vec3::ZERO)));
        assert!(!m.reshapes_to(&m.for_frame(FrameSky::Uniform.parts())) && !m.for_frame(FrameSky::Uniform.parts()).reshapes_to(&m));
    }

    #[test]
    fn a_fitted_turbidity_reshapes_a_shaped_sky_only() {
        let m = SkyModel { hosek_turbidity: Some(3.0), terrain_albedo: [0.5; 3] };
        let fitted = m.for_frame(FrameSky::Turbidity(6.0).parts());
        assert_eq!(fitted, SkyModel { hosek_turbidity: Some(6.0), terrain_albedo: [0.5; 3] });
        assert!(m.reshapes_to(&fitted) && fitted.reshapes_to(&m));
        assert_eq!((m.name(), fitted.name()), ("hosek_wilkie T=3".to_owned(), "hosek_wilkie T=6".to_owned()));
        // Jensen's model has no shape to reshape.
        assert_eq!(SkyModel::uniform().for_frame(FrameSky::Turbidity(6.0).parts()), SkyModel::uniform());
        // A hazier sky puts more of its light near the horizon away from the sun.
        let sun = Some(Vec3::new(0.8, 0.15, -0.2).normalize());
        let away = Vec3::new(-0.8, 0.1, 0.2).normalize();
        let (a3, a6) = (m.for_sun(sun).escape(away).unwrap().0, fitted.for_sun(sun).escape(away).unwrap().0);
        assert!((a3 - a6).abs().max_element() > 0.05 * a3.max_element(), "{a3} {a6}");
    }

    #[test]
    fn terrain_is_linear_in_pa_and_pd() {
        let s = SkyRadiance::new(None, [0.8, 0.8, 0.82], 0.5);
        let (pa, pd) = s.escape(Vec3::new(0.0, -0.2, 1.0).normalize()).unwrap();
        assert_eq!(pa, Vec3::new(0.8, 0.8, 0.82));
        assert_eq!(pd, Vec3::new(0.4, 0.4, 0.41));
        // A sun below the horizon lights no terrain.
        assert_eq!(SkyRadiance::new(None, [0.8; 3], -0.3).escape(-Vec3::Y).unwrap().1, Vec3::ZERO);
    }

    /// A scene with one small triangle far away: nothing occludes the test points.
    fn open_scene() -> crate::geometry::raycast::RayScene {
        use crate::geometry::{Material, Mesh, NodeInfo};
        let mut m = Mesh::default();
        m.positions.extend([Vec3::new(1e4, 1e4, 1e4), Vec3::new(1e4 + 1.0, 1e4, 1e4), Vec3::new(1e4, 1e4 + 1.0, 1e4)]);
        m.uvs.extend([glam::Vec2::ZERO; 3]);
        m.triangles.push([0, 1, 2]);
        m.tri_node.push(0);
        m.tri_material.push(0);
        m.nodes.push(NodeInfo { name: "far".into(), diffuse: false });
        m.materials.push(Material::default());
        crate::geometry::raycast::RayScene::new(m)
    }

    #[test]
    fn paths_under_the_scenes_sky_meet_the_closed_forms_in_open_space() {
        use crate::geometry::ambient::{TransportQuality, transport_under};
        let scene = open_scene();
        let sun = Vec3::new(0.6, 0.35, -0.2).normalize();
        let model = SkyModel { hosek_turbidity: Some(3.0), terrain_albedo: [0.8, 0.8, 0.82] };
        let sky = model.for_sun(Some(sun));
        let q = TransportQuality { paths: 4096, max_bounces: 2 };
        // Facing up: the shaped sky's unit horizontal irradiance, whatever its shape (Monte Carlo
        // over 4096 stratified paths: within 2%); no terrain in view.
        let up = transport_under(&scene, Vec3::ZERO, Vec3::Y, Some(sun), &sky, q, 1);
        assert!((up.c - Vec3::ONE).abs().max_element() < 0.02 && up.b == Vec3::ZERO, "{up:?}");
        // Facing down: only terrain, `c = ρ_t` and `b = ρ_t·l_y` exactly (every path escapes below).
        let down = transport_under(&scene, Vec3::ZERO, -Vec3::Y, Some(sun), &sky, q, 2);
        let rho_t = Vec3::new(0.8, 0.8, 0.82);
        assert!((down.c - rho_t).abs().max_element() < 1e-4, "{down:?}"); // f32 sums of 4096 terms
        assert!((down.b - rho_t * sun.y).abs().max_element() < 1e-4, "{down:?}");
        // The change against the uniform sky along the same paths: zero facing up (both give unit
        // irradiance), up to the shape's Monte Carlo noise.
        let delta = transport_under(&scene, Vec3::ZERO, Vec3::Y, Some(sun), &ShapeMinusUniform(&sky), q, 1);
        assert!(delta.c.abs().max_element() < 0.02, "{delta:?}");
        // A wall facing the low sun sees more of the shaped sky than of the uniform one (½).
        let toward = Vec3::new(sun.x, 0.0, sun.z).normalize();
        let wall = transport_under(&scene, Vec3::ZERO, toward, Some(sun), &sky, q, 3);
        assert!(wall.c.x > 0.5 + 0.8 * 0.5 && wall.c.x < 2.0, "{wall:?}");
    }
}
