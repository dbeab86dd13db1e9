//! `heliar frames INPUT`: how many frames a clip holds, as one JSON object, for planning chunks
//! (`augment --frames A..B`, the Ray driver, a Kubernetes or Slurm array's size).
//!
//! A folder's frames are its `.png`/`.exr` files in name order. A video's are counted by
//! decoding it to the end, since containers' frame counts can be wrong (a truncated file, a
//! variable-rate stream); the container's own count is printed beside it.

use anyhow::{Result, bail};
use clap::Args;
use heliar::run::source::{FolderSource, FrameSource, is_video_path};
use std::path::PathBuf;

#[derive(Args)]
pub struct FramesArgs {
    /// A folder of frames, or a video file.
    input: PathBuf,
}

pub fn run(a: FramesArgs) -> Result<()> {
    let p = &a.input;
    if !p.exists() {
        bail!("{}: no such file or folder", p.display());
    }
    let v = if p.is_dir() {
        let src = FolderSource::open(p, 1.0)?;
        serde_json::json!({ "input": p.display().to_string(), "kind": "folder", "frames": src.len() })
    } else if is_video_path(p) {
        video(p)?
    } else {
        bail!("{}: neither a folder of frames nor a video (.mp4, .mkv, .avi, .mov, …)", p.display());
    };
    println!("{v}");
    Ok(())
}

#[cfg(feature = "opencv")]
fn video(p: &std::path::Path) -> Result<serde_json::Value> {
    use anyhow::Context;
    let mut v = heliar::io::video::VideoSource::open_file(p)?;
    let (container, fps, (w, h)) = (v.frame_count(), v.fps(), v.size());
    let mut n = 0u64;
    while v.read().with_context(|| format!("{}: decoding frame {n}", p.display()))?.is_some() {
        n += 1;
    }
    Ok(serde_json::json!({ "input": p.display().to_string(), "kind": "video", "frames": n, "container_frames": container, "fps": fps, "width": w, "height": h }))
}

#[cfg(not(feature = "opencv"))]
fn video(p: &std::path::Path) -> Result<serde_json::Value> {
    bail!("{}: reading video needs heliar built with `--features opencv`", p.display())
}
