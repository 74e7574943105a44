//! Model stage: bicycle parameters → the linearized Whipple model, its eigenvalues against
//! speed, the weave and capsize speeds and the stable range.
//!
//! In: a [`Benchmark`] parameter set (the 25 parameters of Meijaard, Papadopoulos, Ruina &
//! Schwab 2007, Proc. R. Soc. A 463:1955–1982, plus g), read from BicycleParameters' text
//! format, TOML, or the lab's parametrization ([`lab`]). Out: the canonical matrices
//! `M q̈ + v C₁ q̇ + (g K₀ + v² K₂) q = f`, `q = (φ roll, δ steer)` (their Appendix A), the state
//! matrix, eigenvalues named by mode (weave, capsize, castor), the characteristic speeds, and
//! their standard errors propagated from the parameters'. [`nonlinear`]: the same bicycle's
//! equations without linearization, for the ride stage's replay of a hard kick.

pub mod compare;
pub mod control;
pub mod design;
pub mod eigen;
pub mod lab;
pub mod nonlinear;
pub mod params;
pub mod report;
pub mod sensitivity;
pub mod uncertain;
pub mod weave;

use crate::jet::Scalar;
pub use control::SteerControl;
use nalgebra::{Complex, Matrix2, Matrix4};
pub use params::{trail_keeping_offset, Benchmark, BenchmarkOf, ParamError, Rider, RigidBody};

/// The canonical matrices of the linearized Whipple bicycle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Canonical {
    pub m: Matrix2<f64>,
    pub c1: Matrix2<f64>,
    pub k0: Matrix2<f64>,
    pub k2: Matrix2<f64>,
    /// The stiffness per unit forward acceleration (kg·m): a bicycle whose speed changes at v̇
    /// has `v̇ K_a q` beside `g K₀ q`. Meijaard et al. (2007) linearize at constant speed; their
    /// derivation (App. A) takes the yaw acceleration as `ψ̈ = (v δ̇ + c δ̈) cos λ / w` and the
    /// front wheel's spin momentum as `−I_fyy v / r_f` along its steered axle, whose time
    /// derivatives gain `v̇ δ cos λ / w` and `v̇ δ` terms when v changes:
    /// `K_a,φδ = (S_F + I_Txz / w) cos λ = C₁,φδ − c K₂,φδ`,
    /// `K_a,δδ = (I_Aλz + μ I_Tzz) cos λ / w = C₁,δδ + c K₀,δδ / (w tan λ)`, and zero in the roll
    /// column (C₁'s other parts are ω × H and the centripetal `v ψ̇`, with no derivative of v).
    /// These are the bicycle's own inertial terms, whatever slows it. The forces that slow it
    /// add terms of their own, which depend on how they act and are not modelled here: braked
    /// by 10 N along its heading at the frame's centre of mass, the simulator's linearization
    /// (`sim::linearize`) moves the weave by what K_a gives within 0.18–0.32 of the shift (the
    /// lab's and the benchmark bicycle, 3–6 m/s); on its coasting rides (rolling resistance at
    /// the hubs, drag at the frame, each along its point's velocity) K_a's ω shift is 1.65 times
    /// the simulator's, where the mode shape's change fits the rides (the ride stage's coasting
    /// correction, [`crate::ride::dynamic`], takes that part alone).
    pub ka: Matrix2<f64>,
    pub g: f64,
    /// The forward acceleration (m/s²) the state matrix is taken at ([`Canonical::with_accel`]);
    /// zero: the benchmark's constant speed.
    pub accel_mps2: f64,
    /// A steer controller closing the loop ([`control`]; [`SteerControl::NONE`] for the
    /// Whipple model itself).
    pub control: SteerControl,
}

/// `I/r` with the two-mass-skate limit: zero inertia on a zero radius is zero (Kooijman et
/// al. 2011), not 0/0.
fn spin_over_radius<T: Scalar>(inertia: T, radius: T) -> T {
    if inertia.value() == 0.0 && radius.value() == 0.0 {
        T::c(0.0)
    } else {
        inertia / radius
    }
}

/// `x²`.
fn sq<T: Scalar>(x: T) -> T {
    x * x
}

/// The canonical matrices' entries in any arithmetic: M, C₁, K₀, K₂ and K_a row by row, and g.
#[derive(Debug, Clone, Copy)]
pub struct CanonicalTerms<T> {
    pub m: [T; 4],
    pub c1: [T; 4],
    pub k0: [T; 4],
    pub k2: [T; 4],
    /// The stiffness per unit forward acceleration ([`Canonical::ka`]).
    pub ka: [T; 4],
    pub g: T,
}

