//! The `tyndall` binary: see [`tyndall::cli`].

fn main() {
    // Before any thread starts: it may set an environment variable.
    tyndall::cli::ensure_runtime_dir();
    std::process::exit(tyndall::cli::main());
}
