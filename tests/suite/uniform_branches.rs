//! No shader lets a uniform-buffer value reach control flow (issue 12: memory growth on lavapipe).
//!
//! Lavapipe (Mesa's Vulkan driver on llvmpipe, 22.3 in Debian 12) inlines uniform-buffer values
//! that reach an `if` condition or a loop's exit test (`lvp_find_inlinable_uniforms`, for shaders
//! of more than 100 SSA values): every time such a pipeline is bound with its uniform buffer
//! dirty, it clones the shader, substitutes the buffer's current values, and JIT-compiles a new
//! shader that it never frees. One bind per pass per frame made `heliar live` and `augment` grow
//! by ~5.8 MiB a frame (three new executable mappings a frame). Values that steer branches
//! therefore live in read-only storage buffers, which the driver never inlines; uniforms are
//! kept for values that only enter arithmetic (the camera matrices).
//!
//! The check follows the driver's rule on naga's IR (conservatively): a value is *uniform-only*
//! when it is computed from `var<uniform>` loads, literals and constants alone (the driver's
//! `nir_collect_src_uniforms`: ALU chains down to constant-offset UBO loads); a local variable
//! is uniform-only when every value stored in it is, a function argument when every call passes
//! one, a call's result when every `return` of the callee gives one (the driver sees the shader
//! after function inlining and `vars_to_ssa`). An `if` condition, `switch` selector or `break if`
//! that is uniform-only and reads at least one uniform is a finding. (A loop's exit test is an
//! `if … { break; }` in naga's IR; the driver also accepts induction variables there, which this
//! check does not, so a loop bound read from a uniform is found.)

use heliar::gpu::shaders;
use naga::{AddressSpace, Block, Expression, Function, Handle, Module, Statement};
use std::collections::HashMap;

/// A function of the module: a plain one or an entry point's.
#[derive(Clone, Copy, Debug, Eq, Hash, PartialEq)]
enum Fun {
    Plain(Handle<Function>),
    Entry(usize),
}

/// What a value is made of: `Some(mask)` when it is uniform-only, bit `i` of `mask` set when it
/// reads the module's `i`-th uniform global; `None` when anything else enters it (a texel, a
/// storage buffer, a vertex input, a built-in).
type Source = Option<u64>;

/// Both sources merged (a local variable stored twice, an argument passed at two call sites).
fn merge(a: Source, b: Source) -> Source {
    Some(a? | b?)
}

/// What is known of every function, grown to a fixed point (each entry only ever moves from
/// `Some(0)` to more uniforms, then to `None`).
#[derive(Default)]
struct State {
    /// Each argument, over every call site.
    args: HashMap<(Fun, u32), Source>,
    /// Each local variable, over every store.
    locals: HashMap<(Fun, u32), Source>,
    /// Each function's returned value, over its `return`s.
    returns: HashMap<Handle<Function>, Source>,
    /// Findings: "function: what" with the uniforms read.
    findings: Vec<(String, u64)>,
    changed: bool,
}

impl State {
    fn grow<K: std::hash::Hash + Eq>(map: &mut HashMap<K, Source>, key: K, v: Source, changed: &mut bool) {
        let e = map.entry(key).or_insert(Some(0));
        let m = merge(*e, v);
        if m != *e {
            *e = m;
            *changed = true;
        }
    }
}

/// The operands of an expression.
fn operands(e: &Expression) -> Vec<Handle<Expression>> {
    use Expression as E;
    match e {
        E::Compose { components, .. } => components.clone(),
        E::Access { base, index } => vec![*base, *index],
        E::AccessIndex { base, .. } => vec![*base],
        E::Splat { value, .. } => vec![*value],
        E::Swizzle { vector, .. } => vec![*vector],
        E::Load { pointer } => vec![*pointer],
        E::ImageSample { image, sampler, coordinate, array_index, offset, depth_ref, level, .. } => {
            let mut v = vec![*image, *sampler, *coordinate];
            v.extend(array_index.iter().chain(offset).chain(depth_ref));
            match level {
                naga::SampleLevel::Exact(h) | naga::SampleLevel::Bias(h) => v.push(*h),
                naga::SampleLevel::Gradient { x, y } => v.extend([*x, *y]),
                naga::SampleLevel::Auto | naga::SampleLevel::Zero => {}
            }
            v
        }
        E::ImageLoad { image, coordinate, array_index, sample, level } => {
            let mut v = vec![*image, *coordinate];
            v.extend(array_index.iter().chain(sample).chain(level));
            v
        }
        E::ImageQuery { image, query } => {
            let mut v = vec![*image];
            if let naga::ImageQuery::Size { level: Some(l) } = query {
                v.push(*l);
            }
            v
        }
        E::Unary { expr, .. } | E::Derivative { expr, .. } | E::As { expr, .. } => vec![*expr],
        E::Binary { left, right, .. } => vec![*left, *right],
        E::Select { condition, accept, reject } => vec![*condition, *accept, *reject],
        E::Relational { argument, .. } => vec![*argument],
        E::Math { arg, arg1, arg2, arg3, .. } => std::iter::once(*arg).chain(arg1.iter().chain(arg2).chain(arg3).copied()).collect(),
        E::ArrayLength(h) => vec![*h],
        // Leaves (literals, constants, globals, locals, arguments, call results are handled by
        // the caller) and operations the shaders do not use.
        _ => Vec::new(),
    }
}

