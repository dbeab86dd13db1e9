// The objects' ambient per vertex from the visibility cuts (issue 15 §2; cyberworlds §V-A.3–4,
// Eqs. 3–4): one thread per vertex runs the pointer/counter walk over the vertex's
// self-visibility cut and the neighbouring cuts of the other objects' fields and of the proxy
// field, multiplies the groups' weighted sums at each node of their common refinement and sums
// l_k·v (and the reflected lobe) over it. The layout of every buffer is `src/cuts/flat.rs`;
// `src/gpu/cuts.rs` runs it, `FrameCuts::object_ambient` is the CPU path it matches.
//
// Every value a branch or a loop bound reads comes from a read-only storage buffer, never a
// uniform (tests/suite/uniform_branches.rs).

// Matches MAX_GROUPS / MAX_OPS in src/cuts/flat.rs.
const MAX_GROUPS: u32 = 6u;
const MAX_OPS: u32 = 41u;
// f32(1/255), f32(1/65535): the CPU's decoding constants (`PackedCuts::value_at`), exactly.
const INV_255: f32 = 0.003921568859368563;
const INV_65535: f32 = 1.5259021893143654e-05;
// `cuts::lighting::MIN_BRDF_COS` (sin 3°).
const MIN_BRDF_COS: f32 = 0.052;

struct Params {
    // Tree depth, heap nodes, vertices, lighting parts present (bit 0 sky per Pa, 1 surface per
    // Pa, 2 surface per Pd), segments per walk and their height (`cuts::flat`, "Segments").
    levels: u32,
    nodes: u32,
    vertices: u32,
    lights: u32,
    segments: u32,
    segment_height: u32,
    pad0: u32,
    pad1: u32,
}

struct Vertex {
    // First operand, operands without the proxy field, operands with it, unused.
    ops: vec4<u32>,
    normal: vec4<f32>,
    reflected: vec4<f32>,
}

struct Op {
    bank: u32,
    cut: u32,
    group: u32,
    weight: f32,
}

@group(0) @binding(0) var<storage, read> params: Params;
@group(0) @binding(1) var<storage, read> words: array<u32>;
@group(0) @binding(2) var<storage, read> dirs: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read> lights: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read> vertices: array<Vertex>;
@group(0) @binding(5) var<storage, read> ops: array<Op>;
@group(0) @binding(6) var<storage, read_write> out: array<vec4<f32>>;
// Per vertex, lighting part and segment: E_n, E_r over the segment.
@group(0) @binding(7) var<storage, read_write> partial: array<vec4<f32>>;

// The walk's state per operand: bank, pointer (node index within the bank), end of the cut,
// counter, height and value of the current node, group and weight.
var<private> bank: array<u32, MAX_OPS>;
var<private> pointer: array<u32, MAX_OPS>;
var<private> end_node: array<u32, MAX_OPS>;
var<private> counter: array<u32, MAX_OPS>;
var<private> height: array<u32, MAX_OPS>;
var<private> value: array<f32, MAX_OPS>;
var<private> group: array<u32, MAX_OPS>;
var<private> weight: array<f32, MAX_OPS>;
var<private> sums: array<f32, MAX_GROUPS>;

fn height_at(b: u32, g: u32) -> u32 {
    let w = words[words[8u * b + 1u] + (g >> 3u)];
    return (w >> ((g & 7u) * 4u)) & 15u;
}

fn value_at(b: u32, g: u32) -> f32 {
    let encoding = words[8u * b];
    let base = words[8u * b + 2u];
    if encoding == 1u {
        return f32((words[base + (g >> 5u)] >> (g & 31u)) & 1u);
    }
    if encoding == 8u {
        return f32((words[base + (g >> 2u)] >> ((g & 3u) * 8u)) & 255u) * INV_255;
    }
    return f32((words[base + (g >> 1u)] >> ((g & 1u) * 16u)) & 65535u) * INV_65535;
}

// Step 1 at segment `seg`: every pointer at the node holding the segment's first leaf, its
// counter at the leaves of that node before it (a table of `cuts::flat`).
fn start(first: u32, count: u32, seg: u32) -> u32 {
    var groups = 0u;
    for (var j = 0u; j < count; j++) {
        let op = ops[first + j];
        let offsets = words[8u * op.bank + 3u];
        let at = words[8u * op.bank + 4u] + 2u * (op.cut * params.segments + seg);
        bank[j] = op.bank;
        pointer[j] = words[at];
        end_node[j] = words[offsets + op.cut + 1u];
        counter[j] = words[at + 1u];
        height[j] = height_at(op.bank, pointer[j]);
        value[j] = value_at(op.bank, pointer[j]);
        group[j] = op.group;
        weight[j] = op.weight;
        groups = max(groups, op.group + 1u);
    }
    return groups;
}

fn load(j: u32) {
    if pointer[j] < end_node[j] {
        height[j] = height_at(bank[j], pointer[j]);
        value[j] = value_at(bank[j], pointer[j]);
    }
}

