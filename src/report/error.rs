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
    /// Whether a reader or a stage refused an input (malformed, or not analysable: the command
    /// exits with 2), rather than the machine, the model or a figure failing (1).
    pub fn is_input(&self) -> bool {
        use ReportError as E;
        match self {
            E::Log(_)
            | E::Signal(_)
            | E::Fit(_)
            | E::Analysis { .. }
            | E::Measure(_)
            | E::Inertia(_)
            | E::Measured(_)
            | E::Manifest(_)
            | E::Param(_)
            | E::Ride(_)
            | E::Sensitivity(_) => true,
            E::Read { .. } | E::Data(_) | E::Gap(_) | E::Tensor(_) | E::Output(_) => false,
            #[cfg(feature = "plot")]
            E::Plot(_) => false,
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
