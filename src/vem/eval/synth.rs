//! Synthetic video environment maps: the skies of `tools/gen_vem`, the tests and the sweeps.
//!
//! Two analytic environments, each a smooth radiance function plus small "suns" whose energy is
//! splatted exactly (their discs are far smaller than a pixel or texel):
//! - [`outdoor`]: a clear-sky gradient with a circumsolar glow, a sun moving along an arc (a
//!   time-lapse: 0.4° per frame) and soft clouds drifting across it, one of which covers the sun
//!   from about frame 6 to 14;
//! - [`indoor_lamp`]: a dim room with a window and a ceiling lamp whose output flickers at
//!   115 Hz (a PWM dimmer), which a 21 Hz capture aliases to 10 Hz: the flicker Havran's
//!   temporal filter is for (§3.3, "the first source of flickering").
//!
//! [`render_polar`] and [`render_fisheye`] turn an environment into a polar map or a fisheye HDR
//! image (box-filtered, with the suns splatted bilinearly so that they move smoothly).

use crate::camera::Camera;
use crate::vem::polar::{PolarMap, dir_from_polar};
use crate::io::image::LinearImage;
use glam::{DVec2, Vec3};

/// A distant lighting environment over the upper hemisphere.
pub trait Environment {
    /// Radiance of the smooth part (everything but the suns) in direction `d`.
    fn radiance(&self, d: Vec3) -> [f32; 3];
    /// Compact sources: unit direction and irradiance (RGB) at normal incidence.
    fn suns(&self) -> Vec<(Vec3, [f32; 3])>;
}

/// A soft, drifting cloud.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cloud {
    /// Centre direction (unit).
    pub centre: Vec3,
    /// Angular radius, radians (the edge is soft over the outer 40%).
    pub radius: f32,
    /// Opacity at the centre, 0…1.
    pub opacity: f32,
    /// Radiance of the cloud itself.
    pub rgb: [f32; 3],
}

impl Cloud {
    /// `rgb` (the sky's radiance along `d`) seen through `clouds`, each composited over it.
    pub fn over(clouds: &[Cloud], d: Vec3, mut rgb: [f32; 3]) -> [f32; 3] {
        for cl in clouds {
            let a = cl.cover(d);
            for k in 0..3 {
                rgb[k] = rgb[k] * (1.0 - a) + cl.rgb[k] * a;
            }
        }
        rgb
    }

    /// The fraction of a source toward `dir` that `clouds` let through.
    pub fn transmission(clouds: &[Cloud], dir: Vec3) -> f32 {
        clouds.iter().map(|c| 1.0 - c.cover(dir)).product()
    }

    /// Opacity along `d`.
    pub fn cover(&self, d: Vec3) -> f32 {
        let a = d.dot(self.centre).clamp(-1.0, 1.0).acos() / self.radius;
        let t = ((1.0 - a) / 0.4).clamp(0.0, 1.0);
        self.opacity * t * t * (3.0 - 2.0 * t)
    }
}

/// A clear sky with a sun and clouds.
#[derive(Clone, Debug, PartialEq)]
pub struct OutdoorSky {
    /// Unit direction to the sun.
    pub sun_dir: Vec3,
    /// Sun irradiance at normal incidence when unoccluded.
    pub sun_irradiance: [f32; 3],
    /// Zenith sky radiance.
    pub zenith: [f32; 3],
    /// The clouds.
    pub clouds: Vec<Cloud>,
}

impl Environment for OutdoorSky {
    fn radiance(&self, d: Vec3) -> [f32; 3] {
        let horizon = 1.0 + 1.5 * (1.0 - d.y.clamp(0.0, 1.0)).powi(3);
        let gamma = d.dot(self.sun_dir).clamp(-1.0, 1.0).acos();
        let glow = 4.0 * (-gamma / 0.12).exp() + 0.6 * (-gamma / 0.6).exp();
        let c: [f32; 3] = std::array::from_fn(|k| self.zenith[k] * horizon + glow * [1.0, 0.9, 0.75][k]);
        Cloud::over(&self.clouds, d, c)
    }

    fn suns(&self) -> Vec<(Vec3, [f32; 3])> {
        let t = Cloud::transmission(&self.clouds, self.sun_dir);
        if self.sun_dir.y <= 0.0 || t <= 0.0 {
            return vec![];
        }
        vec![(self.sun_dir, self.sun_irradiance.map(|e| e * t))]
    }
}