/// Meijaard et al. 2007, Appendix A, equations (A 1)–(A 27), term by term, in any arithmetic
/// ([`Scalar`]): with `f64` the model ([`Canonical::from_benchmark`]), with jets its exact
/// derivatives by a parameter ([`crate::jet`]).
pub fn canonical_terms<T: Scalar>(p: &BenchmarkOf<T>) -> CanonicalTerms<T> {
    let n = |x: f64| T::c(x);
    let (sl, cl) = (p.lambda.sin(), p.lambda.cos());
    // (A 1)–(A 6): the whole bicycle's mass, centre of mass and inertia (rear contact, z down).
    let m_t = p.m_r + p.m_b + p.m_h + p.m_f;
    let x_t = (p.x_b * p.m_b + p.x_h * p.m_h + p.w * p.m_f) / m_t;
    let z_t = (-p.r_r * p.m_r + p.z_b * p.m_b + p.z_h * p.m_h - p.r_f * p.m_f) / m_t;
    let i_txx = p.i_rxx
        + p.i_bxx
        + p.i_hxx
        + p.i_fxx
        + p.m_r * p.r_r * p.r_r
        + p.m_b * p.z_b * p.z_b
        + p.m_h * p.z_h * p.z_h
        + p.m_f * p.r_f * p.r_f;
    let i_txz =
        p.i_bxz + p.i_hxz - p.m_b * p.x_b * p.z_b - p.m_h * p.x_h * p.z_h + p.m_f * p.w * p.r_f;
    // (A 7): wheels are symmetric, I_zz = I_xx.
    let (i_rzz, i_fzz) = (p.i_rxx, p.i_fxx);
    let i_tzz = i_rzz
        + p.i_bzz
        + p.i_hzz
        + i_fzz
        + p.m_b * p.x_b * p.x_b
        + p.m_h * p.x_h * p.x_h
        + p.m_f * p.w * p.w;
    // (A 9)–(A 15): the front assembly A = handlebar and fork + front wheel.
    let m_a = p.m_h + p.m_f;
    let x_a = (p.x_h * p.m_h + p.w * p.m_f) / m_a;
    let z_a = (p.z_h * p.m_h - p.r_f * p.m_f) / m_a;
    let i_axx = p.i_hxx + p.i_fxx + p.m_h * sq(p.z_h - z_a) + p.m_f * sq(p.r_f + z_a);
    let i_axz =
        p.i_hxz - p.m_h * (p.x_h - x_a) * (p.z_h - z_a) + p.m_f * (p.w - x_a) * (p.r_f + z_a);
    let i_azz = p.i_hzz + i_fzz + p.m_h * sq(p.x_h - x_a) + p.m_f * sq(p.w - x_a);
    // (A 16)–(A 19): about the steer axis.
    let u_a = (x_a - p.w - p.c) * cl - z_a * sl;
    let i_all = m_a * u_a * u_a + i_axx * sl * sl + n(2.0) * i_axz * sl * cl + i_azz * cl * cl;
    let i_alx = -m_a * u_a * z_a + i_axx * sl + i_axz * cl;
    let i_alz = m_a * u_a * x_a + i_axz * sl + i_azz * cl;
    // (A 20)–(A 22): trail ratio and gyrostatic coefficients.
    let mu = p.c / p.w * cl;
    let s_r = spin_over_radius(p.i_ryy, p.r_r);
    let s_f = spin_over_radius(p.i_fyy, p.r_f);
    let s_t = s_r + s_f;
    let s_a = m_a * u_a + mu * m_t * x_t;
    // (A 23)–(A 27).
    let m12 = i_alx + mu * i_txz;
    CanonicalTerms {
        m: [
            i_txx,
            m12,
            m12,
            i_all + n(2.0) * mu * i_alz + mu * mu * i_tzz,
        ],
        k0: [m_t * z_t, -s_a, -s_a, -s_a * sl],
        k2: [
            n(0.0),
            (s_t - m_t * z_t) / p.w * cl,
            n(0.0),
            (s_a + s_f * sl) / p.w * cl,
        ],
        c1: [
            n(0.0),
            mu * s_t + s_f * cl + i_txz / p.w * cl - mu * m_t * z_t,
            -(mu * s_t + s_f * cl),
            i_alz / p.w * cl + mu * (s_a + i_tzz / p.w * cl),
        ],
        // The v̇ terms of d/dt(v q) in the yaw acceleration and the front wheel's spin
        // ([`Canonical::ka`]): C₁'s φδ and δδ entries less their centripetal and ω × H parts.
        ka: [
            n(0.0),
            (s_f + i_txz / p.w) * cl,
            n(0.0),
            (i_alz + mu * i_tzz) / p.w * cl,
        ],
        g: p.g,
    }
}

