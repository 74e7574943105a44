//! The linear model extended by the candidate effects that add terms or states rather than
//! change parameters: viscous steer damping, compliant tyres and a steer controller's lagging
//! actuator. In: a (possibly modified) parameter set and the extra terms. Out: the state
//! matrix and its eigenvalues at a speed.
//!
//! A lagging actuator ([`LinearBike::actuator_lag_s`] T > 0, with a controller): the torque on
//! the steer is a state τ of its own, `T τ̇ = k(v)·x − τ` (k the controller's gains times the
//! actuator's gain, [`crate::model::control`]), appended after the other states; without the
//! lag τ = k(v)·x at once, the closed loop of [`Canonical::state_matrix`].
//!
//! Rigid wheels: `M q̈ + (v C₁ + D) q̇ + (g K₀ + v² K₂) q = 0`, q = (φ, δ), `D = [[0, 0], [0, c]]`
//! (Meijaard et al. 2007, eq. 1, with a steering-head torque `−c δ̇`).
//!
//! Compliant tyres ([`LinearTyres`]): the lateral no-slip constraints give way to lateral
//! forces at the contacts, so the rear contact's lateral position y and the heading ψ join
//! roll and steer, `q = (y, ψ, φ, δ)`:
//!
//! ```text
//! M_q q̈ + (G_q + D) q̇ + g K_q q = J_rᵀ F_r + J_fᵀ F_f
//! (σ/v) Ḟ_i + F_i = N_i (C_α α_i + C_γ γ_i),   α_r = ψ − ẏ/v,
//! α_f = ψ + δ cos λ − (ẏ + w ψ̇ − c cos λ δ̇)/v,   γ_r = φ,   γ_f = φ + δ sin λ
//! ```
//!
//! built from the bodies: each centre of mass moves sideways by `y + x ψ − z φ` (+ `δ u` on the
//! front assembly, u its lever about the steer axis, Meijaard et al. eq. A 16), each body turns
//! by `(φ, 0, ψ)` (+ `δ (sin λ, 0, cos λ)` in front); `M_q = Σ m JₜᵀJₜ + J_ωᵀ I J_ω`, the wheels'
//! spin momentum `H = −I_yy v/r ŷ` gives `G_q = −Σ J_ωᵀ [H]ₓ J_ω`, and gravity acts on (φ, δ)
//! only, through the Whipple model's `K₀` (the potential's Hessian with the front wheel on the
//! ground). The contacts move sideways by `J_r q = y` and `J_f q = y + w ψ − c cos λ δ` (Pacejka,
//! Tire and Vehicle Dynamics, ch. 1 and 11, for the force lag). In the limit of stiff tyres and
//! no lag it is the Whipple model (tested).

use crate::model::{Benchmark, Canonical};
use nalgebra::{Complex, DMatrix, DVector, Matrix3, Matrix4, Vector3};

/// Linear tyres: lateral force per unit normal load per radian of slip and of camber, and the
/// force's lag.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LinearTyres {
    pub cornering_per_rad: f64,
    pub camber_per_rad: f64,
    pub relaxation_length_m: f64,
}

/// The Whipple model with the extra terms.
#[derive(Debug, Clone, Copy)]
pub struct LinearBike {
    /// The parameters (for the compliant tyres' full lateral equations).
    pub bike: Benchmark,
    pub canonical: Canonical,
    /// Viscous steer damping c (N·m·s/rad).
    pub steer_damping_nms_per_rad: f64,
    pub tyres: Option<LinearTyres>,
    /// The time constant T (s) of a first-order lag between the controller's command and the
    /// torque on the steer; 0 for none (or no controller).
    pub actuator_lag_s: f64,
}

impl LinearBike {
    /// The Whipple model of `bike` with nothing added.
    pub fn whipple(bike: &Benchmark) -> LinearBike {
        LinearBike {
            bike: *bike,
            canonical: Canonical::from_benchmark(bike),
            steer_damping_nms_per_rad: 0.0,
            tyres: None,
            actuator_lag_s: 0.0,
        }
    }

    /// The same bicycle with a steer controller closing the loop ([`crate::model::control`]).
    pub fn with_control(mut self, control: crate::model::SteerControl) -> LinearBike {
        self.canonical.control = control;
        self
    }

