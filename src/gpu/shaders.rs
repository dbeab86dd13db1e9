//! The WGSL sources, embedded in the binary, and their `#include` lines.
//!
//! A pass's shader lives in `shaders/<pass>.wgsl`; code shared by several passes lives in
//! `shaders/common/`. A line `#include "common/x.wgsl"` is replaced by that file (recursively,
//! each file at most once per module), so every module naga sees is plain WGSL. The validation
//! test (`tests/suite/shader_validation.rs`) checks that every `.wgsl` file on disk is listed here and
//! that every resolved module parses and validates.

use super::GpuError;
use std::borrow::Cow;

/// Every shader file, by its path under `shaders/`.
pub const SOURCES: &[(&str, &str)] = &[
    ("common/brdf.wgsl", include_str!("../../shaders/common/brdf.wgsl")),
    ("common/camera.wgsl", include_str!("../../shaders/common/camera.wgsl")),
    ("common/constants.wgsl", include_str!("../../shaders/common/constants.wgsl")),
    ("common/fullscreen.wgsl", include_str!("../../shaders/common/fullscreen.wgsl")),
    ("common/lamp_spots.wgsl", include_str!("../../shaders/common/lamp_spots.wgsl")),
    ("common/lighting.wgsl", include_str!("../../shaders/common/lighting.wgsl")),
    ("common/object.wgsl", include_str!("../../shaders/common/object.wgsl")),
    ("common/sh.wgsl", include_str!("../../shaders/common/sh.wgsl")),
    ("common/vem_lights.wgsl", include_str!("../../shaders/common/vem_lights.wgsl")),
    ("composite.wgsl", include_str!("../../shaders/composite.wgsl")),
    ("cuts/eval.wgsl", include_str!("../../shaders/cuts/eval.wgsl")),
    ("depth_prepass.wgsl", include_str!("../../shaders/depth_prepass.wgsl")),
    ("lamps.wgsl", include_str!("../../shaders/lamps.wgsl")),
    ("shadow_mask.wgsl", include_str!("../../shaders/shadow_mask.wgsl")),
    ("shadow_volume.wgsl", include_str!("../../shaders/shadow_volume.wgsl")),
    ("shadow_volume/extrude.wgsl", include_str!("../../shaders/shadow_volume/extrude.wgsl")),
    ("stencil_resolve.wgsl", include_str!("../../shaders/stencil_resolve.wgsl")),
    ("vem/overlay.wgsl", include_str!("../../shaders/vem/overlay.wgsl")),
    ("vem/shading.wgsl", include_str!("../../shaders/vem/shading.wgsl")),
    ("vem/shadow_atlas.wgsl", include_str!("../../shaders/vem/shadow_atlas.wgsl")),
    ("vem/tonemap.wgsl", include_str!("../../shaders/vem/tonemap.wgsl")),
    ("virtual_shading.wgsl", include_str!("../../shaders/virtual_shading.wgsl")),
];

/// Prefix of an include line.
const INCLUDE: &str = "#include";

/// The source of `name` as written.
pub fn raw(name: &str) -> Option<&'static str> {
    SOURCES.iter().find(|(n, _)| *n == name).map(|(_, s)| *s)
}

/// The source of `name` with its includes resolved.
pub fn resolve(name: &str) -> Result<String, GpuError> {
    let mut out = String::new();
    let mut seen = Vec::new();
    resolve_into(name, &mut out, &mut seen, 0)?;
    Ok(out)
}

fn resolve_into(name: &str, out: &mut String, seen: &mut Vec<String>, depth: usize) -> Result<(), GpuError> {
    const MAX_DEPTH: usize = 16;
    if seen.iter().any(|s| s == name) {
        return Ok(());
    }
    if depth > MAX_DEPTH {
        return Err(GpuError::Shader { name: name.to_owned(), message: "includes nest too deep (a cycle?)".into() });
    }
    seen.push(name.to_owned());
    let src = raw(name).ok_or_else(|| GpuError::Shader { name: name.to_owned(), message: "no such shader file".into() })?;
    for (i, line) in src.lines().enumerate() {
        let t = line.trim();
        if let Some(rest) = t.strip_prefix(INCLUDE) {
            let target = rest.trim().trim_matches('"');
            if target.is_empty() {
                return Err(GpuError::Shader { name: name.to_owned(), message: format!("line {}: empty #include", i + 1) });
            }
            resolve_into(target, out, seen, depth + 1).map_err(|e| match e {
                GpuError::Shader { message, .. } => {
                    GpuError::Shader { name: name.to_owned(), message: format!("line {}: {target}: {message}", i + 1) }
                }
                e => e,
            })?;
        } else {
            out.push_str(line);
            out.push('\n');
        }
    }
    Ok(())
}

/// Compiles `name` into a shader module.
pub fn module(device: &wgpu::Device, name: &str) -> Result<wgpu::ShaderModule, GpuError> {
    let source = resolve(name)?;
    Ok(device.create_shader_module(wgpu::ShaderModuleDescriptor { label: Some(name), source: wgpu::ShaderSource::Wgsl(Cow::Owned(source)) }))
}

/// A storage-buffer entry of a compute pass's bind group layout.
pub fn compute_storage(binding: u32, read_only: bool) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer { ty: wgpu::BufferBindingType::Storage { read_only }, has_dynamic_offset: false, min_binding_size: None },
        count: None,
    }
}

/// The compute pipeline of `entry` in `module` under `layout` (labelled by the entry point).
pub fn compute_pipeline(device: &wgpu::Device, layout: &wgpu::PipelineLayout, module: &wgpu::ShaderModule, entry: &str) -> wgpu::ComputePipeline {
    device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(entry),
        layout: Some(layout),
        module,
        entry_point: Some(entry),
        compilation_options: Default::default(),
        cache: None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn includes_resolve_once_and_unknown_files_are_named() {
        let s = resolve("virtual_shading.wgsl").unwrap();
        assert!(!s.contains(INCLUDE));
        // constants.wgsl is included by two common files but appears once.
        assert_eq!(s.matches("const PI").count(), 1);
        let e = resolve("nope.wgsl").unwrap_err().to_string();
        assert!(e.contains("nope.wgsl"), "{e}");
    }
}
