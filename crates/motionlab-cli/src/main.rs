//! The `motionlab` binary: everything is in the library (src/lib.rs), so that a plugin crate
//! outside this workspace can build the same command with its plugins linked in.

fn main() -> std::process::ExitCode {
    motionlab_cli::main()
}
