//! My motionlab plugins. Each plugin is one file, registered with `register_plugin!` (a
//! built-in stage kind) or `register_custom_plugin!` (a kind of my own, declared in
//! `segment_classifier.rs`); this crate only has to be named by the binary
//! (`my-motionlab/src/main.rs`) to be linked.

pub mod by_duration;
pub mod fixed_interval;
pub mod segment_classifier;

/// What the plugins' unit tests share.
#[cfg(test)]
mod test_support {
    use motionlab_core::{Axis, FrameRate, Motion, PointKind};

    /// A motion of one marker that never moves: `n_frames` at `rate_hz`.
    pub fn still(n_frames: usize, rate_hz: f64) -> Motion {
        let rate = FrameRate::new(rate_hz).unwrap();
        Motion::new(
            "still",
            rate,
            Axis::Z,
            PointKind::Marker,
            vec!["m".into()],
            vec![[0.0; 3]; n_frames],
        )
        .unwrap()
    }
}
