//! Resident memory per frame of the outdoor path's GPU work, one piece at a time (issue 12: the
//! memory growth over long runs on lavapipe). Not a test: run it by hand and compare the modes.
//!
//! ```sh
//! cargo run --example leak_bisect -- MODE [FRAMES] [EVERY]
//! ```
//!
//! Modes, each over the bundled courtyard's LDR footage looped:
//! - `submit`: an empty command encoder submitted and waited for, per frame;
//! - `upload`: the footage written into a texture (`queue.write_texture`), submitted, waited;
//! - `readback`: a texture of the output's size copied into a new mappable buffer and mapped;
//! - `render-off`: the compositor with every switchable pass off (the footage passes through);
//! - `render`: the compositor's full frame at the first frame's estimated lighting;
//! - `session`: estimate → relight → probes → composite, as `augment` and `live` do;
//! - `clear`, `clear-msaa`, `clear-depth`: one render pass that only clears a texture of the
//!   output's size (single-sampled; 4× MSAA resolved into it; a depth-stencil target), submitted
//!   and waited for: plain wgpu, nothing of heliar's;
//! - `draw`, `draw-sample`, `draw-load`: one render pass drawing a full-screen triangle (a
//!   constant colour; a texture read with a sampler; a texture read with `textureLoad`);
//!   `draw-read`: the sampled draw, then its target read back; `draw-write`: the footage
//!   written into the sampled texture, then the draw;
//! - `draw32-read`: the sampled draw into a 32-bit float target (the output's format), read back;
//! - `draw-write-read`: the footage written, the sampled draw, its target read back;
//! - `draw-uniform`, `draw-storage`: the sampled draw branching on a value of a uniform buffer
//!   (a storage buffer), the buffer written each frame with the same values;
//! - `write-buffer`: 64 bytes written into a uniform buffer (`queue.write_buffer`), submitted.
//!
//! Prints `frame,rss_mib` every EVERY frames and the growth per frame after the first quarter.

use heliar::geometry::raycast::RayScene;
use heliar::gpu::{Gpu, GpuOptions};
use heliar::io::frames::Frame;
use heliar::render::{Compositor, CompositorConfig, PassSwitches, VideoFrame};
use std::path::Path;
use std::sync::Arc;

fn rss_mib() -> f64 {
    let s = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    s.lines().find(|l| l.starts_with("VmRSS:")).and_then(|l| l.split_whitespace().nth(1)).and_then(|v| v.parse::<f64>().ok()).unwrap_or(f64::NAN) / 1024.0
}

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let mode = args.get(1).map(String::as_str).unwrap_or("render");
    let frames: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(200);
    let every: usize = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(20);
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/courtyard");
    let scene = heliar::scene::Scene::load(&root)?;
    let seq = scene.sequences.iter().find(|s| s.name == "ldr").unwrap_or(&scene.sequences[0]);
    let lin = seq.photometry.linearizer();
    let footage: Vec<Frame> = seq.files.iter().map(|p| Frame::load(p)).collect::<Result<_, _>>()?;
    let ray = Arc::new(RayScene::new(scene.proxy.clone()));
    let gpu = Arc::new(Gpu::new(GpuOptions::default())?);
    eprintln!("adapter {}, mode {mode}, {frames} frames", gpu.describe());
    let config = CompositorConfig { transfer_paths: 0, ..CompositorConfig::for_scene(&scene) };
    let mut comp = Compositor::for_scene(gpu.clone(), &scene, ray.clone(), config)?;
    if mode == "render-off" {
        comp.set_switches(PassSwitches { virtual_objects: false, virtual_volumes: false, real_volumes: false, transfer: false }, "off");
    }
    let estimator = heliar::estimate::Estimator::new(&scene, ray.clone())?;
    let probes = Box::new(heliar::irradiance::sources::UniformSky::for_scene(&scene));
    let mut session = heliar::run::session::OutdoorSession::new(heliar::run::outdoor::OutdoorStage::new(estimator, probes), comp);
    // The lighting of frame 0, for the modes that do not estimate.
    let first = session.process(0, &seq.times[0], &footage[0], &lin)?;
    let lighting = first.record.lighting;
    let k = &scene.camera.intrinsics;
    let tex = heliar::gpu::texture::Tex::new(&gpu.device, "bisect", (k.width, k.height), wgpu::TextureFormat::Rgba32Float, 1, wgpu::TextureUsages::COPY_DST | wgpu::TextureUsages::COPY_SRC | wgpu::TextureUsages::TEXTURE_BINDING);
    let targets = Targets::new(&gpu, (k.width, k.height));
    let uniform = gpu.device.create_buffer(&wgpu::BufferDescriptor { label: Some("uniform"), size: 64, usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST, mapped_at_creation: false });
    let draw = Draw::new(&gpu, mode, &tex);
    if mode.starts_with("render") {
        let v = VideoFrame::from_frame(&footage[0], &lin);
        let (_, report) = session.compositor.render(&v, &lighting)?;
        eprintln!("passes run: {:?}", report.ran);
    }
    let mut c = Context { gpu, session, footage, lin, times: seq.times.clone(), lighting, tex, targets, uniform, draw };
    let mut rows = Vec::new();
    for i in 0..frames {
        frame(&mut c, mode, i)?;
        if (i + 1) % every == 0 {
            let m = rss_mib();
            println!("{},{m:.1}", i + 1);
            rows.push((i + 1, m));
        }
    }
    let q = rows.len() / 4;
    if rows.len() > q + 1 {
        let (a, b) = (rows[q], rows[rows.len() - 1]);
        eprintln!("{mode}: RSS {:.1} MiB at frame {} -> {:.1} MiB at frame {}: {:+.3} MiB per frame", a.1, a.0, b.1, b.0, (b.1 - a.1) / (b.0 - a.0) as f64);
    }
    Ok(())
}

