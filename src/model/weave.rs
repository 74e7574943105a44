//! What a ride's analysis needs of a linear bicycle model: its state matrix at a speed, with
//! the speed changing, and the oscillatory mode nearest a measured one with its shape
//! ([`LinearWeave`]). The Whipple model implements it here; the gap stage's extended models
//! (damping, tyres) implement it beside themselves, so the ride stage replays a coasting ride
//! on either without knowing the gap stage.

use super::Canonical;
use nalgebra::Complex;

/// A linear bicycle a coasting ride can be replayed on (the ride stage's replay): the Whipple
/// model here ([`Canonical`]), the gap stage's extended ones (damping, tyres) there.
pub trait LinearWeave: Sized {
    /// The same bicycle with its speed changing at `accel_mps2` ([`Canonical::with_accel`]).
    fn accelerating(&self, accel_mps2: f64) -> Self;
    /// The state matrix at speed `v` (m/s).
    fn state_matrix_at(&self, v: f64) -> Option<nalgebra::DMatrix<f64>>;
    /// The oscillatory eigenvalue (ω > 0) at `v` nearest `toward`, with its right eigenvector
    /// scaled so that its largest component is 1.
    fn weave_mode(
        &self,
        v: f64,
        toward: Complex<f64>,
    ) -> Option<(Complex<f64>, nalgebra::DVector<Complex<f64>>)>;
    /// The states that are the roll and the steer angle and their rates.
    fn angle_states(&self) -> [usize; 4];
    /// [`LinearWeave::weave_mode`]'s eigenvalue and its mode shape γ/θ.
    fn weave_shape(&self, v: f64, toward: Complex<f64>) -> Option<(Complex<f64>, Complex<f64>)> {
        let (weave, mode) = self.weave_mode(v, toward)?;
        let [roll, steer, ..] = self.angle_states();
        Some((weave, mode[steer] / mode[roll]))
    }
}

impl LinearWeave for Canonical {
    fn accelerating(&self, accel_mps2: f64) -> Self {
        self.with_accel(accel_mps2)
    }

    fn state_matrix_at(&self, v: f64) -> Option<nalgebra::DMatrix<f64>> {
        let a = self.state_matrix(v)?;
        Some(nalgebra::DMatrix::from_column_slice(4, 4, a.as_slice()))
    }

    fn weave_mode(
        &self,
        v: f64,
        toward: Complex<f64>,
    ) -> Option<(Complex<f64>, nalgebra::DVector<Complex<f64>>)> {
        let w = weave_near(self, v, toward)?;
        let shape = self.mode_shape(v, w)?;
        Some((w, nalgebra::DVector::from_column_slice(&shape)))
    }

    fn angle_states(&self) -> [usize; 4] {
        [0, 1, 2, 3]
    }
}

/// The model's oscillatory eigenvalue (ω > 0) at `v` nearest `toward` (the measured weave):
/// the branch the ride's weave belongs to. `None` when the model has none there.
pub fn weave_near(model: &Canonical, v: f64, toward: Complex<f64>) -> Option<Complex<f64>> {
    model
        .eigenvalues(v)?
        .into_iter()
        .filter(|z| z.im > 0.0)
        .min_by(|a, b| (a - toward).norm().total_cmp(&(b - toward).norm()))
}
