//! Issue 34: the sensitivities of the weave and capsize speeds against independent central
//! differences of the speeds themselves (the model's stability search on perturbed parameters),
//! and the uncertainty budget against the propagation `stability` already does.

use bikeproc::model::sensitivity::sensitivity;
use bikeproc::model::uncertain::Parametrized;
use bikeproc::model::Benchmark;
use std::path::PathBuf;

fn reference(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/reference/bicycleparameters")
        .join(name)
}

/// The weave and capsize speeds of `b` as `stability` finds them (0–10 m/s, refined to 1e-13).
fn speeds(b: &Benchmark) -> (f64, f64) {
    let s = Parametrized::from_benchmark("b", b)
        .nominal_canonical()
        .stability(10.0, 0.01)
        .unwrap();
    (s.weave_speed_mps.unwrap(), s.capsize_speed_mps.unwrap())
}

/// Every parameter's dv/dp equals the central difference of the speeds (step 1e-5 of the
/// parameter; truncation ~1e-10 relative, the speeds' search 1e-13 m/s over a step of ≥ 1e-7)
/// to 1e-4 relative, or 1e-7 m/s per unit for a derivative near zero (the capsize speed's by
/// the inertias is zero: λ = 0 there makes det(g K₀ + v² K₂) vanish, free of M and C₁, and the
/// differences' search noise is ~1e-13/h); the variance shares add up to 1 (none for a file
/// without standard errors), and the budget's standard errors equal the propagation of `stability` (central
/// differences through the parameters, a thousandth of each SE) to 1e-3.
fn check(file: &str) {
    let model = bikeproc::read::bicycle::load(&reference(file)).unwrap();
    let s = sensitivity(&model, &[5.0], 10.0).unwrap();
    let nominal = model.nominal();
    let values = nominal.to_array();
    let mut worst = 0.0f64;
    for (k, p) in s.parameters.iter().enumerate() {
        let h = 1e-5 * values[k].abs().max(1e-2);
        let at = |x: f64| {
            let mut v = values;
            v[k] = x;
            speeds(&Benchmark::from_array(&v))
        };
        let (plus, minus) = (at(values[k] + h), at(values[k] - h));
        let fd = [
            (plus.0 - minus.0) / (2.0 * h),
            (plus.1 - minus.1) / (2.0 * h),
        ];
        let got = [p.d_weave_speed.unwrap(), p.d_capsize_speed.unwrap()];
        for i in 0..2 {
            let err = (got[i] - fd[i]).abs();
            worst = worst.max(err / fd[i].abs().max(1e-3));
            assert!(
                err <= 1e-4 * fd[i].abs() + 1e-7,
                "{file} {} speed {i}: {} against {}",
                p.name,
                got[i],
                fd[i]
            );
        }
    }
    println!("{file}: worst relative difference {worst:.1e}");
    if !nominal.se.iter().any(|&se| se > 0.0) {
        assert!(s
            .parameters
            .iter()
            .all(|p| p.weave_variance_share.is_none()));
        return;
    }
    for share in [
        |p: &bikeproc::model::sensitivity::ParameterSensitivity| p.weave_variance_share,
        |p: &bikeproc::model::sensitivity::ParameterSensitivity| p.capsize_variance_share,
    ] {
        let total: f64 = s.parameters.iter().map(|p| share(p).unwrap()).sum();
        assert!((total - 1.0).abs() < 1e-12, "{file}: shares add to {total}");
    }
    let propagated = model.speeds(10.0, 0.01).unwrap();
    let pairs = [
        (
            s.weave_speed_mps.unwrap(),
            propagated.weave_speed_se_mps.unwrap(),
        ),
        (
            s.capsize_speed_mps.unwrap(),
            propagated.capsize_speed_se_mps.unwrap(),
        ),
    ];
    for (budget, se) in pairs {
        assert!(
            (budget.se - se).abs() < 1e-3 * se,
            "{file}: budget SE {} against {se}",
            budget.se
        );
    }
}

#[test]
fn the_benchmark_bicycles_derivatives_are_its_speeds_differences() {
    check("BenchmarkBenchmark.txt");
}

#[test]
fn a_real_bicycles_derivatives_are_its_speeds_differences() {
    check("RigidBenchmark.txt");
    check("BrowserBenchmark.txt");
}

