//! Storage formats for light-field textures: the paper's signed RGBE, RGB9E5 and half float, with
//! their round trips and measured errors.
//!
//! # How it works
//! - **sRGBE** (Granier §4.2, Appendix A): a shared exponent `e = ⌊log₂ max(|R|,|G|,|B|)⌋ + 2`,
//!   channels `c · 2⁻ᵉ + ½` and exponent `(e + 126)/255`, all four stored as 8-bit fixed point
//!   (`round(x · 255)`); decoded as `(c₈/255 − ½) · 2^(e₈ − 126)`. The largest channel's
//!   `|c| · 2⁻ᵉ` lies in `[¼, ½)`, so the rounding error of every channel is at most half a step,
//!   `2ᵉ/510 ≤ (2/255) · max|c|`: 0.78 % of the texel's largest channel. Signed values keep their
//!   sign — the light-field images need that, because the dual filter has negative lobes.
//!   (`½` is not a multiple of `1/255`, so an exact zero decodes to `±2ᵉ/510`.)
//! - **RGB9E5** (`EXT_texture_shared_exponent`): 9-bit mantissas and a 5-bit shared exponent in
//!   32 bits, non-negative only (negative channels clamp to 0), up to 65408; error at most
//!   `2⁻⁹` of the largest channel.
//! - **Half float** (IEEE binary16 per channel): signed, relative error `≤ 2⁻¹¹` per channel down
//!   to `6·10⁻⁵`, finite up to 65504 (larger values are clamped here).
//!
//! Sizes are per texel as a GPU texture: sRGBE and RGB9E5 4 bytes, half float 8 (RGBA16F: there
//! is no filterable 3-channel half format), f32 16 (RGBA32F).
//!
//! NaN channels are stored as 0 and infinities as the largest finite value, in every format;
//! decoding clamps to the largest finite f32.

use crate::io::image::LinearImage;
use exr::prelude::f16;

/// Largest finite binary16 value.
const HALF_MAX: f32 = 65504.0;
/// RGB9E5: mantissa bits, exponent bias and largest biased exponent.
const RGB9E5_MANTISSA_BITS: i32 = 9;
const RGB9E5_BIAS: i32 = 15;
const RGB9E5_MAX_EXP: i32 = 31;
/// sRGBE exponent offset (`E = (e + 126)/255`) and the exponent range the 8-bit code holds.
const SRGBE_OFFSET: i32 = 126;
/// Texels darker than this fraction of the image peak are left out of the per-texel relative
/// error (their relative error is dominated by the format's absolute floor, not its precision).
pub const REL_ERROR_FLOOR: f32 = 1e-3;

/// The format light-field textures use unless told otherwise: half float. Measured on the
/// synthetic torch's images (`lamps::lightfield::tests`), half keeps every texel within
/// 4.8·10⁻⁴ of its value against 7.8·10⁻³ for sRGBE, is signed (RGB9E5 is not, and 40 % of the
/// texels are negative through the dual filter's lobes), and GPUs filter it in hardware, while
/// shared-exponent codes cannot be interpolated before decoding. sRGBE halves the memory
/// (4 bytes against 8) for an irradiance error still far below the reconstruction's own, so it is
/// the choice when texture memory, not precision, is the limit.
pub const DEFAULT_STORAGE: StorageFormat = StorageFormat::Half;

/// A texel storage format.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum StorageFormat {
    /// 32-bit float per channel (the reference).
    F32,
    /// 16-bit float per channel.
    Half,
    /// Shared-exponent 9-9-9-5.
    Rgb9e5,
    /// Signed RGBE (Granier §4.2).
    Srgbe,
}

impl StorageFormat {
    /// Every format, reference first.
    pub const ALL: [StorageFormat; 4] = [StorageFormat::F32, StorageFormat::Half, StorageFormat::Rgb9e5, StorageFormat::Srgbe];

    /// Bytes per texel as a GPU texture (see the module docs).
    pub fn bytes_per_texel(self) -> usize {
        match self {
            StorageFormat::F32 => 16,
            StorageFormat::Half => 8,
            StorageFormat::Rgb9e5 | StorageFormat::Srgbe => 4,
        }
    }