    /// The state matrix at speed `v` (m/s): of `(φ, δ, φ̇, δ̇)` with rigid wheels, of
    /// `(ψ, φ, δ, ẏ, ψ̇, φ̇, δ̇, F_r, F_f)` with tyres (y itself is neutral and left out),
    /// and the actuator's torque τ last where it lags ([`LinearBike::lags`]). `None` when a
    /// mass matrix is singular or v is not positive with tyres.
    pub fn state_matrix(&self, v: f64) -> Option<DMatrix<f64>> {
        if self.lags() {
            return self.lagged_state_matrix(v);
        }
        match self.tyres {
            None => Some(DMatrix::from_column_slice(
                4,
                4,
                self.rigid_state_matrix(v)?.as_slice(),
            )),
            Some(t) => self.tyre_state_matrix(v, &t),
        }
    }

    /// Whether the controller's torque lags its command: a positive lag and a controller.
    pub fn lags(&self) -> bool {
        self.actuator_lag_s > 0.0 && !self.canonical.control.is_none()
    }

    /// The state matrix with the actuator's torque τ as a last state (`T τ̇ = k(v)·x − τ`):
    /// the uncontrolled bicycle's matrix, τ's column the rates a unit steer torque gives
    /// ([`LinearBike::steer_torque_column`]), τ's row the gains over T on the angle states.
    fn lagged_state_matrix(&self, v: f64) -> Option<DMatrix<f64>> {
        let gains = self.canonical.control.gains_at(v);
        let free = LinearBike {
            canonical: Canonical {
                control: crate::model::SteerControl::NONE,
                ..self.canonical
            },
            actuator_lag_s: 0.0,
            ..*self
        };
        let a = free.state_matrix(v)?;
        let n = a.nrows();
        let torque = self.steer_torque_column(v, n)?;
        let states = self.angle_states();
        let mut out = DMatrix::<f64>::zeros(n + 1, n + 1);
        out.view_mut((0, 0), (n, n)).copy_from(&a);
        for r in 0..n {
            out[(r, n)] = torque[r];
        }
        for (k, s) in gains.iter().zip(states) {
            out[(n, s)] = k / self.actuator_lag_s;
        }
        out[(n, n)] = -1.0 / self.actuator_lag_s;
        Some(out)
    }

    /// The state's rates per N·m of steer torque (the column `M⁻¹ (0, …, 1)ᵀ` in the rates'
    /// rows) for a state of `n` (rigid 4, tyres 9).
    fn steer_torque_column(&self, v: f64, n: usize) -> Option<DVector<f64>> {
        let mut col = DVector::<f64>::zeros(n);
        match self.tyres {
            None => {
                let minv = self.canonical.m.try_inverse()?;
                col[2] = minv[(0, 1)];
                col[3] = minv[(1, 1)];
            }
            Some(_) => {
                let minv = self.tyre_mass_and_gyro(v).0.try_inverse()?;
                for (row, s) in [3, 4, 5, 6].into_iter().enumerate() {
                    col[s] = minv[(row, 3)];
                }
            }
        }
        Some(col)
    }

    /// The Whipple model's state matrix (with its controller, if any) and the damper's −M⁻¹ D
    /// in the steer-rate column.
    fn rigid_state_matrix(&self, v: f64) -> Option<Matrix4<f64>> {
        let c = &self.canonical;
        let mut a = c.state_matrix(v)?;
        let minv = c.m.try_inverse()?;
        for r in 0..2 {
            a[(2 + r, 3)] -= minv[(r, 1)] * self.steer_damping_nms_per_rad;
        }
        Some(a)
    }

