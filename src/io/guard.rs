//! Outputs that never destroy inputs: every command that writes checks its output paths here
//! before it opens them.
//!
//! # The rule
//! An output may not be (or, for an output folder, contain, or sit inside) any of the command's
//! input files or folders, and may not overwrite an existing file of the scene folder, unless the
//! user says `--force`. Paths are compared after resolving symlinks and `..`; an output that does
//! not exist yet is resolved through its deepest existing ancestor, so `out/../scene.toml` and a
//! symlink to an input are caught too. New files inside the scene folder (the bake's cache) are
//! allowed: they overwrite nothing the user made.
//!
//! Writes themselves go through [`super::write_atomic`] (a temporary file and a rename), so an
//! interrupted write leaves the old file whole.

use std::path::{Path, PathBuf};

/// Why an output was refused.
#[derive(Debug, thiserror::Error)]
pub enum GuardError {
    /// The output is one of the inputs.
    #[error("{output}: is the input {input}; writing it would destroy the input (give another output, or --force)")]
    IsInput {
        /// The output as given.
        output: PathBuf,
        /// The input it would overwrite.
        input: PathBuf,
    },
    /// An output folder holds an input, or an output lies inside an input folder.
    #[error("{output}: overlaps the input {input} (an output folder must not be or contain an input; give another output, or --force)")]
    Overlaps {
        /// The output as given.
        output: PathBuf,
        /// The input.
        input: PathBuf,
    },
    /// The output would overwrite an existing file of the scene.
    #[error("{output}: is a file of the scene {scene}; writing it would change the scene (give another output, or --force)")]
    SceneFile {
        /// The output as given.
        output: PathBuf,
        /// The scene folder.
        scene: PathBuf,
    },
}

/// The inputs and the scene a command read, against which its outputs are checked.
#[derive(Clone, Debug, Default)]
pub struct OutputGuard {
    inputs: Vec<(PathBuf, PathBuf)>,
    scene: Option<PathBuf>,
    force: bool,
}

/// `path` with symlinks and `..` resolved; a path that does not exist (yet) is resolved through
/// its deepest existing ancestor.
pub fn resolve(path: &Path) -> PathBuf {
    let abs = if path.is_absolute() { path.to_owned() } else { std::env::current_dir().map(|d| d.join(path)).unwrap_or_else(|_| path.to_owned()) };
    let mut tail = Vec::new();
    let mut head = abs.as_path();
    loop {
        if let Ok(c) = std::fs::canonicalize(head) {
            let mut out = c;
            for part in tail.iter().rev() {
                out = match *part {
                    ".." => out.parent().map(Path::to_owned).unwrap_or(out),
                    "." => out,
                    p => out.join(p),
                };
            }
            return out;
        }
        // A last component `..` has no file name; it is kept and applied after the existing
        // ancestor is resolved (`out/missing/../scene.toml` is `out/scene.toml`).
        let name = head.file_name().and_then(|n| n.to_str()).or_else(|| head.ends_with("..").then_some(".."));
        match (name, head.parent()) {
            (Some(name), Some(parent)) => {
                tail.push(name);
                head = parent;
            }
            _ => return abs,
        }
    }
}

impl OutputGuard {
    /// A guard for a command that read `inputs` (files or folders) of `scene` (its folder, when it
    /// has one); `force` lets every output through (the user said `--force`).
    pub fn new(scene: Option<&Path>, inputs: &[&Path], force: bool) -> Self {
        Self { inputs: inputs.iter().map(|p| (p.to_path_buf(), resolve(p))).collect(), scene: scene.map(resolve), force }
    }

    /// Adds an input.
    pub fn with_input(mut self, input: &Path) -> Self {
        self.inputs.push((input.to_owned(), resolve(input)));
        self
    }

