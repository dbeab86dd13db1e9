//! The pinhole canvas the 3D passes draw into, and the lens warp back to the footage.
//!
//! # How it works
//! The footage is distorted (Brown–Conrady, `scene::camera`); a GPU rasteriser can only draw
//! straight lines, so the 3D passes (depth, shadow volumes, virtual objects) render an
//! undistorted pinhole image, the *canvas*, with the camera's focal lengths (times an optional
//! supersampling factor) and a principal point shifted so that the canvas covers every ray the
//! distorted frame sees (barrel distortion sees more than the pinhole frame of the same size).
//! The final pass works in the footage's own pixel grid: for every output pixel a precomputed
//! map gives the canvas point that the lens maps there (Newton undistortion, once per camera),
//! and the canvas layers are sampled there bilinearly. Untouched video pixels are never
//! resampled, so the footage stays exactly as it came in.
//!
//! The canvas's principal point is moved by less than a pixel so that the lens's centre lies on
//! the footage pixel's phase of the canvas grid (`ss·(c + ½) − ½`): where the lens is near
//! identity, a 1× canvas is then read at texel centres (each texel's own MSAA box) and a 2× one
//! by the composite's four taps on the four texels under the footage pixel (a box over it), as
//! the reference renderer's box filter over each pixel does, instead of taps between texels that
//! widen the filter by up to a pixel (issue 13; `tests/suite/render/lens_filter.rs`, and
//! docs/measurements.md, "the canvas on the footage's pixel phase": the winter composite's frame
//! 3 3.30 → 2.88% at MSAA 4).
//!
//! Projection: OpenCV camera frame to wgpu clip space with reversed depth and an infinite far
//! plane, `z_ndc = near / z`: the ends of the shadow volumes (points at infinity, `w = 0`) land
//! at depth 0 and are never clipped, so z-fail counting needs no far cap (Everitt & Kilgard,
//! "Practical and Robust Stenciled Shadow Volumes", 2002).

use crate::camera::{Camera, Intrinsics, Pose};
use glam::{DMat4, DVec2, DVec3, DVec4, Mat4};

/// Near plane of the canvas projection, metres. Geometry closer to the camera is clipped; z-fail
/// shadow counting stays correct (it only counts volume faces behind the visible surface).
pub const NEAR_M: f64 = 0.02;
/// Extra canvas pixels around the warped footage, so bilinear taps and MSAA edges stay inside.
const CANVAS_MARGIN_PX: f64 = 2.0;
/// Canvas shifts (pixels) this close to a whole pixel are none (see `Canvas::new`).
const PHASE_EPS_PX: f64 = 1e-6;
/// Largest canvas side the passes accept (a lens model whose inverse explodes at the border
/// would otherwise ask for an enormous canvas).
const MAX_CANVAS_SIDE: f64 = 8192.0;

/// Mirrors `Camera` in `shaders/common/camera.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct CameraUniform {
    /// World (homogeneous) to clip space, column-major.
    pub clip_from_world: [[f32; 4]; 4],
    /// Camera centre in the world, `w = 1`.
    pub eye_world: [f32; 4],
    /// Canvas width, height, 1/width, 1/height.
    pub canvas_size: [f32; 4],
}

/// The undistorted canvas of a camera and the warp from the footage's pixels into it.
#[derive(Clone, Debug)]
pub struct Canvas {
    /// The canvas's own pinhole camera (`Lens::BrownConrady` without distortion): its size, and
    /// its focal lengths (the camera's times the supersampling factor) and principal point in
    /// canvas pixels (OpenCV convention).
    pub intrinsics: Intrinsics,
    /// `world_from_camera`.
    pub pose: Pose,
    /// Footage width, pixels.
    pub out_width: u32,
    /// Footage height, pixels.
    pub out_height: u32,
    /// For every footage pixel (row-major): the canvas point its centre maps to, or `[-1, -1]`
    /// where the lens model has no inverse.
    pub warp: Vec<[f32; 2]>,
}