    /// The compliant-tyre model's mass matrix `M_q` and the wheels' gyroscopic `G_q` at speed
    /// `v`, of `q = (y, ψ, φ, δ)` (the module's doc), without damping.
    fn tyre_mass_and_gyro(&self, v: f64) -> (DMatrix<f64>, DMatrix<f64>) {
        let p = &self.bike;
        let (sl, cl) = p.lambda.sin_cos();
        // Bodies: mass, centre of mass (x, z), inertia (xx, yy, zz, xz), front assembly?
        let bodies = [
            (p.m_r, 0.0, -p.r_r, [p.i_rxx, p.i_ryy, p.i_rxx, 0.0], false),
            (
                p.m_b,
                p.x_b,
                p.z_b,
                [p.i_bxx, p.i_byy, p.i_bzz, p.i_bxz],
                false,
            ),
            (
                p.m_h,
                p.x_h,
                p.z_h,
                [p.i_hxx, p.i_hyy, p.i_hzz, p.i_hxz],
                true,
            ),
            (p.m_f, p.w, -p.r_f, [p.i_fxx, p.i_fyy, p.i_fxx, 0.0], true),
        ];
        let mut m = DMatrix::<f64>::zeros(4, 4);
        let mut g = DMatrix::<f64>::zeros(4, 4);
        for (k, &(mass, x, z, i, front)) in bodies.iter().enumerate() {
            // Lateral displacement of the centre of mass per (y, ψ, φ, δ).
            let u = if front {
                (x - p.w - p.c) * cl - z * sl
            } else {
                0.0
            };
            let jt = [1.0, x, -z, u];
            // Rotation (about x, y, z) per (y, ψ, φ, δ).
            let mut jw = DMatrix::<f64>::zeros(3, 4);
            jw[(0, 2)] = 1.0;
            jw[(2, 1)] = 1.0;
            if front {
                jw[(0, 3)] = sl;
                jw[(2, 3)] = cl;
            }
            let inertia = Matrix3::new(i[0], 0.0, i[3], 0.0, i[1], 0.0, i[3], 0.0, i[2]);
            let inertia = DMatrix::from_column_slice(3, 3, inertia.as_slice());
            for a in 0..4 {
                for b in 0..4 {
                    m[(a, b)] += mass * jt[a] * jt[b];
                }
            }
            m += jw.transpose() * &inertia * &jw;
            // The wheels' spin: H = −I_yy v/r ŷ; Ω × H = −[H]ₓ Ω.
            if k == 0 || k == 3 {
                let r = if k == 0 { p.r_r } else { p.r_f };
                let h = Vector3::new(0.0, -i[1] * v / r, 0.0);
                let hx = h.cross_matrix();
                let hx = DMatrix::from_column_slice(3, 3, hx.as_slice());
                g -= jw.transpose() * hx * &jw;
            }
        }
        (m, g)
    }

    fn tyre_state_matrix(&self, v: f64, t: &LinearTyres) -> Option<DMatrix<f64>> {
        if v <= 0.0 || t.relaxation_length_m <= 0.0 {
            return None;
        }
        let p = &self.bike;
        let (sl, cl) = p.lambda.sin_cos();
        let (m, mut g) = self.tyre_mass_and_gyro(v);
        g[(3, 3)] += self.steer_damping_nms_per_rad;
        let mut k = DMatrix::<f64>::zeros(4, 4);
        let k0 = self.canonical.k0 * self.canonical.g;
        for a in 0..2 {
            for b in 0..2 {
                k[(2 + a, 2 + b)] = k0[(a, b)];
            }
        }
        // Static normal loads.
        let m_t = p.m_r + p.m_b + p.m_h + p.m_f;
        let x_t = (p.x_b * p.m_b + p.x_h * p.m_h + p.w * p.m_f) / m_t;
        let n_f = m_t * p.g * x_t / p.w;
        let n_r = m_t * p.g - n_f;
        let jr = [1.0, 0.0, 0.0, 0.0];
        let jf = [1.0, p.w, 0.0, -p.c * cl];
        let minv = m.try_inverse()?;
        // State: (ψ, φ, δ, ẏ, ψ̇, φ̇, δ̇, F_r, F_f); q index 1..4 ↔ state 0..3, q̇ ↔ 3..7.
        let mut a = DMatrix::<f64>::zeros(9, 9);
        // ψ̇, φ̇, δ̇ are states 4, 5, 6.
        a[(0, 4)] = 1.0;
        a[(1, 5)] = 1.0;
        a[(2, 6)] = 1.0;
        // q̈ = M⁻¹(−G q̇ − K q + J_rᵀ F_r + J_fᵀ F_f), rows ẏ..δ̇ are states 3..6.
        let q_state = [None, Some(0), Some(1), Some(2)];
        let qd_state = [3, 4, 5, 6];
        for row in 0..4 {
            for col in 0..4 {
                let mut kq = 0.0;
                let mut gq = 0.0;
                for j in 0..4 {
                    kq += minv[(row, j)] * k[(j, col)];
                    gq += minv[(row, j)] * g[(j, col)];
                }
                if let Some(sc) = q_state[col] {
                    a[(qd_state[row], sc)] -= kq;
                }
                a[(qd_state[row], qd_state[col])] -= gq;
            }
            let (mut fr, mut ff) = (0.0, 0.0);
            for j in 0..4 {
                fr += minv[(row, j)] * jr[j];
                ff += minv[(row, j)] * jf[j];
            }
            a[(qd_state[row], 7)] = fr;
            a[(qd_state[row], 8)] = ff;
            // A controller's steer torque k·(φ, δ, φ̇, δ̇) acts on δ (q index 3).
            let control = &self.canonical.control;
            if !control.is_none() {
                for (k, s) in control.gains_at(v).iter().zip([1, 2, 5, 6]) {
                    a[(qd_state[row], s)] += minv[(row, 3)] * k;
                }
            }
        }
        // Force lag: Ḟ = (v/σ)(N (C_α α + C_γ γ) − F).
        let rate = v / t.relaxation_length_m;
        // α_r = ψ − ẏ/v; γ_r = φ.
        let (ca, cg) = (t.cornering_per_rad, t.camber_per_rad);
        a[(7, 0)] += rate * n_r * ca;
        a[(7, 3)] += -rate * n_r * ca / v;
        a[(7, 1)] += rate * n_r * cg;
        a[(7, 7)] = -rate;
        // α_f = ψ + δ cos λ − (ẏ + w ψ̇ − c cos λ δ̇)/v; γ_f = φ + δ sin λ.
        a[(8, 0)] += rate * n_f * ca;
        a[(8, 2)] += rate * n_f * (ca * cl + cg * sl);
        a[(8, 3)] += -rate * n_f * ca / v;
        a[(8, 4)] += -rate * n_f * ca * p.w / v;
        a[(8, 6)] += rate * n_f * ca * p.c * cl / v;
        a[(8, 1)] += rate * n_f * cg;
        a[(8, 8)] = -rate;
        Some(a)
    }