impl Canonical {
    /// Meijaard et al. 2007, Appendix A, equations (A 1)–(A 27) ([`canonical_terms`]).
    pub fn from_benchmark(p: &Benchmark) -> Canonical {
        let t = canonical_terms(&BenchmarkOf::from_array(p.to_array()));
        let mat = |e: [f64; 4]| Matrix2::new(e[0], e[1], e[2], e[3]);
        Canonical {
            m: mat(t.m),
            c1: mat(t.c1),
            k0: mat(t.k0),
            k2: mat(t.k2),
            ka: mat(t.ka),
            g: t.g,
            accel_mps2: 0.0,
            control: SteerControl::NONE,
        }
    }

    /// The same bicycle with `control` closing the loop.
    pub fn with_control(self, control: SteerControl) -> Canonical {
        Canonical { control, ..self }
    }

    /// The same bicycle speeding up at `accel_mps2` (negative: slowing), its stiffness
    /// `g K₀ + v² K₂ + v̇ K_a` ([`Canonical::ka`]).
    pub fn with_accel(self, accel_mps2: f64) -> Canonical {
        Canonical { accel_mps2, ..self }
    }

    /// The state matrix of `x = (φ, δ, φ̇, δ̇)` at speed `v` (eq. 59 of the seed):
    /// `[[0, I], [−M⁻¹(g K₀ + v² K₂ + v̇ K_a), −M⁻¹ v C₁]]` (v̇ = [`Canonical::accel_mps2`],
    /// zero at constant speed), with a controller's steer torque `T_δ = k(v)·x` added as
    /// `M⁻¹ (0, 1)ᵀ k(v)ᵀ` in the lower rows ([`control`]). `None` when M is singular.
    pub fn state_matrix(&self, v: f64) -> Option<Matrix4<f64>> {
        let minv = self.m.try_inverse()?;
        let k = minv * (self.k0 * self.g + self.k2 * (v * v) + self.ka * self.accel_mps2);
        let c = minv * self.c1 * v;
        let mut a = Matrix4::zeros();
        a[(0, 2)] = 1.0;
        a[(1, 3)] = 1.0;
        for r in 0..2 {
            for col in 0..2 {
                a[(2 + r, col)] = -k[(r, col)];
                a[(2 + r, 2 + col)] = -c[(r, col)];
            }
        }
        if !self.control.is_none() {
            let gains = self.control.gains_at(v);
            for r in 0..2 {
                for (col, k) in gains.iter().enumerate() {
                    a[(2 + r, col)] += minv[(r, 1)] * k;
                }
            }
        }
        Some(a)
    }

    /// The four eigenvalues at speed `v`, sorted by real part then imaginary part.
    ///
    /// Through [`eigen::eigenvalues_in_place`] (Francis' QR with exceptional shifts and an
    /// iteration limit); where it does not converge, through nalgebra's real Schur
    /// decomposition with a limit. Not nalgebra's `complex_eigenvalues()`: it iterates without
    /// one, and its Francis iteration (no exceptional shifts) can stagnate forever, e.g. on a
    /// matrix with two complex pairs of similar modulus. When the Schur decomposition does not
    /// converge either, the same eigenvalues are taken from similar matrices: the transpose,
    /// then the order-reversed matrix and its transpose. `None` when all fail or M is singular.
    pub fn eigenvalues(&self, v: f64) -> Option<[Complex<f64>; 4]> {
        eigenvalues_of(&self.state_matrix(v)?)
    }
}

/// The eigenvalues of a real 4×4 matrix, sorted by real then imaginary part: by
/// [`eigen::eigenvalues_in_place`] (balancing, Hessenberg, Francis QR, no Schur vectors), and
/// where that does not converge by nalgebra's Schur decomposition of the matrix and of its
/// similar forms (see [`Canonical::eigenvalues`] for why not nalgebra's
/// `complex_eigenvalues()`).
pub fn eigenvalues_of(a: &Matrix4<f64>) -> Option<[Complex<f64>; 4]> {
    if !a.iter().all(|x| x.is_finite()) {
        return None;
    }
    let mut rows: [f64; 16] = a.transpose().as_slice().try_into().ok()?;
    let all = match eigen::eigenvalues_in_place(&mut rows, 4) {
        Some(e) => e,
        None => schur_eigenvalues(&nalgebra::DMatrix::from_column_slice(4, 4, a.as_slice()))?,
    };
    let mut out: [Complex<f64>; 4] = all.try_into().ok()?;
    out.sort_by(|x, y| x.re.total_cmp(&y.re).then(x.im.total_cmp(&y.im)));
    Some(out)
}

