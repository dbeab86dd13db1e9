//! Edits of scene folders that never leave a half-valid scene.
//!
//! A new scene is assembled in a temporary sibling folder, loaded and validated there, and only
//! then renamed into place. An edit of an existing scene writes the changed files into a
//! temporary copy of the scene's small files (frame folders are linked, not copied), validates
//! that copy, and then replaces each changed file by an atomic rename.

use anyhow::{Context, Result, bail};
use heliar::scene::Scene;
use std::path::{Path, PathBuf};

/// A temporary sibling of `dir`.
fn temp_sibling(dir: &Path, tag: &str) -> PathBuf {
    let name = dir.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_else(|| "scene".into());
    dir.with_file_name(format!(".{name}.{tag}-{}", std::process::id()))
}

fn copy_tree_linking_big(src: &Path, dst: &Path, link_dirs: &[PathBuf]) -> Result<()> {
    std::fs::create_dir_all(dst).with_context(|| format!("creating {}", dst.display()))?;
    for entry in std::fs::read_dir(src).with_context(|| format!("reading {}", src.display()))? {
        let entry = entry?;
        let p = entry.path();
        let q = dst.join(entry.file_name());
        let link = entry.file_type()?.is_symlink();
        if p.is_dir() {
            if p.file_name().is_some_and(|n| n == "baked") {
                continue;
            }
            // A linked folder stays a link (to where it points): the copy is only read.
            if link_dirs.iter().any(|d| d == &p) || link {
                #[cfg(unix)]
                std::os::unix::fs::symlink(std::fs::canonicalize(&p)?, &q).with_context(|| format!("linking {}", q.display()))?;
                continue;
            }
            copy_tree_linking_big(&p, &q, link_dirs)?;
        } else {
            std::fs::copy(&p, &q).with_context(|| format!("copying {}", p.display()))?;
        }
    }
    Ok(())
}

/// Writes `bytes` to `path` atomically (temporary file in the same folder, then rename:
/// `heliar::io::write_atomic`).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    heliar::io::write_atomic(path, bytes).with_context(|| format!("writing {}", path.display()))
}

/// The scene folder `path` lies in: the nearest folder above it (after resolving symlinks and
/// `..`) that holds a `scene.toml`; `None` outside every scene.
pub fn scene_around(path: &Path) -> Option<PathBuf> {
    let resolved = heliar::io::guard::resolve(path);
    resolved.ancestors().skip(1).find(|d| d.join(heliar::scene::MANIFEST_FILE).is_file()).map(Path::to_owned)
}

/// Checks a file the tool is about to write, with the guard every heliar command uses
/// (`heliar::io::guard::OutputGuard`): it may not be one of `inputs` (or lie in an input folder
/// as an existing file), nor overwrite an existing file of the scene it lies in
/// ([`scene_around`]), unless `force` (`--force`). The scene edits the tool is for (the pose
/// into the scene's camera file, the marks into its manifest) go through [`edit_scene`] instead
/// and are not outputs.
pub fn check_output(output: &Path, inputs: &[&Path], force: bool) -> Result<()> {
    let scene = scene_around(output);
    heliar::io::guard::OutputGuard::new(scene.as_deref(), inputs, force).check_file(output).map_err(anyhow::Error::new)
}

/// `rel` (a path of the scene at `dir`) relative to the scene folder after resolving symlinks and
/// `..` (see `heliar::io::guard::resolve`); `None` when it resolves outside the folder.
pub fn rel_inside(dir: &Path, rel: &Path) -> Option<PathBuf> {
    let root = heliar::io::guard::resolve(dir);
    heliar::io::guard::resolve(&dir.join(rel)).strip_prefix(&root).ok().map(Path::to_owned)
}

/// Checks that the scene at `dir` still loads with `changes` (path relative to the scene → new
/// contents) applied, on a temporary copy; `dir` itself is not touched.
/// `outside`: the scene's own files may lie outside its folder (the user allowed it).
fn validate_edit(dir: &Path, changes: &[(PathBuf, Vec<u8>)], outside: bool) -> Result<()> {
    let scene = Scene::load_with(dir, &heliar::scene::LoadOptions { allow_outside_scene: outside }).with_context(|| format!("loading {}", dir.display()))?;
    let frame_dirs: Vec<PathBuf> = scene.manifest.sequences.iter().map(|s| dir.join(&s.dir)).collect();
    let tmp = temp_sibling(dir, "edit");
    let _ = std::fs::remove_dir_all(&tmp);
    let result = (|| -> Result<Scene> {
        copy_tree_linking_big(dir, &tmp, &frame_dirs)?;
        for (rel, bytes) in changes {
            let p = tmp.join(rel);
            if let Some(parent) = p.parent() {
                std::fs::create_dir_all(parent)?;
            }
            std::fs::write(&p, bytes).with_context(|| format!("writing {}", p.display()))?;
        }
        // The copy links the scene's frame folders (outside the copy): allowed here.
        Scene::load_with(&tmp, &heliar::scene::LoadOptions { allow_outside_scene: true }).context("the edited scene does not load; nothing was changed")
    })();
    let _ = std::fs::remove_dir_all(&tmp);
    result.map(|_| ())
}

