//! The far-field intensity table shared by the IES and EULUMDAT readers: intensity (cd) per
//! direction in the luminaire frame, bilinear between the measured angles, with the file's symmetry
//! expanded.
//!
//! # How it works
//! A file gives intensities on a grid of a *horizontal* angle `h` (the plane) and a *vertical*
//! angle `v` (within the plane), possibly for one half or one quadrant of the planes only. The
//! constructor expands the stored planes by the symmetry into a full, strictly increasing list of
//! planes: the whole circle `[h₀, h₀ + 360°]` for type C (the first plane repeated at `+360°`, so
//! the lookup wraps), `[−90°, 90°]` for types A and B. A query maps the direction to `(h, v)`
//! ([`PhotometricType::angles_from_dir`]), finds the grid cell by bisection and interpolates
//! bilinearly in the angles; a direction outside the measured vertical range (e.g. upward for a
//! file that stops at 90°) has zero intensity.
//!
//! The luminous flux `Φ = ∫ I dω` is integrated exactly for the bilinear interpolant: over each
//! cell the plane-average of `I` is linear in `v`, and `∫ (p + q v) sin v dv` (type C,
//! `dω = sin γ dγ dC`) or `∫ (p + q v) cos v dv` (types A/B, `dω = cos β dβ dB`) has a closed form.

use glam::DVec3;

/// Two angles closer than this (degrees) are the same plane when symmetric images are merged.
const SAME_ANGLE_DEG: f64 = 1e-9;

/// How the angles of a table map to directions (IES LM-63 "photometric type"; EULUMDAT is always
/// type C).
///
/// In the luminaire frame of [`crate::lamps`] (`−Z` nadir, `+X` the C0 plane, `+Y` the C90 plane):
/// - **C** (architectural, road): `v = γ ∈ [0°, 180°]` from nadir, `h = C` counter-clockwise from
///   `+X` seen from above: `dir = (sin γ cos C, sin γ sin C, −cos γ)`.
/// - **B** (floodlights): the planes share the `Y` axis; `h = B` rotates about `Y` from nadir
///   toward `+X`, `v = β` is the elevation out of the `XZ` plane toward `+Y`:
///   `dir = (sin B cos β, sin β, −cos B cos β)`, so `tan B = cos C tan γ`, `sin β = sin C sin γ`.
/// - **A** (automotive): the planes share the `Z` axis; `v` is the elevation above the horizontal
///   and `h` turns from `+X` toward `−Y` (clockwise seen from above, as LM-63 measures it):
///   `dir = (cos v cos h, −cos v sin h, sin v)`; photometric zero (`h = v = 0`) is `+X`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PhotometricType {
    /// Type C: vertical axis, planes through nadir.
    C,
    /// Type B: planes through the lateral (`Y`) axis.
    B,
    /// Type A: planes through the vertical axis, angles from the horizontal.
    A,
}

impl PhotometricType {
    /// `(h, v)` in degrees of a unit direction in the luminaire frame (see the type docs); `h` is
    /// in `[0°, 360°)` for type C and `(−180°, 180°]` for A and B.
    pub fn angles_from_dir(self, d: DVec3) -> (f64, f64) {
        match self {
            PhotometricType::C => {
                let gamma = (-d.z).clamp(-1.0, 1.0).acos().to_degrees();
                let c = d.y.atan2(d.x).to_degrees().rem_euclid(360.0);
                (c, gamma)
            }
            PhotometricType::B => {
                let b = d.x.atan2(-d.z).to_degrees();
                let beta = d.y.clamp(-1.0, 1.0).asin().to_degrees();
                (b, beta)
            }
            PhotometricType::A => {
                let h = (-d.y).atan2(d.x).to_degrees();
                let v = d.z.clamp(-1.0, 1.0).asin().to_degrees();
                (h, v)
            }
        }
    }

    /// The unit direction of `(h, v)` in degrees (inverse of [`Self::angles_from_dir`]).
    pub fn dir_from_angles(self, h_deg: f64, v_deg: f64) -> DVec3 {
        let (h, v) = (h_deg.to_radians(), v_deg.to_radians());
        match self {
            PhotometricType::C => DVec3::new(v.sin() * h.cos(), v.sin() * h.sin(), -v.cos()),
            PhotometricType::B => DVec3::new(h.sin() * v.cos(), v.sin(), -h.cos() * v.cos()),
            PhotometricType::A => DVec3::new(v.cos() * h.cos(), -v.cos() * h.sin(), v.sin()),
        }
    }

