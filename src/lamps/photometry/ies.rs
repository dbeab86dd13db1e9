//! IES LM-63 photometric files (`.ies`): reader, writer and conversion to [`Goniometric`].
//!
//! # Layout
//! An optional version line (`IESNA:LM-63-1995`, `IESNA:LM-63-2002`, `IES:LM-63-2019`,
//! `IESNA91`; none in 1986 files), keyword lines `[KEY] value` (`[MORE]` continues the previous
//! one), then `TILT=NONE` or `TILT=INCLUDE` followed by the lamp-to-luminaire geometry, the
//! number of tilt angles, the angles and their multiplying factors. After that, numbers separated
//! by blanks, commas or line ends: lamp count, lumens per lamp (`−1`: absolute photometry),
//! candela multiplier, vertical and horizontal angle counts, photometric type (1 = C, 2 = B,
//! 3 = A), units (1 = feet, 2 = metres), width, length, height; ballast factor, the
//! "future use" / file-generation-type field, input watts; the vertical angles, the horizontal
//! angles, and the candela values, one run of vertical values per horizontal angle.
//!
//! # Intensities
//! `I = value × candela multiplier × ballast factor` (cd). The tilt factors are kept
//! ([`Tilt::factor_at`]) but not applied: the table is the luminaire as measured.
//! Horizontal-angle symmetry (type C): one angle (0°) → rotational; `0–90°` → quadrant; `0–180°` →
//! mirror in the C0–C180 plane; `90–270°` → mirror in the C90–C270 plane; `0°` to more than
//! `180°` (normally `360°`) → none. Types A/B: `0–90°` mirrored in `h`, `−90–90°` full.

use super::{parse_count, parse_number, read_text, Goniometric, PhotometricType, PhotometryError, Symmetry};
use std::fmt::Write as _;
use std::path::Path;

/// Which revision of LM-63 the first line names.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum IesVersion {
    /// No version line (LM-63-1986).
    Lm63_1986,
    /// `IESNA91`.
    Lm63_1991,
    /// `IESNA:LM-63-1995`.
    Lm63_1995,
    /// `IESNA:LM-63-2002`.
    Lm63_2002,
    /// `IES:LM-63-2019`.
    Lm63_2019,
    /// Another `IES…` line, kept as written.
    Other(String),
}

/// The `TILT=INCLUDE` block: lamp output against the luminaire's tilt.
#[derive(Clone, Debug, PartialEq)]
pub struct Tilt {
    /// Lamp-to-luminaire geometry (1: vertical base-up/down lamp, 2: horizontal lamp along the
    /// 0° plane, 3: horizontal lamp along the 90° plane).
    pub lamp_to_luminaire_geometry: u8,
    /// Tilt angles (degrees), increasing.
    pub angles_deg: Vec<f64>,
    /// Multiplying factor at each angle.
    pub factors: Vec<f64>,
}

impl Tilt {
    /// The factor at a tilt angle, linear between the listed angles and held past the ends.
    pub fn factor_at(&self, angle_deg: f64) -> f64 {
        let a = &self.angles_deg;
        let i = a.partition_point(|&x| x <= angle_deg);
        if i == 0 {
            return self.factors[0];
        }
        if i == a.len() {
            return self.factors[a.len() - 1];
        }
        let t = (angle_deg - a[i - 1]) / (a[i] - a[i - 1]);
        self.factors[i - 1] * (1.0 - t) + self.factors[i] * t
    }
}

/// Unit of the luminous opening's dimensions.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LengthUnit {
    /// Feet (`1`).
    Feet,
    /// Metres (`2`).
    Metres,
}

