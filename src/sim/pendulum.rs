//! Pendulum tests simulated from their physics: a rigid body on the torsion bar (viscous and
//! Coulomb damping, the Cardan joint's swing as a lightly coupled second mode) and a compound
//! pendulum (full nonlinear `sin θ`). The experimenter's sequence is simulated too: rest,
//! turning the body by hand to the release angle, holding it, letting go.
//!
//! The equations are integrated here with a fixed-step classical Runge–Kutta scheme at ten
//! steps per sample (phase error < 1e-8 relative over 120 s at 5 Hz); nothing here calls the
//! estimators.

use super::imu::{BodySample, GRAVITY_MPS2};
use nalgebra::{Matrix4, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// A body on the torsion bar: `I θ̈ + c θ̇ + k θ + F_c sgn θ̇ = −κ √(k k_s) α` (eq. 62 with damping).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Torsion {
    /// Inertia about the bar's axis: body, added weights and fixture (kg·m²).
    pub inertia_kgm2: f64,
    pub stiffness_nm_per_rad: f64,
    /// Viscous damping as a ratio of critical, `c / (2√(kI))`.
    pub damping_ratio: f64,
    /// Coulomb (dry) friction torque (N·m).
    #[serde(default)]
    pub coulomb_nm: f64,
    /// The Cardan joint's swing, a second mode coupled to the torsion.
    #[serde(default)]
    pub swing: Option<Swing>,
}

/// The swing of the body in the Cardan joint about a horizontal axis.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Swing {
    pub freq_hz: f64,
    pub damping_ratio: f64,
    /// Dimensionless stiffness coupling κ between the two modes (mass-normalised).
    pub coupling: f64,
    /// Swing amplitude the release excites (deg).
    pub release_amplitude_deg: f64,
}

/// A compound pendulum: `I_p θ̈ + c θ̇ + m g L sin θ + F_c sgn θ̇ = 0` (eqs. 76–77 without the
/// small-angle step).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Compound {
    pub mass_kg: f64,
    /// Pivot to centre of gravity (m).
    pub pivot_to_cg_m: f64,
    /// Inertia about the pivot axis (kg·m²).
    pub inertia_about_pivot_kgm2: f64,
    /// Viscous damping as a ratio of critical at small amplitude.
    pub damping_ratio: f64,
    #[serde(default)]
    pub coulomb_nm: f64,
}

/// The experimenter's sequence and the record's length.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Release {
    /// Still at the start (s).
    pub rest_s: f64,
    /// Turning the body to the release angle by hand (s).
    pub ramp_s: f64,
    /// Holding it there (s).
    pub hold_s: f64,
    /// Release angle (deg).
    pub amplitude_deg: f64,
    /// Whole record (s).
    pub duration_s: f64,
}

/// The kind of pendulum.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Pendulum {
    Torsion(Torsion),
    Compound(Compound),
}

/// How the body hangs and where the sensor sits on it.
#[derive(Debug, Clone)]
pub struct Placement {
    /// Rotation body → global at rest.
    pub body_rest: UnitQuaternion<f64>,
    /// For a compound pendulum and for the swing: heading of the horizontal pivot axis (rad from X).
    pub axis_heading_rad: f64,
    /// The sensor's location relative to the pivot, in the body frame (m).
    pub sensor_offset_m: Vector3<f64>,
}

/// The truth a simulated test was made from.
#[derive(Debug, Clone, Serialize)]
pub struct PendulumTruth {
    /// Damped frequency of the mode measured (small-amplitude, linear), Hz.
    pub damped_freq_hz: f64,
    pub natural_freq_hz: f64,
    pub damping_ratio: f64,
    /// When the body was let go (s).
    pub release_s: f64,
    /// Release angle (rad).
    pub amplitude_rad: f64,
}

