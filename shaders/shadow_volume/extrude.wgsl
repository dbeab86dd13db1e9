// Shadow-volume construction in a compute pass (the alternative to the CPU builder in
// src/render/volume.rs; both produce the same triangles, in a different order). Paired with
// src/render/volume_compute.rs.
//
// Closed components: one thread per edge emits the side triangle (a, b, L∞) of a silhouette edge
// (one face lit, n·l > 0, the other not), with (a, b) in the dark face's winding; one thread per
// face emits a dark face (n·l ≤ 0) with reversed winding as the cap. Open or non-manifold
// components: one thread per triangle emits its own closed prism (cap moved by `epsilon` to
// the side away from the sun, and three sides). L∞ = (-l, 0) is the point at infinity away from
// the sun. Triangles are appended through an atomic counter that is also the vertex count of
// the indirect draw.

struct Params {
    // xyz: unit direction toward the sun; w: cap offset of per-triangle volumes (metres).
    sun: vec4<f32>,
    // x: edges, y: closed faces, z: open (per-triangle) faces, w: output capacity in vertices.
    counts: vec4<u32>,
}

// Mirrors wgpu's `DrawIndirectArgs`.
struct DrawArgs {
    vertex_count: atomic<u32>,
    instance_count: u32,
    first_vertex: u32,
    first_instance: u32,
}

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> positions: array<vec4<f32>>;
// Closed faces (welded vertex indices) followed by open faces.
@group(0) @binding(2) var<storage, read> faces: array<vec4<u32>>;
// Unit face normals (zero for a degenerate face), same order as `faces`.
@group(0) @binding(3) var<storage, read> normals: array<vec4<f32>>;
// (a, b, f0, f1): edge a→b as it runs in face f0; f1 runs it b→a.
@group(0) @binding(4) var<storage, read> edges: array<vec4<u32>>;
@group(0) @binding(5) var<storage, read_write> out_vertices: array<vec4<f32>>;
@group(0) @binding(6) var<storage, read_write> draw: DrawArgs;

fn lit(face: u32) -> bool {
    return dot(normals[face].xyz, params.sun.xyz) > 0.0;
}

fn emit(a: vec4<f32>, b: vec4<f32>, c: vec4<f32>) {
    let at = atomicAdd(&draw.vertex_count, 3u);
    if (at + 3u > params.counts.w) {
        // Out of room: the caller sized the buffer for the worst case, so this does not happen.
        atomicSub(&draw.vertex_count, 3u);
        return;
    }
    out_vertices[at] = a;
    out_vertices[at + 1u] = b;
    out_vertices[at + 2u] = c;
}

fn infinity() -> vec4<f32> {
    return vec4<f32>(-params.sun.xyz, 0.0);
}

@compute @workgroup_size(64)
fn silhouettes(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if (i >= params.counts.x) {
        return;
    }
    let e = edges[i];
    let lit0 = lit(e.z);
    if (lit0 == lit(e.w)) {
        return;
    }
    let a = positions[e.x];
    let b = positions[e.y];
    if (lit0) {
        // The dark face f1 runs the edge b→a.
        emit(b, a, infinity());
    } else {
        emit(a, b, infinity());
    }
}

@compute @workgroup_size(64)
fn caps(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if (i >= params.counts.y || lit(i)) {
        return;
    }
    let f = faces[i];
    emit(positions[f.z], positions[f.y], positions[f.x]);
}

@compute @workgroup_size(64)
fn triangles(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if (i >= params.counts.z) {
        return;
    }
    let face = params.counts.y + i;
    let n = normals[face].xyz;
    let d = dot(n, params.sun.xyz);
    if (d == 0.0) {
        // Degenerate or parallel to the sun: no shadow.
        return;
    }
    let f = faces[face];
    let offset = vec4<f32>(-sign(d) * params.sun.w * n, 0.0);
    var p0 = positions[f.x] + offset;
    var p1 = positions[f.y] + offset;
    var p2 = positions[f.z] + offset;
    if (d < 0.0) {
        let t = p1;
        p1 = p2;
        p2 = t;
    }
    emit(p0, p1, p2);
    emit(p1, p0, infinity());
    emit(p2, p1, infinity());
    emit(p0, p2, infinity());
}
