//! Every WGSL file under `shaders/` parses and validates with naga (includes resolved), and every
//! file on disk is embedded in the binary, so a shader typo fails `cargo test`, not a user's run.

use heliar::gpu::shaders;
use std::path::{Path, PathBuf};

fn wgsl_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            wgsl_files(&p, out);
        } else if p.extension().is_some_and(|e| e == "wgsl") {
            out.push(p);
        }
    }
}

#[test]
fn every_shader_file_is_embedded_and_validates() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("shaders");
    let mut files = Vec::new();
    wgsl_files(&root, &mut files);
    files.sort();
    assert!(files.len() >= 10, "found {} shader files", files.len());
    for path in &files {
        let name = path.strip_prefix(&root).unwrap().to_string_lossy().replace('\\', "/");
        let embedded = shaders::raw(&name).unwrap_or_else(|| panic!("shaders/{name} is not listed in src/gpu/shaders.rs"));
        assert_eq!(embedded, std::fs::read_to_string(path).unwrap(), "shaders/{name}: embedded copy differs");
        let source = shaders::resolve(&name).unwrap();
        let module = naga::front::wgsl::parse_str(&source).unwrap_or_else(|e| panic!("shaders/{name}: {}", e.emit_to_string(&source)));
        naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::default())
            .validate(&module)
            .unwrap_or_else(|e| panic!("shaders/{name}: {}", e.emit_to_string(&source)));
    }
    assert_eq!(files.len(), shaders::SOURCES.len(), "src/gpu/shaders.rs lists a file that is not on disk");
}