impl Pendulum {
    /// The small-amplitude linear truth of the main mode. With the swing coupled, the torsion
    /// mode's eigenvalue of the 2-DOF linear system (its frequency shifts by O(κ²)).
    pub fn truth(&self, release: &Release) -> PendulumTruth {
        let (wn, zeta) = match self {
            Pendulum::Torsion(t) => {
                let w1 = (t.stiffness_nm_per_rad / t.inertia_kgm2).sqrt();
                match &t.swing {
                    Some(s) if s.coupling != 0.0 => {
                        let w2 = 2.0 * PI * s.freq_hz;
                        let k12 = s.coupling * w1 * w2;
                        let a = Matrix4::new(
                            0.0,
                            1.0,
                            0.0,
                            0.0,
                            -w1 * w1,
                            -2.0 * t.damping_ratio * w1,
                            -k12,
                            0.0,
                            0.0,
                            0.0,
                            0.0,
                            1.0,
                            -k12,
                            0.0,
                            -w2 * w2,
                            -2.0 * s.damping_ratio * w2,
                        );
                        // The eigenvalue nearest the uncoupled torsion mode.
                        let target = nalgebra::Complex::new(
                            -t.damping_ratio * w1,
                            w1 * (1.0 - t.damping_ratio.powi(2)).sqrt(),
                        );
                        let ev = a.complex_eigenvalues();
                        let l = ev
                            .iter()
                            .min_by(|x, y| (*x - target).norm().total_cmp(&(*y - target).norm()))
                            .copied()
                            .unwrap_or(target);
                        (l.norm(), -l.re / l.norm())
                    }
                    _ => (w1, t.damping_ratio),
                }
            }
            Pendulum::Compound(c) => (
                (c.mass_kg * GRAVITY_MPS2 * c.pivot_to_cg_m / c.inertia_about_pivot_kgm2).sqrt(),
                c.damping_ratio,
            ),
        };
        PendulumTruth {
            damped_freq_hz: wn * (1.0 - zeta * zeta).sqrt() / (2.0 * PI),
            natural_freq_hz: wn / (2.0 * PI),
            damping_ratio: zeta,
            release_s: release.rest_s + release.ramp_s + release.hold_s,
            amplitude_rad: release.amplitude_deg.to_radians(),
        }
    }

    /// `[θ̇, θ̈, α̇, α̈]` for state `[θ, θ̇, α, α̇]`.
    fn rhs(&self, y: &[f64; 4]) -> [f64; 4] {
        // Coulomb friction as a steep tanh: smooth enough for RK4 at 1 ms steps.
        let dry = |v: f64| (v / 1e-3).tanh();
        match self {
            Pendulum::Torsion(t) => {
                let w1 = (t.stiffness_nm_per_rad / t.inertia_kgm2).sqrt();
                let mut th = -w1 * w1 * y[0]
                    - 2.0 * t.damping_ratio * w1 * y[1]
                    - t.coulomb_nm / t.inertia_kgm2 * dry(y[1]);
                let mut al = 0.0;
                if let Some(s) = &t.swing {
                    let w2 = 2.0 * PI * s.freq_hz;
                    let k12 = s.coupling * w1 * w2;
                    th -= k12 * y[2];
                    al = -w2 * w2 * y[2] - 2.0 * s.damping_ratio * w2 * y[3] - k12 * y[0];
                }
                [y[1], th, y[3], al]
            }
            Pendulum::Compound(c) => {
                let w2 = c.mass_kg * GRAVITY_MPS2 * c.pivot_to_cg_m / c.inertia_about_pivot_kgm2;
                let th = -w2 * y[0].sin()
                    - 2.0 * c.damping_ratio * w2.sqrt() * y[1]
                    - c.coulomb_nm / c.inertia_about_pivot_kgm2 * dry(y[1]);
                [y[1], th, 0.0, 0.0]
            }
        }
    }

    /// The body's true motion at `rate_hz` over the release sequence.
    pub fn motion(&self, release: &Release, place: &Placement, rate_hz: f64) -> Vec<BodySample> {
        let n = (release.duration_s * rate_hz).round() as usize;
        let dt = 1.0 / rate_hz;
        let t_release = release.rest_s + release.ramp_s + release.hold_s;
        let theta0 = release.amplitude_deg.to_radians();
        let swing_rate0 = match self {
            Pendulum::Torsion(Torsion { swing: Some(s), .. }) => {
                s.release_amplitude_deg.to_radians() * 2.0 * PI * s.freq_hz
            }
            _ => 0.0,
        };
        const SUBSTEPS: usize = 10;
        let h = dt / SUBSTEPS as f64;
        let mut y = [theta0, 0.0, 0.0, swing_rate0];
        let mut t_sim = t_release;
        let mut out = Vec::with_capacity(n);
        for k in 0..n {
            let t = k as f64 * dt;
            let (ang, rate, acc, sw) = if t < t_release {
                let (a, r, c) = hand(t, release, theta0);
                (a, r, c, [0.0; 3])
            } else {
                while t_sim + 0.5 * h < t {
                    y = rk4(|s| self.rhs(s), &y, h);
                    t_sim += h;
                }
                let d = self.rhs(&y);
                (y[0], y[1], d[1], [y[2], y[3], d[3]])
            };
            out.push(self.kinematics(place, ang, rate, acc, sw));
        }
        out
    }

