//! # motionlab-plugins
//!
//! The one list of the crates whose plugins and workflows motionlab links. Plugins register
//! themselves with `inventory`, so nothing calls a plugin crate by name, and a crate nothing
//! names is not linked: its plugins vanish silently. This crate names every one (one entry of
//! [`linked_crates!`] below, one dependency line in its Cargo.toml), and every front end names
//! this crate once:
//!
//! ```ignore
//! use motionlab_plugins as _; // links every built-in plugin and workflow crate
//! ```
//!
//! The CLI and the Python package do so; `tests/registry.rs` checks each crate of [`LINKED`]
//! registers exactly its declared count and that no plugin comes from elsewhere, and
//! `tests/docs_truth.rs` checks this list against this crate's Cargo.toml and the crate table of
//! `docs/ARCHITECTURE.md`.

/// A crate this bundle links, with what it says it registers (its `PLUGIN_COUNT` and
/// `WORKFLOW_COUNT`; 0 for a crate without them).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LinkedCrate {
    /// The package name, as the registry records it (`motionlab-segment`).
    pub package: &'static str,
    pub plugins: usize,
    pub workflows: usize,
}

/// One `use … as _;` line (what keeps the linker from dropping the crate's registrations) and
/// one [`LINKED`] entry per crate.
macro_rules! linked_crates {
    ($($krate:ident => $package:literal { plugins: $p:expr, workflows: $w:expr }),* $(,)?) => {
        $(use $krate as _;)*
        /// Every linked crate, in package-name order.
        pub const LINKED: &[LinkedCrate] =
            &[$(LinkedCrate { package: $package, plugins: $p, workflows: $w }),*];
    };
}

// A new plugin crate: one line here (in name order) and one dependency in Cargo.toml.
linked_crates! {
    motionlab_changepoint => "motionlab-changepoint" { plugins: motionlab_changepoint::PLUGIN_COUNT, workflows: 0 },
    motionlab_eval => "motionlab-eval" { plugins: motionlab_eval::PLUGIN_COUNT, workflows: 0 },
    motionlab_external => "motionlab-external" { plugins: motionlab_external::PLUGIN_COUNT, workflows: 0 },
    motionlab_features => "motionlab-features" { plugins: motionlab_features::PLUGIN_COUNT, workflows: 0 },
    motionlab_gait => "motionlab-gait" { plugins: motionlab_gait::PLUGIN_COUNT, workflows: 0 },
    motionlab_io => "motionlab-io" { plugins: motionlab_io::PLUGIN_COUNT, workflows: 0 },
    motionlab_match => "motionlab-match" { plugins: motionlab_match::PLUGIN_COUNT, workflows: 0 },
    // The `channels` loader's Parquet format: no plugin of its own, a format it registers.
    motionlab_parquet => "motionlab-parquet" { plugins: 0, workflows: 0 },
    motionlab_profile => "motionlab-profile" { plugins: motionlab_profile::PLUGIN_COUNT, workflows: 0 },
    motionlab_segment => "motionlab-segment" { plugins: motionlab_segment::PLUGIN_COUNT, workflows: 0 },
    motionlab_workflows => "motionlab-workflows" { plugins: 0, workflows: motionlab_workflows::WORKFLOW_COUNT },
}

/// The linked crate of a package name.
pub fn find(package: &str) -> Option<&'static LinkedCrate> {
    LINKED.iter().find(|c| c.package == package)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_list_is_sorted_and_each_crate_registers_something_or_says_why_not() {
        let names: Vec<&str> = LINKED.iter().map(|c| c.package).collect();
        let mut sorted = names.clone();
        sorted.sort();
        sorted.dedup();
        assert_eq!(names, sorted, "LINKED must be in name order without duplicates");
        assert_eq!(
            find("motionlab-segment").map(|c| c.plugins),
            Some(motionlab_segment::PLUGIN_COUNT)
        );
        assert!(find("motionlab-cli").is_none());
    }
}
