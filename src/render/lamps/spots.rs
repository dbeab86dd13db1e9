//! The scene's lamps as the lamp term reads them (`shaders/lamps.wgsl`): one [`GpuSpot`] per
//! far-field lamp and per filter position of a light field, their images in one texel buffer,
//! and the taps of the light fields' support mean.
//!
//! # How it works
//! - **Far field** (`ies`, `spot`, `point`): `E = I(ω) cos θ / r²` at the lamp's position
//!   ([`crate::lamps::FarField`]). Spots and points are evaluated in closed form (the smoothstep
//!   of `lamps::analytic`; a point is a spot whose cone holds every direction). A measured table
//!   is resampled once into a latitude–longitude image of the luminaire frame: row `j` at
//!   `γ = j·180°/(H − 1)` from the `−Z` axis, column `i` at azimuth `φ = i·360°/W` from `+X`
//!   toward `+Y`, read bilinearly (wrapping in `φ`) — [`TABLE_SIZE`] texels, 1° in `γ`.
//! - **Light field** (Granier §3.2, Eq. 13–14): filter position `(m, n)` is a textured spot light
//!   at its centre `c_mn`, `E ≈ f_mn Ē'_mn` with `f = cos θ_S cos θ_x / δ²`. The support mean
//!   `Ē'` of `E'_mn(s(x, u), t(x, v))` over `Φ_mn` is a tensor Gauss rule of `taps` nodes per
//!   axis ([`support_taps`]; nodes of [`crate::lamps::lightfield::reconstruct`]'s `Support`
//!   footprint): along the rays from the nodes through `x` the lookup moves by
//!   `h·o·(1 − d/z')` from the central ray's, so the shader needs the central `(s, t)` and the
//!   offsets only. Zero taps is the single lookup along the central ray (`Footprint::Centre`).
//! - **Storage**: every image is stored as half floats ([`crate::lamps::storage::DEFAULT_STORAGE`],
//!   which says why), divided by a per-lamp power-of-two scale (`storage::image_scale`, the
//!   table's peak for tables) that goes into the spot's `scale`, so intensities of any size fit
//!   the half range. Lookups follow [`LightField::sample`] exactly: bilinear between texel
//!   centres, clamped inside the measurement plane, zero outside it.

use crate::lamps::lightfield::bellq::{bellq, gauss_legendre};
use crate::lamps::model::Model;
use crate::lamps::storage::image_scale;
use crate::lamps::Lamp;
use crate::scene::LightKind;
use exr::prelude::f16;
use glam::{DVec3, Vec3};

/// Latitude–longitude size of a resampled table: 72 azimuths (5°) × 181 angles from the axis (1°).
pub const TABLE_SIZE: [u32; 2] = [72, 181];
/// Most taps per axis of the support mean (4 Gauss points per `h/2` cell).
pub const MAX_TAPS: usize = 16;

/// Kinds of spot (`LampSpot.index.x` in `shaders/lamps.wgsl`).
pub const KIND_ANALYTIC: u32 = 0;
/// A resampled far-field table.
pub const KIND_TABLE: u32 = 1;
/// One filter position of a light field.
pub const KIND_FIELD: u32 = 2;
/// No shadow map.
pub const NO_SLOT: u32 = u32::MAX;

/// Mirrors `LampSpot` in `shaders/lamps.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GpuSpot {
    /// Rows of the luminaire frame from the world: `x_lamp[i] = rows[i].xyz · p + rows[i].w`.
    pub rows: [[f32; 4]; 3],
    /// The spot's centre in the luminaire frame (the filter centre; zero for far-field lamps).
    pub centre: [f32; 4],
    /// The spot's centre in the world.
    pub world: [f32; 4],
    /// `k` times the lamp's unit per channel.
    pub scale: [f32; 4],
    /// Analytic: `cos` of the inner and outer half-angles. Light field: `d`, the plane's width
    /// and height, `h`.
    pub params: [f32; 4],
    /// Kind, shadow slot, first texel, unused.
    pub index: [u32; 4],
    /// Image width and height (texels), unused, unused.
    pub dims: [u32; 4],
}