    /// The range a vertical angle must lie in (degrees).
    pub fn vertical_range_deg(self) -> (f64, f64) {
        match self {
            PhotometricType::C => (0.0, 180.0),
            PhotometricType::A | PhotometricType::B => (-90.0, 90.0),
        }
    }
}

/// Which planes a file stores and how the others follow from them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Symmetry {
    /// All planes stored (type C over the full circle, types A/B over `[−90°, 90°]`).
    None,
    /// One plane; the same in every plane (type C only).
    Rotational,
    /// Type C planes `0°–180°`; `C` and `360° − C` are equal (mirror in the C0–C180 plane).
    AboutC0C180,
    /// Type C planes `90°–270°`; `C` and `180° − C` are equal (mirror in the C90–C270 plane).
    AboutC90C270,
    /// Type C planes `0°–90°`; mirrored in both the C0–C180 and the C90–C270 planes.
    Quadrant,
    /// Types A/B planes `0°–90°`; `h` and `−h` are equal.
    Lateral,
}

/// Why a table cannot make a [`Goniometric`] (the readers add the file and line).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TableError {
    /// No angles, or a value count that is not planes × vertical angles.
    #[error("{0}")]
    Shape(String),
    /// Angles that do not strictly increase, or lie outside their range.
    #[error("{0}")]
    Angles(String),
    /// A negative, NaN or infinite intensity.
    #[error("intensity #{index} is {value} (must be finite and ≥ 0)")]
    Value {
        /// Index of the value in plane-major order.
        index: usize,
        /// The value.
        value: f64,
    },
    /// The symmetry does not fit the photometric type or the stored planes.
    #[error("{0}")]
    Symmetry(String),
}

/// Intensity (cd) per direction in the luminaire frame, from a measured table.
#[derive(Clone, Debug, PartialEq)]
pub struct Goniometric {
    kind: PhotometricType,
    /// Expanded plane angles (degrees), strictly increasing.
    h_deg: Vec<f64>,
    /// Vertical angles (degrees), strictly increasing.
    v_deg: Vec<f64>,
    /// Intensities (cd), plane-major: `cd[i_h * v_deg.len() + i_v]`.
    cd: Vec<f64>,
    /// Radius of a disc of the luminous opening's area, metres (0: a point).
    opening_radius_m: f64,
}

/// Checks that angles strictly increase and lie in `[lo, hi]`.
pub(crate) fn check_angles(name: &str, a: &[f64], lo: f64, hi: f64) -> Result<(), TableError> {
    if a.is_empty() {
        return Err(TableError::Shape(format!("no {name}")));
    }
    for (i, &x) in a.iter().enumerate() {
        if !x.is_finite() || x < lo - SAME_ANGLE_DEG || x > hi + SAME_ANGLE_DEG {
            return Err(TableError::Angles(format!("{name} #{i} is {x}° (must lie in [{lo}°, {hi}°])")));
        }
        if i > 0 && x <= a[i - 1] {
            return Err(TableError::Angles(format!("{name} do not increase: #{} is {}°, #{i} is {x}°", i - 1, a[i - 1])));
        }
    }
    Ok(())
}