    /// Checks an output file.
    pub fn check_file(&self, output: &Path) -> Result<(), GuardError> {
        if self.force {
            return Ok(());
        }
        let out = resolve(output);
        for (given, input) in &self.inputs {
            if out == *input {
                return Err(GuardError::IsInput { output: output.to_owned(), input: given.clone() });
            }
            if input.is_dir() && out.starts_with(input) && out.exists() {
                return Err(GuardError::Overlaps { output: output.to_owned(), input: given.clone() });
            }
        }
        if let Some(scene) = &self.scene
            && out.starts_with(scene)
            && out.is_file()
        {
            return Err(GuardError::SceneFile { output: output.to_owned(), scene: scene.clone() });
        }
        Ok(())
    }

    /// Checks an output folder: it may not be, contain or lie inside an input folder, nor be or
    /// contain the scene folder (a single input file beside the outputs is left alone: the
    /// folder's outputs have names of their own).
    pub fn check_dir(&self, output: &Path) -> Result<(), GuardError> {
        if self.force {
            return Ok(());
        }
        let out = resolve(output);
        for (given, input) in &self.inputs {
            if out == *input {
                return Err(GuardError::IsInput { output: output.to_owned(), input: given.clone() });
            }
            if input.is_dir() && (input.starts_with(&out) || out.starts_with(input)) {
                return Err(GuardError::Overlaps { output: output.to_owned(), input: given.clone() });
            }
        }
        if let Some(scene) = &self.scene
            && scene.starts_with(&out)
        {
            return Err(GuardError::SceneFile { output: output.to_owned(), scene: scene.clone() });
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("heliar-guard-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(d.join("scene/frames")).unwrap();
        std::fs::write(d.join("scene/scene.toml"), "x").unwrap();
        std::fs::write(d.join("scene/frames/a.png"), "x").unwrap();
        std::fs::write(d.join("in.csv"), "x").unwrap();
        d
    }

    #[test]
    fn outputs_over_inputs_or_scene_files_are_refused() {
        let d = scratch("refuse");
        let scene = d.join("scene");
        let frames = scene.join("frames");
        let g = OutputGuard::new(Some(&scene), &[&frames, &d.join("in.csv")], false);
        // The input itself, through `..` and through a symlink.
        assert!(matches!(g.check_file(&d.join("in.csv")), Err(GuardError::IsInput { .. })));
        assert!(matches!(g.check_file(&scene.join("../in.csv")), Err(GuardError::IsInput { .. })));
        // `..` after a folder that does not exist (yet) is resolved too.
        assert!(matches!(g.check_file(&d.join("missing/../in.csv")), Err(GuardError::IsInput { .. })));
        assert!(matches!(g.check_file(&d.join("missing/deeper/../../scene/scene.toml")), Err(GuardError::SceneFile { .. })));
        assert_eq!(resolve(&d.join("missing/../scene/new.toml")), resolve(&d).join("scene/new.toml"));
        #[cfg(unix)]
        {
            std::os::unix::fs::symlink(d.join("in.csv"), d.join("link.csv")).unwrap();
            assert!(matches!(g.check_file(&d.join("link.csv")), Err(GuardError::IsInput { .. })));
        }
        // A file of the scene, an input folder as output folder, a folder inside it, the scene
        // folder's parent.
        assert!(matches!(g.check_file(&scene.join("scene.toml")), Err(GuardError::SceneFile { .. })));
        assert!(matches!(g.check_dir(&frames), Err(GuardError::IsInput { .. })));
        assert!(matches!(g.check_dir(&frames.join("out")), Err(GuardError::Overlaps { .. })));
        assert!(matches!(g.check_dir(&d), Err(GuardError::Overlaps { .. })));
        // Allowed: a new file of the scene (a cache), a new output elsewhere, anything with force.
        assert!(g.check_file(&scene.join("baked/new.exr")).is_ok());
        assert!(g.check_file(&d.join("out.csv")).is_ok());
        assert!(g.check_dir(&d.join("out")).is_ok());
        assert!(OutputGuard::new(Some(&scene), &[&frames], true).check_file(&scene.join("scene.toml")).is_ok());
        let msg = g.check_file(&scene.join("scene.toml")).unwrap_err().to_string();
        assert!(msg.contains("scene.toml") && msg.contains("--force"), "{msg}");
        std::fs::remove_dir_all(&d).ok();
    }
}
