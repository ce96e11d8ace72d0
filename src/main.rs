//! The `tyndall` binary: see [`tyndall::cli`].

fn main() {
    std::process::exit(tyndall::cli::main());
}