/// Applies `changes` (path relative to the scene → new contents) to the scene at `dir` after
/// checking that the changed scene loads. Every changed file must lie inside the scene folder
/// (symlinks and `..` resolved): an edit never reaches a file elsewhere.
pub fn edit_scene(dir: &Path, changes: &[(PathBuf, Vec<u8>)]) -> Result<Scene> {
    let mut inside = Vec::with_capacity(changes.len());
    for (rel, bytes) in changes {
        let Some(r) = rel_inside(dir, rel) else {
            bail!("{}: outside the scene folder {}; heliar-calib edits only the scene's own files", dir.join(rel).display(), dir.display());
        };
        inside.push((r, bytes.clone()));
    }
    validate_edit(dir, &inside, false)?;
    for (rel, bytes) in &inside {
        let p = dir.join(rel);
        if let Some(parent) = p.parent() {
            std::fs::create_dir_all(parent)?;
        }
        write_atomic(&p, bytes)?;
    }
    Scene::load(dir).with_context(|| format!("reloading {}", dir.display()))
}

/// Replaces the scene's camera file, which lies outside the scene folder at `target` (the user
/// allowed it), with `bytes`, after checking that the scene loads with it: the new contents go
/// to a temporary file beside `target` (so files it names resolve as they will), and a temporary
/// copy of the scene whose `camera.file` points there is loaded.
pub fn edit_camera_outside(dir: &Path, target: &Path, bytes: &[u8]) -> Result<Scene> {
    let mpath = dir.join(heliar::scene::MANIFEST_FILE);
    let check = heliar::io::temp_path_for(target);
    let result = (|| -> Result<()> {
        std::fs::write(&check, bytes).with_context(|| format!("writing {}", check.display()))?;
        let text = std::fs::read_to_string(&mpath).with_context(|| format!("reading {}", mpath.display()))?;
        let mut doc: toml_edit::DocumentMut = text.parse().with_context(|| format!("{}: not valid TOML", mpath.display()))?;
        let camera = doc.get_mut("camera").and_then(|c| c.as_table_like_mut()).with_context(|| format!("{}: no [camera] table", mpath.display()))?;
        camera.insert("file", toml_edit::value(check.to_string_lossy().into_owned()));
        validate_edit(dir, &[(PathBuf::from(heliar::scene::MANIFEST_FILE), doc.to_string().into_bytes())], true)
    })();
    let _ = std::fs::remove_file(&check);
    result?;
    write_atomic(target, bytes)?;
    Scene::load_with(dir, &heliar::scene::LoadOptions { allow_outside_scene: true }).with_context(|| format!("reloading {}", dir.display()))
}

/// Creates the scene folder `out` from `files` (relative path → contents, or a source file to
/// copy) after validating it in a temporary sibling; `out` must not exist.
pub fn create_scene(out: &Path, files: &[(PathBuf, FileSource)]) -> Result<Scene> {
    if out.exists() {
        bail!("{}: already exists; choose a new folder (heliar-calib never overwrites a scene)", out.display());
    }
    let tmp = temp_sibling(out, "new");
    let _ = std::fs::remove_dir_all(&tmp);
    let result = (|| -> Result<()> {
        for (rel, src) in files {
            let p = tmp.join(rel);
            if let Some(parent) = p.parent() {
                std::fs::create_dir_all(parent)?;
            }
            match src {
                FileSource::Bytes(b) => std::fs::write(&p, b).with_context(|| format!("writing {}", p.display()))?,
                FileSource::Copy(from) => {
                    std::fs::copy(from, &p).with_context(|| format!("copying {}", from.display()))?;
                }
            }
        }
        Scene::load(&tmp).context("the new scene does not load; nothing was written")?;
        Ok(())
    })();
    if let Err(e) = result {
        let _ = std::fs::remove_dir_all(&tmp);
        return Err(e);
    }
    std::fs::rename(&tmp, out).with_context(|| format!("renaming into {}", out.display()))?;
    Scene::load(out).with_context(|| format!("loading {}", out.display()))
}

/// Where a new file's contents come from.
pub enum FileSource {
    /// These bytes.
    Bytes(Vec<u8>),
    /// A copy of this file.
    Copy(PathBuf),
}