/// An IES LM-63 file as written.
#[derive(Clone, Debug, PartialEq)]
pub struct IesFile {
    /// The revision named on the first line.
    pub version: IesVersion,
    /// Keywords in file order (`("TEST", "…")`); free text lines of old files have key `""`.
    pub keywords: Vec<(String, String)>,
    /// `None` for `TILT=NONE`.
    pub tilt: Option<Tilt>,
    /// Number of lamps.
    pub lamp_count: usize,
    /// Lumens per lamp (`−1` for absolute photometry).
    pub lumens_per_lamp: f64,
    /// Candela multiplier.
    pub candela_multiplier: f64,
    /// Photometric type.
    pub photometric_type: PhotometricType,
    /// Unit of `size`.
    pub units: LengthUnit,
    /// Width, length and height of the luminous opening.
    pub size: [f64; 3],
    /// Ballast factor.
    pub ballast_factor: f64,
    /// The field after the ballast factor ("future use" in 1995/2002, the file generation type
    /// in 2019, the ballast-lamp photometric factor in 1991).
    pub file_generation: f64,
    /// Input watts.
    pub input_watts: f64,
    /// Vertical angles (degrees).
    pub vertical_deg: Vec<f64>,
    /// Horizontal angles (degrees).
    pub horizontal_deg: Vec<f64>,
    /// Candela values as written (before the multiplier), one run of `vertical_deg.len()` values
    /// per horizontal angle.
    pub candela: Vec<f64>,
}

/// The numbers after the `TILT=` line, each with its line.
struct Tokens<'a> {
    path: &'a Path,
    toks: Vec<(usize, &'a str)>,
    pos: usize,
    last_line: usize,
}

impl<'a> Tokens<'a> {
    fn next(&mut self, field: &str) -> Result<(usize, &'a str), PhotometryError> {
        let t = self.toks.get(self.pos).copied().ok_or_else(|| PhotometryError::Truncated {
            path: self.path.to_owned(),
            line: self.last_line,
            field: field.to_owned(),
        })?;
        self.pos += 1;
        Ok(t)
    }
    fn number(&mut self, field: &str) -> Result<(usize, f64), PhotometryError> {
        let (line, t) = self.next(field)?;
        Ok((line, parse_number(self.path, line, field, t)?))
    }
    fn count(&mut self, field: &str, min: usize) -> Result<(usize, usize), PhotometryError> {
        let (line, t) = self.next(field)?;
        Ok((line, parse_count(self.path, line, field, t, min)?))
    }
    /// `n` numbers and the line of each.
    fn numbers(&mut self, n: usize, field: &str) -> Result<(Vec<usize>, Vec<f64>), PhotometryError> {
        let mut lines = Vec::with_capacity(n);
        let mut vals = Vec::with_capacity(n);
        for i in 0..n {
            let (l, v) = self.number(&format!("{field} #{i}"))?;
            lines.push(l);
            vals.push(v);
        }
        Ok((lines, vals))
    }
}

/// Checks a list of angles (strictly increasing, within `[lo, hi]`), naming the line of the
/// first offender.
fn check_list(path: &Path, field: &str, lines: &[usize], a: &[f64], lo: f64, hi: f64) -> Result<(), PhotometryError> {
    for (i, &x) in a.iter().enumerate() {
        if x < lo || x > hi {
            return Err(PhotometryError::field(path, lines[i], field, format!("#{i} is {x}° (must lie in [{lo}°, {hi}°])")));
        }
        if i > 0 && x <= a[i - 1] {
            return Err(PhotometryError::field(path, lines[i], field, format!("not increasing: #{} is {}°, #{i} is {x}°", i - 1, a[i - 1])));
        }
    }
    Ok(())
}

impl IesFile {
    /// Reads and validates a file.
    pub fn read(path: &Path) -> Result<Self, PhotometryError> {
        Self::parse(&read_text(path)?, path)
    }