    /// Whether negative values survive.
    pub fn is_signed(self) -> bool {
        !matches!(self, StorageFormat::Rgb9e5)
    }

    /// Lower-case name (as in files and tables).
    pub fn name(self) -> &'static str {
        match self {
            StorageFormat::F32 => "f32",
            StorageFormat::Half => "half",
            StorageFormat::Rgb9e5 => "rgb9e5",
            StorageFormat::Srgbe => "srgbe",
        }
    }

    /// The value after encoding and decoding.
    pub fn round_trip(self, rgb: [f32; 3]) -> [f32; 3] {
        match self {
            StorageFormat::F32 => rgb.map(sanitize),
            StorageFormat::Half => rgb.map(|c| f16::from_f32(sanitize(c).clamp(-HALF_MAX, HALF_MAX)).to_f32()),
            StorageFormat::Rgb9e5 => rgb_from_rgb9e5(rgb9e5_from_rgb(rgb)),
            StorageFormat::Srgbe => rgb_from_srgbe(srgbe_from_rgb(rgb)),
        }
    }

    /// An image after encoding and decoding every texel, stored with a per-image scale: the
    /// power of two at or above the image's largest `|channel|` (one uniform per texture layer on
    /// the GPU; a power of two, so the scaling itself is exact). Without it half floats would
    /// fall into their subnormal range on dim images (light-field values are often near 10⁻⁵).
    pub fn round_trip_image(self, img: &LinearImage) -> LinearImage {
        let scale = image_scale(img);
        LinearImage { width: img.width, height: img.height, data: img.data.iter().map(|&p| self.round_trip(p.map(|c| c / scale)).map(|c| c * scale)).collect() }
    }
}

/// The per-image scale of [`StorageFormat::round_trip_image`] (1 for a black image).
pub fn image_scale(img: &LinearImage) -> f32 {
    let peak = img.data.iter().flat_map(|p| p.iter()).fold(0.0f32, |a, v| if v.is_finite() { a.max(v.abs()) } else { a });
    if peak > 0.0 { (2.0f64).powi((peak as f64).log2().ceil() as i32) as f32 } else { 1.0 }
}

/// NaN → 0, ±∞ → ±f32::MAX.
fn sanitize(c: f32) -> f32 {
    if c.is_nan() { 0.0 } else { c.clamp(-f32::MAX, f32::MAX) }
}

/// `⌊log₂ m⌋` for a positive finite `m` (exact at powers of two: computed in f64).
fn floor_log2(m: f32) -> i32 {
    (m as f64).log2().floor() as i32
}

/// Encodes RGB as signed RGBE: `[R, G, B, E]` 8-bit codes (Granier Appendix A, quantised as an
/// 8-bit fixed-point frame buffer stores `[0, 1]`).
pub fn srgbe_from_rgb(rgb: [f32; 3]) -> [u8; 4] {
    let c = rgb.map(sanitize);
    let m = c.iter().fold(0.0f32, |a, v| a.max(v.abs()));
    let e = if m > 0.0 { (floor_log2(m) + 2).clamp(-SRGBE_OFFSET, 255 - SRGBE_OFFSET) } else { -SRGBE_OFFSET };
    let scale = (2.0f64).powi(-e);
    let code = |v: f32| ((v as f64 * scale + 0.5) * 255.0).round().clamp(0.0, 255.0) as u8;
    [code(c[0]), code(c[1]), code(c[2]), (e + SRGBE_OFFSET) as u8]
}

/// Decodes signed RGBE codes (Granier Appendix A).
pub fn rgb_from_srgbe(code: [u8; 4]) -> [f32; 3] {
    let scale = (2.0f64).powi(code[3] as i32 - SRGBE_OFFSET);
    [0, 1, 2].map(|i| ((code[i] as f64 / 255.0 - 0.5) * scale).clamp(-f32::MAX as f64, f32::MAX as f64) as f32)
}