/// The eigenvalues of a real square matrix of any size, sorted by real then imaginary part;
/// `None` for a non-square or non-finite matrix or when the Schur iteration fails on the matrix
/// and on its similar forms (see [`Canonical::eigenvalues`]).
pub fn eigenvalues_dyn(a: &nalgebra::DMatrix<f64>) -> Option<Vec<Complex<f64>>> {
    let n = a.nrows();
    if n == 0 || a.ncols() != n || !a.iter().all(|x| x.is_finite()) {
        return None;
    }
    let mut rows: Vec<f64> = a.transpose().as_slice().to_vec();
    let mut out = match eigen::eigenvalues_in_place(&mut rows, n) {
        Some(e) => e,
        None => schur_eigenvalues(a)?,
    };
    out.sort_by(|x, y| x.re.total_cmp(&y.re).then(x.im.total_cmp(&y.im)));
    Some(out)
}

/// Where [`eigen::eigenvalues_in_place`] does not converge: nalgebra's real Schur decomposition
/// with an iteration limit, of the matrix and, when that fails too, of its similar forms (the
/// transpose, the order-reversed matrix and its transpose, built only when needed).
fn schur_eigenvalues(a: &nalgebra::DMatrix<f64>) -> Option<Vec<Complex<f64>>> {
    let n = a.nrows();
    let reversed = || nalgebra::DMatrix::from_fn(n, n, |r, c| a[(n - 1 - r, n - 1 - c)]);
    let forms: [&dyn Fn() -> nalgebra::DMatrix<f64>; 4] =
        [&|| a.clone(), &|| a.transpose(), &reversed, &|| {
            reversed().transpose()
        }];
    let schur = forms
        .iter()
        .find_map(|m| nalgebra::Schur::try_new(m(), f64::EPSILON, 500))?;
    Some(schur.complex_eigenvalues().iter().copied().collect())
}

impl Canonical {
    /// The largest real part at speed `v`: the bicycle is stable where it is negative.
    pub fn max_real(&self, v: f64) -> f64 {
        self.eigenvalues(v).map_or(f64::NAN, |e| {
            e.iter().map(|z| z.re).fold(f64::NEG_INFINITY, f64::max)
        })
    }

    /// A right eigenvector of the state matrix for eigenvalue `lambda` (the mode shape), by
    /// inverse iteration ([`eigenvector_near`]). Its first two components are roll and steer.
    pub fn mode_shape(&self, v: f64, lambda: Complex<f64>) -> Option<[Complex<f64>; 4]> {
        let x = eigenvector_near(&self.state_matrix(v)?, lambda)?;
        Some([x[0], x[1], x[2], x[3]])
    }
}

/// A right eigenvector of the real square matrix `a` for its eigenvalue `lambda`, by inverse
/// iteration: three solves with `a − s I`, s a shift 1e-9·(1 + |λ|) off `lambda` in both parts,
/// from a vector of ones, each normalized by its largest component's modulus; returned scaled
/// so that its largest component is 1. Any size, fixed (the rigid bicycle's 4×4, no heap) or
/// dynamic, the same arithmetic. `None` when a solve fails or the iterate is not finite.
pub fn eigenvector_near<D: nalgebra::DimMin<D, Output = D>>(
    a: &nalgebra::OMatrix<f64, D, D>,
    lambda: Complex<f64>,
) -> Option<nalgebra::OVector<Complex<f64>, D>>
where
    nalgebra::DefaultAllocator: nalgebra::allocator::Allocator<D, D>
        + nalgebra::allocator::Allocator<D>
        + nalgebra::allocator::Allocator<nalgebra::U1, D>,
{
    let (rows, cols) = a.shape_generic();
    let shift = lambda + Complex::new(1e-9 * (1.0 + lambda.norm()), 1e-9 * (1.0 + lambda.norm()));
    let m = nalgebra::OMatrix::<Complex<f64>, D, D>::from_fn_generic(rows, cols, |i, j| {
        Complex::new(a[(i, j)], 0.0)
            - if i == j {
                shift
            } else {
                Complex::new(0.0, 0.0)
            }
    });
    let lu = m.lu();
    let mut x = nalgebra::OVector::<Complex<f64>, D>::from_element_generic(
        rows,
        nalgebra::U1,
        Complex::new(1.0, 0.0),
    );
    for _ in 0..3 {
        x = lu.solve(&x)?;
        let big = x.iter().map(|z| z.norm()).fold(0.0, f64::max);
        if !(big.is_finite() && big > 0.0) {
            return None;
        }
        x /= Complex::new(big, 0.0);
    }
    let k = (0..x.len()).max_by(|&i, &j| x[i].norm().total_cmp(&x[j].norm()))?;
    let pivot = x[k];
    Some(x / pivot)
}