/// One lamp's spots and what the per-frame planning needs of it.
#[derive(Clone, Debug)]
pub struct LampSpots {
    /// The light's name.
    pub name: String,
    /// Its spots in [`SpotSet::spots`].
    pub range: std::ops::Range<usize>,
    /// Its position in the world.
    pub position: Vec3,
    /// The radius of its emitting area, metres (`Lamp::emitter_radius_m`): the penumbra of its
    /// shadow map when it has one of its own.
    pub emitter_radius_m: f32,
}

/// Every lamp's spots, built once per scene.
#[derive(Clone, Debug, Default)]
pub struct SpotSet {
    /// Per lamp, in scene order.
    pub lamps: Vec<LampSpots>,
    /// Every spot, `scale` holding the lamp's unit (`k = 1`) and no shadow slot.
    pub spots: Vec<GpuSpot>,
    /// Half-float RGB texels (binary16 bits: `r | g << 16`, `b`).
    pub texels: Vec<[u32; 2]>,
    /// The lamps, for the reach test.
    models: Vec<Lamp>,
}

fn pack(rgb: [f32; 3]) -> [u32; 2] {
    let h = |c: f32| f16::from_f32(c).to_bits() as u32;
    [h(rgb[0]) | (h(rgb[1]) << 16), h(rgb[2])]
}

/// The world-to-luminaire rows and the world position of the luminaire-frame point `c`.
fn frame_rows(lamp: &Lamp, c: DVec3) -> ([[f32; 4]; 3], [f32; 4]) {
    let r = lamp.light.world_from_lamp;
    let p = lamp.light.position;
    let row = |axis: DVec3| [axis.x as f32, axis.y as f32, axis.z as f32, -axis.dot(p) as f32];
    let world = p + r * c;
    ([row(r.x_axis), row(r.y_axis), row(r.z_axis)], [world.x as f32, world.y as f32, world.z as f32, 1.0])
}

/// Direction of texel `(i, j)` of a latitude–longitude table image (module docs).
pub fn table_dir(i: u32, j: u32) -> DVec3 {
    let gamma = j as f64 * std::f64::consts::PI / (TABLE_SIZE[1] - 1) as f64;
    let phi = i as f64 * 2.0 * std::f64::consts::PI / TABLE_SIZE[0] as f64;
    DVec3::new(gamma.sin() * phi.cos(), gamma.sin() * phi.sin(), -gamma.cos())
}

impl SpotSet {
    /// The spots of `lamps` (scene order).
    pub fn new(lamps: &[Lamp]) -> Self {
        let mut set = SpotSet { models: lamps.to_vec(), ..Default::default() };
        for lamp in lamps {
            let start = set.spots.len();
            set.push_lamp(lamp);
            let p = lamp.light.position;
            set.lamps.push(LampSpots {
                name: lamp.light.name.clone(),
                range: start..set.spots.len(),
                position: Vec3::new(p.x as f32, p.y as f32, p.z as f32),
                emitter_radius_m: lamp.emitter_radius_m() as f32,
            });
        }
        set
    }

