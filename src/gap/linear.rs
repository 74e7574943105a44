//! The linear model extended by the candidate effects that add terms rather than change
//! parameters: viscous steer damping. In: canonical matrices (of a possibly modified parameter
//! set) and the extra terms. Out: the state matrix and its eigenvalues at a speed.
//!
//! `M q̈ + (v C₁ + D) q̇ + (g K₀ + v² K₂) q = 0`, `D = [[0, 0], [0, c]]`: a steering-head torque
//! `−c δ̇` beside the Whipple model's (Meijaard et al. 2007, eq. 1 with a steer damper, as in
//! Schwab, Meijaard & Kooijman 2012 for a bicycle's headset).

use crate::model::Canonical;
use nalgebra::{Complex, DMatrix};

/// The Whipple model with the extra terms.
#[derive(Debug, Clone, Copy)]
pub struct LinearBike {
    pub canonical: Canonical,
    /// Viscous steer damping c (N·m·s/rad).
    pub steer_damping_nms_per_rad: f64,
}

impl LinearBike {
    /// The state matrix of `(φ, δ, φ̇, δ̇)` at speed `v` (m/s); `None` when M is singular.
    pub fn state_matrix(&self, v: f64) -> Option<DMatrix<f64>> {
        let c = &self.canonical;
        let minv = c.m.try_inverse()?;
        let k = minv * (c.k0 * c.g + c.k2 * (v * v));
        let mut damping = c.c1 * v;
        damping[(1, 1)] += self.steer_damping_nms_per_rad;
        let d = minv * damping;
        let mut a = DMatrix::zeros(4, 4);
        a[(0, 2)] = 1.0;
        a[(1, 3)] = 1.0;
        for r in 0..2 {
            for col in 0..2 {
                a[(2 + r, col)] = -k[(r, col)];
                a[(2 + r, 2 + col)] = -d[(r, col)];
            }
        }
        Some(a)
    }

    /// The oscillatory eigenvalue (im > 0) nearest `guess` at speed `v`; `None` when there is
    /// none or the eigenvalues cannot be computed.
    pub fn weave_near(&self, v: f64, guess: Complex<f64>) -> Option<Complex<f64>> {
        let ev = crate::model::eigenvalues_dyn(&self.state_matrix(v)?)?;
        ev.into_iter()
            .filter(|z| z.im > 1e-9)
            .min_by(|a, b| (a - guess).norm().total_cmp(&(b - guess).norm()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Benchmark;

    /// Without damping the extended model is the benchmark's: Meijaard et al. 2007, Table 2,
    /// weave at 5 m/s −0.77534188219585 ± 4.46486771378823 i.
    #[test]
    fn without_damping_it_is_the_benchmark() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../shared/reference/bicycleparameters/BenchmarkBenchmark.txt");
        let bike = LinearBike {
            canonical: Canonical::from_benchmark(&Benchmark::load(&path).unwrap()),
            steer_damping_nms_per_rad: 0.0,
        };
        let w = bike.weave_near(5.0, Complex::new(-0.7, 4.5)).unwrap();
        assert!((w.re + 0.77534188219585).abs() < 1e-10, "{w}");
        assert!((w.im - 4.46486771378823).abs() < 1e-10, "{w}");
    }

    /// Damping enters as a steer-rate torque: the characteristic polynomial's s³ coefficient
    /// (the trace of the state matrix, minus) grows by c (M⁻¹)₂₂.
    #[test]
    fn damping_adds_to_the_trace() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../shared/reference/bicycleparameters/BenchmarkBenchmark.txt");
        let canonical = Canonical::from_benchmark(&Benchmark::load(&path).unwrap());
        let free = LinearBike {
            canonical,
            steer_damping_nms_per_rad: 0.0,
        };
        let damped = LinearBike {
            steer_damping_nms_per_rad: 0.4,
            ..free
        };
        let minv = canonical.m.try_inverse().unwrap();
        let dt =
            free.state_matrix(3.0).unwrap().trace() - damped.state_matrix(3.0).unwrap().trace();
        assert!((dt - 0.4 * minv[(1, 1)]).abs() < 1e-12);
    }
}
