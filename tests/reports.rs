//! The checked-in reports are exactly what a fresh regeneration from `data/` and the reference
//! material gives (CI fails otherwise), and regenerating twice gives the same bytes.
#![cfg(feature = "plot")]

use std::path::Path;

#[test]
fn checked_in_reports_match_a_fresh_regeneration() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let reference = root.join("../shared/reference");
    let data = root.join("data");
    let files = bikeproc::report::build(&data, &reference, &mut |_| {}).expect("reports build");
    let again = bikeproc::report::build(&data, &reference, &mut |_| {}).expect("reports build");
    assert!(files == again, "two regenerations differ");
    let mut stale = Vec::new();
    for (rel, bytes) in &files {
        let on_disk = std::fs::read(root.join("reports").join(rel)).unwrap_or_default();
        if &on_disk != bytes {
            stale.push(rel.display().to_string());
        }
    }
    // Nothing checked in that the generator no longer writes.
    let mut extra = Vec::new();
    let mut stack = vec![root.join("reports")];
    while let Some(dir) = stack.pop() {
        for e in std::fs::read_dir(&dir).into_iter().flatten().flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p);
            } else {
                let rel = p.strip_prefix(root.join("reports")).unwrap().to_path_buf();
                if !files.iter().any(|(r, _)| *r == rel) {
                    extra.push(rel.display().to_string());
                }
            }
        }
    }
    assert!(
        stale.is_empty() && extra.is_empty(),
        "reports/ is out of date; run `cargo run --release -- report` and commit.\nstale: {stale:?}\nnot generated any more: {extra:?}"
    );
}
