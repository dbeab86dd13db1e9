//! Set-up shared by the subcommands.

use anyhow::{Context, Result, anyhow};
use heliar::estimate::Estimator;
use heliar::geometry::raycast::RayScene;
use heliar::scene::{Scene, Sequence};
use indicatif::{ProgressBar, ProgressStyle};
use std::path::Path;
use std::sync::Arc;

/// A spinner on stderr for a set-up step.
pub fn spinner(msg: &str) -> ProgressBar {
    let pb = ProgressBar::new_spinner();
    pb.set_style(ProgressStyle::with_template("{spinner} {msg} [{elapsed}]").unwrap_or_else(|_| ProgressStyle::default_spinner()));
    pb.set_message(msg.to_owned());
    pb.enable_steady_tick(std::time::Duration::from_millis(120));
    pb
}

/// A frame progress bar on stderr with rate and ETA.
pub fn frame_bar(n: usize, what: &str) -> ProgressBar {
    let pb = ProgressBar::new(n as u64);
    pb.set_style(
        ProgressStyle::with_template("{prefix} [{bar:30}] {pos}/{len} frames, {per_sec}, ETA {eta}")
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    pb.set_prefix(what.to_owned());
    pb
}

/// Loads a scene and builds the proxy's BVH.
pub fn load_scene(dir: &Path) -> Result<(Scene, Arc<RayScene>)> {
    let scene = Scene::load(dir).with_context(|| format!("loading scene {}", dir.display()))?;
    let ray = Arc::new(RayScene::new(scene.proxy.clone()));
    if ray.skipped_degenerate() > 0 {
        eprintln!("note: {} degenerate proxy triangles left out of ray casts", ray.skipped_degenerate());
    }
    Ok((scene, ray))
}

/// Builds the estimator with a spinner.
pub fn build_estimator(scene: &Scene, ray: Arc<RayScene>) -> Result<Estimator> {
    let pb = spinner("estimator set-up: pixel map, sample pool and weighted-ambient factors");
    let est = Estimator::new(scene, ray).with_context(|| format!("setting up the estimator for {}", scene.root.display()))?;
    pb.finish_and_clear();
    let s = est.stats();
    eprintln!(
        "estimator: {} diffuse pixels, {} candidates, pool of {} (pixel map {:.0} ms, pool {:.0} ms)",
        s.diffuse_pixels, s.candidate_pixels, s.pool_entries, s.pixel_map_ms, s.pool_ms
    );
    Ok(est)
}

/// The named sequence (or the first).
pub fn pick_sequence<'a>(scene: &'a Scene, name: Option<&str>) -> Result<&'a Sequence> {
    scene.sequence(name).ok_or_else(|| match name {
        Some(n) => anyhow!(
            "{}: no sequence named '{n}' (have: {})",
            scene.root.join(heliar::scene::MANIFEST_FILE).display(),
            scene.sequences.iter().map(|s| s.name.as_str()).collect::<Vec<_>>().join(", ")
        ),
        None => anyhow!("{}: the scene has no [[sequences]]", scene.root.join(heliar::scene::MANIFEST_FILE).display()),
    })
}