/// A room with a window and a flickering ceiling lamp.
#[derive(Clone, Debug, PartialEq)]
pub struct IndoorRoom {
    /// Lamp direction (unit).
    pub lamp_dir: Vec3,
    /// Lamp angular radius, radians.
    pub lamp_radius: f32,
    /// Lamp radiance at this instant.
    pub lamp_rgb: [f32; 3],
}

impl Environment for IndoorRoom {
    fn radiance(&self, d: Vec3) -> [f32; 3] {
        // Walls and ceiling: dim, warmer toward the lamp.
        let near = (d.dot(self.lamp_dir).max(0.0)).powi(4);
        let mut c = [0.15 + 0.25 * near, 0.13 + 0.2 * near, 0.11 + 0.12 * near];
        // Window toward +X: 50° wide, 5°–35° elevation.
        let el = d.y.clamp(-1.0, 1.0).asin().to_degrees();
        let az = d.z.atan2(d.x).to_degrees();
        if (5.0..35.0).contains(&el) && az.abs() < 25.0 {
            c = [2.4, 2.7, 3.0];
        }
        if d.dot(self.lamp_dir) >= self.lamp_radius.cos() {
            c = self.lamp_rgb;
        }
        c
    }

    fn suns(&self) -> Vec<(Vec3, [f32; 3])> {
        vec![]
    }
}

/// Capture rate of the generated sequences, Hz (the paper's).
pub const RATE_HZ: f64 = 21.0;

/// Frame `k` of the outdoor sequence at `rate_hz`.
pub fn outdoor(k: usize, rate_hz: f64) -> OutdoorSky {
    let t = k as f32;
    // Sun: azimuth 200° → +0.4°/frame, elevation 35° → +0.1°/frame (a time-lapse).
    let az = (200.0 + 0.4 * t).to_radians();
    let el = (35.0 + 0.1 * t).to_radians();
    // North is −Z, east +X: azimuth clockwise from north.
    let sun_dir = Vec3::new(el.cos() * az.sin(), el.sin(), -el.cos() * az.cos());
    // Clouds drift in azimuth (a negative rate about +Y is clockwise seen from above, like the sun).
    let drift = |start: Vec3, vel_deg: f32| glam::Quat::from_axis_angle(Vec3::Y, (vel_deg * t).to_radians()) * start;
    let _ = rate_hz; // motion is per frame; the rate only labels time
    // A cloud 10° of azimuth ahead of the sun, 1°/frame faster: it covers the sun from about
    // frame 6 to 14 and has left it by frame 17.
    let sun0 = Vec3::new(35f32.to_radians().cos() * 200f32.to_radians().sin(), 35f32.to_radians().sin(), -35f32.to_radians().cos() * 200f32.to_radians().cos());
    let c0 = (glam::Quat::from_axis_angle(Vec3::Y, 10f32.to_radians()) * sun0).normalize();
    let clouds = vec![
        Cloud { centre: drift(c0, -1.4), radius: 0.1, opacity: 0.97, rgb: [0.9, 0.9, 0.95] },
        Cloud { centre: drift(Vec3::new(0.5, 0.6, 0.4).normalize(), 0.8), radius: 0.3, opacity: 0.8, rgb: [1.2, 1.2, 1.25] },
        Cloud { centre: drift(Vec3::new(-0.6, 0.3, 0.3).normalize(), 0.5), radius: 0.25, opacity: 0.9, rgb: [0.7, 0.7, 0.75] },
    ];
    OutdoorSky { sun_dir, sun_irradiance: [30.0, 28.5, 25.5], zenith: [0.35, 0.5, 0.9], clouds }
}

/// Frame `k` of the indoor sequence at `rate_hz`: the lamp flickers by ±25% at 115 Hz.
pub fn indoor_lamp(k: usize, rate_hz: f64) -> IndoorRoom {
    let t = k as f64 / rate_hz;
    let f = 1.0 + 0.25 * (std::f64::consts::TAU * 115.0 * t).sin();
    let lamp_dir = Vec3::new(-0.25, 0.92, 0.3).normalize();
    IndoorRoom { lamp_dir, lamp_radius: 6f32.to_radians(), lamp_rgb: [40.0 * f as f32, 34.0 * f as f32, 24.0 * f as f32] }
}

