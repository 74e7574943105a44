//! Names the build for `bikeproc --version`: the git commit it was built from, or `unknown
//! commit` outside a git checkout.

use std::process::Command;

fn main() {
    let describe = Command::new("git")
        .args(["describe", "--always", "--abbrev=12"])
        .output()
        .ok()
        .filter(|o| o.status.success())
        .and_then(|o| String::from_utf8(o.stdout).ok())
        .map(|s| format!("commit {}", s.trim()))
        .unwrap_or_else(|| "unknown commit".into());
    println!("cargo:rustc-env=BIKEPROC_BUILD={describe}");
    // Rebuilt when the checkout moves to another commit. Only files that exist are named: cargo
    // reruns a build script on every build while a file it names is missing (a fresh clone
    // often has no `.git/packed-refs`, or its branch only there), and with no file named at
    // all, on any change in the package.
    println!("cargo:rerun-if-changed=build.rs");
    let watch = |path: &str| {
        if std::path::Path::new(path).exists() {
            println!("cargo:rerun-if-changed={path}");
        }
    };
    watch(".git/HEAD");
    watch(".git/packed-refs");
    if let Ok(head) = std::fs::read_to_string(".git/HEAD") {
        if let Some(r) = head.trim().strip_prefix("ref: ") {
            watch(&format!(".git/{r}"));
        }
    }
}
