//! Issue 34, item 5: `bikeproc design` against `bikeproc stability` of the file it writes, and
//! the design's optimality (Karush–Kuhn–Tucker) with the constraints' gradients taken by
//! central differences of the speeds, independently of the model's own derivatives.

use bikeproc::model::design::{design, DesignVariable};
use bikeproc::model::{uncertain, Benchmark};
use std::path::PathBuf;
use std::process::Command;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn speeds(b: &Benchmark) -> (f64, f64) {
    let s = uncertain::Parametrized::from_benchmark("b", b)
        .nominal_canonical()
        .stability(10.0, 0.01)
        .unwrap();
    (s.weave_speed_mps.unwrap(), s.capsize_speed_mps.unwrap())
}

/// The lab's bicycle made stable over 2.9–5.2 m/s by trail, head angle and the front wheel's
/// spin inertia: the file written is stable there by `stability`'s own search (to 1e-5 m/s:
/// the design keeps 1e-6 m/s inside), and the change is the smallest: x = −Σ μ_i ∇g_i with
/// μ_i ≥ 0 for the active constraints (the residual under 1 % of |x|).
#[test]
fn a_design_is_stable_where_asked_and_the_smallest_change() {
    let lab = root().join("data/lab_bike.toml");
    let out = std::env::temp_dir().join(format!("bikeproc_design_{}.txt", std::process::id()));
    let run = Command::new(env!("CARGO_BIN_EXE_bikeproc"))
        .args(["design", "--bike"])
        .arg(&lab)
        .args([
            "--stable",
            "2.9:5.2",
            "--vary",
            "trail,head_angle,IFyy",
            "--out",
        ])
        .arg(&out)
        .arg("--json")
        .output()
        .unwrap();
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let j: serde_json::Value = serde_json::from_slice(&run.stdout).unwrap();
    assert_eq!(j["reached"], true);
    let written = Benchmark::load(&out).unwrap();
    std::fs::remove_file(&out).ok();
    let (vw, vc) = speeds(&written);
    assert!(vw <= 2.9 + 1e-5 && vc >= 5.2 - 1e-5, "{vw} {vc}");

    // Optimality, by central differences through the design's own variables.
    let bike = bikeproc::read::bicycle::load(&lab).unwrap().nominal();
    let vars = [
        DesignVariable::Trail,
        DesignVariable::HeadAngle,
        DesignVariable::parse("IFyy").unwrap(),
    ];
    let d = design("lab", &bike, &vars, (2.9, 5.2), 0.5).unwrap();
    let x: Vec<f64> = d.changes.iter().map(|c| c.relative).collect();
    let at = |x: &[f64]| {
        // The bicycle at relative changes x, rebuilt by hand: the fork's offset is the one the
        // trail (+x₀) gives at the original head angle, the trail follows the head angle.
        let mut b = bike;
        let (s0, c0) = bike.lambda.sin_cos();
        let offset = bike.r_f * s0 - bike.c * (1.0 + x[0]) * c0;
        b.lambda = bike.lambda * (1.0 + x[1]);
        let (s, c) = b.lambda.sin_cos();
        b.c = (b.r_f * s - offset) / c;
        b.i_fyy = bike.i_fyy * (1.0 + x[2]);
        speeds(&b)
    };
    let (w0, c0) = at(&x);
    assert!((w0 - d.after_weave_speed_mps.unwrap()).abs() < 1e-9);
    assert!((c0 - d.after_capsize_speed_mps.unwrap()).abs() < 1e-9);
    let h = 1e-6;
    let grad = |k: usize| {
        let (mut p, mut m) = (x.clone(), x.clone());
        p[k] += h;
        m[k] -= h;
        let (a, b) = (at(&p), at(&m));
        // g1 = v_w − A, g2 = B − v_c.
        [(a.0 - b.0) / (2.0 * h), -(a.1 - b.1) / (2.0 * h)]
    };
    let g: Vec<[f64; 2]> = (0..3).map(grad).collect();
    let active: Vec<usize> = [(w0 - 2.9).abs() < 1e-4, (c0 - 5.2).abs() < 1e-4]
        .iter()
        .enumerate()
        .filter(|(_, a)| **a)
        .map(|(i, _)| i)
        .collect();
    assert!(!active.is_empty(), "no constraint active: {w0} {c0}");
    // μ by least squares on x = −G μ, over the active constraints.
    let gm = nalgebra::DMatrix::from_fn(3, active.len(), |r, c| -g[r][active[c]]);
    let xv = nalgebra::DVector::from_column_slice(&x);
    let mu = (gm.transpose() * &gm)
        .cholesky()
        .unwrap()
        .solve(&(gm.transpose() * &xv));
    let residual = (&gm * &mu - &xv).norm();
    assert!(mu.iter().all(|m| *m >= 0.0), "μ {mu}");
    assert!(
        residual < 0.01 * xv.norm(),
        "residual {residual} of {}",
        xv.norm()
    );
}

/// A target beyond the variables' reach is said, with the closest design and exit code 3.
#[test]
fn an_unreachable_target_is_said_with_the_closest() {
    let run = Command::new(env!("CARGO_BIN_EXE_bikeproc"))
        .args(["design", "--bike"])
        .arg(root().join("data/lab_bike.toml"))
        .args(["--stable", "2.5:5", "--vary", "trail,head_angle"])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&run.stdout);
    assert_eq!(run.status.code(), Some(3), "{text}");
    assert!(
        text.contains("not reachable by trail, head_angle within ±50 %"),
        "{text}"
    );
    assert!(text.contains("the closest design"), "{text}");
}

/// A change the model would take but no body has (the handlebar's I_xx cut by 95 % leaves its
/// x–z inertia not positive semi-definite) is not a design: exit 3, said.
#[test]
fn a_change_no_bicycle_has_is_no_design() {
    let run = Command::new(env!("CARGO_BIN_EXE_bikeproc"))
        .args(["design", "--bike"])
        .arg(root().join("data/lab_bike.toml"))
        .args([
            "--stable",
            "2.7:5.2",
            "--vary",
            "IHxx",
            "--max-change",
            "0.95",
        ])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&run.stdout);
    assert_eq!(run.status.code(), Some(3), "{text}");
    assert!(
        text.contains("make no physical bicycle") && text.contains("IHxx"),
        "{text}"
    );
}
