//! Why the reports could not be made: an input of `data/` or `../shared/reference` that cannot be
//! read or analysed (the stage's own error, naming its file), or an output that cannot be
//! written.

use std::path::{Path, PathBuf};

/// An error of the report set, by where it arose.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    /// A folder or file of the inputs that cannot be read (`what` names it; the cause is the
    /// source).
    #[error("{what}")]
    Read {
        what: String,
        source: std::io::Error,
    },
    /// A recording whose free decay could not be fitted (the cause is the source).
    #[error("{}", path.display())]
    Analysis {
        path: PathBuf,
        source: crate::fit::FitError,
    },
    /// An input read but not fit for its report (a column missing, no eigenvalue where one
    /// must be).
    #[error("{0}")]
    Data(String),
    #[error(transparent)]
    Log(#[from] crate::read::log::LogError),
    #[error(transparent)]
    Signal(#[from] crate::signal::SignalError),
    #[error(transparent)]
    Fit(#[from] crate::fit::FitError),
    #[error(transparent)]
    Measure(#[from] crate::fit::MeasureError),
    #[error(transparent)]
    Inertia(#[from] crate::inertia::InertiaError),
    #[error(transparent)]
    Measured(#[from] crate::inertia::measured::MeasuredError),
    #[error(transparent)]
    Manifest(#[from] crate::read::manifest::ManifestError),
    #[error(transparent)]
    Param(#[from] crate::model::ParamError),
    #[error(transparent)]
    Ride(#[from] crate::ride::RideError),
    #[error(transparent)]
    Gap(#[from] crate::gap::GapError),
    #[error(transparent)]
    Tensor(#[from] crate::inertia::TensorError),
    #[error(transparent)]
    Sensitivity(#[from] crate::model::sensitivity::SensitivityError),
    #[cfg(feature = "plot")]
    #[error(transparent)]
    Plot(#[from] crate::plot::PlotError),
    /// The reports' folder could not be written.
    #[error(transparent)]
    Output(#[from] crate::output::OutputError),
}

impl ReportError {
    /// The stage's own error this one wraps (for a read or a fit, its cause), by which the
    /// command decides its exit code as for the stage's error met directly; `None` for an
    /// input unfit for its report ([`ReportError::Data`]).
    pub fn stage_error(&self) -> Option<&(dyn std::error::Error + 'static)> {
        use ReportError as E;
        match self {
            E::Read { source, .. } => Some(source),
            E::Analysis { source, .. } => Some(source),
            E::Data(_) => None,
            E::Log(e) => Some(e),
            E::Signal(e) => Some(e),
            E::Fit(e) => Some(e),
            E::Measure(e) => Some(e),
            E::Inertia(e) => Some(e),
            E::Measured(e) => Some(e),
            E::Manifest(e) => Some(e),
            E::Param(e) => Some(e),
            E::Ride(e) => Some(e),
            E::Gap(e) => Some(e),
            E::Tensor(e) => Some(e),
            E::Sensitivity(e) => Some(e),
            #[cfg(feature = "plot")]
            E::Plot(e) => Some(e),
            E::Output(e) => Some(e),
        }
    }
}

/// The report stage's results.
pub type Result<T, E = ReportError> = std::result::Result<T, E>;

/// `Err(ReportError::Read)` saying `what` was being read, for an I/O error.
pub(super) fn reading<T>(what: String, r: std::io::Result<T>) -> Result<T> {
    r.map_err(|source| ReportError::Read { what, source })
}

/// `Err(ReportError::Analysis)` naming the recording at `path`, for a fit's error.
pub(super) fn analysing<T>(
    path: &Path,
    r: std::result::Result<T, crate::fit::FitError>,
) -> Result<T> {
    r.map_err(|source| ReportError::Analysis {
        path: path.to_path_buf(),
        source,
    })
}