/// Encodes RGB as RGB9E5 (`EXT_texture_shared_exponent`); negative channels become 0.
pub fn rgb9e5_from_rgb(rgb: [f32; 3]) -> u32 {
    let n = RGB9E5_MANTISSA_BITS;
    let max_value = ((1 << n) - 1) as f64 / (1 << n) as f64 * (2.0f64).powi(RGB9E5_MAX_EXP - RGB9E5_BIAS);
    let c = rgb.map(|v| (sanitize(v) as f64).clamp(0.0, max_value));
    let m = c[0].max(c[1]).max(c[2]);
    let low = -RGB9E5_BIAS - 1;
    let exp_floor = if m > 0.0 { (m.log2().floor() as i32).max(low) } else { low };
    let mut exp = exp_floor + 1 + RGB9E5_BIAS;
    if (m / (2.0f64).powi(exp - RGB9E5_BIAS - n) + 0.5).floor() as i64 == 1i64 << n {
        exp += 1;
    }
    let denom = (2.0f64).powi(exp - RGB9E5_BIAS - n);
    let q = c.map(|v| ((v / denom + 0.5).floor() as u32).min((1 << n) - 1));
    q[0] | (q[1] << 9) | (q[2] << 18) | ((exp as u32) << 27)
}

/// Decodes RGB9E5.
pub fn rgb_from_rgb9e5(packed: u32) -> [f32; 3] {
    let exp = (packed >> 27) as i32;
    let scale = (2.0f64).powi(exp - RGB9E5_BIAS - RGB9E5_MANTISSA_BITS);
    [0, 9, 18].map(|s| (((packed >> s) & 0x1ff) as f64 * scale) as f32)
}

/// A format's error over a set of images.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct FormatError {
    /// Mean over texels of `‖decoded − true‖∞ / ‖true‖∞` (texels above
    /// [`REL_ERROR_FLOOR`] × peak).
    pub mean_rel: f64,
    /// Largest such relative error.
    pub max_rel: f64,
    /// Mean over all texels of `‖decoded − true‖∞ / peak` (peak: the largest `|channel|` of the
    /// image).
    pub mean_of_peak: f64,
    /// Largest such error.
    pub max_of_peak: f64,
    /// Fraction of texels with a negative channel (lost by unsigned formats).
    pub negative_fraction: f64,
}

