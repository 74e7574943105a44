//! The simulator's own linearization, for the sealed truth of a ride: its nonlinear equations
//! (with whatever smooth effects they carry: steer viscous friction, compliant tyres, drag,
//! point masses) differentiated by central differences at the upright straight run, and the
//! eigenvalues of that Jacobian followed along the speed.
//!
//! Independent of the analysis's linear model (`crate::model`): only the eigenvalue routine of
//! a real matrix is shared, which is linear algebra, not bicycle physics.

use super::whipple::{self, Drive, LoadInput, Tyres, WhippleParams};
use nalgebra::{Complex, DMatrix};

/// Central-difference step for the state perturbations (rad, rad/s, m/s; N for tyre forces it
/// is scaled by 100).
const STEP: f64 = 1e-6;

/// The lateral Jacobian of the simulator's equations at speed `v` (m/s), upright and straight.
///
/// Rigid wheels (`tyres` = `None`): the state is (roll, steer, roll rate, steer rate), the
/// other rates following from the rolling constraints, and the actuator's torque after them
/// where `drive` has a lagged one ([`whipple::Actuator`]). Compliant tyres: (roll, steer,
/// lateral velocity, yaw rate, roll rate, steer rate, rear and front lateral force); `None`
/// with a lagged actuator, which the simulator does not run on tyres. The loads are evaluated
/// at time 0.
pub fn lateral_jacobian(
    p: &WhippleParams,
    tyres: Option<&Tyres>,
    drive: Drive<'_>,
    v: f64,
) -> Option<DMatrix<f64>> {
    match tyres {
        None => {
            let f = |x: &[f64]| -> Option<Vec<f64>> {
                let (q, qd) = whipple::upright_state(p, v, x[0], x[1], x[2], x[3])?;
                let input = LoadInput {
                    t: 0.0,
                    q: &q,
                    qd: &qd,
                    velocities: whipple::body_velocities(p, &q, &qd),
                    actuator_torque_nm: drive.actuator.map(|_| x[4]),
                };
                let loads = (drive.loads)(&input);
                let qdd = whipple::accelerations_loaded(p, &q, &qd, &loads, drive.motion)?;
                let mut out = vec![x[2], x[3], qdd[3], qdd[6]];
                if let Some(a) = drive.actuator {
                    out.push(((a.command)(&input) - x[4]) / a.lag_s);
                }
                Some(out)
            };
            let n = if drive.actuator.is_some() { 5 } else { 4 };
            central_differences(&f, &vec![1.0; n])
        }
        Some(_) if drive.actuator.is_some() => None,
        Some(tyres) => {
            let (q, qd) = whipple::upright_state(p, v, 0.0, 0.0, 0.0, 0.0)?;
            let base = whipple::tyre_state(&q, &qd);
            // Tyre-state indices of roll, steer; q̇₂ (the lateral velocity, with yaw at
            // zero), q̇₃, q̇₄, q̇₇; the two forces. Yaw and the lateral position are left out:
            // the run turned or shifted is the same run, and the lateral velocity is taken in
            // the heading's axes, u = q̇₂ cos q₃ − q̇₁ sin q₃, u̇ = q̈₂ − q̇₁ q̇₃ at q₃ = 0.
            const IDX: [usize; 8] = [3, 6, 9, 10, 11, 12, 13, 14];
            let f = |x: &[f64]| -> Option<Vec<f64>> {
                let mut y = base;
                for (k, &i) in IDX.iter().enumerate() {
                    y[i] += x[k];
                }
                let q: [f64; 8] = std::array::from_fn(|i| y[i]);
                y[4] = whipple::pitch_on_ground(p, &q, q[4])?;
                let d = whipple::tyre_derivative(p, tyres, 0.0, &y, drive)?;
                let mut out: Vec<f64> = IDX.iter().map(|&i| d[i]).collect();
                out[2] -= y[8] * y[10];
                Some(out)
            };
            let mut scale = [1.0; 8];
            scale[6] = 100.0;
            scale[7] = 100.0;
            central_differences(&f, &scale)
        }
    }
}

fn central_differences(
    f: &dyn Fn(&[f64]) -> Option<Vec<f64>>,
    scale: &[f64],
) -> Option<DMatrix<f64>> {
    let n = scale.len();
    let mut jac = DMatrix::zeros(n, n);
    for j in 0..n {
        let h = STEP * scale[j];
        let mut xp = vec![0.0; n];
        let mut xm = vec![0.0; n];
        xp[j] = h;
        xm[j] = -h;
        let (fp, fm) = (f(&xp)?, f(&xm)?);
        for i in 0..n {
            jac[(i, j)] = (fp[i] - fm[i]) / (2.0 * h);
        }
    }
    Some(jac)
}