/// The local variable a pointer expression is rooted at.
fn root_local(f: &Function, mut p: Handle<Expression>) -> Option<u32> {
    loop {
        match &f.expressions[p] {
            Expression::LocalVariable(l) => return Some(l.index() as u32),
            Expression::Access { base, .. } | Expression::AccessIndex { base, .. } => p = *base,
            _ => return None,
        }
    }
}

/// One pass over `f`: the source of each of its expressions from what `state` knows, then its
/// stores, calls, returns and control flow.
fn visit(uniforms: &HashMap<Handle<naga::GlobalVariable>, u64>, key: Fun, name: &str, f: &Function, state: &mut State) {
    let mut source: Vec<Source> = Vec::with_capacity(f.expressions.len());
    for (h, e) in f.expressions.iter() {
        use Expression as E;
        let own = match e {
            E::Literal(_) | E::Constant(_) | E::Override(_) | E::ZeroValue(_) => Some(0),
            E::GlobalVariable(g) => uniforms.get(g).copied(),
            E::LocalVariable(l) => state.locals.get(&(key, l.index() as u32)).copied().unwrap_or(Some(0)),
            // An entry point's arguments are vertex inputs, varyings and built-ins.
            E::FunctionArgument(i) => match key {
                Fun::Plain(_) => state.args.get(&(key, *i)).copied().unwrap_or(Some(0)),
                Fun::Entry(_) => None,
            },
            E::CallResult(callee) => state.returns.get(callee).copied().unwrap_or(Some(0)),
            E::ImageSample { .. } | E::ImageLoad { .. } | E::ImageQuery { .. } | E::Derivative { .. } | E::ArrayLength(_) => None,
            E::Compose { .. } | E::Access { .. } | E::AccessIndex { .. } | E::Splat { .. } | E::Swizzle { .. } | E::Load { .. } => Some(0),
            E::Unary { .. } | E::Binary { .. } | E::Select { .. } | E::Relational { .. } | E::Math { .. } | E::As { .. } => Some(0),
            // Atomics, ray queries, subgroup and cooperative operations: never uniform-only.
            _ => None,
        };
        // Operands come earlier in the arena than the expressions that use them.
        let v = operands(e).iter().filter(|o| o.index() < h.index()).fold(own, |v, o| merge(v, source[o.index()]));
        source.push(v);
    }
    for (l, local) in f.local_variables.iter() {
        if let Some(init) = local.init {
            State::grow(&mut state.locals, (key, l.index() as u32), source[init.index()], &mut state.changed);
        }
    }
    walk(&f.body, f, key, name, &source, state);
}

fn walk(block: &Block, f: &Function, key: Fun, name: &str, source: &[Source], state: &mut State) {
    let src = |h: &Handle<Expression>| source[h.index()];
    let find = |what: &str, h: &Handle<Expression>, state: &mut State| {
        if let Some(mask @ 1..) = src(h) {
            state.findings.push((format!("{name}: {what}"), mask));
        }
    };
    for s in block.iter() {
        match s {
            Statement::Block(b) => walk(b, f, key, name, source, state),
            Statement::If { condition, accept, reject } => {
                find("an `if` condition", condition, state);
                walk(accept, f, key, name, source, state);
                walk(reject, f, key, name, source, state);
            }
            Statement::Switch { selector, cases } => {
                find("a `switch` selector", selector, state);
                for c in cases {
                    walk(&c.body, f, key, name, source, state);
                }
            }
            Statement::Loop { body, continuing, break_if } => {
                if let Some(b) = break_if {
                    find("a `break if`", b, state);
                }
                walk(body, f, key, name, source, state);
                walk(continuing, f, key, name, source, state);
            }
            Statement::Store { pointer, value } => {
                if let Some(l) = root_local(f, *pointer) {
                    State::grow(&mut state.locals, (key, l), src(value), &mut state.changed);
                }
            }
            Statement::Call { function, arguments, .. } => {
                for (i, a) in arguments.iter().enumerate() {
                    State::grow(&mut state.args, (Fun::Plain(*function), i as u32), src(a), &mut state.changed);
                }
            }
            Statement::Return { value: Some(v) } => {
                if let Fun::Plain(h) = key {
                    State::grow(&mut state.returns, h, src(v), &mut state.changed);
                }
            }
            _ => {}
        }
    }
}