    /// Parses and validates the text of a file; `path` names it in errors.
    pub fn parse(text: &str, path: &Path) -> Result<Self, PhotometryError> {
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        let lines: Vec<&str> = text.lines().map(|l| l.trim_end_matches('\r')).collect();
        let first = lines.first().map(|l| l.trim()).unwrap_or("");
        let upper = first.to_ascii_uppercase();
        let (version, header_start) = match upper.as_str() {
            "IESNA:LM-63-1995" => (IesVersion::Lm63_1995, 1),
            "IESNA:LM-63-2002" => (IesVersion::Lm63_2002, 1),
            "IES:LM-63-2019" => (IesVersion::Lm63_2019, 1),
            u if u.starts_with("IESNA91") => (IesVersion::Lm63_1991, 1),
            u if u.starts_with("IESNA") || u.starts_with("IES:") => (IesVersion::Other(first.to_owned()), 1),
            _ => (IesVersion::Lm63_1986, 0),
        };
        let mut keywords: Vec<(String, String)> = Vec::new();
        let mut tilt_at = None;
        for (i, raw) in lines.iter().enumerate().skip(header_start) {
            let l = raw.trim();
            if l.to_ascii_uppercase().starts_with("TILT") && l.contains('=') {
                tilt_at = Some(i);
                break;
            }
            match l.strip_prefix('[').and_then(|r| r.split_once(']')) {
                Some((key, value)) if key.eq_ignore_ascii_case("MORE") && !keywords.is_empty() => {
                    let last = keywords.len() - 1;
                    keywords[last].1.push('\n');
                    keywords[last].1.push_str(value.trim());
                }
                Some((key, value)) => keywords.push((key.trim().to_owned(), value.trim().to_owned())),
                None if l.is_empty() => {}
                None => keywords.push((String::new(), l.to_owned())),
            }
        }
        let tilt_at = tilt_at.ok_or_else(|| PhotometryError::Truncated { path: path.to_owned(), line: lines.len(), field: "the TILT= line".into() })?;
        let tilt_value = lines[tilt_at].split_once('=').map(|(_, v)| v.trim()).unwrap_or("");
        let mut toks = Tokens { path, toks: Vec::new(), pos: 0, last_line: lines.len() };
        for (i, l) in lines.iter().enumerate().skip(tilt_at + 1) {
            toks.toks.extend(l.split(|c: char| c.is_whitespace() || c == ',').filter(|t| !t.is_empty()).map(|t| (i + 1, t)));
        }
        let tilt = match tilt_value.to_ascii_uppercase().as_str() {
            "NONE" => None,
            "INCLUDE" => Some(parse_tilt(&mut toks)?),
            _ => return Err(PhotometryError::field(path, tilt_at + 1, "TILT", format!("'{tilt_value}': only TILT=NONE and TILT=INCLUDE are read (a separate tilt file is not)"))),
        };
        let mut f = parse_photometry(&mut toks, version, keywords, tilt)?;
        if let Some(&(line, t)) = toks.toks.get(toks.pos) {
            let want = f.vertical_deg.len() * f.horizontal_deg.len();
            return Err(PhotometryError::field(path, line, "candela values", format!("'{t}' after the {want} values the angle counts call for")));
        }
        f.candela.shrink_to_fit();
        Ok(f)
    }

    /// The symmetry the horizontal angles imply (see the module docs).
    pub fn symmetry(&self) -> Result<Symmetry, String> {
        let h = &self.horizontal_deg;
        let (first, last) = (h[0], h[h.len() - 1]);
        let s = match self.photometric_type {
            PhotometricType::C if h.len() == 1 && first == 0.0 => Symmetry::Rotational,
            PhotometricType::C if first == 0.0 && last == 90.0 => Symmetry::Quadrant,
            PhotometricType::C if first == 0.0 && last == 180.0 => Symmetry::AboutC0C180,
            PhotometricType::C if first == 90.0 && last == 270.0 => Symmetry::AboutC90C270,
            PhotometricType::C if first == 0.0 && last > 180.0 && last <= 360.0 => Symmetry::None,
            PhotometricType::A | PhotometricType::B if first == 0.0 && last <= 90.0 && h.len() > 1 => Symmetry::Lateral,
            PhotometricType::A | PhotometricType::B if first >= -90.0 && last <= 90.0 && h.len() > 1 => Symmetry::None,
            t => return Err(format!("horizontal angles {first}°–{last}° ({} of them) fit no type {t:?} symmetry", h.len())),
        };
        Ok(s)
    }

    /// Intensity scale from file values to candela: multiplier × ballast factor.
    pub fn candela_scale(&self) -> f64 {
        self.candela_multiplier * self.ballast_factor
    }

    /// The intensity table (cd), symmetry expanded.
    pub fn goniometric(&self) -> Result<Goniometric, super::TableError> {
        let sym = self.symmetry().map_err(super::TableError::Symmetry)?;
        Ok(Goniometric::new(self.photometric_type, sym, &self.horizontal_deg, &self.vertical_deg, &self.candela)?.scaled(self.candela_scale())?.with_opening(self.opening_radius_m()))
    }

