//! The `motionlab` command with my plugins: every built-in command (`list`, `describe`, `run`,
//! `reproduce`, …) from `motionlab_cli`, plus the plugins and workflows of the crates named here.

// Naming the plugin and workflow crates keeps the linker from dropping their `inventory`
// registrations.
use my_segmenters as _;
use my_workflows as _;

fn main() -> std::process::ExitCode {
    motionlab_cli::main()
}
