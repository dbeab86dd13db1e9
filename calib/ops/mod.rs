//! The calibration steps shared by the command line (`main.rs`) and the app (`ui/`): parsing of
//! inputs, checks and warnings, overlays, and the updates of camera files and manifests. Both
//! front ends call these, so they accept the same inputs, print the same warnings and write the
//! same files (always through `edit.rs`, so a scene is never left half-valid).

pub mod hdr;
pub mod intrinsics;
pub mod mark;
pub mod photometric;
pub mod pose;
pub mod scene;

/// A TOML array of numbers or strings.
pub fn toml_array<T: Into<toml_edit::Value>>(items: impl IntoIterator<Item = T>) -> toml_edit::Item {
    let mut a = toml_edit::Array::new();
    for x in items {
        a.push(x);
    }
    toml_edit::value(a)
}