    /// The radius of a disc with the luminous opening's area, metres. LM-63-2002 §5.10: a
    /// rectangle is `width × length` (height 0 for a flat opening); a negative width and length
    /// mean a circle of that diameter; a vertical opening (height only, or a sphere or cylinder
    /// by negative values) is taken by its largest extent. All zero: a point (0).
    pub fn opening_radius_m(&self) -> f64 {
        let metres = match self.units {
            LengthUnit::Feet => 0.3048,
            LengthUnit::Metres => 1.0,
        };
        let [w, l, h] = self.size.map(|v| if v.is_finite() { v * metres } else { 0.0 });
        if w < 0.0 || l < 0.0 {
            return 0.5 * w.abs().max(l.abs());
        }
        if w > 0.0 && l > 0.0 {
            return (w * l / std::f64::consts::PI).sqrt();
        }
        0.5 * w.abs().max(l.abs()).max(h.abs())
    }

    /// The file as LM-63 text (the version line of `self.version`; numbers in Rust's shortest
    /// round-trip form, ten to a line).
    pub fn to_text(&self) -> String {
        let mut s = String::new();
        match &self.version {
            IesVersion::Lm63_1986 => {}
            IesVersion::Lm63_1991 => s.push_str("IESNA91\n"),
            IesVersion::Lm63_1995 => s.push_str("IESNA:LM-63-1995\n"),
            IesVersion::Lm63_2002 => s.push_str("IESNA:LM-63-2002\n"),
            IesVersion::Lm63_2019 => s.push_str("IES:LM-63-2019\n"),
            IesVersion::Other(v) => s.push_str(&format!("{v}\n")),
        }
        for (k, v) in &self.keywords {
            let mut parts = v.split('\n');
            let head = parts.next().unwrap_or("");
            if k.is_empty() {
                let _ = writeln!(s, "{head}");
            } else {
                let _ = writeln!(s, "[{k}] {head}");
            }
            for more in parts {
                let _ = writeln!(s, "[MORE] {more}");
            }
        }
        let list = |s: &mut String, v: &[f64]| {
            for chunk in v.chunks(10) {
                let _ = writeln!(s, "{}", chunk.iter().map(|x| x.to_string()).collect::<Vec<_>>().join(" "));
            }
        };
        match &self.tilt {
            None => s.push_str("TILT=NONE\n"),
            Some(t) => {
                let _ = writeln!(s, "TILT=INCLUDE\n{}\n{}", t.lamp_to_luminaire_geometry, t.angles_deg.len());
                list(&mut s, &t.angles_deg);
                list(&mut s, &t.factors);
            }
        }
        let kind = match self.photometric_type {
            PhotometricType::C => 1,
            PhotometricType::B => 2,
            PhotometricType::A => 3,
        };
        let units = if self.units == LengthUnit::Feet { 1 } else { 2 };
        let [w, l, h] = self.size;
        let _ = writeln!(s, "{} {} {} {} {} {kind} {units} {w} {l} {h}", self.lamp_count, self.lumens_per_lamp, self.candela_multiplier, self.vertical_deg.len(), self.horizontal_deg.len());
        let _ = writeln!(s, "{} {} {}", self.ballast_factor, self.file_generation, self.input_watts);
        list(&mut s, &self.vertical_deg);
        list(&mut s, &self.horizontal_deg);
        for plane in self.candela.chunks(self.vertical_deg.len().max(1)) {
            list(&mut s, plane);
        }
        s
    }
}

fn parse_tilt(t: &mut Tokens) -> Result<Tilt, PhotometryError> {
    let (line, geometry) = t.count("lamp-to-luminaire geometry", 1)?;
    if geometry > 3 {
        return Err(PhotometryError::field(t.path, line, "lamp-to-luminaire geometry", format!("{geometry} (must be 1, 2 or 3)")));
    }
    let (_, n) = t.count("number of tilt angles", 1)?;
    let (lines, angles_deg) = t.numbers(n, "tilt angles")?;
    check_list(t.path, "tilt angles", &lines, &angles_deg, 0.0, 180.0)?;
    let (lines, factors) = t.numbers(n, "tilt multiplying factors")?;
    if let Some(i) = factors.iter().position(|&f| f < 0.0) {
        return Err(PhotometryError::field(t.path, lines[i], "tilt multiplying factors", format!("#{i} is {} (must be ≥ 0)", factors[i])));
    }
    Ok(Tilt { lamp_to_luminaire_geometry: geometry as u8, angles_deg, factors })
}