impl Goniometric {
    /// A table of stored planes `h_deg` (each with the intensities at `v_deg`, plane-major in
    /// `cd`) and the symmetry that gives the others. Validates shapes, monotone angles in range
    /// and finite, non-negative intensities.
    pub fn new(kind: PhotometricType, symmetry: Symmetry, h_deg: &[f64], v_deg: &[f64], cd: &[f64]) -> Result<Self, TableError> {
        let (vlo, vhi) = kind.vertical_range_deg();
        check_angles("vertical angles", v_deg, vlo, vhi)?;
        if v_deg.len() < 2 {
            return Err(TableError::Shape("a table needs at least two vertical angles".into()));
        }
        let (hlo, hhi) = if kind == PhotometricType::C { (0.0, 360.0) } else { (-90.0, 90.0) };
        check_angles("horizontal angles", h_deg, hlo, hhi)?;
        let nv = v_deg.len();
        if cd.len() != h_deg.len() * nv {
            return Err(TableError::Shape(format!("{} intensities for {} planes × {nv} vertical angles", cd.len(), h_deg.len())));
        }
        if let Some((index, &value)) = cd.iter().enumerate().find(|(_, v)| !v.is_finite() || **v < 0.0) {
            return Err(TableError::Value { index, value });
        }
        let images = mirror_images(kind, symmetry, h_deg)?;
        // (angle, source plane), sorted; symmetric images that land on a stored plane are dropped.
        let mut planes: Vec<(f64, usize)> = Vec::new();
        for (j, imgs) in images.iter().enumerate() {
            for &a in imgs {
                planes.push((a, j));
            }
        }
        planes.sort_by(|a, b| a.0.total_cmp(&b.0));
        planes.dedup_by(|b, a| (b.0 - a.0).abs() < SAME_ANGLE_DEG);
        if kind == PhotometricType::C {
            let (a0, j0) = planes[0];
            planes.push((a0 + 360.0, j0));
        } else if planes.len() < 2 {
            return Err(TableError::Symmetry("types A and B need at least two planes".into()));
        }
        let mut out = Self { kind, h_deg: Vec::with_capacity(planes.len()), v_deg: v_deg.to_vec(), cd: Vec::with_capacity(planes.len() * nv), opening_radius_m: 0.0 };
        for (a, j) in planes {
            out.h_deg.push(a);
            out.cd.extend_from_slice(&cd[j * nv..(j + 1) * nv]);
        }
        Ok(out)
    }

    /// A table sampled from a function `f(h_deg, v_deg) → cd` on the given angles (all planes
    /// stored, or the ones the symmetry needs). For tests and analytic set-ups.
    pub fn from_fn(kind: PhotometricType, symmetry: Symmetry, h_deg: &[f64], v_deg: &[f64], f: impl Fn(f64, f64) -> f64) -> Result<Self, TableError> {
        let cd: Vec<f64> = h_deg.iter().flat_map(|&h| v_deg.iter().map(move |&v| (h, v))).map(|(h, v)| f(h, v)).collect();
        Self::new(kind, symmetry, h_deg, v_deg, &cd)
    }

    /// The table with a luminous opening of `radius_m` (the radius of a disc of its area; the
    /// lamp's shadows get a penumbra of that source size). Negative or non-finite radii give 0.
    pub fn with_opening(mut self, radius_m: f64) -> Self {
        self.opening_radius_m = if radius_m.is_finite() { radius_m.max(0.0) } else { 0.0 };
        self
    }

    /// The radius of a disc of the luminous opening's area, metres (0: a point source).
    pub fn opening_radius_m(&self) -> f64 {
        self.opening_radius_m
    }

    /// The photometric type of the angles.
    pub fn kind(&self) -> PhotometricType {
        self.kind
    }

    /// The expanded plane angles (degrees).
    pub fn planes_deg(&self) -> &[f64] {
        &self.h_deg
    }

    /// The vertical angles (degrees).
    pub fn vertical_deg(&self) -> &[f64] {
        &self.v_deg
    }

    /// The largest intensity in the table (cd).
    pub fn max_cd(&self) -> f64 {
        self.cd.iter().copied().fold(0.0, f64::max)
    }

    /// Multiplies every intensity by `k` (e.g. cd/klm to cd). `k` must be finite and ≥ 0.
    pub fn scaled(mut self, k: f64) -> Result<Self, TableError> {
        if !k.is_finite() || k < 0.0 {
            return Err(TableError::Value { index: 0, value: k });
        }
        self.cd.iter_mut().for_each(|v| *v *= k);
        Ok(self)
    }

    /// Intensity (cd) at plane `h_deg` and vertical angle `v_deg`, bilinear in the angles; zero
    /// outside the measured range. NaN angles give 0.
    pub fn intensity_at_deg(&self, h_deg: f64, v_deg: f64) -> f64 {
        if !h_deg.is_finite() || !v_deg.is_finite() {
            return 0.0;
        }
        let h = match self.kind {
            PhotometricType::C => {
                let mut h = h_deg.rem_euclid(360.0);
                if h < self.h_deg[0] {
                    h += 360.0;
                }
                h
            }
            _ => h_deg,
        };
        let (Some((i0, th)), Some((k0, tv))) = (cell(&self.h_deg, h), cell(&self.v_deg, v_deg)) else {
            return 0.0;
        };
        let nv = self.v_deg.len();
        let at = |i: usize, k: usize| self.cd[i * nv + k];
        let i1 = (i0 + 1).min(self.h_deg.len() - 1);
        let k1 = (k0 + 1).min(nv - 1);
        let lo = at(i0, k0) * (1.0 - tv) + at(i0, k1) * tv;
        let hi = at(i1, k0) * (1.0 - tv) + at(i1, k1) * tv;
        lo * (1.0 - th) + hi * th
    }

