//! The module graph of the runtime follows one order, so that it has no circle:
//!
//! error → input → model → kernels → bodies → forces → groom → render → config →
//! memory_plan → output → solver → simulation → scene
//!
//! A module may use (through `crate::...` paths) only itself and the modules before it.
//! The test reads every file under `runtime/src`, takes the `crate::` paths of its code
//! (comments left out), maps each to its top-level module (a name re-exported at the
//! crate root to the module it comes from) and checks every edge against the order.
//! `super::` paths stay inside a folder and are not edges.

use std::collections::{BTreeMap, BTreeSet};
use std::fs;
use std::path::{Path, PathBuf};

/// The top-level modules in dependency order.
const ORDER: [&str; 14] = [
    "error",
    "input",
    "model",
    "kernels",
    "bodies",
    "forces",
    "groom",
    "render",
    "config",
    "memory_plan",
    "output",
    "solver",
    "simulation",
    "scene",
];

/// Files of the solver that step a strand in time; the static solve must not use them.
const INTEGRATOR_FILES: [&str; 3] = ["adaptive", "one_step", "rk4"];

fn src_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("src")
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let mut entries: Vec<PathBuf> = fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("cannot read {}: {e}", dir.display()))
        .map(|e| e.expect("directory entry").path())
        .collect();
    entries.sort();
    for path in entries {
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|x| x == "rs") {
            out.push(path);
        }
    }
}

/// The code of a file with its comments blanked (line structure kept): `//` to the end
/// of the line and `/* ... */`, outside string and character literals.
fn strip_comments(text: &str) -> String {
    let chars: Vec<char> = text.chars().collect();
    let mut out = String::with_capacity(text.len());
    let mut i = 0;
    let (mut in_string, mut block_depth) = (false, 0usize);
    while i < chars.len() {
        let c = chars[i];
        let next = chars.get(i + 1).copied();
        if block_depth > 0 {
            if c == '*' && next == Some('/') {
                block_depth -= 1;
                i += 2;
            } else if c == '/' && next == Some('*') {
                block_depth += 1;
                i += 2;
            } else {
                if c == '\n' {
                    out.push('\n');
                }
                i += 1;
            }
            continue;
        }
        if in_string {
            out.push(c);
            if c == '\\' {
                if let Some(n) = next {
                    out.push(n);
                }
                i += 2;
                continue;
            }
            if c == '"' {
                in_string = false;
            }
            i += 1;
            continue;
        }
        match (c, next) {
            ('/', Some('/')) => {
                while i < chars.len() && chars[i] != '\n' {
                    i += 1;
                }
            }
            ('/', Some('*')) => {
                block_depth = 1;
                i += 2;
            }
            ('"', _) => {
                in_string = true;
                out.push(c);
                i += 1;
            }
            // a character literal such as '"' or '\'' (not a lifetime: those have no
            // closing quote right after one character)
            ('\'', Some(n)) if chars.get(i + 2) == Some(&'\'') && n != '\\' => {
                out.push_str("' '");
                i += 3;
            }
            ('\'', Some('\\')) => {
                let end = (i + 2..chars.len())
                    .find(|&k| chars[k] == '\'')
                    .unwrap_or(i + 2);
                out.push_str("' '");
                i = end + 1;
            }
            _ => {
                out.push(c);
                i += 1;
            }
        }
    }
    out
}

fn is_ident(c: char) -> bool {
    c.is_alphanumeric() || c == '_'
}

/// The first identifiers of the paths after every `crate::` in `code`, with their line
/// numbers: `crate::a::b` gives `a`; `crate::{a::b, c}` gives `a` and `c`.
fn crate_paths(code: &str) -> Vec<(usize, String)> {
    let mut found = Vec::new();
    let bytes: Vec<char> = code.chars().collect();
    let line_of = |pos: usize| bytes[..pos].iter().filter(|&&c| c == '\n').count() + 1;
    let pattern: Vec<char> = "crate::".chars().collect();
    let mut i = 0;
    while i + pattern.len() <= bytes.len() {
        let preceded = i > 0 && (is_ident(bytes[i - 1]) || bytes[i - 1] == ':');
        if bytes[i..i + pattern.len()] != pattern[..] || preceded {
            i += 1;
            continue;
        }
        let mut j = i + pattern.len();
        if bytes.get(j) == Some(&'{') {
            // the top-level entries of the group
            let mut depth = 0;
            let mut at_entry_start = true;
            while j < bytes.len() {
                let c = bytes[j];
                match c {
                    '{' => {
                        depth += 1;
                        if depth == 1 {
                            at_entry_start = true;
                        }
                    }
                    '}' => {
                        depth -= 1;
                        if depth == 0 {
                            break;
                        }
                    }
                    ',' if depth == 1 => at_entry_start = true,
                    c if depth == 1 && at_entry_start && is_ident(c) => {
                        let start = j;
                        while j < bytes.len() && is_ident(bytes[j]) {
                            j += 1;
                        }
                        found.push((line_of(start), bytes[start..j].iter().collect()));
                        at_entry_start = false;
                        continue;
                    }
                    _ => {}
                }
                j += 1;
            }
        } else {
            let start = j;
            while j < bytes.len() && is_ident(bytes[j]) {
                j += 1;
            }
            if j > start {
                found.push((line_of(start), bytes[start..j].iter().collect()));
            }
        }
        i = j.max(i + 1);
    }
    found
}