fn parse_photometry(t: &mut Tokens, version: IesVersion, keywords: Vec<(String, String)>, tilt: Option<Tilt>) -> Result<IesFile, PhotometryError> {
    let path = t.path;
    let (_, lamp_count) = t.count("number of lamps", 1)?;
    let (line, lumens_per_lamp) = t.number("lumens per lamp")?;
    if lumens_per_lamp <= 0.0 && lumens_per_lamp != -1.0 {
        return Err(PhotometryError::field(path, line, "lumens per lamp", format!("{lumens_per_lamp} (must be > 0, or −1 for absolute photometry)")));
    }
    let (line, candela_multiplier) = t.number("candela multiplier")?;
    if candela_multiplier <= 0.0 {
        return Err(PhotometryError::field(path, line, "candela multiplier", format!("{candela_multiplier} (must be > 0)")));
    }
    let (_, nv) = t.count("number of vertical angles", 2)?;
    let (line, nh) = t.count("number of horizontal angles", 1)?;
    if nv * nh > super::MAX_LIST_LEN * 10 {
        return Err(PhotometryError::field(path, line, "number of angles", format!("{nv} × {nh} candela values is more than this reader takes")));
    }
    let (line, kind) = t.count("photometric type", 1)?;
    let photometric_type = match kind {
        1 => PhotometricType::C,
        2 => PhotometricType::B,
        3 => PhotometricType::A,
        k => return Err(PhotometryError::field(path, line, "photometric type", format!("{k} (must be 1 = C, 2 = B or 3 = A)"))),
    };
    let (line, units) = t.count("units type", 1)?;
    let units = match units {
        1 => LengthUnit::Feet,
        2 => LengthUnit::Metres,
        u => return Err(PhotometryError::field(path, line, "units type", format!("{u} (must be 1 = feet or 2 = metres)"))),
    };
    let size = [t.number("width")?.1, t.number("length")?.1, t.number("height")?.1];
    let (line, ballast_factor) = t.number("ballast factor")?;
    if ballast_factor <= 0.0 {
        return Err(PhotometryError::field(path, line, "ballast factor", format!("{ballast_factor} (must be > 0)")));
    }
    let file_generation = t.number("file generation type / future use")?.1;
    let input_watts = t.number("input watts")?.1;
    let (vlines, vertical_deg) = t.numbers(nv, "vertical angles")?;
    let (lo, hi) = photometric_type.vertical_range_deg();
    check_list(path, "vertical angles", &vlines, &vertical_deg, lo, hi)?;
    let (hlines, horizontal_deg) = t.numbers(nh, "horizontal angles")?;
    let (hlo, hhi) = if photometric_type == PhotometricType::C { (0.0, 360.0) } else { (-90.0, 90.0) };
    check_list(path, "horizontal angles", &hlines, &horizontal_deg, hlo, hhi)?;
    let (clines, candela) = t.numbers(nv * nh, "candela values")?;
    if let Some(i) = candela.iter().position(|&c| c < 0.0) {
        return Err(PhotometryError::field(path, clines[i], "candela values", format!("#{i} (plane {}, vertical angle {}) is {} (must be ≥ 0)", i / nv, i % nv, candela[i])));
    }
    let f = IesFile {
        version,
        keywords,
        tilt,
        lamp_count,
        lumens_per_lamp,
        candela_multiplier,
        photometric_type,
        units,
        size,
        ballast_factor,
        file_generation,
        input_watts,
        vertical_deg,
        horizontal_deg,
        candela,
    };
    f.symmetry().map_err(|m| PhotometryError::field(path, hlines[nh - 1], "horizontal angles", m))?;
    Ok(f)
}