/// What the modes work on.
struct Context {
    gpu: Arc<Gpu>,
    session: heliar::run::session::OutdoorSession,
    footage: Vec<Frame>,
    lin: heliar::io::frames::Linearizer,
    times: Vec<chrono::DateTime<chrono::FixedOffset>>,
    lighting: heliar::lighting::Lighting,
    tex: heliar::gpu::texture::Tex,
    targets: Targets,
    uniform: wgpu::Buffer,
    draw: Draw,
}

/// Frame `i` of `mode`.
fn frame(c: &mut Context, mode: &str, i: usize) -> anyhow::Result<()> {
    let j = i % c.footage.len();
    match mode {
        "submit" => {
            let enc = c.gpu.device.create_command_encoder(&Default::default());
            c.gpu.queue.submit([enc.finish()]);
            c.gpu.wait()?;
        }
        "upload" => {
            let v = VideoFrame::from_frame(&c.footage[j], &c.lin);
            c.tex.write(&c.gpu.queue, &v.rgba);
            c.gpu.queue.submit(std::iter::empty::<wgpu::CommandBuffer>());
            c.gpu.wait()?;
        }
        "readback" => {
            heliar::gpu::readback::read_texture(&c.gpu, &c.tex.texture, 16)?;
        }
        "render" | "render-off" => {
            let v = VideoFrame::from_frame(&c.footage[j], &c.lin);
            c.session.compositor.render(&v, &c.lighting)?;
        }
        "session" => {
            c.session.process(i, &c.times[j], &c.footage[j], &c.lin)?;
        }
        "clear" | "clear-msaa" | "clear-depth" => clear_pass(&c.gpu, mode, &c.targets)?,
        "draw" | "draw-sample" | "draw-load" => c.draw.pass(&c.gpu, &c.targets)?,
        "draw-uniform" | "draw-storage" => {
            c.gpu.queue.write_buffer(&c.draw.params, 0, bytemuck::cast_slice(&[0.75f32, 0.5, 0.25, 1.0]));
            c.draw.pass(&c.gpu, &c.targets)?;
        }
        "write-buffer" => {
            c.gpu.queue.write_buffer(&c.uniform, 0, &[i as u8; 64]);
            c.gpu.queue.submit(std::iter::empty::<wgpu::CommandBuffer>());
            c.gpu.wait()?;
        }
        "draw-write-read" => {
            let v = VideoFrame::from_frame(&c.footage[j], &c.lin);
            c.tex.write(&c.gpu.queue, &v.rgba);
            c.draw.pass(&c.gpu, &c.targets)?;
            heliar::gpu::readback::read_texture(&c.gpu, &c.targets.colour.texture, 8)?;
        }
        "draw32-read" => {
            c.draw.pass32(&c.gpu, &c.targets)?;
            heliar::gpu::readback::read_texture(&c.gpu, &c.targets.colour32.texture, 16)?;
        }
        "draw-read" => {
            c.draw.pass(&c.gpu, &c.targets)?;
            heliar::gpu::readback::read_texture(&c.gpu, &c.targets.colour.texture, 8)?;
        }
        "draw-write" => {
            let v = VideoFrame::from_frame(&c.footage[j], &c.lin);
            c.tex.write(&c.gpu.queue, &v.rgba);
            c.draw.pass(&c.gpu, &c.targets)?;
        }
        m => anyhow::bail!("unknown mode {m}"),
    }
    Ok(())

}