    /// Intensity (cd) toward a unit direction in the luminaire frame.
    pub fn intensity_cd(&self, dir_in_lamp: DVec3) -> f64 {
        let (h, v) = self.kind.angles_from_dir(dir_in_lamp);
        self.intensity_at_deg(h, v)
    }

    /// Luminous flux `∫ I dω` (lm) of the bilinear interpolant, integrated exactly cell by cell.
    pub fn flux_lm(&self) -> f64 {
        let nv = self.v_deg.len();
        let mut total = 0.0;
        for i in 0..self.h_deg.len().saturating_sub(1) {
            let dh = (self.h_deg[i + 1] - self.h_deg[i]).to_radians();
            for k in 0..nv.saturating_sub(1) {
                let (v0, v1) = (self.v_deg[k].to_radians(), self.v_deg[k + 1].to_radians());
                // plane-averaged intensity at v0 and v1; linear in v between them
                let f0 = 0.5 * (self.cd[i * nv + k] + self.cd[(i + 1) * nv + k]);
                let f1 = 0.5 * (self.cd[i * nv + k + 1] + self.cd[(i + 1) * nv + k + 1]);
                let q = (f1 - f0) / (v1 - v0);
                let p = f0 - q * v0;
                let integral = match self.kind {
                    // ∫ (p + q v) sin v dv = −p cos v + q (sin v − v cos v)
                    PhotometricType::C => {
                        let g = |v: f64| -p * v.cos() + q * (v.sin() - v * v.cos());
                        g(v1) - g(v0)
                    }
                    // ∫ (p + q v) cos v dv = p sin v + q (cos v + v sin v)
                    _ => {
                        let g = |v: f64| p * v.sin() + q * (v.cos() + v * v.sin());
                        g(v1) - g(v0)
                    }
                };
                total += dh * integral;
            }
        }
        total
    }
}

/// The cell `[a[i], a[i+1]]` holding `x` and the fraction within it; `None` outside
/// `[a₀, a_last]` (a one-angle axis holds only that angle).
fn cell(a: &[f64], x: f64) -> Option<(usize, f64)> {
    let n = a.len();
    if n == 1 {
        return ((x - a[0]).abs() < SAME_ANGLE_DEG).then_some((0, 0.0));
    }
    if x < a[0] - SAME_ANGLE_DEG || x > a[n - 1] + SAME_ANGLE_DEG {
        return None;
    }
    let i = a.partition_point(|&v| v <= x).clamp(1, n - 1) - 1;
    let t = ((x - a[i]) / (a[i + 1] - a[i])).clamp(0.0, 1.0);
    Some((i, t))
}