impl Canvas {
    /// The canvas of `camera` with `supersample` canvas pixels per footage pixel (≥ 1) at the
    /// principal point.
    pub fn new(camera: &Camera, supersample: f64) -> Self {
        let k = &camera.intrinsics;
        let ss = supersample.max(1.0);
        let (w, h) = (k.width, k.height);
        let norm: Vec<Option<DVec2>> = (0..h)
            .flat_map(|row| (0..w).map(move |col| (col, row)))
            .map(|(col, row)| k.pinhole_from_pixel(DVec2::new(col as f64, row as f64)))
            .collect();
        let (mut lo, mut hi) = (DVec2::splat(f64::MAX), DVec2::splat(f64::MIN));
        for p in norm.iter().flatten() {
            lo = lo.min(*p);
            hi = hi.max(*p);
        }
        if lo.x > hi.x {
            // No pixel inverts (a pathological lens model): an empty map over the pinhole frame.
            lo = DVec2::new(-k.cx / k.fx, -k.cy / k.fy);
            hi = DVec2::new((w as f64 - k.cx) / k.fx, (h as f64 - k.cy) / k.fy);
        }
        let (fx, fy) = (k.fx * ss, k.fy * ss);
        // The canvas's principal point, moved by less than a pixel so that the lens's centre
        // (where the warp is a pure scale by `ss`) falls on the same phase of the canvas's pixel
        // grid as the footage pixel there: `ss·(c + ½) − ½` (OpenCV centres), the point between
        // a 2× canvas's texels or a 1× canvas's texel centre. Near the centre the composite's
        // taps then land on texel centres instead of between them (see `warp_footprint`).
        // (A lens-free camera at 1× is on that phase already: no shift, also when rounding puts
        // it a hair below.)
        let shift = |c: f64, lo: f64, f: f64| {
            let s = (ss * (c + 0.5) - 0.5 - (-lo * f + CANVAS_MARGIN_PX)).rem_euclid(1.0);
            if s > 1.0 - PHASE_EPS_PX { 0.0 } else { s }
        };
        let (sx, sy) = (shift(k.cx, lo.x, fx), shift(k.cy, lo.y, fy));
        let width = ((hi.x - lo.x) * fx + 2.0 * CANVAS_MARGIN_PX + sx).ceil().clamp(1.0, MAX_CANVAS_SIDE);
        let height = ((hi.y - lo.y) * fy + 2.0 * CANVAS_MARGIN_PX + sy).ceil().clamp(1.0, MAX_CANVAS_SIDE);
        let (cx, cy) = (-lo.x * fx + CANVAS_MARGIN_PX + sx, -lo.y * fy + CANVAS_MARGIN_PX + sy);
        let warp = norm
            .iter()
            .map(|p| match p {
                Some(p) => {
                    let q = [(fx * p.x + cx) as f32, (fy * p.y + cy) as f32];
                    if q[0] >= 0.0 && q[1] >= 0.0 && (q[0] as f64) < width && (q[1] as f64) < height { q } else { [-1.0, -1.0] }
                }
                None => [-1.0, -1.0],
            })
            .collect();
        Self { intrinsics: Intrinsics::pinhole(width as u32, height as u32, fx, fy, cx, cy), pose: camera.pose, out_width: w, out_height: h, warp }
    }

    /// The warp with each footage pixel's footprint on the canvas: `[x, y, sx, sy]`, where
    /// `(x, y)` is [`Canvas::warp`]'s point and `sx`, `sy` the canvas distances between the
    /// points of the pixel's horizontal and vertical neighbours, halved (canvas pixels per
    /// footage pixel: the supersampling factor times the lens's local scale). The composite
    /// box-filters the canvas over that footprint when it spans more than a canvas pixel.
    pub fn warp_footprint(&self) -> Vec<[f32; 4]> {
        let (w, h) = (self.out_width as usize, self.out_height as usize);
        let at = |c: usize, r: usize| -> Option<glam::Vec2> {
            let p = self.warp[r * w + c];
            (p[0] >= 0.0).then(|| glam::Vec2::from(p))
        };
        // Half the distance between the two neighbours along one axis (one-sided at borders).
        let span = |a: Option<glam::Vec2>, b: Option<glam::Vec2>, centre: glam::Vec2, steps: f32| -> f32 {
            match (a, b) {
                (Some(a), Some(b)) => (b - a).length() / steps,
                (Some(a), None) => (centre - a).length(),
                (None, Some(b)) => (b - centre).length(),
                (None, None) => 1.0,
            }
        };
        (0..w * h)
            .map(|i| {
                let (c, r) = (i % w, i / w);
                let Some(p) = at(c, r) else { return [-1.0, -1.0, 1.0, 1.0] };
                let left = c.checked_sub(1).and_then(|c| at(c, r));
                let right = (c + 1 < w).then(|| at(c + 1, r)).flatten();
                let up = r.checked_sub(1).and_then(|r| at(c, r));
                let down = (r + 1 < h).then(|| at(c, r + 1)).flatten();
                [p.x, p.y, span(left, right, p, 2.0), span(up, down, p, 2.0)]
            })
            .collect()
    }