    fn push_lamp(&mut self, lamp: &Lamp) {
        let (rows, world) = frame_rows(lamp, DVec3::ZERO);
        let first = self.texels.len() as u32;
        let mut spot = GpuSpot { rows, centre: [0.0; 4], world, scale: [1.0; 4], params: [0.0; 4], index: [KIND_ANALYTIC, NO_SLOT, 0, 0], dims: [0; 4] };
        match (&lamp.model, &lamp.light.kind) {
            (Model::Field(lf), _) => {
                let (img0, g) = (&lf.images()[0], *lf.grid());
                let scale = lf.images().iter().map(image_scale).fold(0.0f32, f32::max).max(f32::MIN_POSITIVE);
                for img in lf.images() {
                    self.texels.extend(img.data.iter().map(|&p| pack(p.map(|c| c / scale))));
                }
                let size = lf.size_m();
                for n in 0..g.counts[1] {
                    for m in 0..g.counts[0] {
                        let c = g.centre(m, n).extend(0.0);
                        let (rows, world) = frame_rows(lamp, c);
                        let texel = first + (g.index(m, n) * (img0.width * img0.height) as usize) as u32;
                        self.spots.push(GpuSpot {
                            rows,
                            centre: [c.x as f32, c.y as f32, 0.0, 0.0],
                            world,
                            scale: [scale; 4],
                            params: [lf.distance_m() as f32, size[0] as f32, size[1] as f32, g.spacing_m as f32],
                            index: [KIND_FIELD, NO_SLOT, texel, 0],
                            dims: [img0.width, img0.height, 0, 0],
                        });
                    }
                }
                return;
            }
            (Model::Table(t), _) => {
                let values: Vec<f32> = (0..TABLE_SIZE[1]).flat_map(|j| (0..TABLE_SIZE[0]).map(move |i| (i, j))).map(|(i, j)| t.intensity_cd(table_dir(i, j)) as f32).collect();
                let peak = values.iter().fold(0.0f32, |a, v| a.max(v.abs())).max(f32::MIN_POSITIVE);
                self.texels.extend(values.iter().map(|v| pack([v / peak; 3])));
                spot.scale = [peak; 4];
                spot.index = [KIND_TABLE, NO_SLOT, first, 0];
                spot.dims = [TABLE_SIZE[0], TABLE_SIZE[1], 0, 0];
            }
            (_, LightKind::Spot { intensity_cd, inner_deg, outer_deg }) => {
                spot.scale = [*intensity_cd as f32; 4];
                spot.params = [inner_deg.to_radians().cos() as f32, outer_deg.to_radians().cos() as f32, 0.0, 0.0];
            }
            (_, LightKind::Point { intensity_cd }) => {
                // Every direction inside the inner cone: a point.
                spot.scale = [*intensity_cd as f32; 4];
                spot.params = [-2.0, -3.0, 0.0, 0.0];
            }
            (_, LightKind::Ies { .. } | LightKind::LightField { .. }) => {
                // A model that does not match its kind cannot be built by `Lamp::load`.
                spot.scale = [0.0; 4];
            }
        }
        self.spots.push(spot);
    }

    /// Why lamp `i`'s light cannot reach the box `lo..hi` (`None`: it may). Conservative: a
    /// lamp is kept unless its emission provably misses the box's bounding sphere.
    pub fn misses(&self, i: usize, lo: Vec3, hi: Vec3) -> Option<String> {
        let lamp = self.models.get(i)?;
        let (centre, radius) = ((0.5 * (lo + hi)).as_dvec3(), (0.5 * (hi - lo)).length() as f64);
        let to = lamp.light.lamp_from_world_point(centre);
        let dist = to.length();
        if dist <= radius {
            return None;
        }
        let spread = (radius / dist).asin();
        let dir = to / dist;
        // Angle of the box seen from the lamp, from the luminaire's −Z axis.
        let from_axis = (-dir.z).clamp(-1.0, 1.0).acos();
        match (&lamp.model, &lamp.light.kind) {
            (Model::Field(_), _) => {
                // Light fields light only what lies in front of their sampling plane (z < 0).
                let corners = (0..8).map(|k| Vec3::new(if k & 1 == 0 { lo.x } else { hi.x }, if k & 2 == 0 { lo.y } else { hi.y }, if k & 4 == 0 { lo.z } else { hi.z }));
                let front = corners.map(|p| lamp.light.lamp_from_world_point(p.as_dvec3()).z).any(|z| z < 0.0);
                (!front).then(|| "the objects' bounds are behind its sampling plane".to_owned())
            }
            (Model::Table(t), _) => {
                // Any table direction within the box's cone (plus one texel) with light.
                let texel = (2.0 * std::f64::consts::PI / TABLE_SIZE[0] as f64).max(std::f64::consts::PI / (TABLE_SIZE[1] - 1) as f64);
                let cos_max = (spread + texel).min(std::f64::consts::PI).cos();
                let lit = (0..TABLE_SIZE[1]).any(|j| (0..TABLE_SIZE[0]).any(|i| {
                    let d = table_dir(i, j);
                    d.dot(dir) >= cos_max && t.intensity_cd(d) > 0.0
                }));
                (!lit).then(|| "its photometric table gives no light toward the objects' bounds".to_owned())
            }
            (_, LightKind::Spot { outer_deg, .. }) => (from_axis - spread > outer_deg.to_radians())
                .then(|| format!("the objects' bounds are {:.1}° off its axis, outside its {outer_deg}° cone", from_axis.to_degrees())),
            _ => None,
        }
    }
}