/// The modes of the bicycle, as named at high speed and followed down by continuity.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Mode {
    /// The oscillatory mode (the eigenvalue with positive imaginary part; its conjugate is
    /// `WeaveConjugate`).
    Weave,
    WeaveConjugate,
    /// The slow real mode, unstable above the capsize speed.
    Capsize,
    /// The fast real mode (steer castering).
    Castor,
}

/// Eigenvalues against speed, each column a named branch.
#[derive(Debug, Clone)]
pub struct Sweep {
    pub speeds_mps: Vec<f64>,
    /// Per speed, the eigenvalues in the order of `modes`.
    pub eigenvalues: Vec<[Complex<f64>; 4]>,
    pub modes: [Mode; 4],
}

/// The 24 orders of four, in lexicographic order (the order [`match_order`] tries them in).
const ORDERS: [[usize; 4]; 24] = {
    let mut out = [[0usize; 4]; 24];
    let mut n = 0;
    let mut a = 0;
    while a < 4 {
        let mut b = 0;
        while b < 4 {
            let mut c = 0;
            while c < 4 {
                if a != b && a != c && b != c && a + b + c >= 3 {
                    // The one index left: 0 + 1 + 2 + 3 = 6.
                    out[n] = [a, b, c, 6 - a - b - c];
                    n += 1;
                }
                c += 1;
            }
            b += 1;
        }
        a += 1;
    }
    out
};

/// Matches `next` to `prev` (all 24 orders; the closest in total distance).
pub fn match_order(prev: &[Complex<f64>; 4], next: &[Complex<f64>; 4]) -> [Complex<f64>; 4] {
    let mut best = *next;
    let mut best_d = f64::INFINITY;
    // Ties (a complex pair meeting two reals, as below the weave speed: both assignments are
    // equally near by symmetry) go to the naming of [`name_at`] (the larger real is capsize),
    // not to the last bit of rounding, which a 1e-12 change of a parameter flipped.
    let mut named: Option<[Complex<f64>; 4]> = None;
    let mut off_naming = |c: &[Complex<f64>; 4]| -> f64 {
        let named = named.get_or_insert_with(|| name_at(next));
        (0..4).map(|i| (c[i] - named[i]).norm_sqr()).sum()
    };
    for p in ORDERS {
        let dist: f64 = (0..4).map(|i| (prev[i] - next[p[i]]).norm_sqr()).sum();
        let tie = (dist - best_d).abs() <= 1e-12 * (1.0 + best_d);
        if dist < best_d && !tie {
            best_d = dist;
            best = p.map(|k| next[k]);
        } else if tie {
            let candidate = p.map(|k| next[k]);
            if off_naming(&candidate) < off_naming(&best) {
                best_d = best_d.min(dist);
                best = candidate;
            }
        }
    }
    best
}

/// Names the eigenvalues at one speed: a complex pair is the weave (positive imaginary part
/// first); of the real ones the larger is capsize, the smaller castor. With two complex pairs
/// (or four reals) the slower-decaying pair or values are taken as weave.
fn name_at(ev: &[Complex<f64>; 4]) -> [Complex<f64>; 4] {
    let tol = 1e-9;
    let mut complex: Vec<Complex<f64>> = ev.iter().copied().filter(|z| z.im > tol).collect();
    let mut real: Vec<Complex<f64>> = ev.iter().copied().filter(|z| z.im.abs() <= tol).collect();
    complex.sort_by(|a, b| b.re.total_cmp(&a.re));
    real.sort_by(|a, b| b.re.total_cmp(&a.re));
    match (complex.len(), real.len()) {
        (1, 2) => [complex[0], complex[0].conj(), real[0], real[1]],
        (2, 0) => [complex[0], complex[0].conj(), complex[1], complex[1].conj()],
        (0, 4) => [real[0], real[1], real[2], real[3]],
        _ => *ev,
    }
}