/// The weave eigenvalue's derivatives at 5 m/s against central differences of the eigenvalue.
#[test]
fn the_weave_eigenvalues_derivatives_are_its_differences() {
    let model = bikeproc::read::bicycle::load(&reference("BenchmarkBenchmark.txt")).unwrap();
    let s = sensitivity(&model, &[5.0], 10.0).unwrap();
    let w = &s.weave_derivatives[0];
    // Meijaard et al. 2007, Table 2: −0.77534188219585 ± 4.46486771378823i at 5 m/s.
    assert!((w.re + 0.77534188219585).abs() < 1e-12 && (w.im - 4.46486771378823).abs() < 1e-12);
    let values = model.nominal().to_array();
    for k in 0..26 {
        let h = 1e-5 * values[k].abs().max(1e-2);
        let weave = |x: f64| {
            let mut v = values;
            v[k] = x;
            let ev = Parametrized::from_benchmark("b", &Benchmark::from_array(&v))
                .nominal_canonical()
                .eigenvalues(5.0)
                .unwrap();
            ev.into_iter()
                .filter(|z| z.im > 0.0)
                .min_by(|a, b| (a.re - w.re).abs().total_cmp(&(b.re - w.re).abs()))
                .unwrap()
        };
        let (plus, minus) = (weave(values[k] + h), weave(values[k] - h));
        let fd = (plus - minus) / (2.0 * h);
        for (got, want) in [(w.d_re[k], fd.re), (w.d_im[k], fd.im)] {
            assert!(
                (got - want).abs() <= 1e-5 * want.abs() + 1e-8,
                "{}: {got} against {want}",
                Benchmark::NAMES[k]
            );
        }
    }
}

/// With every length fixed the equations of motion scale time by √g (M q̈ + v C₁ q̇ + (g K₀ +
/// v² K₂) q = 0 is unchanged under t → t/√k, v → v√k, g → k g): so the weave and capsize
/// speeds are proportional to √g and their elasticity by g is exactly 1/2, on every bicycle.
#[test]
fn the_speeds_elasticity_by_gravity_is_one_half() {
    for file in [
        "BenchmarkBenchmark.txt",
        "RigidBenchmark.txt",
        "YellowBenchmark.txt",
    ] {
        let model = bikeproc::read::bicycle::load(&reference(file)).unwrap();
        let s = sensitivity(&model, &[], 10.0).unwrap();
        let g = s.parameters.iter().find(|p| p.name == "g").unwrap();
        for e in [g.weave_elasticity, g.capsize_elasticity] {
            let e = e.unwrap();
            assert!((e - 0.5).abs() < 1e-9, "{file}: {e}");
        }
    }
}

/// The lab bicycle's budget by measurement: the inputs' shares add up to 1, and the repeats
/// said to halve the weave speed's standard error do so when that measurement's standard
/// errors are divided by √n and the speed's error is propagated again (and n − 1 repeats do
/// not).
#[test]
fn the_lab_bicycles_budget_names_the_test_to_repeat() {
    use bikeproc::inertia::bike::LabBike;
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("data/lab_bike.toml");
    let model = bikeproc::read::bicycle::load(&path).unwrap();
    let s = sensitivity(&model, &[], 10.0).unwrap();
    let total: f64 = s
        .inputs
        .iter()
        .map(|i| i.weave_variance_share.unwrap())
        .sum();
    assert!((total - 1.0).abs() < 1e-12, "{total}");
    let top = &s.measurements[0];
    let n = top
        .repeats_to_halve_weave_se
        .expect("one measurement dominates");
    let body_name = top
        .measurement
        .strip_suffix(" inertia")
        .expect("an inertia");
    let se_with = |repeats: f64| {
        let mut bike = LabBike::load(&path).unwrap();
        let body = match body_name {
            "front_wheel" => &mut bike.front_wheel,
            "rear_wheel" => &mut bike.rear_wheel,
            "frame" => &mut bike.frame,
            _ => &mut bike.handlebar,
        };
        let k = repeats.sqrt();
        body.ixx_se_kgm2 /= k;
        body.iyy_se_kgm2 /= k;
        body.izz_se_kgm2 /= k;
        body.ixz_se_kgm2 /= k;
        Parametrized::from_lab("lab", &bike)
            .speeds(10.0, 0.01)
            .unwrap()
            .weave_speed_se_mps
            .unwrap()
    };
    let se0 = s.weave_speed_mps.unwrap().se;
    assert!((se_with(1.0) - se0).abs() < 1e-3 * se0);
    assert!(se_with(n as f64) <= 0.5 * se0 * (1.0 + 1e-3), "{n} repeats");
    assert!(
        se_with((n - 1) as f64) > 0.5 * se0,
        "{} repeats suffice",
        n - 1
    );
}
