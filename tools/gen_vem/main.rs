//! `gen-vem`: writes small synthetic video environment map sequences (fisheye HDR EXR frames, the
//! fisheye calibration and the true power per frame) for the tests and the demo.
//!
//! - `outdoor`: a sun moving along an arc (0.4° per frame) with clouds drifting across; one cloud
//!   covers the sun from about frame 6 to 14.
//! - `lamp`: a room with a window and a ceiling lamp flickering at 115 Hz, which the 21 Hz capture
//!   aliases to 10 Hz.
//!
//! The skies are [`heliar::vem::eval::synth`]'s; the lens is an equidistant 180° fisheye looking up
//! with north at the top of the image. Output is deterministic.

use anyhow::{Context, Result};
use clap::{Parser, ValueEnum};
use heliar::io::image::ExrPrecision;
use heliar::vem::capture::lens_file::fisheye_toml;
use heliar::camera::Camera;
use heliar::vem::polar::{IrradianceReference, luminance};
use heliar::vem::eval::synth::{Environment, RATE_HZ, indoor_lamp, outdoor, render_fisheye, render_polar};
use glam::Vec3;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
enum Which {
    Outdoor,
    Lamp,
    All,
}

#[derive(Parser)]
#[command(name = "gen-vem", about = "Synthetic VEM sequences: fisheye HDR EXR frames, calibration, true power")]
struct Cli {
    /// Output folder; each sequence goes into a subfolder (outdoor/, lamp/).
    #[arg(long)]
    out: PathBuf,
    /// Which sequence.
    #[arg(long, value_enum, default_value = "all")]
    sequence: Which,
    /// Fisheye image size (square), pixels.
    #[arg(long, default_value_t = 80)]
    size: u32,
    /// Frames per sequence.
    #[arg(long, default_value_t = 24)]
    frames: usize,
    /// Store 32-bit floats instead of half floats.
    #[arg(long)]
    float: bool,
}

fn write_sequence(dir: &Path, name: &str, cli: &Cli, env_at: impl Fn(usize) -> Box<dyn Environment>) -> Result<()> {
    let frames = dir.join("frames");
    std::fs::create_dir_all(&frames).with_context(|| format!("creating {}", frames.display()))?;
    std::fs::create_dir_all(dir.join("calib"))?;
    let cam = Camera::equidistant_up(cli.size, 180.0);
    let calib = dir.join("calib/fisheye.toml");
    std::fs::write(&calib, fisheye_toml(&cam, &format!("gen-vem: {name} sequence, equidistant 180° fisheye looking up, north (−Z) at the top")))
        .with_context(|| format!("writing {}", calib.display()))?;
    let mut truth = String::from("frame,time_s,power_r,power_g,power_b,power_luminance,e_up_r,e_up_g,e_up_b,sun_x,sun_y,sun_z,sun_irradiance_luminance\n");
    let precision = if cli.float { ExrPrecision::Float } else { ExrPrecision::Half };
    for k in 0..cli.frames {
        let env = env_at(k);
        let img = render_fisheye(env.as_ref(), &cam, 3);
        let path = frames.join(format!("frame_{k:04}.exr"));
        img.write_exr(&path, precision).with_context(|| format!("writing {}", path.display()))?;
        // Truth from a finer polar rendering.
        let fine = render_polar(env.as_ref(), 720, 180, 2);
        let p = fine.total_power();
        let e = IrradianceReference::new(&fine, 1).irradiance(Vec3::Y);
        let (sun, sun_e) = env.suns().first().map_or((Vec3::ZERO, 0.0), |(d, e)| (*d, luminance(*e)));
        let pl = 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2];
        writeln!(
            truth,
            "{k},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6}",
            k as f64 / RATE_HZ,
            p[0],
            p[1],
            p[2],
            pl,
            e[0],
            e[1],
            e[2],
            sun.x,
            sun.y,
            sun.z,
            sun_e
        )?;
    }
    let tpath = dir.join("truth.csv");
    std::fs::write(&tpath, truth).with_context(|| format!("writing {}", tpath.display()))?;
    println!("wrote {} frames of {}×{} to {}", cli.frames, cli.size, cli.size, dir.display());
    Ok(())
}

fn main() -> Result<()> {
    let cli = Cli::parse();
    if matches!(cli.sequence, Which::Outdoor | Which::All) {
        write_sequence(&cli.out.join("outdoor"), "outdoor", &cli, |k| Box::new(outdoor(k, RATE_HZ)))?;
    }
    if matches!(cli.sequence, Which::Lamp | Which::All) {
        write_sequence(&cli.out.join("lamp"), "lamp", &cli, |k| Box::new(indoor_lamp(k, RATE_HZ)))?;
    }
    Ok(())
}
