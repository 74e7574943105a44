//! What the commands write: standard output (JSON or text) that fails cleanly when its reader
//! has gone, files replaced in one step, and progress on a terminal (indicatif; hidden when
//! standard error is not a terminal and with `--json`).

use anyhow::Result;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::path::Path;

/// Writes through a temporary file and a rename: a reader never sees half a file.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    Ok(bikeproc::output::write_atomic(path, bytes)?)
}

/// Refuses, before any work, an output file that is one of the inputs (`inputs` and the
/// optional `more`): writing it would destroy what the command reads.
pub fn refuse_files_over_inputs(
    outputs: &[&Path],
    inputs: &[&Path],
    more: Option<&Path>,
) -> Result<()> {
    let mut all = inputs.to_vec();
    all.extend(more);
    Ok(bikeproc::output::refuse_files_over_inputs(outputs, &all)?)
}

/// Prints JSON (`--json`) or the plain text.
pub fn emit<T: serde::Serialize>(
    json: bool,
    value: &T,
    text: impl FnOnce() -> String,
) -> Result<()> {
    if json {
        // Streamed to standard output: a million speeds' JSON is a gigabyte, never held whole.
        use std::io::Write as _;
        let mut stdout = std::io::BufWriter::with_capacity(1 << 16, std::io::stdout().lock());
        serde_json::to_writer_pretty(&mut stdout, value)
            .map_err(std::io::Error::from)
            .and_then(|()| stdout.write_all(b"\n"))
            .and_then(|()| stdout.flush())
            .map_err(stdout_error)
    } else {
        out(&text())
    }
}

/// Whether standard output was closed when bikeproc started (`>&-`). Rust's runtime opens
/// `/dev/null` read-write on a standard descriptor it finds closed, before `main`, so what is
/// written there is lost and `--version >&-` ended with 0. A shell's `> /dev/null` opens it
/// write-only: `/dev/null` open read-write on descriptor 1 is taken as closed.
pub fn stdout_closed() -> bool {
    use rustix::fs::{fcntl_getfl, fstat, stat, OFlags};
    let out = std::io::stdout();
    let (Ok(mode), Ok(st), Ok(null)) = (fcntl_getfl(&out), fstat(&out), stat("/dev/null")) else {
        return false;
    };
    let same_device = st.st_rdev == null.st_rdev && st.st_ino == null.st_ino;
    same_device && (mode & OFlags::RWMODE) == OFlags::RDWR
}

/// Whether a message to standard error could not be written (a full disk, a closed or gone
/// reader): the command then ends with exit code 1 ([`super::main`]).
pub static STDERR_FAILED: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Writes a line to standard error, never panicking (as `eprintln!` does when it cannot);
/// a failure is remembered in [`STDERR_FAILED`].
pub fn note_line(line: &str) {
    use std::io::Write as _;
    let mut stderr = std::io::stderr().lock();
    if writeln!(stderr, "{line}")
        .and_then(|()| stderr.flush())
        .is_err()
    {
        STDERR_FAILED.store(true, std::sync::atomic::Ordering::SeqCst);
    }
}

/// [`note_line`] with `format!` arguments.
macro_rules! note {
    ($($arg:tt)*) => {
        $crate::cli::io::note_line(&format!($($arg)*))
    };
}
pub(crate) use note;

/// Writes to standard output: a reader that has gone (`bikeproc … | head`) or a full disk is
/// an error (exit 1) naming standard output, never a panic. (A standard stream closed at the
/// start, `>&-`, is /dev/null to a Rust program: its runtime reopens it so.)
pub fn out(text: &str) -> Result<()> {
    use std::io::Write as _;
    let mut stdout = std::io::stdout().lock();
    stdout
        .write_all(text.as_bytes())
        .and_then(|()| stdout.flush())
        .map_err(stdout_error)
}

/// A failed write to standard output, said as what happened to it.
fn stdout_error(e: std::io::Error) -> anyhow::Error {
    match e.kind() {
        std::io::ErrorKind::BrokenPipe => {
            anyhow::anyhow!("standard output: its reader has gone (broken pipe); output cut short")
        }
        _ => anyhow::anyhow!("standard output: {e}"),
    }
}

/// A progress bar on standard error, `[####    ] done/total what`; drawn only on a terminal
/// (indicatif's standard-error target) and never with `--json`.
pub fn progress(json: bool) -> ProgressBar {
    let bar = ProgressBar::with_draw_target(
        None,
        if json {
            ProgressDrawTarget::hidden()
        } else {
            ProgressDrawTarget::stderr()
        },
    );
    if let Ok(style) = ProgressStyle::with_template("[{bar:30}] {pos}/{len} {msg}") {
        bar.set_style(style.progress_chars("## "));
    }
    bar
}

/// Shows `done` of `total` of the stage `what` on `bar` (the caller clears it at the end).
pub fn advance(bar: &ProgressBar, what: &str, done: usize, total: usize) {
    if bar.message() != what {
        bar.set_message(what.to_string());
    }
    bar.set_length(total as u64);
    bar.set_position(done as u64);
}