    /// Clip space from camera space (OpenCV frame, homogeneous), reversed depth, infinite far.
    pub fn clip_from_camera(&self) -> DMat4 {
        let (w, h) = (self.intrinsics.width as f64, self.intrinsics.height as f64);
        // OpenCV pixel (u, v) has its centre at framebuffer coordinate (u + ½, v + ½).
        DMat4::from_cols(
            DVec4::new(2.0 * self.intrinsics.fx / w, 0.0, 0.0, 0.0),
            DVec4::new(0.0, -2.0 * self.intrinsics.fy / h, 0.0, 0.0),
            DVec4::new(2.0 * (self.intrinsics.cx + 0.5) / w - 1.0, 1.0 - 2.0 * (self.intrinsics.cy + 0.5) / h, 0.0, 1.0),
            DVec4::new(0.0, 0.0, NEAR_M, 0.0),
        )
    }

    /// Camera from world (homogeneous).
    pub fn camera_from_world(&self) -> DMat4 {
        let r = self.pose.rotation.transpose();
        let t = -(r * self.pose.translation);
        DMat4::from_cols(r.x_axis.extend(0.0), r.y_axis.extend(0.0), r.z_axis.extend(0.0), t.extend(1.0))
    }

    /// Clip from world (homogeneous).
    pub fn clip_from_world(&self) -> DMat4 {
        self.clip_from_camera() * self.camera_from_world()
    }

    /// The uniform the passes read.
    pub fn uniform(&self) -> CameraUniform {
        let m: Mat4 = self.clip_from_world().as_mat4();
        let e = self.pose.translation.as_vec3();
        CameraUniform {
            clip_from_world: m.to_cols_array_2d(),
            eye_world: [e.x, e.y, e.z, 1.0],
            canvas_size: [self.intrinsics.width as f32, self.intrinsics.height as f32, 1.0 / self.intrinsics.width as f32, 1.0 / self.intrinsics.height as f32],
        }
    }

    /// Unit world direction of the ray through the centre of canvas pixel `i` (row-major), from
    /// the camera centre `pose.translation`.
    pub fn pixel_dir(&self, i: u32) -> glam::Vec3 {
        let (u, v) = ((i % self.intrinsics.width) as f64, (i / self.intrinsics.width) as f64);
        (self.pose.rotation * DVec3::new((u - self.intrinsics.cx) / self.intrinsics.fx, (v - self.intrinsics.cy) / self.intrinsics.fy, 1.0).normalize()).as_vec3()
    }

    /// World ray (camera centre, unit direction) through footage pixel coordinates `(x, y)`
    /// (OpenCV convention: pixel centres at integers), through the lens: [`Canvas::warp`]
    /// interpolated bilinearly between the four nearest footage pixels (the nearest one's where
    /// a neighbour has no inverse). `None` outside the footage or where the lens model has no
    /// inverse. What a pointer on the shown frame looks at (the live window's dragging).
    pub fn footage_ray(&self, x: f64, y: f64) -> Option<(DVec3, DVec3)> {
        let (w, h) = (self.out_width as usize, self.out_height as usize);
        if !(x >= -0.5 && y >= -0.5 && x < w as f64 - 0.5 && y < h as f64 - 0.5) {
            return None;
        }
        let at = |c: usize, r: usize| Some(self.warp[r * w + c]).filter(|p| p[0] >= 0.0).map(|p| DVec2::new(p[0] as f64, p[1] as f64));
        let (cx, cy) = (x.clamp(0.0, (w - 1) as f64), y.clamp(0.0, (h - 1) as f64));
        let (c0, r0) = (cx.floor() as usize, cy.floor() as usize);
        let (c1, r1) = ((c0 + 1).min(w - 1), (r0 + 1).min(h - 1));
        let (fx, fy) = (cx - c0 as f64, cy - r0 as f64);
        let p = match (at(c0, r0), at(c1, r0), at(c0, r1), at(c1, r1)) {
            (Some(a), Some(b), Some(c), Some(d)) => (a * (1.0 - fx) + b * fx) * (1.0 - fy) + (c * (1.0 - fx) + d * fx) * fy,
            _ => at(x.round().clamp(0.0, (w - 1) as f64) as usize, y.round().clamp(0.0, (h - 1) as f64) as usize)?,
        };
        let d = DVec3::new((p.x - self.intrinsics.cx) / self.intrinsics.fx, (p.y - self.intrinsics.cy) / self.intrinsics.fy, 1.0).normalize();
        Some((self.pose.translation, self.pose.rotation * d))
    }