/// Render targets for the clear-only modes.
struct Targets {
    colour: heliar::gpu::texture::Tex,
    colour32: heliar::gpu::texture::Tex,
    msaa: heliar::gpu::texture::Tex,
    depth: heliar::gpu::texture::Tex,
}

impl Targets {
    fn new(gpu: &Gpu, size: (u32, u32)) -> Self {
        let usage = wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC;
        Self {
            colour: heliar::gpu::texture::Tex::new(&gpu.device, "clear", size, wgpu::TextureFormat::Rgba16Float, 1, usage | wgpu::TextureUsages::TEXTURE_BINDING),
            colour32: heliar::gpu::texture::Tex::new(&gpu.device, "draw32", size, wgpu::TextureFormat::Rgba32Float, 1, usage),
            msaa: heliar::gpu::texture::Tex::new(&gpu.device, "clear msaa", size, wgpu::TextureFormat::Rgba16Float, 4, wgpu::TextureUsages::RENDER_ATTACHMENT),
            depth: heliar::gpu::texture::Tex::new(&gpu.device, "clear depth", size, gpu.depth_format, 1, wgpu::TextureUsages::RENDER_ATTACHMENT),
        }
    }
}

/// One render pass that only clears, submitted and waited for.
fn clear_pass(gpu: &Gpu, mode: &str, t: &Targets) -> anyhow::Result<()> {
    let mut enc = gpu.device.create_command_encoder(&Default::default());
    let clear = wgpu::Operations { load: wgpu::LoadOp::Clear(wgpu::Color::BLACK), store: wgpu::StoreOp::Store };
    let colour = match mode {
        "clear-msaa" => Some(wgpu::RenderPassColorAttachment { view: &t.msaa.view, depth_slice: None, resolve_target: Some(&t.colour.view), ops: wgpu::Operations { load: wgpu::LoadOp::Clear(wgpu::Color::BLACK), store: wgpu::StoreOp::Discard } }),
        "clear" => Some(wgpu::RenderPassColorAttachment { view: &t.colour.view, depth_slice: None, resolve_target: None, ops: clear }),
        _ => None,
    };
    let depth = (mode == "clear-depth").then(|| wgpu::RenderPassDepthStencilAttachment {
        view: &t.depth.view,
        depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Clear(1.0), store: wgpu::StoreOp::Store }),
        stencil_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Clear(0), store: wgpu::StoreOp::Store }),
    });
    let colours = [colour];
    drop(enc.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some("clear"),
        color_attachments: if mode == "clear-depth" { &[] } else { &colours },
        depth_stencil_attachment: depth,
        timestamp_writes: None,
        occlusion_query_set: None,
        multiview_mask: None,
    }));
    gpu.queue.submit([enc.finish()]);
    gpu.wait()?;
    Ok(())
}

/// A full-screen triangle into the colour target, reading `source` as the mode says.
struct Draw {
    pipeline: Option<wgpu::RenderPipeline>,
    pipeline32: Option<wgpu::RenderPipeline>,
    bind_group: Option<wgpu::BindGroup>,
    params: wgpu::Buffer,
}