/// The weave and capsize eigenvalues (1/s) at each of `speeds_mps`, followed by continuity:
/// at the highest speed the weave is the oscillatory eigenvalue of least modulus and capsize
/// the real one of least modulus; each lower speed takes the eigenvalue nearest the previous
/// one. Returned in the order of `speeds_mps` (which must be sorted ascending); `None` when a
/// Jacobian or its eigenvalues cannot be computed.
pub fn weave_and_capsize(
    p: &WhippleParams,
    tyres: Option<&Tyres>,
    drive: Drive<'_>,
    speeds_mps: &[f64],
) -> Option<Vec<(Complex<f64>, Complex<f64>)>> {
    let mut out = Vec::with_capacity(speeds_mps.len());
    let mut prev: Option<(Complex<f64>, Complex<f64>)> = None;
    for &v in speeds_mps.iter().rev() {
        let ev = crate::model::eigenvalues_dyn(&lateral_jacobian(p, tyres, drive, v)?)?;
        let nearest = |target: Complex<f64>, upper: bool| {
            ev.iter()
                .copied()
                .filter(|z| !upper || z.im >= 0.0)
                .min_by(|a, b| (a - target).norm().total_cmp(&(b - target).norm()))
        };
        let pair = match prev {
            None => {
                let weave = ev
                    .iter()
                    .copied()
                    .filter(|z| z.im > 1e-6)
                    .min_by(|a, b| a.norm().total_cmp(&b.norm()))?;
                let capsize = ev
                    .iter()
                    .copied()
                    .filter(|z| z.im.abs() <= 1e-9 * (1.0 + z.re.abs()))
                    .min_by(|a, b| a.norm().total_cmp(&b.norm()))?;
                (weave, capsize)
            }
            Some((w, c)) => (nearest(w, true)?, nearest(c, true)?),
        };
        out.push(pair);
        prev = Some(pair);
    }
    out.reverse();
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gap::linear::LinearBike;
    use crate::model::{Benchmark, Canonical};

    fn no_loads(_: &LoadInput<'_>) -> Vec<whipple::Load> {
        Vec::new()
    }

    const FREE: Drive<'static> = Drive {
        loads: &no_loads,
        motion: whipple::Motion::Free,
        actuator: None,
    };

    /// Rigid wheels and no loads: the Jacobian's eigenvalues are the benchmark's (Meijaard et
    /// al. 2007) to 1e-6, weave and capsize named as the model names them.
    #[test]
    fn rigid_weave_and_capsize_are_the_benchmark_ones() {
        let b = Benchmark::meijaard_2007();
        let p = WhippleParams::from_benchmark(&b);
        let speeds = [4.5, 5.0, 6.0, 7.0];
        let got = weave_and_capsize(&p, None, FREE, &speeds).unwrap();
        let want = Canonical::from_benchmark(&b).sweep(&speeds).unwrap();
        for (g, w) in got.iter().zip(&want.eigenvalues) {
            assert!((g.0 - w[0]).norm() < 1e-6, "{g:?} vs {w:?}");
            assert!((g.1 - w[2]).norm() < 1e-6, "{g:?} vs {w:?}");
        }
    }

    /// Very stiff tyres (cornering 2000 /rad, relaxation 1 mm) behave as rolling without slip:
    /// the weave is the rigid one within 1 %.
    #[test]
    fn stiff_tyres_give_the_rigid_weave() {
        let b = Benchmark::meijaard_2007();
        let p = WhippleParams::from_benchmark(&b);
        let tyres = Tyres {
            model: whipple::TyreModel {
                cornering_per_rad: 2000.0,
                camber_per_rad: 0.0,
                relaxation_length_m: 0.001,
            },
            normal_n: super::super::ride::static_normal_loads(&b),
        };
        let speeds = [5.0, 6.0];
        let rigid = weave_and_capsize(&p, None, FREE, &speeds).unwrap();
        let soft = weave_and_capsize(&p, Some(&tyres), FREE, &speeds).unwrap();
        for (r, s) in rigid.iter().zip(&soft) {
            assert!(
                (r.0 - s.0).norm() < 0.01 * r.0.norm(),
                "rigid {:?}, stiff tyres {:?}",
                r.0,
                s.0
            );
        }
    }

    /// A steer motor on a roll-rate law (T = 20 φ̇ N·m, at every speed) whose torque lags its
    /// command by 50 ms: the simulator's Jacobian with the torque as a fifth state
    /// ([`whipple::Actuator`]) has the analysis model's five eigenvalues
    /// ([`crate::gap::linear::LinearBike::actuator_lag_s`], written apart from it) to 1e-5 at
    /// 2–6 m/s, and the lag moves the weave (by more than 0.05 1/s) from the unlagged loop.
    #[test]
    fn a_lagged_motors_eigenvalues_are_the_analysis_models() {
        use crate::gap::linear::LinearBike;
        use crate::model::control::{ControllerSpec, SteerControl};
        let b = Benchmark::meijaard_2007();
        let p = WhippleParams::from_benchmark(&b);
        let gain = 20.0;
        let loads = |i: &LoadInput<'_>| vec![whipple::Load::Steer(i.actuator_torque_nm.unwrap())];
        let command = |i: &LoadInput<'_>| gain * i.qd[3];
        let drive = Drive {
            loads: &loads,
            motion: whipple::Motion::Free,
            actuator: Some(whipple::Actuator {
                lag_s: 0.05,
                command: &command,
            }),
        };
        let spec = ControllerSpec {
            description: String::new(),
            speeds_mps: vec![0.0],
            roll_nm_per_rad: None,
            steer_nm_per_rad: None,
            roll_rate_nms_per_rad: Some(vec![gain]),
            steer_rate_nms_per_rad: None,
        };
        let control = SteerControl::from_spec(&spec, std::path::Path::new("law.toml")).unwrap();
        let unlagged = LinearBike::whipple(&b).with_control(control);
        let lagged = LinearBike {
            actuator_lag_s: 0.05,
            ..unlagged
        };
        for v in [2.0, 3.0, 4.0, 6.0] {
            let sim = crate::model::eigenvalues_dyn(&lateral_jacobian(&p, None, drive, v).unwrap())
                .unwrap();
            let ours = lagged.eigenvalues(v).unwrap();
            assert_eq!((sim.len(), ours.len()), (5, 5));
            for z in &ours {
                let near = sim
                    .iter()
                    .map(|s| (s - z).norm())
                    .fold(f64::INFINITY, f64::min);
                assert!(
                    near < 1e-5 * (1.0 + z.norm()),
                    "{v} m/s: {z} not in {sim:?}"
                );
            }
            let w = unlagged.weave_near(v, Complex::new(0.0, 4.0)).unwrap();
            let wl = lagged.weave_near(v, w).unwrap();
            assert!((w - wl).norm() > 0.05, "{v} m/s: {w} vs {wl}");
        }
    }

    /// A bicycle braked by 10 N along its heading at the frame's centre of mass: the analysis
    /// model at the same deceleration ([`Canonical::with_accel`], its `v̇ K_a`) moves the weave
    /// as the simulator's own linearization of the braked bicycle does, but for the braking
    /// force's own terms, which it leaves out. Measured at 3–6 m/s: what K_a leaves of the
    /// shift is 0.31–0.32 of it on the benchmark bicycle (a = −0.102 m/s², σ's shift +0.007 to
    /// +0.015 1/s), 0.18–0.19 on the lab's (−0.635 m/s², ω's −0.07 to −0.16 1/s). Bound: 0.4.
    #[test]
    fn a_braked_bicycles_weave_moves_as_its_accel_stiffness_says() {
        let lab = crate::read::bicycle::load(std::path::Path::new(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/data/lab_bike.toml"
        )))
        .unwrap()
        .nominal();
        let force_n = 10.0;
        let brake = |input: &LoadInput<'_>| {
            let (s, c) = input.q[2].sin_cos();
            vec![whipple::Load::Force {
                body: whipple::Body::Frame,
                offset_body_m: [0.0; 3],
                force_n: [-force_n * c, -force_n * s, 0.0],
            }]
        };
        let braked = Drive {
            loads: &brake,
            motion: whipple::Motion::Free,
            actuator: None,
        };
        for (name, b) in [("benchmark", Benchmark::meijaard_2007()), ("lab", lab)] {
            let p = WhippleParams::from_benchmark(&b);
            // Upright and straight, the force slows the whole bicycle and spins its wheels down.
            let mass = b.m_r
                + b.m_b
                + b.m_h
                + b.m_f
                + b.i_ryy / (b.r_r * b.r_r)
                + b.i_fyy / (b.r_f * b.r_f);
            let accel = -force_n / mass;
            let speeds = [3.0, 4.0, 5.0, 6.0];
            let free = weave_and_capsize(&p, None, FREE, &speeds).unwrap();
            let slowing = weave_and_capsize(&p, None, braked, &speeds).unwrap();
            let model = LinearBike::whipple(&b);
            let slowing_model = LinearBike {
                canonical: model.canonical.with_accel(accel),
                ..model
            };
            for (k, &v) in speeds.iter().enumerate() {
                let (sim_free, sim_braked) = (free[k].0, slowing[k].0);
                let constant = model.weave_near(v, sim_free).unwrap();
                assert!((constant - sim_free).norm() < 1e-5);
                let with_ka = slowing_model.weave_near(v, sim_braked).unwrap();
                let left = (with_ka - sim_braked).norm() / (sim_braked - sim_free).norm();
                assert!(
                    left < 0.4,
                    "{name}, {v} m/s, {accel:.3} m/s²: simulator {sim_free:.4} → {sim_braked:.4}, \
                     with K_a {with_ka:.4}: {left:.2} of the shift left"
                );
            }
        }
    }
}