    /// Canvas pixel coordinates of a world point in front of the camera.
    pub fn canvas_from_world(&self, p: DVec3) -> Option<DVec2> {
        let c = self.pose.camera_from_world(p);
        (c.z > 0.0).then(|| DVec2::new(self.intrinsics.fx * c.x / c.z + self.intrinsics.cx, self.intrinsics.fy * c.y / c.z + self.intrinsics.cy))
    }
}

/// Layout of the bind group that holds only the camera uniform (group 0 of the depth prepass
/// and the shadow volumes).
pub fn camera_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("camera"),
        entries: &[uniform_entry(0, wgpu::ShaderStages::VERTEX)],
    })
}

/// A uniform-buffer layout entry.
pub fn uniform_entry(binding: u32, visibility: wgpu::ShaderStages) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty: wgpu::BindingType::Buffer { ty: wgpu::BufferBindingType::Uniform, has_dynamic_offset: false, min_binding_size: None },
        count: None,
    }
}

/// A read-only storage-buffer layout entry of the fragment stage.
pub fn storage_entry(binding: u32) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::FRAGMENT,
        ty: wgpu::BindingType::Buffer { ty: wgpu::BufferBindingType::Storage { read_only: true }, has_dynamic_offset: false, min_binding_size: None },
        count: None,
    }
}

