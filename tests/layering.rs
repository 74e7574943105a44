//! The data flow's direction, checked on the source: no analysis module uses the simulator
//! (`sim`), so that a test recovering what the simulator put in proves something (brief: the
//! generator must not share the analysis code, and the analysis must not lean on the
//! generator). Only `sim` itself and the `simulate` command (its arguments and handler) may;
//! unit tests (`#[cfg(test)]` modules) may simulate their inputs.

use std::path::{Path, PathBuf};

fn sources(dir: &Path, out: &mut Vec<PathBuf>) {
    let mut entries: Vec<PathBuf> = std::fs::read_dir(dir)
        .expect("src/ is readable")
        .map(|e| e.expect("a directory entry").path())
        .collect();
    entries.sort();
    for p in entries {
        if p.is_dir() {
            sources(&p, out);
        } else if p.extension().is_some_and(|e| e == "rs") {
            out.push(p);
        }
    }
}

/// The lines of `text` that are code outside unit tests, with their numbers.
fn code_lines(text: &str) -> impl Iterator<Item = (usize, &str)> {
    text.lines()
        .enumerate()
        .take_while(|(_, l)| l.trim() != "#[cfg(test)]")
        .filter(|(_, l)| !l.trim_start().starts_with("//"))
        .map(|(i, l)| (i + 1, l))
}

#[test]
fn no_analysis_module_uses_the_simulator() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let allowed = [
        src.join("sim"),
        src.join("blind"),
        src.join("cli/simulate.rs"),
        src.join("cli/args.rs"),
    ];
    let mut files = Vec::new();
    sources(&src, &mut files);
    assert!(files.len() > 30, "{} source files found", files.len());
    let mut offences = Vec::new();
    for f in files
        .iter()
        .filter(|f| !allowed.iter().any(|a| f.starts_with(a)))
    {
        let text = std::fs::read_to_string(f).expect("a source file");
        for (n, line) in code_lines(&text) {
            if ["crate::sim", "bikeproc::sim", "super::sim", "use sim"]
                .iter()
                .any(|p| line.contains(p))
            {
                offences.push(format!("{}:{n}: {}", f.display(), line.trim()));
            }
        }
    }
    assert!(offences.is_empty(), "{}", offences.join("\n"));
}

/// The simulator is the lab: it never runs the analysis (`gap`, the ride stage's fits). The
/// calibrations that diagnose its campaigns live above both, in `blind/`.
#[test]
fn the_simulator_runs_no_analysis() {
    let sim = Path::new(env!("CARGO_MANIFEST_DIR")).join("src/sim");
    let mut files = Vec::new();
    sources(&sim, &mut files);
    assert!(files.len() >= 10, "{} simulator files found", files.len());
    let mut offences = Vec::new();
    for f in &files {
        let text = std::fs::read_to_string(f).expect("a source file");
        for (n, line) in code_lines(&text) {
            if ["crate::gap", "crate::ride", "crate::blind"]
                .iter()
                .any(|p| line.contains(p))
            {
                offences.push(format!("{}:{n}: {}", f.display(), line.trim()));
            }
        }
    }
    assert!(offences.is_empty(), "{}", offences.join("\n"));
}

/// The check finds a use where there is one (it would pass on anything otherwise).
#[test]
fn the_check_sees_a_use_of_the_simulator() {
    let text = "use crate::fit;\nfn f() { let r = crate::sim::draw::seeded(1); }\n#[cfg(test)]\nmod tests { use crate::sim; }\n";
    let hits: Vec<usize> = code_lines(text)
        .filter(|(_, l)| l.contains("crate::sim"))
        .map(|(n, _)| n)
        .collect();
    assert_eq!(hits, vec![2]);
}

/// The model's parametrizations convert one way: the lab's converts to the benchmark's, never
/// back (`params` does not use `lab` or `uncertain`; `lab` does not use `uncertain`).
#[test]
fn the_model_modules_form_no_circle() {
    let model = Path::new(env!("CARGO_MANIFEST_DIR")).join("src/model");
    let uses = |file: &str, module: &str| {
        let text = std::fs::read_to_string(model.join(file)).expect("a model source");
        let found = code_lines(&text).any(|(_, l)| {
            l.contains(&format!("super::{module}")) || l.contains(&format!("model::{module}"))
        });
        found
    };
    assert!(!uses("params.rs", "lab"));
    assert!(!uses("params.rs", "uncertain"));
    assert!(!uses("lab.rs", "uncertain"));
    assert!(uses("uncertain.rs", "lab"), "the check reads the sources");
}