/// For each stored plane, the angles it stands for under the symmetry (type C angles in
/// `[0°, 360°)`).
fn mirror_images(kind: PhotometricType, symmetry: Symmetry, h: &[f64]) -> Result<Vec<Vec<f64>>, TableError> {
    let first = h[0];
    let last = h[h.len() - 1];
    let near = |a: f64, b: f64| (a - b).abs() < SAME_ANGLE_DEG;
    let wrap = |a: f64| {
        let w = a.rem_euclid(360.0);
        if near(w, 360.0) { 0.0 } else { w }
    };
    let bad = |what: &str| Err(TableError::Symmetry(format!("{what} (planes {first}°–{last}°, {symmetry:?} symmetry, type {kind:?})")));
    let is_c = kind == PhotometricType::C;
    match symmetry {
        Symmetry::None if is_c => Ok(h.iter().map(|&a| vec![wrap(a)]).collect()),
        Symmetry::None => Ok(h.iter().map(|&a| vec![a]).collect()),
        Symmetry::Rotational if is_c && h.len() == 1 => Ok(vec![vec![0.0]]),
        Symmetry::Rotational => bad("rotational symmetry needs a single type C plane"),
        Symmetry::AboutC0C180 if is_c && near(first, 0.0) && near(last, 180.0) => {
            Ok(h.iter().map(|&a| vec![wrap(a), wrap(360.0 - a)]).collect())
        }
        Symmetry::Quadrant if is_c && near(first, 0.0) && near(last, 90.0) => {
            Ok(h.iter().map(|&a| vec![wrap(a), wrap(180.0 - a), wrap(180.0 + a), wrap(360.0 - a)]).collect())
        }
        Symmetry::AboutC90C270 if is_c && near(first, 90.0) && near(last, 270.0) => {
            Ok(h.iter().map(|&a| vec![wrap(a), wrap(180.0 - a)]).collect())
        }
        Symmetry::Lateral if !is_c && near(first, 0.0) && last <= 90.0 + SAME_ANGLE_DEG => {
            Ok(h.iter().map(|&a| vec![a, -a]).collect())
        }
        _ => bad("the stored planes do not fit the symmetry"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn steps(lo: f64, hi: f64, step: f64) -> Vec<f64> {
        let n = ((hi - lo) / step).round() as usize;
        (0..=n).map(|i| lo + i as f64 * step).collect()
    }

    #[test]
    fn direction_angle_round_trip_for_each_type() {
        for kind in [PhotometricType::C, PhotometricType::B, PhotometricType::A] {
            for &(h, v) in &[(10.0f64, 20.0f64), (80.0, 45.0), (-30.0, 60.0), (170.0, -40.0)] {
                let (h, v) = match kind {
                    PhotometricType::C => (h.rem_euclid(360.0), v.abs()),
                    _ => (h, v),
                };
                let d = kind.dir_from_angles(h, v);
                assert!((d.length() - 1.0).abs() < 1e-12);
                let (h2, v2) = kind.angles_from_dir(d);
                // acos/atan2 round trip: 1e-9° is far above f64 rounding near these angles
                assert!((h2 - h).abs() < 1e-9 && (v2 - v).abs() < 1e-9, "{kind:?} {h} {v} → {h2} {v2}");
            }
        }
        // nadir is γ = 0 (type C) and B = β = 0 (type B)
        assert_eq!(PhotometricType::C.angles_from_dir(-DVec3::Z).1, 0.0);
        let (b, beta) = PhotometricType::B.angles_from_dir(-DVec3::Z);
        assert!(b.abs() < 1e-12 && beta.abs() < 1e-12);
        // the type B relations to type C: tan B = cos C tan γ, sin β = sin C sin γ
        let (c, g) = (35f64.to_radians(), 50f64.to_radians());
        let d = PhotometricType::C.dir_from_angles(35.0, 50.0);
        let (b, beta) = PhotometricType::B.angles_from_dir(d);
        assert!((b.to_radians().tan() - c.cos() * g.tan()).abs() < 1e-12);
        assert!((beta.to_radians().sin() - c.sin() * g.sin()).abs() < 1e-12);
    }

    #[test]
    fn lambertian_flux_closed_form() {
        // I = I₀ cos γ on the lower hemisphere: Φ = π I₀. The interpolant is piecewise linear in
        // γ: its error is ≤ Δγ²/8 · max|cos''| relative, 0.1% for 5° steps.
        let v = steps(0.0, 90.0, 5.0);
        let g = Goniometric::from_fn(PhotometricType::C, Symmetry::Rotational, &[0.0], &v, |_, v| 1000.0 * v.to_radians().cos()).unwrap();
        let flux = g.flux_lm();
        assert!((flux / (std::f64::consts::PI * 1000.0) - 1.0).abs() < 1e-3, "{flux}");
        // an isotropic source sampled over the full sphere: 4π I exactly (constant interpolant)
        let iso = Goniometric::from_fn(PhotometricType::C, Symmetry::None, &steps(0.0, 360.0, 30.0), &steps(0.0, 180.0, 10.0), |_, _| 2.0).unwrap();
        assert!((iso.flux_lm() - 8.0 * std::f64::consts::PI).abs() < 1e-9);
        let iso_b = Goniometric::from_fn(PhotometricType::B, Symmetry::None, &steps(-90.0, 90.0, 15.0), &steps(-90.0, 90.0, 10.0), |_, _| 2.0).unwrap();
        // the front hemisphere only: 2π I
        assert!((iso_b.flux_lm() - 4.0 * std::f64::consts::PI).abs() < 1e-9);
    }

    #[test]
    fn symmetries_expand_to_the_same_intensities() {
        // f is symmetric in both the C0–C180 and the C90–C270 plane.
        let f = |c: f64, g: f64| (1.0 + 0.5 * (2.0 * c.to_radians()).cos()) * (g.to_radians().cos().max(0.0) + 0.1);
        let v = steps(0.0, 180.0, 10.0);
        let full = Goniometric::from_fn(PhotometricType::C, Symmetry::None, &steps(0.0, 360.0, 15.0), &v, f).unwrap();
        let half = Goniometric::from_fn(PhotometricType::C, Symmetry::AboutC0C180, &steps(0.0, 180.0, 15.0), &v, f).unwrap();
        let half90 = Goniometric::from_fn(PhotometricType::C, Symmetry::AboutC90C270, &steps(90.0, 270.0, 15.0), &v, f).unwrap();
        let quad = Goniometric::from_fn(PhotometricType::C, Symmetry::Quadrant, &steps(0.0, 90.0, 15.0), &v, f).unwrap();
        assert_eq!(full.planes_deg().len(), 25);
        for t in [&half, &half90, &quad] {
            assert_eq!(t.planes_deg(), full.planes_deg());
        }
        let mut rng = 0x2545_f491_4f6c_dd1du64;
        let mut next = || {
            rng ^= rng << 13;
            rng ^= rng >> 7;
            rng ^= rng << 17;
            (rng >> 11) as f64 / (1u64 << 53) as f64
        };
        for _ in 0..500 {
            let d = DVec3::new(next() - 0.5, next() - 0.5, next() - 0.5).normalize();
            let want = full.intensity_cd(d);
            for t in [&half, &half90, &quad] {
                // same samples, same grid: equal up to f64 rounding of the sums
                assert!((t.intensity_cd(d) - want).abs() < 1e-12, "{d}");
            }
        }
    }

    #[test]
    fn interpolation_hits_samples_and_wraps() {
        let v = steps(0.0, 90.0, 10.0);
        let g = Goniometric::from_fn(PhotometricType::C, Symmetry::None, &steps(0.0, 350.0, 10.0), &v, |c, g| c + g).unwrap();
        assert_eq!(g.intensity_at_deg(40.0, 30.0), 70.0);
        // between 350° and the wrapped 0° plane (value c = 0): halfway at 355°
        assert!((g.intensity_at_deg(355.0, 0.0) - 175.0).abs() < 1e-12);
        assert!((g.intensity_at_deg(-5.0, 0.0) - 175.0).abs() < 1e-12);
        // above the measured 90°: dark
        assert_eq!(g.intensity_at_deg(10.0, 120.0), 0.0);
        assert_eq!(g.intensity_at_deg(f64::NAN, 10.0), 0.0);
    }

    #[test]
    fn bad_tables_are_rejected() {
        let v = [0.0, 10.0, 20.0];
        assert!(matches!(Goniometric::new(PhotometricType::C, Symmetry::Rotational, &[0.0], &[0.0, 20.0, 10.0], &[1.0; 3]), Err(TableError::Angles(_))));
        assert!(matches!(Goniometric::new(PhotometricType::C, Symmetry::Rotational, &[0.0], &v, &[1.0, f64::NAN, 1.0]), Err(TableError::Value { index: 1, .. })));
        assert!(matches!(Goniometric::new(PhotometricType::C, Symmetry::Rotational, &[0.0], &v, &[1.0, -1.0, 1.0]), Err(TableError::Value { index: 1, .. })));
        assert!(matches!(Goniometric::new(PhotometricType::C, Symmetry::Rotational, &[0.0], &v, &[1.0; 2]), Err(TableError::Shape(_))));
        assert!(matches!(Goniometric::new(PhotometricType::C, Symmetry::Quadrant, &[0.0, 45.0], &v, &[1.0; 6]), Err(TableError::Symmetry(_))));
        assert!(matches!(Goniometric::new(PhotometricType::C, Symmetry::None, &[0.0], &[0.0, 200.0], &[1.0; 2]), Err(TableError::Angles(_))));
    }
}