/// Places where a uniform value reaches control flow, as "function: what (uniform names)".
fn uniform_branches(module: &Module) -> Vec<String> {
    let globals: Vec<_> = module.global_variables.iter().filter(|(_, g)| g.space == AddressSpace::Uniform).collect();
    assert!(globals.len() <= 64, "more uniform globals than the mask holds");
    let uniforms: HashMap<_, u64> = globals.iter().enumerate().map(|(i, (h, _))| (*h, 1 << i)).collect();
    let names = |t: u64| -> String {
        globals.iter().enumerate().filter(|(i, _)| t & (1 << i) != 0).map(|(_, (_, g))| g.name.clone().unwrap_or_default()).collect::<Vec<_>>().join(", ")
    };
    let mut state = State::default();
    loop {
        state.changed = false;
        state.findings.clear();
        for (h, f) in module.functions.iter() {
            visit(&uniforms, Fun::Plain(h), f.name.as_deref().unwrap_or("?"), f, &mut state);
        }
        for (i, ep) in module.entry_points.iter().enumerate() {
            visit(&uniforms, Fun::Entry(i), &ep.name, &ep.function, &mut state);
        }
        if !state.changed {
            break;
        }
    }
    state.findings.iter().map(|(w, t)| format!("{w} depends on uniform {}", names(*t))).collect()
}

fn parse(name: &str, source: &str) -> Module {
    naga::front::wgsl::parse_str(source).unwrap_or_else(|e| panic!("{name}: {}", e.emit_to_string(source)))
}

#[test]
fn no_shader_branches_on_a_uniform_buffer_value() {
    let mut bad = Vec::new();
    for (name, _) in shaders::SOURCES.iter().filter(|(n, _)| !n.starts_with("common/")) {
        let source = shaders::resolve(name).unwrap();
        bad.extend(uniform_branches(&parse(name, &source)).into_iter().map(|f| format!("shaders/{name}: {f}")));
    }
    assert!(bad.is_empty(), "uniform values reach control flow (lavapipe recompiles and leaks the shader on every bind; use var<storage, read>):\n{}", bad.join("\n"));
}

/// The analysis finds a uniform through a local variable, a function argument and a returned
/// value, and nothing when the same values come from a storage buffer.
#[test]
fn the_analysis_follows_locals_arguments_and_returns() {
    let src = |space: &str| {
        format!(
            "struct P {{ mode: vec4<f32> }}
            @group(0) @binding(0) var<{space}> p: P;
            fn pick(m: f32) -> f32 {{ if (m > 0.5) {{ return 1.0; }} return 0.0; }}
            fn mode() -> f32 {{ return p.mode.y; }}
            @fragment fn fs() -> @location(0) vec4<f32> {{
                var k = p.mode.x * 2.0;
                var s = 0.0;
                for (var i = 0; i < i32(p.mode.w); i++) {{ s += 1.0; }}
                if (k > 1.0) {{ s += 1.0; }}
                if (mode() > 0.0) {{ s += 2.0; }}
                return vec4<f32>(pick(p.mode.z) + s);
            }}"
        )
    };
    let found = uniform_branches(&parse("uniform", &src("uniform")));
    // The loop's exit test, `k`, `mode()` in fs, and `m` in pick.
    assert_eq!(found.len(), 4, "{found:#?}");
    assert!(found.iter().any(|f| f.starts_with("pick: an `if` condition depends on uniform p")), "{found:#?}");
    assert_eq!(found.iter().filter(|f| f.starts_with("fs: ")).count(), 3, "{found:#?}");
    assert!(uniform_branches(&parse("storage", &src("storage, read"))).is_empty());
}