    fn kinematics(
        &self,
        place: &Placement,
        ang: f64,
        rate: f64,
        acc: f64,
        swing: [f64; 3],
    ) -> BodySample {
        let z = Vector3::z_axis();
        let u = Vector3::new(
            place.axis_heading_rad.cos(),
            place.axis_heading_rad.sin(),
            0.0,
        );
        let (orientation, omega, alpha) = match self {
            Pendulum::Torsion(_) => {
                let rz = UnitQuaternion::from_axis_angle(&z, ang);
                let u_now = rz * u;
                let ru = UnitQuaternion::from_scaled_axis(u * swing[0]);
                let omega = z.into_inner() * rate + u_now * swing[1];
                let alpha =
                    z.into_inner() * acc + u_now * swing[2] + z.cross(&u_now) * (rate * swing[1]);
                (rz * ru * place.body_rest, omega, alpha)
            }
            Pendulum::Compound(_) => {
                let ru = UnitQuaternion::from_scaled_axis(u * ang);
                (ru * place.body_rest, u * rate, u * acc)
            }
        };
        let r = orientation * place.sensor_offset_m;
        BodySample {
            orientation,
            omega_global: omega,
            accel_global: alpha.cross(&r) + omega.cross(&omega.cross(&r)),
        }
    }
}

/// The hand's motion before the release: still, a smooth turn (cubic smoothstep), held.
/// Returns angle, rate and acceleration.
fn hand(t: f64, r: &Release, theta0: f64) -> (f64, f64, f64) {
    if t < r.rest_s || r.ramp_s <= 0.0 {
        return if t < r.rest_s {
            (0.0, 0.0, 0.0)
        } else {
            (theta0, 0.0, 0.0)
        };
    }
    let u = (t - r.rest_s) / r.ramp_s;
    if u >= 1.0 {
        return (theta0, 0.0, 0.0);
    }
    (
        theta0 * u * u * (3.0 - 2.0 * u),
        theta0 * 6.0 * u * (1.0 - u) / r.ramp_s,
        theta0 * (6.0 - 12.0 * u) / (r.ramp_s * r.ramp_s),
    )
}

/// One classical Runge–Kutta step.
pub fn rk4<const N: usize, F: Fn(&[f64; N]) -> [f64; N]>(f: F, y: &[f64; N], h: f64) -> [f64; N] {
    let add = |a: &[f64; N], b: &[f64; N], s: f64| -> [f64; N] {
        std::array::from_fn(|i| a[i] + s * b[i])
    };
    let k1 = f(y);
    let k2 = f(&add(y, &k1, 0.5 * h));
    let k3 = f(&add(y, &k2, 0.5 * h));
    let k4 = f(&add(y, &k3, h));
    std::array::from_fn(|i| y[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn free_decay_matches_closed_form() {
        // Linear, viscous only: θ(t) = θ0 e^{−σt}(cos ω_d t + σ/ω_d sin ω_d t).
        let p = Pendulum::Torsion(Torsion {
            inertia_kgm2: 1.0,
            stiffness_nm_per_rad: 25.0,
            damping_ratio: 0.02,
            coulomb_nm: 0.0,
            swing: None,
        });
        let rel = Release {
            rest_s: 0.0,
            ramp_s: 0.0,
            hold_s: 0.0,
            amplitude_deg: 10.0,
            duration_s: 20.0,
        };
        let place = Placement {
            body_rest: UnitQuaternion::identity(),
            axis_heading_rad: 0.0,
            sensor_offset_m: Vector3::new(0.2, 0.0, 0.0),
        };
        let m = p.motion(&rel, &place, 100.0);
        let (w, z) = (5.0f64, 0.02);
        let (s, wd) = (z * w, w * (1.0 - z * z).sqrt());
        for (k, b) in m.iter().enumerate().step_by(97) {
            let t = k as f64 / 100.0;
            let want =
                10f64.to_radians() * (-s * t).exp() * ((wd * t).cos() + s / wd * (wd * t).sin());
            let got = b.orientation.scaled_axis().z;
            assert!((got - want).abs() < 1e-9, "t={t}: {got} vs {want}");
        }
    }
}