    /// The mode's γ/θ (steer over roll, complex) at eigenvalue `lambda` and speed `v` (from
    /// [`LinearBike::mode_vector`]). `None` when the matrix or the iteration fails.
    pub fn mode_shape(&self, v: f64, lambda: Complex<f64>) -> Option<Complex<f64>> {
        let x = self.mode_vector(v, lambda)?;
        let [roll, steer, ..] = self.angle_states();
        let ratio = x[steer] / x[roll];
        ratio.is_finite().then_some(ratio)
    }

    /// The right eigenvector of the state matrix at eigenvalue `lambda` and speed `v`, by
    /// inverse iteration ([`crate::model::eigenvector_near`]), scaled so that its largest
    /// component is 1. `None` when the matrix or the iteration fails.
    pub fn mode_vector(&self, v: f64, lambda: Complex<f64>) -> Option<DVector<Complex<f64>>> {
        crate::model::eigenvector_near(&self.state_matrix(v)?, lambda)
    }

    /// Roll, steer and their rates: states 0–3 with rigid wheels; 1, 2, 5, 6 with tyres (ψ
    /// first, [`LinearBike::state_matrix`]).
    pub fn angle_states(&self) -> [usize; 4] {
        if self.tyres.is_some() {
            [1, 2, 5, 6]
        } else {
            [0, 1, 2, 3]
        }
    }

    /// Every eigenvalue of the state matrix at speed `v` (a rigid bicycle's without a lag
    /// through the fixed 4×4 decomposition, [`crate::model::eigenvalues_of`]).
    pub fn eigenvalues(&self, v: f64) -> Option<Vec<Complex<f64>>> {
        self.modes(v).map(|m| m.eigenvalues)
    }

    /// The oscillatory eigenvalue (im > 0) nearest `guess` at speed `v`; `None` when there is
    /// none or the eigenvalues cannot be computed.
    pub fn weave_near(&self, v: f64, guess: Complex<f64>) -> Option<Complex<f64>> {
        nearest_oscillatory(self.eigenvalues(v)?, guess)
    }

    /// [`LinearBike::weave_near`] and, with `shape`, that mode's γ/θ
    /// ([`LinearBike::mode_shape`]), the state matrix made once (a rigid bicycle's the fixed
    /// 4×4: the same numbers, a fifth of the gap stage's predictions' time).
    pub fn weave_and_shape(
        &self,
        v: f64,
        guess: Complex<f64>,
        shape: bool,
    ) -> Option<(Complex<f64>, Option<Complex<f64>>)> {
        self.modes(v)?.weave_and_shape(guess, shape)
    }

