//! EULUMDAT files (`.ldt`): reader, writer and conversion to [`Goniometric`].
//!
//! # Layout
//! One field per line (Stockmar 1990): 1 company/format, 2 type indicator `Ityp`, 3 symmetry
//! indicator `Isym`, 4 number of C-planes `Mc`, 5 their spacing `Dc`, 6 number of γ angles `Ng`,
//! 7 their spacing `Dg`, 8–12 report number, luminaire name and number, file name, date/user,
//! 13–15 luminaire length/diameter, width, height (mm), 16–17 luminous area length/diameter and
//! width, 18–21 luminous area heights in C0/C90/C180/C270, 22 downward flux fraction (%), 23
//! light output ratio (%), 24 intensity conversion factor, 25 tilt during measurement, 26 number
//! `n` of lamp sets, then six lines per set (number of lamps, type, total flux in lm, colour
//! temperature, colour rendering, wattage), ten direct ratios, the `Mc` C angles, the `Ng` γ
//! angles, and the intensities (cd/klm) of the stored planes, `Ng` per plane.
//!
//! # Symmetry (`Isym`)
//! 0: all `Mc` planes; 1: one plane (rotational); 2: C0–C180 (`Mc/2 + 1` planes); 3: C270–C90
//! through C0 (`Mc/2 + 1` planes, mirrored in the C90–C270 plane); 4: C0–C90 (`Mc/4 + 1`).
//!
//! # Intensities
//! `I = value × conversion factor × Φ/1000` (cd) with `Φ` the total lamp flux of the first lamp
//! set; a file without a positive flux keeps cd/klm.
//!
//! Files with several lamp sets are read set by set (six lines each); the rare writers that
//! group the lines field by field are not told apart.

use super::{parse_count, parse_number, read_text, Goniometric, PhotometricType, PhotometryError, Symmetry, TableError};
use std::fmt::Write as _;
use std::path::Path;

/// One lamp set (line 26a–26f).
#[derive(Clone, Debug, PartialEq)]
pub struct LampSet {
    /// Number of lamps (negative in some absolute-photometry files).
    pub count: i64,
    /// Type of lamps.
    pub kind: String,
    /// Total luminous flux of the lamps (lm).
    pub flux_lm: f64,
    /// Colour appearance / temperature.
    pub colour: String,
    /// Colour rendering group / index.
    pub colour_rendering: String,
    /// Wattage including ballast (W).
    pub watts: f64,
}

/// A EULUMDAT file as written.
#[derive(Clone, Debug, PartialEq)]
pub struct LdtFile {
    /// Line 1.
    pub header: String,
    /// `Ityp` (0–3).
    pub type_indicator: u8,
    /// `Isym` (0–4).
    pub symmetry: u8,
    /// `Dc`: C-plane spacing (degrees, 0 if not equidistant).
    pub c_step_deg: f64,
    /// `Dg`: γ spacing (degrees, 0 if not equidistant).
    pub gamma_step_deg: f64,
    /// Lines 8–12: report number, luminaire name, luminaire number, file name, date/user.
    pub texts: [String; 5],
    /// Lines 13–21: luminaire length, width, height; luminous area length, width; luminous
    /// area heights in C0, C90, C180, C270 (mm).
    pub dimensions_mm: [f64; 9],
    /// Line 22: downward flux fraction (%).
    pub downward_flux_fraction_pct: f64,
    /// Line 23: light output ratio (%).
    pub light_output_ratio_pct: f64,
    /// Line 24: conversion factor for the intensities.
    pub conversion_factor: f64,
    /// Line 25: tilt of the luminaire during measurement (degrees).
    pub tilt_deg: f64,
    /// The lamp sets.
    pub lamp_sets: Vec<LampSet>,
    /// Direct ratios for room indices k = 0.6 … 5.
    pub direct_ratios: [f64; 10],
    /// The `Mc` C angles (degrees).
    pub c_deg: Vec<f64>,
    /// The `Ng` γ angles (degrees).
    pub gamma_deg: Vec<f64>,
    /// Intensities (cd/klm) of the stored planes, `Ng` per plane.
    pub intensities: Vec<f64>,
}

/// The file's lines with a cursor.
struct Lines<'a> {
    path: &'a Path,
    lines: Vec<&'a str>,
    pos: usize,
}

impl<'a> Lines<'a> {
    fn text(&mut self, field: &str) -> Result<(usize, &'a str), PhotometryError> {
        let l = self.lines.get(self.pos).ok_or_else(|| PhotometryError::Truncated { path: self.path.to_owned(), line: self.lines.len(), field: field.to_owned() })?;
        self.pos += 1;
        Ok((self.pos, l.trim()))
    }
    fn number(&mut self, field: &str) -> Result<f64, PhotometryError> {
        let (line, t) = self.text(field)?;
        parse_number(self.path, line, field, t)
    }
    fn count(&mut self, field: &str, min: usize) -> Result<(usize, usize), PhotometryError> {
        let (line, t) = self.text(field)?;
        Ok((line, parse_count(self.path, line, field, t, min)?))
    }
    /// `n` one-per-line numbers, with the line of the first.
    fn numbers(&mut self, n: usize, field: &str) -> Result<(usize, Vec<f64>), PhotometryError> {
        let first = self.pos + 1;
        let v = (0..n).map(|i| self.number(&format!("{field} #{i}"))).collect::<Result<_, _>>()?;
        Ok((first, v))
    }
}

