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
    // Pa, 2 surface per Pd).
    levels: u32,
    nodes: u32,
    vertices: u32,
    lights: u32,
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
    let w = words[words[4u * b + 1u] + (g >> 3u)];
    return (w >> ((g & 7u) * 4u)) & 15u;
}

fn value_at(b: u32, g: u32) -> f32 {
    let encoding = words[4u * b];
    let base = words[4u * b + 2u];
    if encoding == 1u {
        return f32((words[base + (g >> 5u)] >> (g & 31u)) & 1u);
    }
    if encoding == 8u {
        return f32((words[base + (g >> 2u)] >> ((g & 3u) * 8u)) & 255u) * INV_255;
    }
    return f32((words[base + (g >> 1u)] >> ((g & 1u) * 16u)) & 65535u) * INV_65535;
}

// Step 1: every pointer at its cut's first node, every counter at zero.
fn start(first: u32, count: u32) -> u32 {
    var groups = 0u;
    for (var j = 0u; j < count; j++) {
        let op = ops[first + j];
        let offsets = words[4u * op.bank + 3u];
        bank[j] = op.bank;
        pointer[j] = words[offsets + op.cut];
        end_node[j] = words[offsets + op.cut + 1u];
        counter[j] = 0u;
        height[j] = height_at(op.bank, pointer[j]);
        value[j] = value_at(op.bank, pointer[j]);
        group[j] = op.group;
        weight[j] = op.weight;
        groups = max(groups, op.group + 1u);
    }
    return groups;
}

// Step 3: operand j moves on by `leaves` leaves (over whole nodes when they are skipped).
fn advance(j: u32, leaves: u32) {
    var left = leaves;
    loop {
        if left == 0u {
            break;
        }
        let rest = (1u << height[j]) - counter[j];
        if left >= rest {
            left -= rest;
            pointer[j] += 1u;
            counter[j] = 0u;
            if pointer[j] < end_node[j] {
                height[j] = height_at(bank[j], pointer[j]);
                value[j] = value_at(bank[j], pointer[j]);
            }
        } else {
            counter[j] += left;
            left = 0u;
        }
    }
}

struct Sums {
    // E_n and E_r of the first light, then of the second (`two`).
    n0: vec3<f32>,
    r0: vec3<f32>,
    n1: vec3<f32>,
    r1: vec3<f32>,
}

// The walk over `count` operands from `first`, summing lights `l0` (and `l1` when `two`) times
// the product over the nodes of the common refinement (Steps 1–4, and Eq. 3's sum).
fn walk(first: u32, count: u32, l0: u32, l1: u32, two: bool, n: vec3<f32>, r: vec3<f32>) -> Sums {
    var s = Sums(vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0));
    let groups = start(first, count);
    let levels = params.levels;
    let total = 1u << levels;
    var leaf = 0u;
    loop {
        if leaf >= total {
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
        if product != 0.0 {
            let k = ((1u << (levels - h)) - 1u) + (leaf >> h);
            let d = dirs[k].xyz;
            let spec = max(dot(r, d), 0.0) / max(dot(n, d), MIN_BRDF_COS);
            let lv0 = lights[l0 + k].xyz * product;
            s.n0 += lv0;
            s.r0 += lv0 * spec;
            if two {
                let lv1 = lights[l1 + k].xyz * product;
                s.n1 += lv1;
                s.r1 += lv1 * spec;
            }
        }
        let step = 1u << h;
        for (var j = 0u; j < count; j++) {
            advance(j, step);
        }
        leaf += step;
    }
    return s;
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let v = id.x;
    if v >= params.vertices {
        return;
    }
    let vx = vertices[v];
    let n = vx.normal.xyz;
    let r = vx.reflected.xyz;
    let nodes = params.nodes;
    let mask = params.lights;
    // The surface parts with the objects' visibility only, the sky with the proxy field too
    // (`FrameCuts::vertex_ambient`).
    var surf = Sums(vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0));
    if (mask & 6u) != 0u {
        let has_pa = (mask & 2u) != 0u;
        let has_pd = (mask & 4u) != 0u;
        let l0 = select(2u * nodes, nodes, has_pa);
        surf = walk(vx.ops.x, vx.ops.y, l0, 2u * nodes, has_pa && has_pd, n, r);
        if !has_pa {
            // Only the part per Pd: it was summed as the first light.
            surf = Sums(vec3<f32>(0.0), vec3<f32>(0.0), surf.n0, surf.r0);
        } else if !has_pd {
            surf.n1 = vec3<f32>(0.0);
            surf.r1 = vec3<f32>(0.0);
        }
    }
    let sky = walk(vx.ops.x, vx.ops.z, 0u, 0u, false, n, r);
    out[4u * v] = vec4<f32>(sky.n0 + surf.n0, 1.0);
    out[4u * v + 1u] = vec4<f32>(sky.r0 + surf.r0, 0.0);
    out[4u * v + 2u] = vec4<f32>(surf.n1, 0.0);
    out[4u * v + 3u] = vec4<f32>(surf.r1, 0.0);
}
