//! `heliar merge`: the outputs of `heliar augment --frames A..B` chunks joined into one: folders
//! into a folder, videos into a video (see `heliar::run::augment::merge`).

use anyhow::Result;
use clap::Args;
use heliar::run::augment::{MergeOptions, merge};
use std::path::PathBuf;

#[derive(Args)]
pub struct MergeArgs {
    /// The chunks' output folders or video files, in any order (they are sorted by their first
    /// frame). Video chunks are best written lossless (`.mkv`).
    #[arg(required = true)]
    chunks: Vec<PathBuf>,
    /// The merged folder (report.jsonl, summary.json and the frames: hard links, else copies), or
    /// the merged video (`.mkv`, `.mp4`, `.avi`, with OUT.report.jsonl and OUT.summary.json).
    #[arg(long)]
    output: PathBuf,
    /// Write even where the output would overwrite a chunk.
    #[arg(long)]
    force: bool,
}

pub fn run(a: MergeArgs) -> Result<()> {
    let outcome = merge(&MergeOptions { chunks: a.chunks, output: a.output, force: a.force })?;
    let o = &outcome.outputs;
    let n = outcome.frames.len();
    eprintln!(
        "merged frames {}..{} ({n} frames, {} linked, {} copied) into {}, {} and {}",
        outcome.frames.start,
        outcome.frames.end,
        outcome.linked,
        n - outcome.linked,
        o.target.display(),
        o.report.display(),
        o.summary.display()
    );
    Ok(())
}