impl LdtFile {
    /// Reads and validates a file.
    pub fn read(path: &Path) -> Result<Self, PhotometryError> {
        Self::parse(&read_text(path)?, path)
    }

    /// Parses and validates the text of a file; `path` names it in errors.
    pub fn parse(text: &str, path: &Path) -> Result<Self, PhotometryError> {
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        let mut l = Lines { path, lines: text.lines().map(|s| s.trim_end_matches('\r')).collect(), pos: 0 };
        let header = l.text("company identification (line 1)")?.1.to_owned();
        let (line, ityp) = l.count("type indicator Ityp", 0)?;
        if ityp > 3 {
            return Err(PhotometryError::field(path, line, "type indicator Ityp", format!("{ityp} (must be 0–3)")));
        }
        let (sym_line, isym) = l.count("symmetry indicator Isym", 0)?;
        if isym > 4 {
            return Err(PhotometryError::field(path, sym_line, "symmetry indicator Isym", format!("{isym} (must be 0–4)")));
        }
        let (mc_line, mc) = l.count("number of C-planes Mc", 1)?;
        let divisor = [1, 1, 2, 4, 4][isym];
        if mc % divisor != 0 {
            return Err(PhotometryError::field(path, mc_line, "number of C-planes Mc", format!("{mc} is not a multiple of {divisor}, as Isym = {isym} needs")));
        }
        let c_step_deg = l.number("C-plane spacing Dc")?;
        let (_, ng) = l.count("number of intensities per C-plane Ng", 2)?;
        let gamma_step_deg = l.number("γ spacing Dg")?;
        let mut texts: [String; 5] = Default::default();
        for (i, name) in ["measurement report number", "luminaire name", "luminaire number", "file name", "date/user"].iter().enumerate() {
            texts[i] = l.text(name)?.1.to_owned();
        }
        let mut dimensions_mm = [0.0; 9];
        let dim_names = ["luminaire length", "luminaire width", "luminaire height", "luminous area length", "luminous area width", "luminous height C0", "luminous height C90", "luminous height C180", "luminous height C270"];
        for (d, name) in dimensions_mm.iter_mut().zip(dim_names) {
            *d = l.number(name)?;
        }
        let downward_flux_fraction_pct = l.number("downward flux fraction")?;
        let light_output_ratio_pct = l.number("light output ratio")?;
        let conversion_factor = l.number("conversion factor for luminous intensities")?;
        let tilt_deg = l.number("tilt during measurement")?;
        let (_, n_sets) = l.count("number of lamp sets", 0)?;
        let mut lamp_sets = Vec::with_capacity(n_sets);
        for i in 0..n_sets {
            let f = |s: &str| format!("lamp set {} {s}", i + 1);
            let count = l.number(&f("number of lamps"))? as i64;
            let kind = l.text(&f("type of lamps"))?.1.to_owned();
            let flux_lm = l.number(&f("total luminous flux"))?;
            let colour = l.text(&f("colour temperature"))?.1.to_owned();
            let colour_rendering = l.text(&f("colour rendering"))?.1.to_owned();
            let watts = l.number(&f("wattage"))?;
            lamp_sets.push(LampSet { count, kind, flux_lm, colour, colour_rendering, watts });
        }
        let mut direct_ratios = [0.0; 10];
        for (i, d) in direct_ratios.iter_mut().enumerate() {
            *d = l.number(&format!("direct ratio #{i}"))?;
        }
        let (c_line, c_deg) = l.numbers(mc, "C angles")?;
        let (g_line, gamma_deg) = l.numbers(ng, "γ angles")?;
        let stored = stored_plane_count(isym as u8, mc);
        let (i_line, intensities) = l.numbers(stored * ng, "intensities")?;
        if let Some(i) = intensities.iter().position(|&v| v < 0.0) {
            return Err(PhotometryError::field(path, i_line + i, "intensities", format!("#{i} is {} (must be ≥ 0)", intensities[i])));
        }
        if let Some((k, extra)) = l.lines.iter().enumerate().skip(l.pos).find(|(_, s)| !s.trim().is_empty()) {
            return Err(PhotometryError::field(path, k + 1, "end of file", format!("'{}' after the {} intensities Isym = {isym}, Mc = {mc}, Ng = {ng} call for", extra.trim(), stored * ng)));
        }
        let f = LdtFile {
            header,
            type_indicator: ityp as u8,
            symmetry: isym as u8,
            c_step_deg,
            gamma_step_deg,
            texts,
            dimensions_mm,
            downward_flux_fraction_pct,
            light_output_ratio_pct,
            conversion_factor,
            tilt_deg,
            lamp_sets,
            direct_ratios,
            c_deg,
            gamma_deg,
            intensities,
        };
        // Angle checks name the first line of the offending list.
        if let Err(e) = super::goniometric::check_angles("C angles", &f.c_deg, 0.0, 360.0 - 1e-9) {
            return Err(PhotometryError::field(path, c_line, "C angles", e.to_string()));
        }
        if f.c_deg[0] != 0.0 {
            return Err(PhotometryError::field(path, c_line, "C angles", format!("the first is {}° (must be 0°)", f.c_deg[0])));
        }
        if let Err(e) = super::goniometric::check_angles("γ angles", &f.gamma_deg, 0.0, 180.0) {
            return Err(PhotometryError::field(path, g_line, "γ angles", e.to_string()));
        }
        f.goniometric().map_err(|e| PhotometryError::field(path, sym_line, "symmetry indicator Isym", e.to_string()))?;
        Ok(f)
    }