/// Names re-exported at the crate root (`pub use module::...::{A, B}` in `lib.rs`),
/// mapped to the top-level module they come from.
fn root_reexports(lib: &str) -> BTreeMap<String, String> {
    let code = strip_comments(lib);
    let mut map = BTreeMap::new();
    for statement in code.split(';') {
        let Some(rest) = statement.trim().strip_prefix("pub use ") else {
            continue;
        };
        let module: String = rest.chars().take_while(|&c| is_ident(c)).collect();
        if !ORDER.contains(&module.as_str()) {
            continue;
        }
        let names = rest.rsplit("::").next().unwrap_or_default();
        for name in names
            .split(|c: char| !is_ident(c))
            .filter(|s| !s.is_empty())
        {
            map.insert(name.to_string(), module.clone());
        }
    }
    map
}

/// The top-level module of a file under `src`, and its path inside it.
fn module_of(src: &Path, file: &Path) -> (String, Vec<String>) {
    let rel = file.strip_prefix(src).expect("file under src");
    let mut parts: Vec<String> = rel
        .iter()
        .map(|p| p.to_string_lossy().trim_end_matches(".rs").to_string())
        .collect();
    let top = parts.remove(0);
    (top, parts)
}

/// One `crate::` use.
#[derive(Debug)]
struct Edge {
    from: String,
    to: String,
    file: String,
    line: usize,
}

fn edges() -> Vec<Edge> {
    let src = src_dir();
    let lib = fs::read_to_string(src.join("lib.rs")).expect("lib.rs");
    let reexports = root_reexports(&lib);
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    let mut edges = Vec::new();
    for file in files {
        let (from, _) = module_of(&src, &file);
        if from == "lib" {
            continue;
        }
        let text = fs::read_to_string(&file).expect("source file");
        for (line, first) in crate_paths(&strip_comments(&text)) {
            let to = if ORDER.contains(&first.as_str()) {
                first
            } else if let Some(m) = reexports.get(&first) {
                m.clone()
            } else {
                panic!(
                    "{}:{line}: `crate::{first}` is neither a top-level module nor a name \
                     re-exported at the crate root from one",
                    file.display()
                );
            };
            edges.push(Edge {
                from: from.clone(),
                to,
                file: file
                    .strip_prefix(&src)
                    .unwrap_or(&file)
                    .display()
                    .to_string(),
                line,
            });
        }
    }
    edges
}

fn rank(module: &str) -> usize {
    ORDER
        .iter()
        .position(|m| *m == module)
        .unwrap_or_else(|| panic!("top-level module `{module}` is not in ORDER"))
}

#[test]
fn every_top_level_module_is_placed_in_the_order() {
    let src = src_dir();
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    let modules: BTreeSet<String> = files
        .iter()
        .map(|f| module_of(&src, f).0)
        .filter(|m| m != "lib")
        .collect();
    let ordered: BTreeSet<String> = ORDER.iter().map(|m| m.to_string()).collect();
    assert_eq!(
        modules, ordered,
        "runtime/src's top-level modules and ORDER differ"
    );
}

#[test]
fn module_graph_follows_the_order() {
    let edges = edges();
    let against: Vec<String> = edges
        .iter()
        .filter(|e| rank(&e.to) > rank(&e.from))
        .map(|e| format!("{}:{}: {} uses {}", e.file, e.line, e.from, e.to))
        .collect();
    assert!(
        against.is_empty(),
        "edges against the order {}:\n{}",
        ORDER.join(" → "),
        against.join("\n")
    );
}

#[test]
fn the_graph_reader_sees_the_known_edges() {
    // the reader must find what is there, or the order test could pass on nothing
    let pairs: BTreeSet<(String, String)> = edges().into_iter().map(|e| (e.from, e.to)).collect();
    for (from, to) in [
        ("simulation", "solver"),
        ("solver", "kernels"),
        ("kernels", "model"),
        ("scene", "config"),
        ("output", "config"),
        ("forces", "error"),
    ] {
        assert!(
            pairs.contains(&(from.to_string(), to.to_string())),
            "no edge {from} → {to} found; edges: {pairs:?}"
        );
    }
    let grouped = crate_paths("use crate::{model::strand::Strand, error::{Error, Result}};");
    let names: Vec<&str> = grouped.iter().map(|(_, n)| n.as_str()).collect();
    assert_eq!(names, ["model", "error"]);
    let code = strip_comments("let x = 1; // crate::scene\n/* crate::scene */ let s = \"//\";");
    assert!(crate_paths(&code).is_empty(), "{code}");
}

#[test]
fn statics_uses_no_integrator_file() {
    let src = src_dir();
    let text = fs::read_to_string(src.join("solver/statics.rs")).expect("solver/statics.rs");
    let code = strip_comments(&text);
    for name in INTEGRATOR_FILES {
        for prefix in ["super::", "crate::solver::"] {
            let path = format!("{prefix}{name}");
            assert!(
                !code.contains(&path),
                "solver/statics.rs uses `{path}`: shared step assembly belongs in \
                 solver/system.rs"
            );
        }
    }
}
