//! Volume of the 3-D convex hull of a frame's markers and its change (Sonoda et al. §2.3).
//!
//! `Vol[i]` = volume (mm³) of the convex hull of every valid marker at frame `i`;
//! `D[i] = |Vol[i] − Vol[i−1]|` (mm³ per frame).
//!
//! # Why the hull is written here
//!
//! A body has 20–45 markers, and a sequence has thousands of frames. `parry3d-f64` (measured
//! here at 12 µs per 41-point frame) and `scipy.spatial.ConvexHull` (qhull, 61.5 µs with Python
//! overhead) are general-purpose and allocate per call, and neither can re-use last frame's
//! hull. The hull below is a quickhull with reusable buffers, and [`HullTracker`] exploits
//! temporal coherence: consecutive frames usually have the same hull combinatorics, which can be
//! *certified* much faster than rebuilt, and when they do not, the change is almost always local
//! (an edge flip, a point coming out, a vertex sinking in) and is *repaired* in place, then
//! certified, instead of rebuilt. See `crates/motionlab-features/benches/README.md` for the
//! measured numbers.
//!
//! # Robustness
//!
//! Real marker sets contain duplicates (two markers on one spot), coplanar and collinear subsets,
//! and missing samples. Every orientation decision ("is q above the plane of face f?") is exact:
//! a floating-point evaluation whose rounding error is bounded a priori (see [`Plane`](predicates::Plane)) decides
//! when the bound allows, and Shewchuk's adaptive exact `orient3d` (crate `robust`) decides the
//! rest. A point is added to the hull only when it is *strictly* above a face, so points on the
//! hull surface and duplicates are simply absorbed, and the quickhull invariants (visible region
//! is a disc, its horizon a simple cycle, orphaned outside points see a new face) hold exactly.
//! A frame with fewer than 4 valid points, or whose valid points are all collinear or coplanar
//! (exactly), has volume 0 and is **flagged** ([`Degeneracy`]); nothing panics and no NaN is
//! produced for a frame with valid points.
//!
//! # Temporal coherence ([`HullTracker`])
//!
//! Given last frame's triangles (as marker triples) and this frame's positions, the triangles
//! are still the hull when, for every triangle, every other valid point lies *strictly* below
//! its plane. Proof: such a triangle is then a facet of the convex hull (its plane supports the
//! set and touches it only at the triangle's three vertices); distinct facets that together form
//! a closed surface without boundary must be the whole boundary of the hull. The check is one
//! plane evaluation per (triangle, point) with an a-priori error bound; pairs the bound cannot
//! decide go to the exact predicate. With AVX2 + FMA (detected at run time) four triangles are
//! tested per instruction, one per lane, against each point in turn — the triangles' planes are
//! built lane-wise, each test is a multiply, two FMAs and a compare, and the same pass sums the
//! volume (see `uncertain_triangles_avx2` for the bound); other CPUs run a portable loop. Both
//! are checked against the exact predicate on near-degenerate grids far from the origin, and
//! must (and do) make the same decisions frame by frame on real takes. When it fails (a point
//! pokes out, an edge became reflex, or a hull vertex sank inward) the tracker first tries local
//! repairs of the triangles — edge flips, beneath–beyond insertion of the point, removal of a
//! degree-3 vertex — that keep the surface closed, and certifies the result the same way (so
//! the proof covers repaired triangles too). A triangle no repair applies to yet (a fold
//! elsewhere can put a hull vertex above it) is retried after the other failed triangles, whose
//! repairs often rewrite it; only when nothing applies is the hull rebuilt. On CMU 86_01 39 % of
//! the frames change combinatorics; all but 6 of those 1778 frames (the first among them) are
//! repaired. Each triangle's term of the volume comes out of its certification, so a repaired
//! frame's volume costs no extra pass.
//!
//! **Missing samples:** the hull is taken over the valid markers of the frame only. `D[i]` is
//! NaN when the set of valid markers differs between frames `i−1` and `i` (a marker dropping out
//! changes the hull without any movement, so its jump is not a body change), or when either frame
//! is degenerate (flagged), and at `i = 0`.

mod hull_volume;
mod kernel;
#[cfg(target_arch = "x86_64")]
mod kernel_avx2;
mod predicates;
mod quickhull;
#[cfg(test)]
mod tests;
mod tracker;

use motionlab_core::Point3;
use serde::Serialize;

pub use hull_volume::{HullVolumeParams, HullVolumes, cached_hull_volumes, hull_volumes};
pub use quickhull::{HullBuilder, convex_hull_volume};
pub use tracker::{HullTracker, TrackerStats};

const NONE: u32 = u32::MAX;

/// Why a frame has no proper hull (its volume is reported as 0).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Degeneracy {
    /// Fewer than 4 valid points.
    TooFewPoints,
    /// All valid points coincide or lie on one line.
    Collinear,
    /// All valid points lie in one plane.
    Coplanar,
}

/// The hull of one point set.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HullVolume {
    /// Volume in mm³ (0 when degenerate).
    pub volume_mm3: f64,
    /// Set when the valid points span less than 3 dimensions.
    pub degenerate: Option<Degeneracy>,
}

#[inline(always)]
fn sub(a: Point3, b: Point3) -> Point3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// All three coordinates finite (the sample is not missing)?
fn is_finite(p: Point3) -> bool {
    p.iter().all(|c| c.is_finite())
}