// Step 3: operand j moves on by `leaves` leaves (over whole nodes when they are skipped). The
// common cases, staying in the node or moving to the next one, run no loop (llvmpipe counts
// loop iterations, `cuts::flat`).
fn advance(j: u32, leaves: u32) {
    var left = leaves;
    let rest = (1u << height[j]) - counter[j];
    if left < rest {
        counter[j] += left;
        return;
    }
    left -= rest;
    pointer[j] += 1u;
    counter[j] = 0u;
    load(j);
    loop {
        if left == 0u {
            break;
        }
        let size = 1u << height[j];
        if left < size {
            counter[j] = left;
            break;
        }
        left -= size;
        pointer[j] += 1u;
        load(j);
    }
}

// The walk over `count` operands from `first` over segment `seg`, summing the light at `l` times
// the product over the nodes of the common refinement that start in the segment (Steps 1–4, and
// Eq. 3's sum): `E_n` and `E_r` in a 2×4 matrix's columns.
fn walk(first: u32, count: u32, seg: u32, l: u32, n: vec3<f32>, r: vec3<f32>) -> mat2x4<f32> {
    var en = vec3<f32>(0.0);
    var er = vec3<f32>(0.0);
    let groups = start(first, count, seg);
    let levels = params.levels;
    var leaf = seg << params.segment_height;
    let end = leaf + (1u << params.segment_height);
    loop {
        if leaf >= end {
            break;
        }
        // Step 2: the lowest current node; each group's weighted sum, their product.
        var h = 99u;
        for (var g = 0u; g < groups; g++) {
            sums[g] = 0.0;
        }
        for (var j = 0u; j < count; j++) {
            h = min(h, height[j]);
            sums[group[j]] += value[j] * weight[j];
        }
        var product = 1.0;
        for (var g = 0u; g < groups; g++) {
            product *= sums[g];
        }
        // A zero self-visibility node entered at its first leaf is skipped whole (the CPU
        // walk's shortcut; a zero contributes nothing either way).
        if value[0] == 0.0 && counter[0] == 0u {
            h = height[0];
            product = 0.0;
        }
        // The node starts at `node_start`: before the segment only on its first step, and then it
        // is the segment's where it starts that sums it.
        let node_start = leaf & ~((1u << h) - 1u);
        if product != 0.0 && node_start == leaf {
            let k = ((1u << (levels - h)) - 1u) + (leaf >> h);
            let d = dirs[k].xyz;
            let spec = max(dot(r, d), 0.0) / max(dot(n, d), MIN_BRDF_COS);
            let lv = lights[l + k].xyz * product;
            en += lv;
            er += lv * spec;
        }
        let step = node_start + (1u << h) - leaf;
        for (var j = 0u; j < count; j++) {
            advance(j, step);
        }
        leaf += step;
    }
    return mat2x4<f32>(vec4<f32>(en, 0.0), vec4<f32>(er, 0.0));
}

// One thread per vertex, lighting part and segment. The parts (`FrameCuts::vertex_ambient`): the
// sky per unit Pa over the product with the proxy field, the surface per unit Pa and per unit Pd
// over the objects' visibility only; a part that is absent stays zero. One walk per thread, over
// one segment (llvmpipe's loop limit, `cuts::flat`, "Segments").
@compute @workgroup_size(64)
fn walk_segments(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let t = id.x + id.y * groups.x * 64u;
    let segs = params.segments;
    let v = t / (3u * segs);
    let part = (t / segs) % 3u;
    let seg = t % segs;
    if v >= params.vertices {
        return;
    }
    let vx = vertices[v];
    var sums = mat2x4<f32>(vec4<f32>(0.0), vec4<f32>(0.0));
    if ((params.lights >> part) & 1u) != 0u {
        let count = select(vx.ops.y, vx.ops.z, part == 0u);
        sums = walk(vx.ops.x, count, seg, part * params.nodes, vx.normal.xyz, vx.reflected.xyz);
    }
    partial[2u * t] = sums[0];
    partial[2u * t + 1u] = sums[1];
}

// One thread per vertex and lighting part: its segments added in order into its two rows of
// `out` (six per vertex; `cuts::flat::FrameOps::ambient` adds the parts as the CPU does).
@compute @workgroup_size(64)
fn add_segments(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let t = id.x + id.y * groups.x * 64u;
    if t >= 3u * params.vertices {
        return;
    }
    let segs = params.segments;
    var en = vec4<f32>(0.0);
    var er = vec4<f32>(0.0);
    for (var s = 0u; s < segs; s++) {
        en += partial[2u * (t * segs + s)];
        er += partial[2u * (t * segs + s) + 1u];
    }
    let v = t / 3u;
    let part = t % 3u;
    out[6u * v + 2u * part] = en;
    out[6u * v + 2u * part + 1u] = er;
}
