//! What the streaming (`*_online`) trackers share: reading a stream's frames of points.

use motionlab_core::streaming::check_sample;
use motionlab_core::{DataKind, Error, ErrorKind, Point3, Result, StreamLayout};

/// The layout's points, or an error naming the stage when the stream carries channels.
pub(crate) fn require_points(layout: &StreamLayout, stage: &str) -> Result<usize> {
    if layout.kind != DataKind::Points || layout.names.is_empty() {
        return Err(Error::new(
            ErrorKind::InvalidParameter,
            format!(
                "{stage} reads frames of marker or joint positions, and this stream carries {}",
                if layout.kind == DataKind::Points { "no point" } else { "channels" }
            ),
        ));
    }
    Ok(layout.names.len())
}

/// One frame of `m` points from a sample (x, y, z per point, mm), checked: a point with any
/// non-finite coordinate is missing and becomes all NaN, as a loaded motion's are.
pub(crate) fn frame_points(
    sample: &[f64],
    m: usize,
    index: usize,
    stage: &str,
    out: &mut Vec<Point3>,
) -> Result<()> {
    check_sample(sample, 3 * m, index, stage)?;
    out.clear();
    out.extend(
        sample.chunks_exact(3).map(|p| {
            if p.iter().all(|c| c.is_finite()) { [p[0], p[1], p[2]] } else { [f64::NAN; 3] }
        }),
    );
    Ok(())
}
