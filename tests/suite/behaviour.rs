//! Behaviour bit for bit: `tools/check_behaviour.py` runs `augment`, `estimate`, `vem` and
//! `vem --scene` on copies of the bundled scenes with this build's `heliar`, hashes the output
//! frames and the JSON lines (timings left out) and compares them with
//! `tools/behaviour_hashes.json`. The stored hashes change only on purpose: a change that is
//! meant to change behaviour runs `python3 tools/check_behaviour.py --update` and says so in its
//! commit message.
//!
//! The dev profile gives the same bits as the release build (no fast-math in Rust; the GPU passes
//! run on the same software rasteriser), which is what lets CI check it with the test build.

use std::process::Command;

#[test]
fn outputs_on_the_bundled_scenes_match_the_stored_hashes() {
    let root = env!("CARGO_MANIFEST_DIR");
    let out = Command::new("python3")
        .arg(format!("{root}/tools/check_behaviour.py"))
        .arg("--bin")
        .arg(env!("CARGO_BIN_EXE_heliar"))
        .output()
        .expect("python3 (tools/setup.sh --tests installs it)");
    let (stdout, stderr) = (String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    assert!(out.status.success(), "behaviour changed or a command failed:\n{stdout}\n{stderr}");
    assert!(stdout.contains("stored hashes match") && !stdout.contains("differ"), "{stdout}");
}