impl Canonical {
    /// Eigenvalues at every speed, named at the highest speed and tracked down by continuity
    /// (through the speeds where real pairs merge into complex ones). Errors on a singular M.
    pub fn sweep(&self, speeds_mps: &[f64]) -> Result<Sweep, ParamError> {
        let mut order: Vec<usize> = (0..speeds_mps.len()).collect();
        order.sort_by(|&a, &b| speeds_mps[b].total_cmp(&speeds_mps[a]));
        let mut out = vec![[Complex::new(0.0, 0.0); 4]; speeds_mps.len()];
        // The eigenvalues speed by speed on rayon's threads; their naming in order after.
        use rayon::prelude::*;
        let each: Vec<Option<[Complex<f64>; 4]>> = speeds_mps
            .par_iter()
            .with_min_len(1024)
            .map(|&v| self.eigenvalues(v))
            .collect();
        let mut prev: Option<[Complex<f64>; 4]> = None;
        for i in order {
            let ev = each[i].ok_or(ParamError::SingularMass)?;
            let named = match prev {
                None => name_at(&ev),
                Some(p) => match_order(&p, &ev),
            };
            out[i] = named;
            prev = Some(named);
        }
        Ok(Sweep {
            speeds_mps: speeds_mps.to_vec(),
            eigenvalues: out,
            modes: [
                Mode::Weave,
                Mode::WeaveConjugate,
                Mode::Capsize,
                Mode::Castor,
            ],
        })
    }
}

/// A speed where the stability changes, and which mode crosses there.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Crossing {
    pub speed_mps: f64,
    /// `true` when the bicycle becomes stable with increasing speed.
    pub becomes_stable: bool,
    /// Whether a complex pair (Hopf) or a real eigenvalue (pitchfork) crosses zero.
    pub oscillatory: bool,
}

/// Stability against speed.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Stability {
    /// Ranges of speed where every eigenvalue has a negative real part, `[lo, hi]`, `hi` `None`
    /// when stable up to the end of the range searched.
    pub stable_ranges_mps: Vec<(f64, Option<f64>)>,
    pub crossings: Vec<Crossing>,
    /// The weave speed: where the weave pair becomes stable (the first oscillatory crossing to
    /// stable).
    pub weave_speed_mps: Option<f64>,
    /// The capsize speed: where a real eigenvalue becomes unstable above the weave speed.
    pub capsize_speed_mps: Option<f64>,
    /// The speed where the weave's real pair merges into a complex pair.
    pub weave_merge_speed_mps: Option<f64>,
}

/// Stable speed ranges as text, `lo – hi` (or `above lo` when stable to the end of the
/// search), with `decimals` and a `unit` suffix (e.g. " m/s", or "" in a table headed m/s).
pub fn ranges_text(ranges: &[(f64, Option<f64>)], decimals: usize, unit: &str) -> Vec<String> {
    ranges
        .iter()
        .map(|(lo, hi)| match hi {
            Some(h) => format!("{lo:.decimals$} – {h:.decimals$}{unit}"),
            None => format!("above {lo:.decimals$}{unit}"),
        })
        .collect()
}

/// Bisection to 1e-13 m/s on a sign change of `f` between `a` and `b`.
pub(crate) fn bisect(mut a: f64, mut b: f64, f: impl Fn(f64) -> f64) -> f64 {
    let fa = f(a);
    for _ in 0..200 {
        let m = 0.5 * (a + b);
        if (b - a) < 1e-13 || m <= a || m >= b {
            break;
        }
        if (f(m) > 0.0) == (fa > 0.0) {
            a = m;
        } else {
            b = m;
        }
    }
    0.5 * (a + b)
}

