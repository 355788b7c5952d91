//! The `motionlab` command with my plugins: every built-in command (`list`, `describe`, `run`,
//! `reproduce`, …) from `motionlab_cli`, plus the plugins of the crates named here.

// Naming the plugin crate keeps the linker from dropping its `inventory` registrations.
use my_segmenters as _;

fn main() -> std::process::ExitCode {
    motionlab_cli::main()
}