    /// Number of C-planes `Mc`.
    pub fn c_plane_count(&self) -> usize {
        self.c_deg.len()
    }

    /// Scale from the file's cd/klm to candela (see the module docs).
    pub fn candela_scale(&self) -> f64 {
        let flux = self.lamp_sets.first().map(|s| s.flux_lm).filter(|f| *f > 0.0).unwrap_or(1000.0);
        self.conversion_factor * flux / 1000.0
    }

    /// The stored planes' C angles (degrees), in the order of `intensities`.
    pub fn stored_planes_deg(&self) -> Vec<f64> {
        let mc = self.c_deg.len();
        let n = stored_plane_count(self.symmetry, mc);
        let first = if self.symmetry == 3 { 3 * mc / 4 } else { 0 };
        (0..n).map(|k| if self.symmetry == 1 { 0.0 } else { self.c_deg[(first + k) % mc] }).collect()
    }

    /// The intensity table (cd), symmetry expanded.
    pub fn goniometric(&self) -> Result<Goniometric, TableError> {
        let ng = self.gamma_deg.len();
        let planes = self.stored_planes_deg();
        let (sym, h, cd): (Symmetry, Vec<f64>, Vec<f64>) = match self.symmetry {
            0 => (Symmetry::None, planes, self.intensities.clone()),
            1 => (Symmetry::Rotational, planes, self.intensities.clone()),
            2 => (Symmetry::AboutC0C180, planes, self.intensities.clone()),
            // C270…C0…C90 stand for their mirror images 180° − C, which run from 270° down to
            // 90°: reversed, they are the increasing planes C90…C270.
            3 => {
                let h = planes.iter().rev().map(|c| (180.0 - c).rem_euclid(360.0)).collect();
                let cd = self.intensities.chunks(ng).rev().flatten().copied().collect();
                (Symmetry::AboutC90C270, h, cd)
            }
            4 => (Symmetry::Quadrant, planes, self.intensities.clone()),
            s => return Err(TableError::Symmetry(format!("Isym = {s}"))),
        };
        Ok(Goniometric::new(PhotometricType::C, sym, &h, &self.gamma_deg, &cd)?.scaled(self.candela_scale())?.with_opening(self.opening_radius_m()))
    }

    /// The radius of a disc with the luminous area's size, metres: lines 16–17 are its length (or
    /// diameter) and width, a width of 0 meaning a circle of that diameter.
    pub fn opening_radius_m(&self) -> f64 {
        let (l, w) = (self.dimensions_mm[3].abs() * 1e-3, self.dimensions_mm[4].abs() * 1e-3);
        if !(l.is_finite() && w.is_finite()) {
            return 0.0;
        }
        if w > 0.0 && l > 0.0 { (l * w / std::f64::consts::PI).sqrt() } else { 0.5 * l.max(w) }
    }

    /// The file as EULUMDAT text (one field per line, numbers in Rust's shortest round-trip form).
    pub fn to_text(&self) -> String {
        let mut s = String::new();
        let mut put = |v: &dyn std::fmt::Display| {
            let _ = writeln!(s, "{v}");
        };
        put(&self.header);
        put(&self.type_indicator);
        put(&self.symmetry);
        put(&self.c_deg.len());
        put(&self.c_step_deg);
        put(&self.gamma_deg.len());
        put(&self.gamma_step_deg);
        self.texts.iter().for_each(|t| put(t));
        self.dimensions_mm.iter().for_each(|d| put(d));
        for v in [self.downward_flux_fraction_pct, self.light_output_ratio_pct, self.conversion_factor, self.tilt_deg] {
            put(&v);
        }
        put(&self.lamp_sets.len());
        for set in &self.lamp_sets {
            put(&set.count);
            put(&set.kind);
            put(&set.flux_lm);
            put(&set.colour);
            put(&set.colour_rendering);
            put(&set.watts);
        }
        for v in self.direct_ratios.iter().chain(&self.c_deg).chain(&self.gamma_deg).chain(&self.intensities) {
            put(v);
        }
        s
    }
}

/// Planes stored for `Isym` with `Mc` C-planes (`Mc2 − Mc1 + 1` of the format).
fn stored_plane_count(isym: u8, mc: usize) -> usize {
    match isym {
        1 => 1,
        2 | 3 => mc / 2 + 1,
        4 => mc / 4 + 1,
        _ => mc,
    }
}
