//! The `helixbif` command line ([`cli`]).

mod cli;

fn main() -> std::process::ExitCode {
    cli::main()
}