/// Splats `e` (irradiance) bilinearly at continuous coordinates `(x, y)` (cell centres at
/// integers) into cells of solid angle `cell_sr(col, row)`; `wrap_x` wraps columns.
fn splat(data: &mut [[f32; 3]], w: u32, h: u32, x: f64, y: f64, e: [f32; 3], wrap_x: bool, cell_sr: impl Fn(u32, u32) -> f32) {
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = ((x - x0) as f32, (y - y0) as f32);
    for (ox, oy, wgt) in [(0, 0, (1.0 - fx) * (1.0 - fy)), (1, 0, fx * (1.0 - fy)), (0, 1, (1.0 - fx) * fy), (1, 1, fx * fy)] {
        let mut c = x0 as i64 + ox;
        let r = (y0 as i64 + oy).clamp(0, h as i64 - 1);
        if wrap_x {
            c = c.rem_euclid(w as i64);
        } else if c < 0 || c >= w as i64 {
            continue;
        }
        let (c, r) = (c as u32, r as u32);
        let sr = cell_sr(c, r);
        if sr > 0.0 {
            let p = &mut data[(r * w + c) as usize];
            for k in 0..3 {
                p[k] += wgt * e[k] / sr;
            }
        }
    }
}

/// The polar map of an environment: the smooth part box-filtered with `sub × sub` samples per
/// texel, the suns splatted with their exact energy.
pub fn render_polar(env: &dyn Environment, width: u32, height: u32, sub: u32) -> PolarMap {
    let sub = sub.max(1);
    let mut m = PolarMap::new(width, height);
    for j in 0..height {
        for i in 0..width {
            let mut acc = [0.0f32; 3];
            for b in 0..sub {
                for a in 0..sub {
                    let d = dir_from_polar(i as f32 + (a as f32 + 0.5) / sub as f32, j as f32 + (b as f32 + 0.5) / sub as f32, width, height);
                    let r = env.radiance(d);
                    for k in 0..3 {
                        acc[k] += r[k];
                    }
                }
            }
            m.data[(j * width + i) as usize] = acc.map(|v| v / (sub * sub) as f32);
        }
    }
    for (d, e) in env.suns() {
        if let Some((x, y)) = crate::vem::polar::polar_from_dir(d, width, height) {
            let sr: Vec<f32> = (0..height).map(|j| m.row_solid_angle(j)).collect();
            splat(&mut m.data, width, height, x as f64 - 0.5, y as f64 - 0.5, e, true, |_, r| sr[r as usize]);
        }
    }
    m
}

/// Solid angle of a fisheye pixel (finite differences of the unprojection), 0 outside the field of
/// view.
pub fn fisheye_pixel_sr(cam: &Camera, u: f64, v: f64) -> f32 {
    let d = |du: f64, dv: f64| cam.world_dir_from_pixel(DVec2::new(u + du, v + dv));
    match (d(-0.5, 0.0), d(0.5, 0.0), d(0.0, -0.5), d(0.0, 0.5)) {
        (Some(a), Some(b), Some(c), Some(e)) => (b - a).cross(e - c).length() as f32,
        _ => 0.0,
    }
}

/// A fisheye HDR image of an environment (black outside the field of view or below the horizon).
pub fn render_fisheye(env: &dyn Environment, cam: &Camera, sub: u32) -> LinearImage {
    let sub = sub.max(1);
    let (w, h) = (cam.intrinsics.width, cam.intrinsics.height);
    let mut img = LinearImage::from_fn(w, h, |u, v| {
        let mut acc = [0.0f32; 3];
        for b in 0..sub {
            for a in 0..sub {
                let uv = DVec2::new(u as f64 - 0.5 + (a as f64 + 0.5) / sub as f64, v as f64 - 0.5 + (b as f64 + 0.5) / sub as f64);
                if let Some(d) = cam.world_dir_from_pixel(uv).map(|d| d.as_vec3()).filter(|d| d.y >= 0.0) {
                    let r = env.radiance(d);
                    for k in 0..3 {
                        acc[k] += r[k];
                    }
                }
            }
        }
        acc.map(|x| x / (sub * sub) as f32)
    });
    for (d, e) in env.suns() {
        if let Some(p) = cam.pixel_from_world_dir(d.as_dvec3()) {
            splat(&mut img.data, w, h, p.x, p.y, e, false, |c, r| fisheye_pixel_sr(cam, c as f64, r as f64));
        }
    }
    img
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn suns_keep_their_energy_in_both_renderings() {
        let sky = OutdoorSky { clouds: vec![], ..outdoor(0, RATE_HZ) };
        let smooth = OutdoorSky { sun_irradiance: [0.0; 3], ..sky.clone() };
        let (a, b) = (render_polar(&sky, 360, 90, 1).total_power(), render_polar(&smooth, 360, 90, 1).total_power());
        for k in 0..3 {
            assert!(((a[k] - b[k]) - sky.sun_irradiance[k] as f64).abs() < 1e-3 * sky.sun_irradiance[k] as f64);
        }
        let cam = Camera::equidistant_up(256, 180.0);
        let (fa, fb) = (render_fisheye(&sky, &cam, 1), render_fisheye(&smooth, &cam, 1));
        let mut e = 0.0f64;
        for v in 0..256u32 {
            for u in 0..256u32 {
                let i = (v * 256 + u) as usize;
                e += (fa.data[i][1] - fb.data[i][1]) as f64 * fisheye_pixel_sr(&cam, u as f64, v as f64) as f64;
            }
        }
        assert!((e - sky.sun_irradiance[1] as f64).abs() < 1e-3 * e, "{e}");
    }

    #[test]
    fn the_cloud_covers_the_sun_in_the_middle_of_the_sequence() {
        let e = |k| outdoor(k, RATE_HZ).suns().first().map_or(0.0, |s| s.1[1]);
        let all: Vec<f32> = (0..24).map(e).collect();
        assert!(all[..4].iter().chain(&all[17..]).all(|&x| x > 25.0), "{all:?}");
        assert!(all[6..15].iter().all(|&x| x < 3.0), "{all:?}");
    }
}

