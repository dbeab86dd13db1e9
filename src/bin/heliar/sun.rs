//! `heliar sun`: solar position for one place and time, or a CSV batch.

use anyhow::{Context, Result, bail};
use chrono::DateTime;
use clap::Args;
use heliar::sun::{GeoFrame, Observer, sun_position};
use std::io::Write;
use std::path::PathBuf;

#[derive(Args)]
pub struct SunArgs {
    /// Latitude, degrees north (default: the scene's).
    #[arg(long, allow_hyphen_values = true)]
    lat: Option<f64>,
    /// Longitude, degrees east (default: the scene's).
    #[arg(long, allow_hyphen_values = true)]
    lon: Option<f64>,
    /// Time, RFC 3339 with offset (e.g. 2024-06-21T15:30:00+02:00).
    #[arg(long)]
    time: Option<String>,
    /// Height above sea level, metres.
    #[arg(long, allow_hyphen_values = true)]
    elevation: Option<f64>,
    /// Air pressure for refraction, mbar.
    #[arg(long, allow_hyphen_values = true)]
    pressure: Option<f64>,
    /// Air temperature for refraction, °C.
    #[arg(long, allow_hyphen_values = true)]
    temperature: Option<f64>,
    /// ΔT = TT − UT1, seconds (estimated from the date when absent).
    #[arg(long, allow_hyphen_values = true)]
    delta_t: Option<f64>,
    /// A scene folder: gives defaults for the place and adds the direction in its world frame.
    #[arg(long)]
    scene: Option<PathBuf>,
    /// Batch mode: rows of `lat,lon,time[,elevation_m]` (a header row is allowed).
    #[arg(long, conflicts_with_all = ["lat", "lon", "time"])]
    csv: Option<PathBuf>,
    /// Where batch output goes (default: stdout).
    #[arg(long, requires = "csv")]
    output: Option<PathBuf>,
    /// Write the output even over the input CSV or a file of the scene.
    #[arg(long)]
    force: bool,
}

/// The command-line option (or, for values from a CSV row, the column) of an [`Observer`] field.
fn option_of(field: &str, csv_row: bool) -> String {
    let (option, column) = match field {
        "latitude_deg" => ("--lat", Some("lat")),
        "longitude_deg" => ("--lon", Some("lon")),
        "elevation_m" => ("--elevation", Some("elevation_m")),
        "pressure_mbar" => ("--pressure", None),
        "temperature_c" => ("--temperature", None),
        "delta_t_s" => ("--delta-t", None),
        other => (other, None),
    };
    match column {
        Some(c) if csv_row => format!("column {c} (or {option})"),
        _ => option.to_owned(),
    }
}

pub fn run(a: SunArgs) -> Result<()> {
    let scene = match &a.scene {
        Some(dir) => Some(crate::common::read_scene(dir)?),
        None => None,
    };
    let scene = scene.as_ref();
    if let Some(csv) = &a.csv {
        return run_csv(&a, csv, scene);
    }
    let time = a.time.as_deref().context("--time is required (or --csv FILE)")?;
    let t = DateTime::parse_from_rfc3339(time).with_context(|| format!("--time '{time}' is not RFC 3339 with offset"))?;
    let obs = observer(&a, scene, a.lat, a.lon, None, false)?;
    let p = sun_position(&obs, &t)?;
    let mut v = serde_json::json!({
        "time": t.to_rfc3339(),
        "latitude_deg": obs.latitude_deg,
        "longitude_deg": obs.longitude_deg,
        "elevation_m": obs.elevation_m,
        "zenith_deg": p.zenith_deg,
        "apparent_zenith_deg": p.apparent_zenith_deg,
        "azimuth_deg": p.azimuth_deg,
        "above_horizon": p.above_horizon(),
    });
    if let Some(g) = scene.map(|s| s.geo) {
        v["dir_world"] = serde_json::json!(g.sun_dir_in_world(&p).to_array());
    }
    println!("{}", serde_json::to_string_pretty(&v)?);
    Ok(())
}