/// Which crate a source file belongs to (the library, or the `bikeproc` command: `main.rs` and
/// `cli/`) and its module path within it (`src/gap/fit.rs` → `["gap", "fit"]`).
fn module_of(src: &Path, file: &Path) -> (bool, Vec<String>) {
    let rel = file.strip_prefix(src).expect("a file under src/");
    let mut parts: Vec<String> = rel
        .with_extension("")
        .components()
        .map(|c| c.as_os_str().to_string_lossy().into_owned())
        .collect();
    if matches!(
        parts.last().map(String::as_str),
        Some("mod" | "lib" | "main")
    ) {
        parts.pop();
    }
    let bin = rel.starts_with("main.rs") || rel.starts_with("cli");
    (bin, parts)
}

/// The paths a file's code names: its `use` trees expanded (`a::{b, c::d}` → `a::b`,
/// `a::c::d`) and every `crate::`, `super::` and `self::` path written inline. Comments and
/// unit-test modules (`#[cfg(test)] mod … { … }`) are left out.
fn paths_named(text: &str) -> Vec<String> {
    let mut code = String::new();
    let mut lines = text.lines().peekable();
    while let Some(line) = lines.next() {
        let t = line.trim();
        if t == "#[cfg(test)]"
            && lines
                .peek()
                .is_some_and(|n| n.trim_start().starts_with("mod "))
        {
            let mut depth = 0i64;
            let mut opened = false;
            for l in lines.by_ref() {
                depth += l.matches('{').count() as i64 - l.matches('}').count() as i64;
                opened |= l.contains('{');
                if (opened && depth <= 0) || (!opened && l.trim_end().ends_with(';')) {
                    break;
                }
            }
            continue;
        }
        if t.starts_with("//") {
            continue;
        }
        code.push_str(line);
        code.push('\n');
    }
    fn expand(tree: &str) -> Vec<String> {
        let mut items = Vec::new();
        let (mut depth, mut current) = (0, String::new());
        for ch in tree.chars() {
            match ch {
                '{' => depth += 1,
                '}' => depth -= 1,
                _ => {}
            }
            if ch == ',' && depth == 0 {
                items.push(std::mem::take(&mut current));
            } else {
                current.push(ch);
            }
        }
        items.push(current);
        let mut out = Vec::new();
        for item in items.iter().filter(|i| !i.is_empty()) {
            match (item.find('{'), item.rfind('}')) {
                (Some(open), Some(close)) => {
                    for inner in expand(&item[open + 1..close]) {
                        out.push(format!("{}{inner}", &item[..open]));
                    }
                }
                _ => out.push(item.split(" as ").next().unwrap_or(item).to_string()),
            }
        }
        out
    }
    let mut paths = Vec::new();
    // A `use` declaration starts its line (after any visibility) and runs to its `;`.
    let mut offset = 0;
    for line in code.lines() {
        let start = offset;
        offset += line.len() + 1;
        let t = line.trim_start();
        let t = ["pub(crate) ", "pub(super) ", "pub "]
            .iter()
            .find_map(|v| t.strip_prefix(v))
            .unwrap_or(t);
        let Some(tree) = t.strip_prefix("use ") else {
            continue;
        };
        let at = start + (line.len() - tree.len());
        if let Some(end) = code[at..].find(';') {
            let tree: String = code[at..at + end]
                .chars()
                .filter(|c| !c.is_whitespace())
                .collect();
            paths.extend(expand(&tree));
        }
    }
    let word = |c: char| c.is_alphanumeric() || c == '_' || c == ':';
    for start in ["crate::", "super::", "self::"] {
        for (at, _) in code.match_indices(start) {
            if code[..at].chars().last().is_some_and(word) {
                continue;
            }
            let path: String = code[at..].chars().take_while(|&c| word(c)).collect();
            let path = path.trim_end_matches(':');
            // `super::{a, b}` and `super::*` are the `use` trees' (above).
            if path.contains("::") {
                paths.push(path.to_string());
            }
        }
    }
    paths
}