    /// The state matrix at speed `v` and its eigenvalues: what every ride at that speed
    /// shares, whatever branch it follows ([`Modes::weave_and_shape`]). `None` when the
    /// matrix or its eigenvalues cannot be computed.
    pub fn modes(&self, v: f64) -> Option<Modes> {
        match self.tyres {
            None if !self.lags() => {
                let a = self.rigid_state_matrix(v)?;
                let eigenvalues = crate::model::eigenvalues_of(&a)?.to_vec();
                Some(Modes {
                    matrix: StateMatrix::Rigid(a),
                    eigenvalues,
                    angles: [0, 1],
                })
            }
            _ => {
                let a = self.state_matrix(v)?;
                let eigenvalues = crate::model::eigenvalues_dyn(&a)?;
                let [roll, steer, ..] = self.angle_states();
                Some(Modes {
                    matrix: StateMatrix::General(a),
                    eigenvalues,
                    angles: [roll, steer],
                })
            }
        }
    }
}

/// A bicycle's state matrix at one speed with its eigenvalues ([`LinearBike::modes`]).
#[derive(Debug, Clone)]
pub struct Modes {
    matrix: StateMatrix,
    eigenvalues: Vec<Complex<f64>>,
    /// The roll and steer states.
    angles: [usize; 2],
}

/// A rigid bicycle's fixed 4×4 state matrix, or any other's.
#[derive(Debug, Clone)]
enum StateMatrix {
    Rigid(Matrix4<f64>),
    General(DMatrix<f64>),
}

impl Modes {
    /// The oscillatory eigenvalue nearest `guess` and, with `shape`, its mode's γ/θ (the
    /// eigenvector's steer over its roll, by inverse iteration,
    /// [`crate::model::eigenvector_near`]); `None` without such an eigenvalue, and no γ/θ
    /// where the iteration fails or the ratio is not finite.
    pub fn weave_and_shape(
        &self,
        guess: Complex<f64>,
        shape: bool,
    ) -> Option<(Complex<f64>, Option<Complex<f64>>)> {
        use crate::model::eigenvector_near;
        let w = nearest_oscillatory(self.eigenvalues.iter().copied(), guess)?;
        if !shape {
            return Some((w, None));
        }
        let [roll, steer] = self.angles;
        let angles = match &self.matrix {
            StateMatrix::Rigid(a) => eigenvector_near(a, w).map(|x| [x[roll], x[steer]]),
            StateMatrix::General(a) => eigenvector_near(a, w).map(|x| [x[roll], x[steer]]),
        };
        let [roll, steer] = angles?;
        let ratio = steer / roll;
        ratio.is_finite().then_some((w, Some(ratio)))
    }
}

/// The oscillatory eigenvalue (im > 0) of `eigenvalues` nearest `guess`.
fn nearest_oscillatory(
    eigenvalues: impl IntoIterator<Item = Complex<f64>>,
    guess: Complex<f64>,
) -> Option<Complex<f64>> {
    eigenvalues
        .into_iter()
        .filter(|z| z.im > 1e-9)
        .min_by(|a, b| (a - guess).norm().total_cmp(&(b - guess).norm()))
}

impl crate::model::weave::LinearWeave for LinearBike {
    /// Rigid wheels: the Whipple model's `v̇ K_a` ([`Canonical::ka`]). With compliant tyres the
    /// state matrix stays the constant-speed one (their v̇ terms are not derived here); a
    /// replay ([`crate::ride::dynamic::replay_coasting`]) still runs it at the changing speed.
    fn accelerating(&self, accel_mps2: f64) -> Self {
        LinearBike {
            canonical: self.canonical.with_accel(accel_mps2),
            ..*self
        }
    }

    fn state_matrix_at(&self, v: f64) -> Option<DMatrix<f64>> {
        self.state_matrix(v)
    }

    fn weave_mode(
        &self,
        v: f64,
        toward: Complex<f64>,
    ) -> Option<(Complex<f64>, DVector<Complex<f64>>)> {
        let w = self.weave_near(v, toward)?;
        Some((w, self.mode_vector(v, w)?))
    }

