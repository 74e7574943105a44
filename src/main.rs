//! The `bikeproc` command: the command line ([`cli`]) over the library. Exit code 0 on
//! success, 2 when an input is malformed or cannot be analysed, 1 otherwise.

mod cli;

fn main() -> std::process::ExitCode {
    cli::main()
}