impl Draw {
    fn new(gpu: &Gpu, mode: &str, source: &heliar::gpu::texture::Tex) -> Self {
        let storage = mode == "draw-storage";
        let usage = if storage { wgpu::BufferUsages::STORAGE } else { wgpu::BufferUsages::UNIFORM };
        let params = gpu.device.create_buffer(&wgpu::BufferDescriptor { label: Some("params"), size: 16, usage: usage | wgpu::BufferUsages::COPY_DST, mapped_at_creation: false });
        if !mode.starts_with("draw") {
            return Self { pipeline: None, pipeline32: None, bind_group: None, params };
        }
        let body = match mode {
            // Enough instructions (sixteen taps) that lavapipe considers inlining the branch's uniform.
            "draw-uniform" | "draw-storage" => {
                "var c = vec4f(0.0); for (var k = 0; k < 16; k += 1) { c += textureLoad(t, vec2i(p.xy) + vec2i(k % 4, k / 4), 0) * (1.0 + 0.1 * f32(k)); } \
                 if (u.x > 0.5) { return c * u.y; } return c + vec4f(u.z);"
            }
            "draw-sample" | "draw-read" | "draw-write" | "draw-write-read" | "draw32-read" => "return textureSampleLevel(t, s, p.xy / vec2f(textureDimensions(t)), 0.0);",
            "draw-load" => "return textureLoad(t, vec2i(p.xy), 0);",
            _ => "return vec4f(0.5, 0.25, 0.125, 1.0);",
        };
        let src = format!(
            "@group(0) @binding(0) var t: texture_2d<f32>;\n@group(0) @binding(1) var s: sampler;\n@group(0) @binding(2) var<{}> u: vec4f;\n\
             @vertex fn vs(@builtin(vertex_index) i: u32) -> @builtin(position) vec4f {{\n\
             let x = f32((i << 1u) & 2u) * 2.0 - 1.0; let y = f32(i & 2u) * 2.0 - 1.0; return vec4f(x, y, 0.0, 1.0); }}\n\
             @fragment fn fs(@builtin(position) p: vec4f) -> @location(0) vec4f {{ _ = t; _ = s; _ = u; {body} }}\n",
            if storage { "storage, read" } else { "uniform" }
        );
        let d = &gpu.device;
        let module = d.create_shader_module(wgpu::ShaderModuleDescriptor { label: Some("draw"), source: wgpu::ShaderSource::Wgsl(src.into()) });
        let layout = d.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("draw"),
            entries: &[
                wgpu::BindGroupLayoutEntry { binding: 0, visibility: wgpu::ShaderStages::FRAGMENT, ty: wgpu::BindingType::Texture { sample_type: wgpu::TextureSampleType::Float { filterable: false }, view_dimension: wgpu::TextureViewDimension::D2, multisampled: false }, count: None },
                wgpu::BindGroupLayoutEntry { binding: 1, visibility: wgpu::ShaderStages::FRAGMENT, ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::NonFiltering), count: None },
                wgpu::BindGroupLayoutEntry {
                    binding: 2,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Buffer { ty: if storage { wgpu::BufferBindingType::Storage { read_only: true } } else { wgpu::BufferBindingType::Uniform }, has_dynamic_offset: false, min_binding_size: None },
                    count: None,
                },
            ],
        });
        let sampler = d.create_sampler(&wgpu::SamplerDescriptor::default());
        let bind_group = d.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("draw"),
            layout: &layout,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(&source.view) },
                wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::Sampler(&sampler) },
                wgpu::BindGroupEntry { binding: 2, resource: params.as_entire_binding() },
            ],
        });
        let pl = d.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor { label: Some("draw"), bind_group_layouts: &[Some(&layout)], immediate_size: 0 });
        let make = |format: wgpu::TextureFormat| {
            d.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some("draw"),
                layout: Some(&pl),
                vertex: wgpu::VertexState { module: &module, entry_point: Some("vs"), compilation_options: Default::default(), buffers: &[] },
                primitive: Default::default(),
                depth_stencil: None,
                multisample: Default::default(),
                fragment: Some(wgpu::FragmentState { module: &module, entry_point: Some("fs"), compilation_options: Default::default(), targets: &[Some(format.into())] }),
                multiview_mask: None,
                cache: None,
            })
        };
        Self { pipeline: Some(make(wgpu::TextureFormat::Rgba16Float)), pipeline32: Some(make(wgpu::TextureFormat::Rgba32Float)), bind_group: Some(bind_group), params }
    }

    fn pass(&self, gpu: &Gpu, t: &Targets) -> anyhow::Result<()> {
        self.pass_into(gpu, &t.colour.view, self.pipeline.as_ref())
    }

    fn pass32(&self, gpu: &Gpu, t: &Targets) -> anyhow::Result<()> {
        self.pass_into(gpu, &t.colour32.view, self.pipeline32.as_ref())
    }

    fn pass_into(&self, gpu: &Gpu, view: &wgpu::TextureView, pipeline: Option<&wgpu::RenderPipeline>) -> anyhow::Result<()> {
        let (Some(pipeline), Some(bg)) = (pipeline, &self.bind_group) else { anyhow::bail!("no pipeline") };
        let mut enc = gpu.device.create_command_encoder(&Default::default());
        {
            let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("draw"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment { view, depth_slice: None, resolve_target: None, ops: wgpu::Operations { load: wgpu::LoadOp::Clear(wgpu::Color::BLACK), store: wgpu::StoreOp::Store } })],
                ..Default::default()
            });
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, bg, &[]);
            pass.draw(0..3, 0..1);
        }
        gpu.queue.submit([enc.finish()]);
        gpu.wait()?;
        Ok(())
    }
}