/// The root of `f` between `a` and `b` (where it changes sign) to 1e-13 by regula falsi with
/// the Illinois modification (Dowell & Jarratt 1971): superlinear where `f` is smooth, and the
/// bracket always holds the root. Falls back to the bracket's middle when an interpolated point
/// leaves it.
pub(crate) fn illinois(a: f64, b: f64, f: impl Fn(f64) -> f64) -> f64 {
    let (mut a, mut b) = (a, b);
    let (mut fa, mut fb) = (f(a), f(b));
    if fa == 0.0 {
        return a;
    }
    if fb == 0.0 {
        return b;
    }
    let mut kept = 0i8;
    for _ in 0..200 {
        if (b - a).abs() < 1e-13 {
            break;
        }
        let mut c = (a * fb - b * fa) / (fb - fa);
        if !(c > a.min(b) && c < a.max(b)) {
            c = 0.5 * (a + b);
        }
        let fc = f(c);
        if fc == 0.0 || !fc.is_finite() {
            return c;
        }
        if (fc > 0.0) == (fb > 0.0) {
            b = c;
            fb = fc;
            if kept == -1 {
                fa *= 0.5;
            }
            kept = -1;
        } else {
            a = c;
            fa = fc;
            if kept == 1 {
                fb *= 0.5;
            }
            kept = 1;
        }
        // Close enough when the last step moved the bracket by less than the tolerance.
        if (b - a).abs() < 1e-13 {
            break;
        }
    }
    0.5 * (a + b)
}

impl Canonical {
    /// The stable ranges and characteristic speeds in `[0, v_max]`, scanning at `step` and
    /// refining every change by bisection to 1e-13 m/s.
    pub fn stability(&self, v_max: f64, step: f64) -> Result<Stability, ParamError> {
        if self.m.try_inverse().is_none() {
            return Err(ParamError::SingularMass);
        }
        let n = (v_max / step).ceil() as usize;
        let speeds: Vec<f64> = (0..=n).map(|i| (i as f64 * step).min(v_max)).collect();
        let mr: Vec<f64> = speeds.iter().map(|&v| self.max_real(v)).collect();
        if mr.iter().any(|x| !x.is_finite()) {
            return Err(ParamError::NoEigenvalues);
        }
        // A crossing is oscillatory when the eigenvalue at the boundary with the largest real
        // part has a non-zero imaginary part.
        let mut crossings = Vec::new();
        for i in 1..speeds.len() {
            if (mr[i - 1] < 0.0) != (mr[i] < 0.0) {
                let v = bisect(speeds[i - 1], speeds[i], |v| self.max_real(v));
                let ev = self.eigenvalues(v).ok_or(ParamError::SingularMass)?;
                let top = ev
                    .iter()
                    .max_by(|a, b| a.re.total_cmp(&b.re))
                    .copied()
                    .unwrap_or_default();
                crossings.push(Crossing {
                    speed_mps: v,
                    becomes_stable: mr[i] < 0.0,
                    oscillatory: top.im.abs() > 1e-6,
                });
            }
        }
        let mut ranges = Vec::new();
        let mut lo = if mr[0] < 0.0 { Some(0.0) } else { None };
        for c in &crossings {
            if c.becomes_stable {
                lo = Some(c.speed_mps);
            } else if let Some(l) = lo.take() {
                ranges.push((l, Some(c.speed_mps)));
            }
        }
        if let Some(l) = lo {
            ranges.push((l, None));
        }
        let weave = crossings
            .iter()
            .find(|c| c.becomes_stable && c.oscillatory)
            .map(|c| c.speed_mps);
        let capsize = crossings
            .iter()
            .find(|c| !c.becomes_stable && !c.oscillatory && weave.is_none_or(|w| c.speed_mps > w))
            .map(|c| c.speed_mps);
        // The weave pair's merge: below the weave speed, the highest speed with no complex
        // eigenvalue near the weave branch.
        let sweep = self.sweep(&speeds)?;
        let complex_count = |v: f64| {
            self.eigenvalues(v)
                .map_or(0, |ev| ev.iter().filter(|z| z.im.abs() > 1e-7).count())
        };
        let merge = weave.and_then(|w| {
            let idx = speeds.iter().rposition(|&v| v <= w)?;
            let j = (0..=idx)
                .rev()
                .find(|&j| sweep.eigenvalues[j][0].im.abs() < 1e-9)?;
            if j + 1 >= speeds.len() {
                return None;
            }
            // The number of complex eigenvalues changes where the weave's real pair merges.
            let below = complex_count(speeds[j]);
            Some(bisect(speeds[j], speeds[j + 1], |v| {
                if complex_count(v) > below {
                    1.0
                } else {
                    -1.0
                }
            }))
        });
        Ok(Stability {
            stable_ranges_mps: ranges,
            crossings,
            weave_speed_mps: weave,
            capsize_speed_mps: capsize,
            weave_merge_speed_mps: merge,
        })
    }
}

#[cfg(test)]
mod tests {

