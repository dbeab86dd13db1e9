// A single triangle that covers the whole viewport (no vertex buffer).

struct FullscreenOut {
    @builtin(position) position: vec4<f32>,
    // Viewport coordinates in [0, 1], origin at the top left.
    @location(0) uv: vec2<f32>,
}

// Vertex `index` (0, 1, 2) of the covering triangle (-1,-1), (3,-1), (-1,3) at clip depth `depth`.
fn fullscreen_vertex(index: u32, depth: f32) -> FullscreenOut {
    let x = f32((index << 1u) & 2u) * 2.0 - 1.0;
    let y = f32(index & 2u) * 2.0 - 1.0;
    var out: FullscreenOut;
    out.position = vec4<f32>(x, y, depth, 1.0);
    out.uv = vec2<f32>((x + 1.0) * 0.5, (1.0 - y) * 0.5);
    return out;
}
