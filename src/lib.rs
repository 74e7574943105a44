//! bikeproc: from the raw IMU logs of a bicycle-dynamics lab to inertias, Whipple-model
//! eigenvalues and the sim-to-real gap.
//!
//! The data flow, one module per stage:
//!
//! ```text
//! read ──► signal ──► spectral ──► fit ──► (inertia ──► model ──► ride ──► gap)
//!  ▲                                                                    │
//!  └──────────── sim (writes logs from its own physics) ────  report ◄──┘
//! ```
//!
//! - [`read`]: every file from outside (IMU logs, tables, manifests, bicycle files), recognised
//!   by content → checked values.
//! - [`signal`]: a log or CSV → one scalar oscillation signal.
//! - [`spectral`]: a signal → its spectrum and peaks (the fit's first guess).
//! - [`fit`]: a signal → free-decay segment, damped-sinusoid fit, standard errors.
//! - [`inertia`]: test folders → bar stiffness, moments, tensors (with standard errors).
//! - [`model`]: bicycle parameters → the linear Whipple model, eigenvalues, stable speeds.
//! - [`ride`]: a ride's log pair → θ(t), γ(t), the weave eigenvalue after the kick, the model's.
//! - [`gap`]: a campaign's eigenvalues and the measured bicycle → where they part, which
//!   unmodelled effect explains it, how far it shrinks on rides left out.
//! - [`sim`]: the lab simulated from physics (never calls the estimators; no analysis module
//!   uses it, and it uses none, `tests/layering.rs`).
//! - [`blind`]: simulated campaigns and studies diagnosed from their files and compared with
//!   their sealed truth: the calibrations, above both.
//! - [`report`]: the checked-in reports, regenerated from `data/` and the reference signals
//!   (one file per report).
//! - `plot` (feature `plot`): SVG figures for the reports.
//! - [`output`]: every file written whole, a report folder replaced as a whole.
//! - [`fuzzing`]: the readers of outside files as fuzz targets.

pub mod blind;
pub mod fit;

/// The most sweeps an iterative decomposition (SVD, symmetric eigen) may take: they converge
/// in tens; a matrix that needs more holds something no data gives (NaN, 1e300), and is an
/// error rather than a loop without end.
pub const MAX_DECOMPOSITION_ITERATIONS: usize = 1_000;
pub mod fuzzing;
pub mod gap;
pub mod inertia;
pub mod jet;
pub mod model;
pub mod output;
#[cfg(feature = "plot")]
pub mod plot;
pub mod read;
pub mod report;
pub mod ride;
pub mod signal;
pub mod sim;
pub mod spectral;
pub mod stats;
#[cfg(test)]
mod testing;
pub mod uncertainty;