/// The file-level import graph of src/: an edge from each file to every other file whose
/// module it names (the longest module prefix of each path; `bikeproc::` from the command is
/// the library's `crate::`).
fn import_graph(src: &Path) -> Vec<(PathBuf, Vec<PathBuf>)> {
    let mut files = Vec::new();
    sources(src, &mut files);
    let modules: Vec<((bool, Vec<String>), PathBuf)> = files
        .iter()
        .map(|f| (module_of(src, f), f.clone()))
        .collect();
    let find = |bin: bool, path: &[String]| -> Option<PathBuf> {
        (0..=path.len()).rev().find_map(|k| {
            modules
                .iter()
                .find(|((b, m), _)| *b == bin && m.as_slice() == &path[..k])
                .map(|(_, f)| f.clone())
        })
    };
    let mut graph = Vec::new();
    for f in &files {
        let (bin, me) = module_of(src, f);
        let text = std::fs::read_to_string(f).expect("a source file");
        let mut targets: Vec<PathBuf> = Vec::new();
        for p in paths_named(&text) {
            let mut parts: Vec<String> = p.split("::").map(str::to_string).collect();
            parts.retain(|s| !s.is_empty());
            let Some(first) = parts.first().cloned() else {
                continue;
            };
            let (crate_bin, base): (bool, Vec<String>) = match first.as_str() {
                "crate" => (bin, Vec::new()),
                "bikeproc" => (false, Vec::new()),
                "self" => (bin, me.clone()),
                "super" => {
                    let mut base = me.clone();
                    base.pop();
                    while parts.get(1).is_some_and(|s| s == "super") {
                        base.pop();
                        parts.remove(0);
                    }
                    (bin, base)
                }
                _ => {
                    // A path from a child module of this one (`use child::Item` in a mod.rs).
                    let mut child = me.clone();
                    child.push(first.clone());
                    if modules.iter().any(|((b, m), _)| *b == bin && *m == child) {
                        parts.insert(0, String::new());
                        (bin, me.clone())
                    } else {
                        continue;
                    }
                }
            };
            let mut full = base;
            full.extend(parts.into_iter().skip(1));
            if let Some(target) = find(crate_bin, &full) {
                if target != *f && !targets.contains(&target) {
                    targets.push(target);
                }
            }
        }
        targets.sort();
        graph.push((f.clone(), targets));
    }
    graph
}

/// A circle of the graph, if there is one: the files along it, back to the first.
fn a_circle(graph: &[(PathBuf, Vec<PathBuf>)]) -> Option<Vec<PathBuf>> {
    fn visit(
        graph: &[(PathBuf, Vec<PathBuf>)],
        at: usize,
        state: &mut [u8],
        stack: &mut Vec<usize>,
    ) -> Option<Vec<PathBuf>> {
        state[at] = 1;
        stack.push(at);
        for t in &graph[at].1 {
            let Some(next) = graph.iter().position(|(f, _)| f == t) else {
                continue;
            };
            if state[next] == 1 {
                let from = stack.iter().position(|&s| s == next).unwrap_or(0);
                let mut circle: Vec<PathBuf> =
                    stack[from..].iter().map(|&s| graph[s].0.clone()).collect();
                circle.push(graph[next].0.clone());
                return Some(circle);
            }
            if state[next] == 0 {
                if let Some(c) = visit(graph, next, state, stack) {
                    return Some(c);
                }
            }
        }
        stack.pop();
        state[at] = 2;
        None
    }
    let mut state = vec![0u8; graph.len()];
    (0..graph.len()).find_map(|start| {
        (state[start] == 0)
            .then(|| visit(graph, start, &mut state, &mut Vec::new()))
            .flatten()
    })
}

/// Issue 78: no two files of src/ import each other, directly or round a longer circle (a
/// parent module and its children included: what both need lives in a file of its own).
#[test]
fn no_import_circle_between_files_of_src() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let graph = import_graph(&src);
    assert!(graph.len() > 80, "{} files", graph.len());
    let edges: usize = graph.iter().map(|(_, t)| t.len()).sum();
    assert!(
        edges > 300,
        "{edges} imports found: the parser reads the sources"
    );
    if let Some(circle) = a_circle(&graph) {
        let names: Vec<String> = circle
            .iter()
            .map(|f| f.strip_prefix(&src).unwrap_or(f).display().to_string())
            .collect();
        panic!("an import circle: {}", names.join(" → "));
    }
}

/// The circle test finds a circle where there is one, through `use` trees, inline paths and a
/// parent's `use child::…`, and none in a chain.
#[test]
fn the_circle_check_sees_a_circle() {
    let dir = std::env::temp_dir().join(format!("bikeproc_circle_{}", std::process::id()));
    let src = dir.join("src");
    std::fs::create_dir_all(src.join("a")).unwrap();
    std::fs::write(src.join("lib.rs"), "pub mod a;\npub mod b;\n").unwrap();
    std::fs::write(
        src.join("a/mod.rs"),
        "pub mod c;\nuse c::Thing;\n// use crate::b::Other;\n",
    )
    .unwrap();
    std::fs::write(src.join("b.rs"), "pub fn f() {}\n").unwrap();
    std::fs::write(
        src.join("a/c.rs"),
        "use crate::{b, x::{y, z}};\npub struct Thing;\n",
    )
    .unwrap();
    assert!(a_circle(&import_graph(&src)).is_none());
    std::fs::write(
        src.join("b.rs"),
        "pub fn f() { let _ = crate::a::c::Thing; }\n",
    )
    .unwrap();
    std::fs::write(
        src.join("a/c.rs"),
        "use crate::{b::f, x};\npub struct Thing;\n",
    )
    .unwrap();
    let circle = a_circle(&import_graph(&src)).expect("b.rs → a/c.rs → b.rs");
    assert_eq!(circle.len(), 3, "{circle:?}");
    std::fs::write(src.join("b.rs"), "pub fn f() {}\n").unwrap();
    std::fs::write(
        src.join("a/c.rs"),
        "pub fn g() { super::super::b::f(); }\nuse super::Thing;\n",
    )
    .unwrap();
    std::fs::write(
        src.join("a/mod.rs"),
        "pub mod c;\npub struct Thing;\npub use c::g;\n",
    )
    .unwrap();
    assert!(a_circle(&import_graph(&src)).is_some(), "a/mod.rs ↔ a/c.rs");
    std::fs::remove_dir_all(&dir).ok();
}

