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