/// A 2D float texture layout entry of the fragment stage, `filterable` or not.
pub fn texture_entry(binding: u32, filterable: bool) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::FRAGMENT,
        ty: wgpu::BindingType::Texture { sample_type: wgpu::TextureSampleType::Float { filterable }, view_dimension: wgpu::TextureViewDimension::D2, multisampled: false },
        count: None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::Intrinsics;

    fn camera(distortion: [f64; 5]) -> Camera {
        Camera {
            intrinsics: Intrinsics::brown_conrady(320, 240, 260.0, 260.5, 161.2, 118.9, distortion),
            pose: Pose::look_at(DVec3::new(4.5, 1.7, 9.0), DVec3::new(-2.5, 0.6, -4.0), DVec3::Y).unwrap(),
        }
    }

    #[test]
    fn projection_matches_the_pinhole_model_and_depth_is_reversed() {
        let canvas = Canvas::new(&camera([0.0; 5]), 1.0);
        let m = canvas.clip_from_world();
        for p in [DVec3::new(0.0, 0.0, 0.0), DVec3::new(-2.0, 1.5, -3.0), DVec3::new(3.0, 0.2, 5.0)] {
            let clip = m * p.extend(1.0);
            let ndc = clip.truncate() / clip.w;
            let want = canvas.canvas_from_world(p).unwrap();
            // NDC → OpenCV pixel coordinates of the canvas.
            let u = (ndc.x + 1.0) / 2.0 * canvas.intrinsics.width as f64 - 0.5;
            let v = (1.0 - ndc.y) / 2.0 * canvas.intrinsics.height as f64 - 0.5;
            assert!((DVec2::new(u, v) - want).length() < 1e-9, "{u},{v} vs {want}");
            let z = canvas.pose.camera_from_world(p).z;
            assert!((ndc.z - NEAR_M / z).abs() < 1e-12);
        }
        // A direction at infinity (w = 0) in front of the camera lands at depth exactly 0.
        let d = canvas.pose.rotation * DVec3::new(0.1, -0.05, 1.0);
        let clip = m * d.extend(0.0);
        assert_eq!(clip.z, 0.0);
        assert!(clip.w > 0.0);
    }

    #[test]
    fn warp_sends_each_footage_pixel_to_the_canvas_point_of_its_ray() {
        let cam = camera([-0.08, 0.012, 0.0005, -0.0003, 0.0]);
        let canvas = Canvas::new(&cam, 1.0);
        // Barrel distortion: the canvas is larger than the footage.
        assert!(canvas.intrinsics.width > 320 && canvas.intrinsics.height > 240, "{}×{}", canvas.intrinsics.width, canvas.intrinsics.height);
        for (col, row) in [(0u32, 0u32), (319, 239), (160, 120), (17, 201), (300, 5)] {
            let (o, d) = cam.pixel_ray(col, row).unwrap();
            let want = canvas.canvas_from_world(o + d * 7.0).unwrap();
            let got = canvas.warp[(row * 320 + col) as usize];
            assert!((DVec2::new(got[0] as f64, got[1] as f64) - want).length() < 1e-3, "{col},{row}: {got:?} vs {want}");
            assert!(got[0] >= 0.0 && (got[0] as u32) < canvas.intrinsics.width && (got[1] as u32) < canvas.intrinsics.height);
        }
    }

    #[test]
    fn a_footage_ray_is_the_calibrated_camera_s_ray_through_the_lens() {
        let cam = camera([-0.08, 0.012, 0.0005, -0.0003, 0.0]);
        let canvas = Canvas::new(&cam, 2.0);
        for (col, row) in [(0u32, 0u32), (319, 239), (160, 120), (17, 201)] {
            let (o, d) = cam.pixel_ray(col, row).unwrap();
            let (o2, d2) = canvas.footage_ray(col as f64, row as f64).unwrap();
            assert!((o - o2).length() < 1e-12);
            // The warp is stored in f32 canvas pixels: 1e-3 px at f ≈ 520 is 2e-6 rad.
            assert!(d.angle_between(d2) < 1e-5, "{col},{row}: {d} vs {d2}");
        }
        // Between pixel centres: the lens's own ray within a hundredth of a pixel (the warp is
        // smooth over a pixel; 0.01 px at f ≈ 260 is 4e-5 rad).
        for uv in [DVec2::new(100.3, 57.8), DVec2::new(2.5, 230.25), DVec2::new(318.9, 0.1)] {
            let (_, d) = cam.ray_at(uv).unwrap();
            let (_, d2) = canvas.footage_ray(uv.x, uv.y).unwrap();
            assert!(d.angle_between(d2) < 4e-5, "{uv}: {}", d.angle_between(d2));
        }
        assert!(canvas.footage_ray(-0.6, 10.0).is_none() && canvas.footage_ray(319.6, 10.0).is_none() && canvas.footage_ray(f64::NAN, 1.0).is_none());
    }

    #[test]
    fn the_footprint_is_the_supersampling_factor_times_the_lens_scale() {
        // Pinhole: every footage pixel spans exactly `supersample` canvas pixels.
        for ss in [1.0, 2.0, 3.0] {
            let canvas = Canvas::new(&camera([0.0; 5]), ss);
            let f = canvas.warp_footprint();
            for i in [0usize, 161, 320 * 120 + 160, 320 * 240 - 1] {
                assert_eq!([f[i][0], f[i][1]], canvas.warp[i]);
                assert!((f[i][2] - ss as f32).abs() < 1e-3 && (f[i][3] - ss as f32).abs() < 1e-3, "ss {ss}, pixel {i}: {:?}", f[i]);
            }
        }
        // Barrel distortion: the undistorted canvas stretches toward the corners, so a corner
        // pixel covers more canvas than the centre.
        let canvas = Canvas::new(&camera([-0.08, 0.012, 0.0005, -0.0003, 0.0]), 1.0);
        let f = canvas.warp_footprint();
        let (centre, corner) = (f[320 * 120 + 160], f[0]);
        assert!(corner[2] > centre[2] * 1.05 && centre[2] > 0.9 && centre[2] < 1.1, "{centre:?} {corner:?}");
    }

    #[test]
    fn the_lens_centre_falls_on_the_footage_pixels_phase_of_the_canvas_grid() {
        // With the lens: the principal point's canvas point is the canvas's own principal point
        // (the distortion vanishes there); it lies on the phase `ss·(c + ½) − ½` of the grid, a
        // texel centre at 1× and the point between two texels at 2×, to rounding.
        for ss in [1.0, 2.0, 3.0] {
            let cam = camera([-0.08, 0.012, 0.0005, -0.0003, 0.0]);
            let canvas = Canvas::new(&cam, ss);
            for (got, c) in [(canvas.intrinsics.cx, cam.intrinsics.cx), (canvas.intrinsics.cy, cam.intrinsics.cy)] {
                let off = got - (ss * (c + 0.5) - 0.5);
                assert!((off - off.round()).abs() < 1e-9, "ss {ss}: {got} against the phase of {c} ({off})");
            }
            // The shift (under a pixel) keeps every footage pixel on the canvas.
            assert!(canvas.warp.iter().all(|p| p[0] >= 0.0), "ss {ss}: a pixel fell off the canvas");
        }
        // Without a lens the 1× canvas is the footage's grid moved by the margin: no shift.
        let canvas = Canvas::new(&camera([0.0; 5]), 1.0);
        for (i, p) in canvas.warp.iter().enumerate() {
            let (col, row) = ((i % 320) as f32, (i / 320) as f32);
            assert!((p[0] - col - CANVAS_MARGIN_PX as f32).abs() < 1e-3 && (p[1] - row - CANVAS_MARGIN_PX as f32).abs() < 1e-3, "{i}: {p:?}");
        }
    }
}