/// Measures `format` on `images`, each stored with its per-image scale
/// ([`StorageFormat::round_trip_image`]).
pub fn measure(format: StorageFormat, images: &[LinearImage]) -> FormatError {
    let (mut n_rel, mut n_all, mut n_neg) = (0usize, 0usize, 0usize);
    let mut e = FormatError::default();
    for img in images {
        let peak = img.data.iter().flat_map(|p| p.iter()).fold(0.0f32, |a, v| a.max(v.abs()));
        if peak <= 0.0 {
            continue;
        }
        let stored = format.round_trip_image(img);
        for (&p, &d) in img.data.iter().zip(&stored.data) {
            let err = (0..3).map(|c| (d[c] as f64 - p[c] as f64).abs()).fold(0.0, f64::max);
            let mag = p.iter().fold(0.0f32, |a, v| a.max(v.abs()));
            n_all += 1;
            n_neg += p.iter().any(|&c| c < 0.0) as usize;
            e.mean_of_peak += err / peak as f64;
            e.max_of_peak = e.max_of_peak.max(err / peak as f64);
            if mag >= REL_ERROR_FLOOR * peak {
                n_rel += 1;
                e.mean_rel += err / mag as f64;
                e.max_rel = e.max_rel.max(err / mag as f64);
            }
        }
    }
    e.mean_rel /= n_rel.max(1) as f64;
    e.mean_of_peak /= n_all.max(1) as f64;
    e.negative_fraction = n_neg as f64 / n_all.max(1) as f64;
    e
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Deterministic values over many octaves, both signs.
    fn values() -> Vec<[f32; 3]> {
        let mut s = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = move || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 53) as f64
        };
        (0..20_000)
            .map(|_| {
                let octave = (next() * 40.0 - 20.0).exp2();
                [0; 3].map(|_| ((next() * 2.0 - 1.0) * octave) as f32)
            })
            .collect()
    }

    #[test]
    fn srgbe_round_trip_within_its_bound() {
        for v in values() {
            let m = v.iter().fold(0.0f32, |a, c| a.max(c.abs())) as f64;
            let d = rgb_from_srgbe(srgbe_from_rgb(v));
            for c in 0..3 {
                // half an 8-bit step of the mantissa, 2^e/510 ≤ (2/255)·max|c| (module docs);
                // the 1e-6 covers the f32 rounding of the decoded value
                let err = (d[c] as f64 - v[c] as f64).abs();
                assert!(err <= m * 2.0 / 255.0 * (1.0 + 1e-6), "{v:?} → {d:?}");
                // the sign survives wherever the value is more than one step from zero
                if (v[c] as f64).abs() > m * 4.0 / 255.0 {
                    assert_eq!(d[c].signum(), v[c].signum());
                }
            }
        }
        // the paper's exponent: 0.3 → e = ⌊log₂ 0.3⌋ + 2 = 0 → code 126
        assert_eq!(srgbe_from_rgb([0.3, 0.0, 0.0])[3], 126);
        // zero and NaN encode to the smallest exponent and decode to (almost) zero
        let z = rgb_from_srgbe(srgbe_from_rgb([0.0, f32::NAN, 0.0]));
        assert!(z.iter().all(|c| c.abs() < 1e-38));
        // the largest finite value stays finite
        assert!(rgb_from_srgbe(srgbe_from_rgb([f32::INFINITY, 1.0, 0.0]))[0].is_finite());
    }

    #[test]
    fn rgb9e5_and_half_within_their_bounds() {
        for v in values() {
            let pos = v.map(|c| c.abs().min(60000.0));
            let m = pos.iter().fold(0.0f32, |a, c| a.max(*c)) as f64;
            let d = rgb_from_rgb9e5(rgb9e5_from_rgb(pos));
            for c in 0..3 {
                // half a mantissa step: 2^(exp−B−N)/2 ≤ 2⁻⁹ · max (the spec's rounding), and
                // below 2⁻²⁴ (the smallest step) everything rounds to a multiple of it
                assert!((d[c] as f64 - pos[c] as f64).abs() <= m * 2f64.powi(-9) * (1.0 + 1e-6) + 2f64.powi(-25), "{pos:?} → {d:?}");
            }
            let h = StorageFormat::Half.round_trip(v);
            for c in 0..3 {
                // binary16: relative 2⁻¹¹ for normals, absolute 2⁻²⁵ for subnormals
                let x = v[c].clamp(-HALF_MAX, HALF_MAX) as f64;
                assert!((h[c] as f64 - x).abs() <= x.abs() * 2f64.powi(-11) + 2f64.powi(-25), "{x} → {}", h[c]);
            }
        }
        // negatives are lost by RGB9E5, kept by the others
        assert_eq!(StorageFormat::Rgb9e5.round_trip([-1.0, 2.0, 0.5]), [0.0, 2.0, 0.5]);
        assert!(StorageFormat::Srgbe.round_trip([-1.0, 2.0, 0.5])[0] < -0.98);
        // the rounding that carries into the next exponent (0.999999 · 2^k rounds up to 512)
        let d = rgb_from_rgb9e5(rgb9e5_from_rgb([1.0 - 1e-7, 0.0, 0.0]));
        assert!((d[0] - 1.0).abs() < 1e-6);
    }

    #[test]
    fn measured_errors_rank_the_formats() {
        let img = LinearImage::from_fn(32, 32, |x, y| {
            let s = (x as f32 * 0.3).sin() * 5.0 + (y as f32 * 0.2).cos();
            [s, s * 0.5 + 3.0, (x + y) as f32 * 0.1]
        });
        let errs = StorageFormat::ALL.map(|f| measure(f, std::slice::from_ref(&img)));
        assert_eq!(errs[0].max_rel, 0.0);
        // half is the most precise of the compact ones; sRGBE within its 0.78 % per texel
        assert!(errs[1].max_rel < errs[3].max_rel && errs[3].max_rel <= 2.0 / 255.0 * 1.001);
        // the image has negative texels: RGB9E5 loses them (an error of 100 % of such a channel)
        assert!(errs[2].negative_fraction > 0.1 && errs[2].max_rel >= 0.99);
    }
}
