//! `uvpin` command line; everything lives in the library.

fn main() -> std::process::ExitCode {
    uvpin::cli::main()
}
