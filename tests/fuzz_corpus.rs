//! Issue 14 item 3, on stable: every input in the fuzzers' checked-in corpus (`fuzz/seeds/`,
//! seeds and what the fuzzing runs kept, minimized) and every crash they found
//! (`fuzz/regressions/`) goes through its target again, which must return without a panic.
//! The fuzzers themselves run on nightly: see the README.

use std::path::Path;

#[test]
fn the_fuzz_corpus_and_regressions_replay_without_a_panic() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz");
    let mut replayed = 0;
    for (name, target) in bikeproc::fuzzing::TARGETS {
        let mut inputs = 0;
        for folder in ["seeds", "regressions"] {
            let dir = root.join(folder).join(name);
            let Ok(entries) = std::fs::read_dir(&dir) else {
                assert_eq!(folder, "regressions", "no corpus for {name}");
                continue;
            };
            let mut files: Vec<_> = entries.map(|e| e.unwrap().path()).collect();
            files.sort();
            for f in files {
                let bytes = std::fs::read(&f).unwrap();
                let outcome = std::panic::catch_unwind(|| target(&bytes));
                assert!(outcome.is_ok(), "{name}: {} panics", f.display());
                inputs += 1;
            }
        }
        assert!(inputs > 0, "{name}: an empty corpus");
        replayed += inputs;
    }
    println!("{replayed} inputs replayed");
}