/// Brightens (`factor > 1`) or darkens the texels of `map` within `radius` of `centre`.
pub fn scale_cap(map: &mut PolarMap, centre: Vec3, radius: f32, factor: f32) {
    let c = radius.cos();
    for j in 0..map.height {
        for i in 0..map.width {
            if map.texel_dir(i, j).dot(centre) >= c {
                let p = &mut map.data[(j * map.width + i) as usize];
                *p = p.map(|v| v * factor);
            }
        }
    }
}

/// Pairs of polar maps (`width × height`) that differ by a small local change, for the coherence
/// sweep: a 6° patch of sky 10% brighter, a faint 3° cloud appearing, the sun moving by 0.25°, two
/// consecutive frames of [`outdoor`], and the brighter patch on a sky without sun.
pub fn local_changes(width: u32, height: u32) -> Vec<(&'static str, PolarMap, PolarMap)> {
    let sky = outdoor(0, RATE_HZ);
    let base = render_polar(&sky, width, height, 2);
    // A patch of clear sky well away from the sun (azimuth ≈ 63°, elevation 37°).
    let patch = Vec3::new(0.6, 0.5, 0.3).normalize();
    let mut bright = base.clone();
    scale_cap(&mut bright, patch, 6f32.to_radians(), 1.1);
    let mut clouded = sky.clone();
    clouded.clouds.push(Cloud { centre: patch, radius: 3f32.to_radians(), opacity: 0.5, rgb: [1.0; 3] });
    let mut moved = sky.clone();
    moved.sun_dir = glam::Quat::from_axis_angle(Vec3::Y, -0.25f32.to_radians()) * moved.sun_dir;
    let no_sun = OutdoorSky { sun_irradiance: [0.0; 3], ..sky.clone() };
    let a = render_polar(&no_sun, width, height, 2);
    let mut b = a.clone();
    scale_cap(&mut b, patch, 6f32.to_radians(), 1.1);
    vec![
        ("patch_10pct", base.clone(), bright),
        ("small_cloud", base.clone(), render_polar(&clouded, width, height, 2)),
        ("sun_0.25deg", base.clone(), render_polar(&moved, width, height, 2)),
        ("next_frame", base, render_polar(&outdoor(1, RATE_HZ), width, height, 2)),
        ("patch_no_sun", a, b),
    ]
}

/// Test maps for the error sweep: a sunny sky, the same sky with the sun behind a cloud, and the
/// indoor room.
pub fn error_maps(width: u32, height: u32) -> Vec<(&'static str, PolarMap)> {
    let cloudy = (0..24).min_by(|&a, &b| {
        let e = |k| outdoor(k, RATE_HZ).suns().first().map_or(0.0, |s| s.1[1]);
        e(a).total_cmp(&e(b))
    });
    vec![
        ("sunny", render_polar(&outdoor(0, RATE_HZ), width, height, 2)),
        ("sun_behind_cloud", render_polar(&outdoor(cloudy.unwrap_or(20), RATE_HZ), width, height, 2)),
        ("indoor", render_polar(&indoor_lamp(0, RATE_HZ), width, height, 2)),
    ]
}
