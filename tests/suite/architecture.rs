//! The crate's layering rule, checked on its own source (ARCHITECTURE.md, "Layering").
//!
//! Reads every `crate::…` path in `src/` (comments and `#[cfg(test)]` modules left out, as
//! `../shared/tools/module_graph.py` does) and checks that:
//! - each top-level module imports only the modules ARCHITECTURE.md allows it (the table below
//!   is that table; change both together);
//! - there is no import cycle between top-level modules, nor between the submodules one level
//!   down (`render::frame` ↔ `render::compositor` was one);
//! - every source file stays under `MAX_FILE_LINES` and every function under `MAX_FN_LINES`,
//!   with the exceptions listed (and why).

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// Which top-level modules each module may import (lower layers only).
const ALLOWED: &[(&str, &[&str])] = &[
    ("lighting", &[]),
    ("geometry", &[]),
    ("sun", &[]),
    ("io", &[]),
    ("report", &[]),
    ("camera", &["geometry"]),
    ("scene", &["camera", "geometry", "io", "sky", "sun"]),
    ("estimate", &["camera", "geometry", "io", "lamps", "scene", "sky", "sun"]),
    ("envmap", &["camera", "estimate", "geometry", "io", "lighting", "scene", "sky", "sun"]),
    ("irradiance", &["envmap", "geometry", "lighting", "scene", "sky"]),
    ("vem", &["camera", "geometry", "io", "report", "scene", "sky"]),
    ("lamps", &["geometry", "io", "report", "scene"]),
    ("cuts", &["geometry", "io", "report"]),
    ("sky", &["geometry"]),
    ("opencv_calib", &["camera", "geometry", "io"]),
    ("gpu", &["camera", "geometry", "io"]),
    ("render", &["camera", "geometry", "gpu", "io", "irradiance", "lamps", "lighting", "scene", "sky", "vem"]),
    ("run", &["camera", "cuts", "envmap", "estimate", "geometry", "gpu", "io", "irradiance", "lighting", "render", "report", "scene", "sun", "vem"]),
    ("live", &["camera", "estimate", "geometry", "gpu", "io", "irradiance", "lighting", "render", "report", "run", "scene", "vem"]),
];

/// Longest source file, lines (ARCHITECTURE.md: "a module that passes ~500 lines becomes a
/// folder").
const MAX_FILE_LINES: usize = 500;

/// Files allowed past [`MAX_FILE_LINES`], each with its reason.
const LONG_FILES: &[(&str, &str)] = &[];