    fn angle_states(&self) -> [usize; 4] {
        LinearBike::angle_states(self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn benchmark() -> Benchmark {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../shared/reference/bicycleparameters/BenchmarkBenchmark.txt");
        Benchmark::load(&path).unwrap()
    }

    /// A coasting ride replayed on the rigid extended model and on the Whipple model it is
    /// built from (`ride::dynamic::replay_coasting`, two eigenvector codes, two state-matrix
    /// types) gives one bias: the gap stage's "no effect" is the ride stage's.
    #[test]
    fn the_coasting_replay_is_the_ride_stages() {
        use crate::ride::dynamic::{replay_coasting, CoastingWindow, ReplayStart};
        let b = benchmark();
        let window = CoastingWindow {
            start_s: 7.0,
            end_s: 9.5,
            t_ref_s: 8.1,
            rate_hz: 100.0,
            structure: crate::ride::modal::Structure {
                real_modes: 1,
                drift: false,
                trend: false,
                curve_terms: 0,
            },
            estimator: crate::ride::modal::Estimator::Capped,
            speed_mps: 4.5,
            accel_mps2: -0.15,
            measured: Complex::new(-0.4, 4.8),
            weave_start: Complex::new(0.02, -0.01),
            real_start: [0.004, -0.002, -0.02, 0.01],
            real_rates: [-8.0, 0.0],
        };
        for from in [ReplayStart::Weave, ReplayStart::Fitted] {
            let rigid = replay_coasting(&LinearBike::whipple(&b), &window, from).unwrap();
            let whipple = replay_coasting(&Canonical::from_benchmark(&b), &window, from).unwrap();
            assert!(rigid[1].abs() > 1e-4, "{rigid:?}");
            for (x, y) in rigid.iter().zip(&whipple) {
                assert!((x - y).abs() < 1e-9, "{from:?}: {rigid:?} {whipple:?}");
            }
        }
    }

    /// Without damping the extended model is the benchmark's: Meijaard et al. 2007, Table 2,
    /// weave at 5 m/s −0.77534188219585 ± 4.46486771378823 i.
    #[test]
    fn without_damping_it_is_the_benchmark() {
        let bike = LinearBike::whipple(&benchmark());
        let w = bike.weave_near(5.0, Complex::new(-0.7, 4.5)).unwrap();
        assert!((w.re + 0.77534188219585).abs() < 1e-10, "{w}");
        assert!((w.im - 4.46486771378823).abs() < 1e-10, "{w}");
    }

    /// Damping enters as a steer-rate torque: the characteristic polynomial's s³ coefficient
    /// (the trace of the state matrix, minus) grows by c (M⁻¹)₂₂.
    #[test]
    fn damping_adds_to_the_trace() {
        let free = LinearBike::whipple(&benchmark());
        let damped = LinearBike {
            steer_damping_nms_per_rad: 0.4,
            ..free
        };
        let minv = free.canonical.m.try_inverse().unwrap();
        let dt =
            free.state_matrix(3.0).unwrap().trace() - damped.state_matrix(3.0).unwrap().trace();
        assert!((dt - 0.4 * minv[(1, 1)]).abs() < 1e-12);
    }

    /// The mode shape of the extended model is the Whipple model's (`Canonical::mode_shape`,
    /// fixed-size code) without extensions, and stays close with stiff tyres.
    #[test]
    fn mode_shape_matches_the_canonical_models() {
        let rigid = LinearBike::whipple(&benchmark());
        let w = rigid.weave_near(5.0, Complex::new(-0.7, 4.5)).unwrap();
        let ours = rigid.mode_shape(5.0, w).unwrap();
        let shape = rigid.canonical.mode_shape(5.0, w).unwrap();
        let theirs = shape[1] / shape[0];
        assert!(
            (ours - theirs).norm() < 1e-8 * theirs.norm(),
            "{ours} vs {theirs}"
        );
        let stiff = LinearBike {
            tyres: Some(LinearTyres {
                cornering_per_rad: 1e5,
                camber_per_rad: 0.0,
                relaxation_length_m: 1e-4,
            }),
            ..rigid
        };
        let ws = stiff.weave_near(5.0, w).unwrap();
        let s = stiff.mode_shape(5.0, ws).unwrap();
        assert!(
            (s - theirs).norm() < 1e-3 * theirs.norm(),
            "{s} vs {theirs}"
        );
    }

    /// A lag of 1 µs between the controller's command and its torque is no lag: rigid and
    /// on tyres, the lagged model's weave and mode shape are the unlagged loop's within 1e-4
    /// (the lag's own eigenvalue at −10⁶ 1/s), the torque's column built for each.
    #[test]
    fn a_vanishing_lag_is_the_closed_loop() {
        use crate::model::control::{ControllerSpec, SteerControl};
        let spec = ControllerSpec {
            description: String::new(),
            speeds_mps: vec![0.0, 6.0],
            roll_nm_per_rad: Some(vec![5.0, 0.0]),
            steer_nm_per_rad: None,
            roll_rate_nms_per_rad: Some(vec![15.0, 3.0]),
            steer_rate_nms_per_rad: Some(vec![-1.0, 0.0]),
        };
        let control = SteerControl::from_spec(&spec, std::path::Path::new("law.toml")).unwrap();
        let rigid = LinearBike::whipple(&benchmark()).with_control(control);
        let tyred = LinearBike {
            tyres: Some(LinearTyres {
                cornering_per_rad: 12.0,
                camber_per_rad: 0.7,
                relaxation_length_m: 0.05,
            }),
            ..rigid
        };
        for bike in [rigid, tyred] {
            let lagged = LinearBike {
                actuator_lag_s: 1e-6,
                ..bike
            };
            assert!(lagged.lags() && !bike.lags());
            for v in [2.5, 4.0] {
                let (w, s) = bike
                    .weave_and_shape(v, Complex::new(-1.0, 4.0), true)
                    .unwrap();
                let (wl, sl) = lagged.weave_and_shape(v, w, true).unwrap();
                let (s, sl) = (s.unwrap(), sl.unwrap());
                assert!((w - wl).norm() < 1e-4 * w.norm(), "{v}: {w} vs {wl}");
                assert!((s - sl).norm() < 1e-4 * s.norm(), "{v}: {s} vs {sl}");
            }
        }
    }

    /// Stiff tyres without lag are rolling without slip: the weave of the 9-state model is the
    /// benchmark's (Table 2) at 3, 5 and 8 m/s, to 1e-3 with C_α = 1e5 /rad, σ = 1e-4 m.
    #[test]
    fn stiff_tyres_are_the_whipple_model() {
        let rigid = LinearBike::whipple(&benchmark());
        let stiff = LinearBike {
            tyres: Some(LinearTyres {
                cornering_per_rad: 1e5,
                camber_per_rad: 0.0,
                relaxation_length_m: 1e-4,
            }),
            ..rigid
        };
        for v in [3.0, 5.0, 8.0] {
            let a = rigid.weave_near(v, Complex::new(-0.5, 4.0)).unwrap();
            let b = stiff.weave_near(v, a).unwrap();
            assert!((a - b).norm() < 1e-3 * a.norm(), "{v}: {a} vs {b}");
        }
    }

    /// One speed's eigenproblem serves every ride at that speed, whatever branch each follows:
    /// on tyres (several oscillatory modes) each guess gets from one [`Modes`] the eigenvalue
    /// nearest it and that mode's γ/θ, bit for bit those of [`LinearBike::weave_near`] and
    /// [`LinearBike::mode_shape`], which solve it again each.
    #[test]
    fn one_speeds_modes_serve_every_branch() {
        let tyred = LinearBike {
            tyres: Some(LinearTyres {
                cornering_per_rad: 12.0,
                camber_per_rad: 0.7,
                relaxation_length_m: 0.05,
            }),
            ..LinearBike::whipple(&benchmark())
        };
        let v = 4.0;
        let oscillatory: Vec<Complex<f64>> = tyred
            .eigenvalues(v)
            .unwrap()
            .into_iter()
            .filter(|z| z.im > 1e-9)
            .collect();
        assert!(oscillatory.len() >= 2, "{oscillatory:?}");
        let modes = tyred.modes(v).unwrap();
        for &z in &oscillatory {
            let guess = z + Complex::new(1e-3, -1e-3);
            let (w, s) = modes.weave_and_shape(guess, true).unwrap();
            assert_eq!(w, z);
            assert_eq!(w, tyred.weave_near(v, guess).unwrap());
            assert_eq!(s.unwrap(), tyred.mode_shape(v, w).unwrap());
        }
    }
}