/// The lines of src/ outside the reader module (and `output.rs`, where a file to be written
/// has only its name to say its format) that look at a file's extension.
fn extension_uses(src: &Path) -> Vec<String> {
    let allowed = [src.join("read"), src.join("output.rs")];
    let mut files = Vec::new();
    sources(src, &mut files);
    let mut found = Vec::new();
    for f in files
        .iter()
        .filter(|f| !allowed.iter().any(|a| f.starts_with(a)))
    {
        let text = std::fs::read_to_string(f).expect("a source file");
        for (n, line) in code_lines(&text) {
            if line.contains(".extension()") {
                found.push(format!("{}:{n}: {}", f.display(), line.trim()));
            }
        }
    }
    found
}

/// Issue 78: a format is chosen by the file's content (`read::kind`) in the reader module,
/// never by its extension elsewhere.
#[test]
fn no_format_is_chosen_by_extension_outside_the_readers() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let found = extension_uses(&src);
    assert!(found.is_empty(), "{}", found.join("\n"));
    // The check reads the sources: the reader module itself does look at extensions.
    let kind = std::fs::read_to_string(src.join("read/kind.rs")).unwrap();
    assert!(code_lines(&kind).any(|(_, l)| l.contains(".extension()")));
}

/// Issue 78: anyhow only in the command (`main.rs`, `cli/`); the library's errors are types.
#[test]
fn anyhow_only_in_the_command() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    sources(&src, &mut files);
    let found: Vec<String> = files
        .iter()
        .filter(|f| !(f.starts_with(src.join("cli")) || f.ends_with("main.rs")))
        .flat_map(|f| {
            let text = std::fs::read_to_string(f).expect("a source file");
            code_lines(&text)
                .filter(|(_, l)| l.contains("anyhow"))
                .map(|(n, l)| format!("{}:{n}: {}", f.display(), l.trim()))
                .collect::<Vec<_>>()
        })
        .collect();
    assert!(found.is_empty(), "{}", found.join("\n"));
    let cli = std::fs::read_to_string(src.join("cli/mod.rs")).unwrap();
    assert!(
        code_lines(&cli).any(|(_, l)| l.contains("anyhow")),
        "the check reads the sources"
    );
}

/// The top-level lines of `text` after its first unit-test module that are not themselves in
/// a unit-test module, with their numbers.
fn code_after_tests(text: &str) -> Vec<usize> {
    let lines: Vec<&str> = text.lines().collect();
    let mut found = Vec::new();
    let (mut depth, mut seen_tests, mut in_tests) = (0i64, false, false);
    for (i, l) in lines.iter().enumerate() {
        let at_top = depth == 0;
        if at_top {
            let test_mod = l.trim() == "#[cfg(test)]"
                && lines
                    .get(i + 1)
                    .is_some_and(|n| n.starts_with("mod ") && n.contains('{'));
            if test_mod {
                seen_tests = true;
                in_tests = true;
            } else if l.starts_with("mod ") && in_tests {
                // The test module's own line.
            } else if !l.trim().is_empty() {
                in_tests = false;
                if seen_tests {
                    found.push(i + 1);
                }
            }
        }
        depth += l.matches('{').count() as i64 - l.matches('}').count() as i64;
    }
    found
}

/// Issue 78: a file's unit tests come last; no code follows them.
#[test]
fn unit_tests_close_their_files() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    sources(&src, &mut files);
    let found: Vec<String> = files
        .iter()
        .filter_map(|f| {
            let lines = code_after_tests(&std::fs::read_to_string(f).expect("a source file"));
            (!lines.is_empty()).then(|| format!("{}:{:?}", f.display(), lines))
        })
        .collect();
    assert!(
        found.is_empty(),
        "code after the unit tests: {}",
        found.join("; ")
    );
    let late = "fn a() {}\n#[cfg(test)]\nmod tests {\n    fn t() {}\n}\n\nfn b() {}\n";
    assert_eq!(
        code_after_tests(late),
        vec![7],
        "the check sees code after the tests"
    );
}
