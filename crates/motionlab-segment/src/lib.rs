//! # motionlab-segment
//!
//! Segmenters and fusers, one file each. A new segmenter is one file like
//! [`speed_minima`]: a documented params struct, a `ParamGuard` into the checked stage, the
//! `Segmenter` impl and one `register_plugin!` line — plus its `mod` line below.
//!
//! The `*_online` files are the three Sonoda trackers in causal form: streaming segmenters
//! (`motionlab_core::streaming`) that decide each candidate a stated number of frames after it,
//! the same candidates as the offline stage with the same parameters.

/// How many plugins this crate registers: the registry test (`tests/registry.rs`) checks the
/// binary holds exactly this many from this crate, so a plugin that silently vanishes (a
/// missing `mod` line, a crate left unlinked) fails it. Adding a plugin means counting it here.
pub const PLUGIN_COUNT: usize = 10;

/// The inputs the Sonoda stages' defaults were tuned on (`experiments/sonoda_defaults.toml`):
/// SHA-256 of CMU 86_01, 86_09 and mocap6 13_29, 13_30, 13_31, 14_14, 14_20 as shipped in
/// `data/` (`data/MANIFEST.md`). Declared in each of those plugins' schemas
/// ([`motionlab_core::registry::DEFAULTS_TUNED_ON_KEY`]), so an evaluation at the defaults says
/// per sequence whether it is scored on its own tuning data.
pub const SONODA_DEFAULTS_TUNED_ON: [&str; 7] = [
    "f3d98b96940de9107bc9bfa5a5ecec2a029cdb45713e333d7bc69a0893cfac07",
    "e4baaca37a4e7feb6888083f6d1e2d9307884a834d8bd39a944f8089d99a41f5",
    "5d652718c31a6e56aea62d6057d0257ae1144a414398ad8e1ff9a974ddd59b8a",
    "fe22588ae74eee5e5034cca7ce4f7b5dd5460f96da40c176b3981f8707e87438",
    "0527685d3d25f5fcf2d0b9ba92da6af092379433e9c809d76964892780076c6b",
    "bdeb88b304e912b5b691e89225bef1f8b0fca026eacbd35509e82d929e4afa77",
    "4bb31962cb2a7fd7758f97dfe3778609ada26a5904a51793130808291b5dc72a",
];

pub mod direction_change;
pub mod direction_change_online;
pub mod fastest_marker_speed;
pub mod fastest_marker_speed_online;
pub mod hull_volume_change;
pub mod hull_volume_change_online;
pub mod pca_error_rise;
pub mod segment_clusters;
pub mod speed_minima;
mod stream_frames;
#[cfg(test)]
mod test_data;
pub mod thresholds;
pub mod union_merge;
