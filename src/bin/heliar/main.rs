//! The `heliar` command.

mod bake;
mod augment;
mod bench;
mod bench_cuts;
mod bench_estimate_sun;
mod bench_irradiance;
mod bench_lamps;
mod bench_lamps_gpu;
mod bench_render;
mod bench_render_parts;
mod bench_render_sun;
mod bench_vem;
mod bench_vem_sun;
mod common;
mod estimate;
mod frames;
mod live;
mod merge;
mod precompute;
mod sun;
mod vem;

use clap::{Parser, Subcommand};

#[derive(Parser)]
#[command(name = "heliar", version, about = "Virtual objects lit and shadowed by the real sun and sky in outdoor video")]
struct Cli {
    #[command(subcommand)]
    command: Command,
    /// Read files a scene names outside its folder (absolute paths, `..`, symlinks out, glTF
    /// buffers and images); refused by default.
    #[arg(long, global = true)]
    allow_outside_scene: bool,
}

#[derive(Subcommand)]
enum Command {
    /// Solar position (NREL SPA) for a place and time, or a CSV batch.
    Sun(sun::SunArgs),
    /// Estimate sun and sky intensities for every frame of a scene's sequence (JSON lines).
    Estimate(estimate::EstimateArgs),
    /// Error-against-run-time sweeps.
    Bench(bench::BenchArgs),
    /// Bake the normal, weighted-ambient and albedo environment maps (cached by input hashes).
    Bake(bake::BakeArgs),
    /// Precompute the visibility cuts of the scene's moving objects (cached by input hashes, beside the bake).
    Precompute(precompute::PrecomputeArgs),
    /// Write the environment map relit for a frame's (or given) lighting, as EXR.
    Relight(bake::RelightArgs),
    /// Irradiance from the irradiance volume at a point and normal, as JSON.
    Irradiance(bake::IrradianceArgs),
    /// Directional lights from captured HDR video environment maps (JSON lines); with --scene,
    /// the scene's virtual objects lit, shadowed and composited with them on the GPU.
    Vem(vem::VemArgs),
    /// Composite the scene's virtual objects into a frame sequence (estimate → relight → composite).
    Augment(augment::AugmentArgs),
    /// Join the outputs of `augment --frames` chunks into one (report, summary, frames or video).
    Merge(merge::MergeArgs),
    /// How many frames a folder or video holds (JSON), for planning chunks.
    Frames(frames::FramesArgs),
    /// Composite live: a camera, stream or file played as one, in a window (feature `opencv`).
    Live(live::LiveArgs),
}

fn main() {
    let cli = Cli::parse();
    common::set_load_options(heliar::scene::LoadOptions { allow_outside_scene: cli.allow_outside_scene });
    let result = match cli.command {
        Command::Sun(a) => sun::run(a),
        Command::Estimate(a) => estimate::run(a),
        Command::Bench(a) => bench::run(a),
        Command::Bake(a) => bake::run_bake(a),
        Command::Precompute(a) => precompute::run(a),
        Command::Relight(a) => bake::run_relight(a),
        Command::Irradiance(a) => bake::run_irradiance(a),
        Command::Vem(a) => vem::run(a),
        Command::Augment(a) => augment::run(a),
        Command::Live(a) => live::run(a),
        Command::Merge(a) => merge::run(a),
        Command::Frames(a) => frames::run(a),
    };
    if let Err(e) = result {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}
