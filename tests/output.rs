//! Issue 14 item 4: a report folder is replaced as a whole. Writers of a folder (the mechanism
//! `bikeproc report` uses, `output::replace_dir`) are killed with SIGINT and SIGKILL at random
//! moments, alone and two at once: the folder always holds one complete set, never a mix of
//! two, a partial one or a stray temporary file.

use bikeproc::output::replace_dir;
use bikeproc::sim::rng::Rng;
use std::path::{Path, PathBuf};
use std::process::{Child, Command};
use std::time::Duration;

/// Files per set, and bytes per file: a set takes a few milliseconds to write.
const FILES: usize = 60;
const BYTES: usize = 20_000;

/// Set `generation`: every file says which generation it belongs to.
fn set(generation: u64) -> Vec<(PathBuf, Vec<u8>)> {
    (0..FILES)
        .map(|k| {
            let mut bytes = format!("{generation}\n").into_bytes();
            bytes.resize(BYTES, b'0' + (k % 10) as u8);
            (PathBuf::from(format!("sub{}/f{k:02}.md", k % 3)), bytes)
        })
        .collect()
}

/// The generation `dir` holds, checking that it is one whole set and nothing else.
fn check(dir: &Path) -> u64 {
    let mut found = Vec::new();
    for sub in std::fs::read_dir(dir).unwrap() {
        let sub = sub.unwrap().path();
        assert!(sub.is_dir(), "stray {}", sub.display());
        for f in std::fs::read_dir(&sub).unwrap() {
            found.push(f.unwrap().path());
        }
    }
    assert_eq!(found.len(), FILES, "a partial set: {found:?}");
    let mut generations = found.iter().map(|p| {
        let bytes = std::fs::read(p).unwrap();
        assert_eq!(bytes.len(), BYTES, "{} half written", p.display());
        let text =
            String::from_utf8_lossy(&bytes[..bytes.iter().position(|&b| b == b'\n').unwrap()])
                .into_owned();
        text.parse::<u64>().unwrap()
    });
    let first = generations.next().unwrap();
    assert!(generations.all(|g| g == first), "a mix of sets");
    first
}

/// The child: writes generation after generation into the folder until it is killed.
fn child_loop(dir: &Path, start: u64) -> ! {
    let mut g = start;
    loop {
        replace_dir(dir, &set(g)).unwrap();
        g += 1;
    }
}

fn spawn(dir: &Path, start: u64) -> Child {
    Command::new(std::env::current_exe().unwrap())
        .args([
            "--exact",
            "writers_killed_at_random_leave_one_whole_set",
            "--nocapture",
        ])
        .env(
            "BIKEPROC_OUTPUT_CHILD",
            format!("{}|{start}", dir.display()),
        )
        .spawn()
        .unwrap()
}

fn kill(child: &mut Child, signal: &str) {
    let _ = Command::new("kill")
        .args([signal, &child.id().to_string()])
        .status();
    let _ = child.wait();
}

#[cfg(target_os = "linux")]
#[test]
fn writers_killed_at_random_leave_one_whole_set() {
    if let Ok(spec) = std::env::var("BIKEPROC_OUTPUT_CHILD") {
        let (dir, start) = spec.split_once('|').unwrap();
        child_loop(Path::new(dir), start.parse().unwrap());
    }
    let root = std::env::temp_dir().join(format!("bikeproc_kill_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&root);
    std::fs::create_dir_all(&root).unwrap();
    let dir = root.join("reports");
    replace_dir(&dir, &set(0)).unwrap();
    let mut rng = Rng::new(14);
    let mut seen = std::collections::BTreeSet::new();
    for round in 0..24u64 {
        let signal = if round % 2 == 0 { "-INT" } else { "-KILL" };
        let two = round % 3 == 2;
        let mut children = vec![spawn(&dir, 1_000 * (round + 1))];
        if two {
            children.push(spawn(&dir, 1_000_000 * (round + 1)));
        }
        std::thread::sleep(Duration::from_millis(150 + (rng.uniform() * 400.0) as u64));
        for c in &mut children {
            kill(c, signal);
        }
        seen.insert(check(&dir));
    }
    // Nothing was left beside the folder after a writer that ran to the end (the next writer
    // removes the killed ones' leftovers).
    replace_dir(&dir, &set(7)).unwrap();
    assert_eq!(check(&dir), 7);
    let beside: Vec<_> = std::fs::read_dir(&root)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(
        beside,
        vec![std::ffi::OsString::from("reports")],
        "left beside"
    );
    println!("{} generations seen after kills", seen.len());
    assert!(seen.len() > 12, "the writers did not get to write");
    std::fs::remove_dir_all(&root).unwrap();
}
