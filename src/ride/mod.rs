//! Ride stage (dynamic tests, seed §5.4): a ride's log pair → θ(t), γ(t) → the experimental
//! weave eigenvalue, beside the model's.
//!
//! - [`read`]: the log pair → roll θ and steer γ on the 100 Hz grid, the kick and the catch,
//!   the speed from the reed switch.
//! - [`amplitude`]: a ride's fit → what the kick's size does to it, from the measured
//!   bicycle's nonlinear equations.
//! - [`dynamic`]: one ride or a campaign: window, speed, fit, the model beside it.
//! - [`speed`]: the speed where the eigenvalue applies, from the noted reading carried by
//!   the measured slowing, the reed switch, and the rolling kinematics, compared.
//! - [`csv`]: rides from other instruments (read in [`crate::read::ride_csv`]) → each free
//!   decay fitted, the speed from the wheel-speed column.
//! - [`kicks`]: a long recording's kicks and the free decay after each, from its roll rate.
//! - Campaigns and studies come from their manifests, read in [`crate::read::rides`] and
//!   [`crate::read::study`].
//! - [`model_weave`]: the model's oscillatory mode nearest a measured weave at the ride's
//!   speed, with its errors and shape: every instrument's ride set beside the model.
//! - [`modal`]: θ and γ over the free motion → the modes they share (weave σ ± iω, real
//!   modes), standard errors, mode shape.

pub mod amplitude;
pub mod csv;
pub mod dynamic;
pub mod kicks;
pub mod modal;
pub mod model_weave;
pub mod read;
pub mod speed;

pub use read::*;

/// A number given from outside (a speed reading, a sampling rate) outside the range its
/// quantity takes: "0.05 m/s is not a riding speed (expected from 0.1 to 30 m/s)".
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{} {unit} is not {what} (expected from {lo} to {hi} {unit})", crate::read::manifest::number_text(*.value))]
pub struct OutOfRange {
    pub value: f64,
    pub unit: &'static str,
    /// What a number in range is ("a riding speed").
    pub what: &'static str,
    pub lo: f64,
    pub hi: f64,
}

impl OutOfRange {
    /// `value` when finite and within `lo..=hi`, else the error naming `what` it is not.
    pub fn check(
        value: f64,
        (lo, hi): (f64, f64),
        unit: &'static str,
        what: &'static str,
    ) -> Result<f64, OutOfRange> {
        if value.is_finite() && (lo..=hi).contains(&value) {
            Ok(value)
        } else {
            Err(OutOfRange {
                value,
                unit,
                what,
                lo,
                hi,
            })
        }
    }
}