/// The taps of the support mean with `points` Gauss points per `h/2` cell: `(offset in units of
/// h, weight)` per axis, the weights summing to 1 (module docs). Empty for `points = 0`.
pub fn support_taps(points: usize) -> Vec<[f32; 4]> {
    if points == 0 {
        return Vec::new();
    }
    let rule = gauss_legendre(points.min(MAX_TAPS / 4));
    // Four cells of width ½ over [−1, 1], as `Footprint::Support` integrates.
    let nodes: Vec<(f64, f64)> = (0..4).flat_map(|i| rule.iter().map(move |&(x, w)| (-1.0 + 0.5 * (i as f64 + 0.5 + 0.5 * x), 0.25 * w * bellq(-1.0 + 0.5 * (i as f64 + 0.5 + 0.5 * x))))).collect();
    let sum: f64 = nodes.iter().map(|n| n.1).sum();
    nodes.iter().map(|&(o, w)| [o as f32, (w / sum) as f32, 0.0, 0.0]).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn support_taps_integrate_the_basis_and_stay_inside_the_support() {
        for k in 1..=4 {
            let taps = support_taps(k);
            assert_eq!(taps.len(), 4 * k);
            let sum: f32 = taps.iter().map(|t| t[1]).sum();
            assert!((sum - 1.0).abs() < 1e-6, "{k}: {sum}");
            assert!(taps.iter().all(|t| t[0].abs() < 1.0 && t[1] > 0.0));
            // symmetric: the mean offset is zero
            let m1: f32 = taps.iter().map(|t| t[0] * t[1]).sum();
            assert!(m1.abs() < 1e-6);
        }
        // The second moment of the normalised basis: 3 and 4 points per cell integrate its
        // quadratic pieces times x² (degree 4) exactly, so they agree.
        let m2 = |k: usize| support_taps(k).iter().map(|t| t[0] * t[0] * t[1]).sum::<f32>();
        assert!((m2(3) - m2(4)).abs() < 1e-6);
        assert!(support_taps(0).is_empty());
    }

    #[test]
    fn table_directions_cover_the_sphere_from_the_axis() {
        assert!((table_dir(0, 0) - DVec3::NEG_Z).length() < 1e-12);
        assert!((table_dir(5, TABLE_SIZE[1] - 1) - DVec3::Z).length() < 1e-12);
        // γ = 90°, φ = 90°: +Y
        assert!((table_dir(TABLE_SIZE[0] / 4, (TABLE_SIZE[1] - 1) / 2) - DVec3::Y).length() < 1e-12);
    }

    fn lamp(kind: LightKind, position: DVec3, aim: DVec3, model: Model) -> Lamp {
        use crate::scene::lights::world_from_lamp;
        use crate::scene::{Light, Schedule};
        let light = Light { name: "l".into(), field: "lights[0]".into(), kind, position, world_from_lamp: world_from_lamp(aim, 0.0).unwrap(), scale: 1.0, schedule: Schedule::Always };
        Lamp { light, model }
    }

    #[test]
    fn lamps_that_cannot_reach_the_box_say_why_and_the_others_are_kept() {
        use crate::lamps::photometry::{Goniometric, PhotometricType, Symmetry};
        use crate::lamps::SpotLight;
        let (lo, hi) = (Vec3::new(-0.5, 0.0, -0.5), Vec3::new(0.5, 1.0, 0.5));
        let above = DVec3::new(0.0, 4.0, 0.0);
        let spot_kind = LightKind::Spot { intensity_cd: 100.0, inner_deg: 10.0, outer_deg: 20.0 };
        let spot_model = Model::Spot(SpotLight::new(100.0, DVec3::NEG_Z, 10.0, 20.0).unwrap());
        // A narrow table: light only within 15° of the axis.
        let v: Vec<f64> = (0..=180).map(f64::from).collect();
        let table = Goniometric::from_fn(PhotometricType::C, Symmetry::Rotational, &[0.0], &v, |_, g| if g <= 15.0 { 50.0 } else { 0.0 }).unwrap();
        let lamps = vec![
            lamp(spot_kind.clone(), above, DVec3::NEG_Y, spot_model.clone()),
            lamp(spot_kind, above, DVec3::X, spot_model),
            lamp(LightKind::Ies { path: "t.ies".into() }, above, DVec3::NEG_Y, Model::Table(table.clone())),
            lamp(LightKind::Ies { path: "t.ies".into() }, above, DVec3::new(1.0, -0.3, 0.0), Model::Table(table)),
            lamp(LightKind::Point { intensity_cd: 1.0 }, above, DVec3::Y, Model::Point(crate::lamps::PointLight::new(1.0).unwrap())),
        ];
        let set = SpotSet::new(&lamps);
        assert_eq!(set.spots.len(), 5);
        assert_eq!(set.misses(0, lo, hi), None);
        assert!(set.misses(1, lo, hi).unwrap().contains("outside its 20° cone"));
        assert_eq!(set.misses(2, lo, hi), None);
        assert!(set.misses(3, lo, hi).unwrap().contains("no light toward"));
        // a point lights every direction, whatever its aim
        assert_eq!(set.misses(4, lo, hi), None);
        // the box around the lamp: always reached
        assert_eq!(set.misses(1, Vec3::splat(-5.0), Vec3::splat(5.0)), None);
    }

    #[test]
    fn a_light_field_is_one_spot_per_filter_position_at_its_centre() {
        use crate::io::image::LinearImage;
        use crate::lamps::lightfield::{FilterGrid, LightField};
        let grid = FilterGrid { counts: [3, 2], spacing_m: 0.01 };
        let lf = LightField::new(grid, 0.5, [2.0, 2.0], vec![LinearImage::from_fn(4, 4, |x, _| [x as f32 * 3.0, 1.0, -2.0]); 6], std::path::Path::new("<test>")).unwrap();
        let pos = DVec3::new(1.0, 3.0, -2.0);
        let l = lamp(LightKind::LightField { dir: "<memory>".into() }, pos, DVec3::NEG_Y, Model::Field(Box::new(lf)));
        let set = SpotSet::new(std::slice::from_ref(&l));
        assert_eq!(set.spots.len(), 6);
        assert_eq!(set.texels.len(), 6 * 16);
        // the images are divided by the power of two above their peak (9 → 16)
        assert!(set.spots.iter().all(|s| s.scale[0] == 16.0 && s.index[0] == KIND_FIELD));
        assert_eq!(set.texels[3][0] & 0xffff, f16::from_f32(9.0 / 16.0).to_bits() as u32);
        // spot (m, n) = (2, 1): centre (h, h/2) in the luminaire frame; its world place and rows
        // map it back there
        let s = set.spots[grid.index(2, 1)];
        assert_eq!(s.index[2], grid.index(2, 1) as u32 * 16);
        let w = Vec3::new(s.world[0], s.world[1], s.world[2]);
        let back = s.rows.map(|r| Vec3::new(r[0], r[1], r[2]).dot(w) + r[3]);
        assert!((back[0] - 0.01).abs() < 1e-5 && (back[1] - 0.005).abs() < 1e-5 && back[2].abs() < 1e-5, "{back:?}");
        // behind its sampling plane (above a lamp aimed down) it cannot light a box
        assert!(set.misses(0, Vec3::new(0.5, 4.0, -2.5), Vec3::new(1.5, 5.0, -1.5)).unwrap().contains("behind"));
        assert_eq!(set.misses(0, Vec3::new(0.5, 0.0, -2.5), Vec3::new(1.5, 1.0, -1.5)), None);
    }

    #[test]
    fn halves_pack_low_then_high() {
        let [a, b] = pack([1.0, -2.0, 0.5]);
        assert_eq!(a & 0xffff, f16::from_f32(1.0).to_bits() as u32);
        assert_eq!(a >> 16, f16::from_f32(-2.0).to_bits() as u32);
        assert_eq!(b, f16::from_f32(0.5).to_bits() as u32);
    }
}