fn sources(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap().flatten() {
        let p = e.path();
        if p.is_dir() {
            sources(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

/// The code of a file without comments and without its test module.
fn code(path: &Path) -> String {
    let text = std::fs::read_to_string(path).unwrap();
    let text = match text.find("#[cfg(test)]") {
        Some(i) => &text[..i],
        None => &text,
    };
    text.lines().map(|l| l.split("//").next().unwrap_or("")).collect::<Vec<_>>().join("\n")
}

/// `render::compositor` for `src/render/compositor/mod.rs`, `lib` for `src/lib.rs`.
fn module_of(src: &Path, path: &Path) -> Vec<String> {
    let rel = path.strip_prefix(src).unwrap().with_extension("");
    let mut parts: Vec<String> = rel.components().map(|c| c.as_os_str().to_string_lossy().into_owned()).collect();
    if parts.last().is_some_and(|p| p == "mod") {
        parts.pop();
    }
    parts
}

/// Every `crate::a::b` path in `code`, as `[a, b]` (`b` only when it is a module name).
fn crate_paths(code: &str) -> Vec<Vec<String>> {
    let mut out = Vec::new();
    let mut rest = code;
    while let Some(i) = rest.find("crate::") {
        rest = &rest[i + 7..];
        let path: Vec<String> = rest
            .split(|c: char| !(c.is_ascii_alphanumeric() || c == '_' || c == ':'))
            .next()
            .unwrap_or("")
            .split("::")
            .filter(|s| !s.is_empty())
            .take(2)
            .map(str::to_owned)
            .collect();
        if !path.is_empty() {
            out.push(path);
        }
    }
    out
}

struct Graph {
    edges: BTreeMap<String, BTreeSet<String>>,
}

impl Graph {
    fn cycles(&self) -> Vec<String> {
        let mut found = Vec::new();
        let mut state: BTreeMap<&str, u8> = BTreeMap::new();
        let mut stack: Vec<&str> = Vec::new();
        fn visit<'a>(g: &'a Graph, v: &'a str, state: &mut BTreeMap<&'a str, u8>, stack: &mut Vec<&'a str>, found: &mut Vec<String>) {
            state.insert(v, 1);
            stack.push(v);
            for w in g.edges.get(v).into_iter().flatten() {
                match state.get(w.as_str()) {
                    Some(1) => {
                        let i = stack.iter().position(|s| s == w).unwrap();
                        found.push(format!("{} -> {w}", stack[i..].join(" -> ")));
                    }
                    None => visit(g, w, state, stack, found),
                    _ => {}
                }
            }
            stack.pop();
            state.insert(v, 2);
        }
        for v in self.edges.keys() {
            if !state.contains_key(v.as_str()) {
                visit(self, v, &mut state, &mut stack, &mut found);
            }
        }
        found
    }
}

fn graphs() -> (Graph, Graph) {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    sources(&src, &mut files);
    let mut tops: BTreeSet<String> = BTreeSet::new();
    let mut modules = Vec::new();
    for f in &files {
        let m = module_of(&src, f);
        if m.first().is_some_and(|t| t == "bin" || t == "lib") {
            continue;
        }
        tops.insert(m[0].clone());
        modules.push((m, code(f)));
    }
    let (mut top, mut sub) = (Graph { edges: BTreeMap::new() }, Graph { edges: BTreeMap::new() });
    for (m, text) in &modules {
        for p in crate_paths(text) {
            if !tops.contains(&p[0]) {
                continue;
            }
            if p[0] != m[0] {
                top.edges.entry(m[0].clone()).or_default().insert(p[0].clone());
            }
            // One level down: `render::frame` → `render::compositor`, within and across modules.
            let a = m.iter().take(2).cloned().collect::<Vec<_>>().join("::");
            let b = p.iter().take(2).cloned().collect::<Vec<_>>().join("::");
            let nested = a.starts_with(&format!("{b}::")) || b.starts_with(&format!("{a}::"));
            if a != b && !nested && !(p.len() == 1 && p[0] == m[0]) {
                sub.edges.entry(a).or_default().insert(b);
            }
        }
    }
    (top, sub)
}

#[test]
fn every_module_imports_only_the_layers_below_it() {
    let (top, _) = graphs();
    let allowed: BTreeMap<&str, BTreeSet<&str>> = ALLOWED.iter().map(|(m, a)| (*m, a.iter().copied().collect())).collect();
    let mut bad = Vec::new();
    for (m, uses) in &top.edges {
        let Some(ok) = allowed.get(m.as_str()) else {
            bad.push(format!("{m}: not in the layering table (tests/suite/architecture.rs, ARCHITECTURE.md)"));
            continue;
        };
        for u in uses {
            if !ok.contains(u.as_str()) {
                bad.push(format!("{m} imports {u}"));
            }
        }
    }
    assert!(bad.is_empty(), "imports against the layering rule:\n{}", bad.join("\n"));
}

#[test]
fn the_module_graph_has_no_cycles() {
    let (top, sub) = graphs();
    let mut cycles = top.cycles();
    cycles.extend(sub.cycles());
    assert!(cycles.is_empty(), "import cycles:\n{}", cycles.join("\n"));
}

#[test]
fn source_files_stay_short() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut files = Vec::new();
    for d in ["src", "calib", "tools", "python/src"] {
        sources(&root.join(d), &mut files);
    }
    let exceptions: BTreeMap<&str, &str> = LONG_FILES.iter().copied().collect();
    let mut long = Vec::new();
    for f in files {
        let n = std::fs::read_to_string(&f).unwrap().lines().count();
        let rel = f.strip_prefix(root).unwrap().to_string_lossy().replace('\\', "/");
        if n > MAX_FILE_LINES && !exceptions.contains_key(rel.as_str()) {
            long.push(format!("{rel}: {n} lines"));
        }
    }
    assert!(long.is_empty(), "files over {MAX_FILE_LINES} lines (split them, or list them with a reason):\n{}", long.join("\n"));
}

/// Longest function body, lines, from its `fn` line to its closing brace (ARCHITECTURE.md: a
/// function reads top to bottom on one screen, "about 80 lines").
const MAX_FN_LINES: usize = 90;

/// Functions allowed past [`MAX_FN_LINES`] (`path::name`), each with its reason.
const LONG_FUNCTIONS: &[(&str, &str)] = &[(
    "src/vem/fir/design.rs::remez_lowpass",
    "the Remez exchange as one algorithm (grid, extremal set, Lagrange interpolation, exchange), in the order of Parks and McClellan's description; its parts share a dozen arrays",
)];

/// `(name, first line, lines)` of every `fn` outside test modules, found by its indentation: the
/// body ends at the first `}` line indented as the `fn` line.
fn functions(text: &str) -> Vec<(String, usize, usize)> {
    let text = match text.find("#[cfg(test)]") {
        Some(i) => &text[..i],
        None => text,
    };
    let lines: Vec<&str> = text.lines().collect();
    let mut out = Vec::new();
    for (i, l) in lines.iter().enumerate() {
        let t = l.trim_start();
        let indent = l.len() - t.len();
        let t = t.strip_prefix("pub(crate) ").or_else(|| t.strip_prefix("pub(super) ")).or_else(|| t.strip_prefix("pub ")).unwrap_or(t);
        let Some(rest) = t.strip_prefix("fn ") else { continue };
        let name: String = rest.chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect();
        if l.trim_end().ends_with(';') {
            continue; // a trait method without a body
        }
        let close = " ".repeat(indent) + "}";
        if let Some(end) = lines[i + 1..].iter().position(|m| m.starts_with(&close) && (m.len() == close.len() || !m[close.len()..].starts_with(' '))) {
            out.push((name, i + 1, end + 2));
        }
    }
    out
}

#[test]
fn functions_stay_short() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut files = Vec::new();
    for d in ["src", "calib", "tools", "python/src"] {
        sources(&root.join(d), &mut files);
    }
    let exceptions: BTreeMap<&str, &str> = LONG_FUNCTIONS.iter().copied().collect();
    let mut long = Vec::new();
    for f in files {
        let rel = f.strip_prefix(root).unwrap().to_string_lossy().replace('\\', "/");
        for (name, line, n) in functions(&std::fs::read_to_string(&f).unwrap()) {
            let key = format!("{rel}::{name}");
            if n > MAX_FN_LINES && !exceptions.contains_key(key.as_str()) {
                long.push(format!("{key} (line {line}): {n} lines"));
            }
        }
    }
    assert!(long.is_empty(), "functions over {MAX_FN_LINES} lines (split them, or list them with a reason):\n{}", long.join("\n"));
}

#[test]
fn the_function_scanner_measures_bodies() {
    let text = "fn a() {\n    x();\n}\n\nimpl T {\n    pub fn b(&self) -> u32 {\n        if c {\n        }\n        1\n    }\n    fn d();\n}\n";
    let f = functions(text);
    assert_eq!(f, vec![("a".to_string(), 1, 3), ("b".to_string(), 6, 5)]);
}
