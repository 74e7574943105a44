//! The `bikeproc` command: the command line ([`cli`]) over the library. Exit code 0 on
//! success; 2 when an input is malformed or cannot be analysed, an option is refused for its
//! value or for the input it came with, or an output would overwrite an input; 3 when
//! `design` does not reach its target range (the closest design is printed); 1 otherwise.

mod cli;

fn main() -> std::process::ExitCode {
    cli::main()
}
