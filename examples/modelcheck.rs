use bikeproc::model::{Benchmark, Canonical};
fn main() {
    let mut files: Vec<_> = std::fs::read_dir("../shared/reference/bicycleparameters").unwrap().map(|e| e.unwrap().path()).filter(|p| p.to_string_lossy().ends_with("Benchmark.txt")).collect();
    files.sort();
    for f in files {
        match Benchmark::load(&f) {
            Ok(b) => {
                let c = Canonical::from_benchmark(&b);
                match c.stability(10.0, 0.01) {
                    Ok(s) => println!("{}: {:?} weave {:?} capsize {:?}", f.display(), s.stable_ranges_mps, s.weave_speed_mps, s.capsize_speed_mps),
                    Err(e) => println!("{}: ERR {e}", f.display()),
                }
            }
            Err(e) => println!("LOAD ERR {e}"),
        }
    }
}
