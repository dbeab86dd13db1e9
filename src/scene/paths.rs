//! Paths named by a scene's files, resolved against the scene folder and kept inside it.
//!
//! Every path in `scene.toml`, the camera file and the glTF files' buffer and image URIs is
//! joined to the folder it is relative to and resolved (symlinks and `..` included, through
//! `io::guard::resolve`); a path that lands outside the scene folder is refused, naming the file
//! and the field, unless [`LoadOptions::allow_outside_scene`] (`--allow-outside-scene` on the
//! command line). An absolute path in a manifest is outside unless it points into the folder.

use super::{SceneError, invalid};
use crate::io::guard::resolve;
use std::path::{Path, PathBuf};

/// How [`super::Scene::load_with`] reads a scene.
#[derive(Clone, Debug, Default)]
pub struct LoadOptions {
    /// Read files the scene names outside its folder (absolute paths, `..`, symlinks out).
    pub allow_outside_scene: bool,
}

/// The scene folder paths are kept in.
#[derive(Clone, Debug)]
pub(crate) struct Within {
    root: PathBuf,
    /// The resolved folder, or `None` when paths may go anywhere.
    confine: Option<PathBuf>,
}

impl Within {
    pub(crate) fn new(root: &Path, options: &LoadOptions) -> Self {
        Self { root: root.to_owned(), confine: (!options.allow_outside_scene).then(|| resolve(root)) }
    }

    /// The resolved scene folder paths must stay in (`None`: anywhere).
    pub(crate) fn confine(&self) -> Option<&Path> {
        self.confine.as_deref()
    }

    /// `rel` (field `field` of `file`) joined to the scene folder; refused when it resolves
    /// outside.
    pub(crate) fn join(&self, file: &Path, field: &str, rel: &str) -> Result<PathBuf, SceneError> {
        let p = self.root.join(rel);
        self.check(file, field, &p)?;
        Ok(p)
    }

    /// Refuses `p` (named by field `field` of `file`) when it resolves outside the scene folder.
    pub(crate) fn check(&self, file: &Path, field: &str, p: &Path) -> Result<(), SceneError> {
        let Some(root) = &self.confine else { return Ok(()) };
        let resolved = resolve(p);
        if resolved.starts_with(root) {
            return Ok(());
        }
        Err(invalid(
            file,
            field,
            format!(
                "{} resolves to {}, outside the scene folder {}: a scene reads only files inside its folder \
                 (--allow-outside-scene to read it anyway)",
                p.display(),
                resolved.display(),
                root.display()
            ),
        ))
    }
}
