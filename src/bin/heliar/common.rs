//! Set-up shared by the subcommands: spinners and progress bars (the [`BarObserver`] of the
//! library's frame loops), scene loading, the estimator, and the interrupt counter.

use anyhow::{Context, Result};
use heliar::estimate::Estimator;
use heliar::geometry::raycast::RayScene;
use heliar::scene::{LoadOptions, Scene};
use indicatif::{ProgressBar, ProgressStyle};
use std::path::Path;
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};

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

/// Progress bars and notes of the library's frame loops on stderr.
#[derive(Default)]
pub struct BarObserver {
    bar: Option<ProgressBar>,
}

impl heliar::run::Observer for BarObserver {
    fn start(&mut self, what: &str, total: Option<usize>, done: usize) {
        let bar = match total {
            Some(n) => frame_bar(n, what),
            None => {
                let b = ProgressBar::new_spinner();
                b.set_style(ProgressStyle::with_template("{prefix} {pos} frames, {per_sec} [{elapsed}]").unwrap_or_else(|_| ProgressStyle::default_spinner()));
                b.set_prefix(what.to_owned());
                b
            }
        };
        bar.set_position(done as u64);
        bar.reset_eta();
        self.bar = Some(bar);
    }
    fn advance(&mut self) {
        if let Some(b) = &self.bar {
            b.inc(1);
        }
    }
    fn finish(&mut self) {
        if let Some(b) = self.bar.take() {
            b.finish_and_clear();
        }
    }
    fn note(&mut self, message: &str) {
        match &self.bar {
            Some(b) => b.suspend(|| eprintln!("{message}")),
            None => eprintln!("{message}"),
        }
    }
}

/// Counts Ctrl-C and SIGTERM: the first asks the running loop to finish the frame in hand and
/// close its output; the second exits at once (status 130).
pub fn interrupt_counter() -> Arc<AtomicUsize> {
    let stop = Arc::new(AtomicUsize::new(0));
    let flag = stop.clone();
    if let Err(e) = ctrlc::set_handler(move || {
        if flag.fetch_add(1, Ordering::SeqCst) == 0 {
            eprintln!("\ninterrupted: finishing the current frame and closing the output (again to quit at once)");
        } else {
            eprintln!("\ninterrupted twice: exiting without closing the output");
            std::process::exit(130);
        }
    }) {
        eprintln!("warning: cannot catch Ctrl-C ({e}); an interrupt will end the run without closing the output");
    }
    stop
}

/// How every subcommand loads scenes (`--allow-outside-scene`), set once from the command line.
static LOAD_OPTIONS: std::sync::OnceLock<LoadOptions> = std::sync::OnceLock::new();

/// Sets the scene loading options of this run.
pub fn set_load_options(options: LoadOptions) {
    let _ = LOAD_OPTIONS.set(options);
}

/// The scene loading options of this run.
pub fn load_options() -> LoadOptions {
    LOAD_OPTIONS.get().cloned().unwrap_or_default()
}

/// Loads a scene with this run's options.
pub fn read_scene(dir: &Path) -> Result<Scene> {
    Scene::load_with(dir, &load_options()).with_context(|| format!("loading scene {}", dir.display()))
}

/// Loads a scene and builds the proxy's BVH.
pub fn load_scene(dir: &Path) -> Result<(Scene, Arc<RayScene>)> {
    let scene = read_scene(dir)?;
    let mut scene = scene;
    let ray = Arc::new(RayScene::new(scene.proxy.clone()));
    if ray.skipped_degenerate() > 0 {
        eprintln!("note: {} degenerate proxy triangles left out of ray casts", ray.skipped_degenerate());
    }
    // `terrain_albedo = "map"`: measured once here, so every stage of the run uses the same value.
    let terrain = heliar::envmap::bake::terrain::resolve_scene(&mut scene, &ray).with_context(|| format!("measuring the terrain albedo on the environment map of {}", dir.display()))?;
    if let Some(t) = terrain {
        let [r, g, b] = t.albedo_rgb;
        match t.source {
            heliar::scene::settings::TerrainSource::Fallback => eprintln!("note: {}", t.note.as_deref().unwrap_or("no terrain albedo from the map")),
            _ => eprintln!("terrain albedo ({r:.3}, {g:.3}, {b:.3}) from the environment map ({})", t.note.as_deref().unwrap_or("")),
        }
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

/// Refuses `outputs` (files) that would overwrite one of `inputs` or an existing file of the
/// scene folder `scene`, unless `force` (`heliar::io::guard`); call before anything is written.
pub fn guard_files(scene: Option<&Path>, inputs: &[&Path], outputs: &[&Path], force: bool) -> Result<()> {
    let guard = heliar::io::guard::OutputGuard::new(scene, inputs, force);
    for out in outputs {
        guard.check_file(out)?;
    }
    Ok(())
}

/// Writes `path` through a temporary file beside it and a rename (`heliar::io::write_via_temp`):
/// an interrupted or failed write leaves the old file whole. Parent folders are created.
pub fn write_output(path: &Path, write: impl FnOnce(&Path) -> Result<()>) -> Result<()> {
    if let Some(parent) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(parent).with_context(|| format!("creating {}", parent.display()))?;
    }
    heliar::io::write_via_temp(path, write).with_context(|| format!("writing {}", path.display()))
}
