//! The `bikeproc` command: the command line ([`cli`]) over the library.
//!
//! Exit codes (`cli::Exit`, decided from the error's kind in `cli::exit_for` alone):
//!
//! | code | when |
//! |---|---|
//! | 0 | done (`--help` and `--version` included) |
//! | 1 | anything else: a file that cannot be read or written for the machine's reasons, standard output or standard error gone, the model or a figure failing |
//! | 2 | the command line or an input: an unknown or malformed option, a value refused for its range, an option the input does not take, an input malformed, of another kind than the command reads, or not analysable (no ride of a campaign analysed), an output that would overwrite an input |
//! | 3 | `design` did not reach its target range (the closest design is printed) |

mod cli;

fn main() -> std::process::ExitCode {
    cli::main()
}