    /// Illinois regula falsi finds √2 and a weave-like crossing (a smooth function crossing zero
    /// with a curvature) to 1e-13, in far fewer evaluations than bisection's 40.
    #[test]
    fn illinois_converges_fast_to_the_root() {
        use std::cell::Cell;
        for (f, lo, hi, root) in [
            (
                Box::new(|v: f64| v * v - 2.0) as Box<dyn Fn(f64) -> f64>,
                1.0,
                2.0,
                2f64.sqrt(),
            ),
            (
                Box::new(|v: f64| (1.0 - v / 4.3).tanh() + 0.2 * (1.0 - v / 4.3).powi(2)),
                4.28,
                4.32,
                4.3,
            ),
        ] {
            let calls = Cell::new(0);
            let x = illinois(lo, hi, |v| {
                calls.set(calls.get() + 1);
                f(v)
            });
            assert!((x - root).abs() < 1e-13, "{x} vs {root}");
            assert!(calls.get() <= 14, "{} evaluations", calls.get());
        }
    }

    use super::*;

    #[test]
    fn mode_shapes_are_eigenvectors() {
        let c = Canonical::from_benchmark(&Benchmark::meijaard_2007());
        for v in [1.0, 5.0, 8.0] {
            let a = c.state_matrix(v).unwrap().map(|x| Complex::new(x, 0.0));
            for lambda in c.eigenvalues(v).unwrap() {
                let m = c.mode_shape(v, lambda).unwrap();
                let x = nalgebra::Vector4::new(m[0], m[1], m[2], m[3]);
                let r = (a * x - x * lambda).norm();
                assert!(r < 1e-8, "v = {v}, λ = {lambda}: residual {r}");
                // The state holds the angles and their rates: rates = λ·angles.
                assert!(
                    (m[2] - m[0] * lambda).norm() < 1e-8 && (m[3] - m[1] * lambda).norm() < 1e-8
                );
            }
        }
    }

    #[test]
    fn eigenvalues_where_nalgebras_francis_iteration_stagnates() {
        // A state matrix of the lab bicycle (a Monte Carlo draw at 1.24 m/s) on which
        // `Schur::try_new` never converges; its transpose does.
        let a = Matrix4::new(
            0.0,
            0.0,
            1.0,
            0.0,
            0.0,
            0.0,
            0.0,
            1.0,
            15.092852850371253,
            -2.0322055634793577,
            -0.47880788461045326,
            -1.1919159002898172,
            1.5465328770071665,
            10.15522753343885,
            5.212423607350845,
            -2.221382804670737,
        );
        assert!(nalgebra::Schur::try_new(a, f64::EPSILON, 10_000).is_none());
        let ev = eigenvalues_of(&a).unwrap();
        for z in ev {
            // det(A − zI) = 0 to rounding.
            let m = a.map(|x| Complex::new(x, 0.0)) - Matrix4::<Complex<f64>>::identity() * z;
            assert!(m.determinant().norm() < 1e-10, "{z}");
        }
        assert!(
            (ev[3].re - 2.7310498958369887).abs() < 1e-12
                && (ev[0].re + 4.081145240477584).abs() < 1e-12
        );
    }

    #[test]
    fn benchmark_matrices_match_meijaard_2007() {
        let c = Canonical::from_benchmark(&Benchmark::meijaard_2007());
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-13 * b.abs().max(1.0);
        let want_m = [
            [80.81722, 2.31941332208709],
            [2.31941332208709, 0.29784188199686],
        ];
        let want_c1 = [
            [0.0, 33.86641391492494],
            [-0.85035641456978, 1.68540397397560],
        ];
        let want_k0 = [
            [-80.95, -2.59951685249872],
            [-2.59951685249872, -0.80329488458618],
        ];
        let want_k2 = [[0.0, 76.59734589573222], [0.0, 2.65431523794604]];
        for r in 0..2 {
            for s in 0..2 {
                assert!(close(c.m[(r, s)], want_m[r][s]), "M{r}{s} {}", c.m[(r, s)]);
                assert!(
                    close(c.c1[(r, s)], want_c1[r][s]),
                    "C1{r}{s} {}",
                    c.c1[(r, s)]
                );
                assert!(
                    close(c.k0[(r, s)] * 1.0, want_k0[r][s]),
                    "K0{r}{s} {}",
                    c.k0[(r, s)]
                );
                assert!(
                    close(c.k2[(r, s)], want_k2[r][s]),
                    "K2{r}{s} {}",
                    c.k2[(r, s)]
                );
            }
        }
    }
}