/// The observer of a query: the options over the scene's `[place]`, checked with its limits.
fn observer(a: &SunArgs, scene: Option<&heliar::scene::Scene>, lat: Option<f64>, lon: Option<f64>, elev: Option<f64>, csv_row: bool) -> Result<Observer> {
    let s = scene.as_ref().map(|s| s.observer);
    let lat = lat.or(s.map(|o| o.latitude_deg)).context("--lat is required (or --scene)")?;
    let lon = lon.or(s.map(|o| o.longitude_deg)).context("--lon is required (or --scene)")?;
    let mut o = s.unwrap_or_else(|| Observer::new(lat, lon, 0.0));
    o.latitude_deg = lat;
    o.longitude_deg = lon;
    if let Some(e) = elev.or(a.elevation) {
        o.elevation_m = e;
    }
    if let Some(p) = a.pressure {
        o.pressure_mbar = p;
    }
    if let Some(t) = a.temperature {
        o.temperature_c = t;
    }
    if a.delta_t.is_some() {
        o.delta_t_s = a.delta_t;
    }
    // The limits of scene.toml's [place], from the same check.
    o.validate().map_err(|(field, msg)| anyhow::anyhow!("{}: {msg} (the limits of scene.toml's place.{field})", option_of(field, csv_row)))?;
    Ok(o)
}

/// `--csv`: one output row per input row (`lat,lon,time[,elevation_m]`), to stdout or, whole,
/// through a temporary file into `--output`.
fn run_csv(a: &SunArgs, csv: &std::path::Path, scene: Option<&heliar::scene::Scene>) -> Result<()> {
    let geo: Option<GeoFrame> = scene.map(|s| s.geo);
    if let Some(p) = &a.output {
        crate::common::guard_files(a.scene.as_deref(), &[csv], &[p.as_path()], a.force)?;
    }
    let text = std::fs::read_to_string(csv).with_context(|| format!("reading {}", csv.display()))?;
    // To a file: the whole table, then one write through a temporary file and a rename.
    let mut buf: Vec<u8> = Vec::new();
    let mut out: Box<dyn Write + '_> = match &a.output {
        Some(_) => Box::new(&mut buf),
        None => Box::new(std::io::stdout()),
    };
    let mut header = "lat,lon,time,elevation_m,zenith_deg,apparent_zenith_deg,azimuth_deg,above_horizon".to_string();
    if geo.is_some() {
        header += ",dir_x,dir_y,dir_z";
    }
    writeln!(out, "{header}")?;
    for (i, line) in text.lines().enumerate() {
        let f: Vec<&str> = line.split(',').map(str::trim).collect();
        if line.trim().is_empty() || line.trim_start().starts_with('#') {
            continue;
        }
        let lat = f.first().and_then(|s| s.parse::<f64>().ok());
        if i == 0 && lat.is_none() {
            continue; // header
        }
        let line = csv_line(a, scene, geo, csv, i, &f, lat)?;
        writeln!(out, "{line}")?;
    }
    drop(out);
    if let Some(p) = &a.output {
        crate::common::write_output(p, |tmp| Ok(std::fs::write(tmp, &buf)?))?;
    }
    Ok(())
}

/// One output row of `--csv` for input row `i` (fields `f`, its latitude parsed as `lat`).
fn csv_line(a: &SunArgs, scene: Option<&heliar::scene::Scene>, geo: Option<GeoFrame>, csv: &std::path::Path, i: usize, f: &[&str], lat: Option<f64>) -> Result<String> {
    let row = || format!("{}: row {}", csv.display(), i + 1);
    if f.len() < 3 || f.len() > 4 {
        bail!("{}: expected lat,lon,time[,elevation_m], got {} fields", row(), f.len());
    }
    let lat = lat.with_context(|| format!("{}: lat '{}' is not a number", row(), f[0]))?;
    let lon: f64 = f[1].parse().with_context(|| format!("{}: lon '{}' is not a number", row(), f[1]))?;
    let t = DateTime::parse_from_rfc3339(f[2]).with_context(|| format!("{}: time '{}' is not RFC 3339", row(), f[2]))?;
    let elev = match f.get(3) {
        Some(s) if !s.is_empty() => Some(s.parse::<f64>().with_context(|| format!("{}: elevation '{s}' is not a number", row()))?),
        _ => None,
    };
    let obs = observer(a, scene, Some(lat), Some(lon), elev, true).with_context(row)?;
    let p = sun_position(&obs, &t).with_context(row)?;
    let mut line = format!(
        "{lat},{lon},{},{},{:.6},{:.6},{:.6},{}",
        t.to_rfc3339(),
        obs.elevation_m,
        p.zenith_deg,
        p.apparent_zenith_deg,
        p.azimuth_deg,
        p.above_horizon()
    );
    if let Some(g) = geo {
        let d = g.sun_dir_in_world(&p);
        line += &format!(",{:.7},{:.7},{:.7}", d.x, d.y, d.z);
    }
    Ok(line)
}
