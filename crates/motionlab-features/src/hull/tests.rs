//! Tests of the hull: known volumes, exact predicates on degenerate inputs, the tracker against
//! rebuilding on real takes, and the AVX2 and portable kernels against each other.

use super::kernel::{Soa, uncertain_triangles_portable};
#[cfg(target_arch = "x86_64")]
use super::kernel_avx2::uncertain_triangles_avx2;
use super::predicates::{orient_exact, orient_fast};
use super::*;
use motionlab_core::Motion;
use motionlab_testkit::{Rng, cube_corners, motion_from_fn};

use crate::simd::FORCE_PORTABLE;

fn vol(points: &[Point3]) -> f64 {
    let h = convex_hull_volume(points);
    assert_eq!(h.degenerate, None, "{points:?}");
    h.volume_mm3
}

fn close(a: f64, b: f64, rel: f64) -> bool {
    (a - b).abs() <= rel * a.abs().max(b.abs())
}

/// Independent computation: parry3d's convex hull (`try_convex_hull`), its volume by the
/// divergence theorem about the points' centroid. (parry's `ConvexPolyhedron` mass
/// properties were not used: they merge nearly coplanar faces with a tolerance and were
/// found up to 1e-6 relative off on real frames, e.g. dance1 frame 237, where scipy/qhull
/// and parry's own triangles agree with ours to 1e-15.)
fn parry_volume(points: &[Point3]) -> f64 {
    let pts: Vec<parry3d_f64::math::Vector> =
        points.iter().map(|p| parry3d_f64::math::Vector::new(p[0], p[1], p[2])).collect();
    let (verts, idx) = parry3d_f64::transformation::try_convex_hull(&pts).expect("parry hull");
    let c = points
        .iter()
        .fold([0.0; 3], |a, q| [a[0] + q[0], a[1] + q[1], a[2] + q[2]])
        .map(|x| x / points.len() as f64);
    let v = |i: u32| {
        let p = verts[i as usize];
        [p.x, p.y, p.z]
    };
    idx.iter()
        .map(|t| {
            let (a, b, d) = (sub(v(t[0]), c), sub(v(t[1]), c), sub(v(t[2]), c));
            a[0] * (b[1] * d[2] - b[2] * d[1]) - a[1] * (b[0] * d[2] - b[2] * d[0])
                + a[2] * (b[0] * d[1] - b[1] * d[0])
        })
        .sum::<f64>()
        / 6.0
}

fn rotate(p: Point3, axis: Point3, angle: f64) -> Point3 {
    // Rodrigues' rotation about a unit axis.
    let (s, c) = angle.sin_cos();
    let k = axis;
    let kxp = [k[1] * p[2] - k[2] * p[1], k[2] * p[0] - k[0] * p[2], k[0] * p[1] - k[1] * p[0]];
    let kdp = k[0] * p[0] + k[1] * p[1] + k[2] * p[2];
    [0, 1, 2].map(|i| p[i] * c + kxp[i] * s + k[i] * kdp * (1.0 - c))
}

#[test]
fn unit_cube_is_one_also_with_interior_surface_and_duplicate_points() {
    let cube = cube_corners([0.0; 3], 1.0);
    assert_eq!(vol(&cube), 1.0);
    let mut more = cube.clone();
    more.extend_from_slice(&cube); // every corner twice
    more.push([0.5, 0.5, 0.5]); // centre
    more.extend([
        [0.5, 0.5, 0.0],
        [0.5, 0.5, 1.0],
        [0.0, 0.5, 0.5],
        [0.5, 0.0, 0.0],
        [1.0, 1.0, 0.5],
    ]); // on faces/edges
    assert!(close(vol(&more), 1.0, 1e-15), "{}", vol(&more));
    // A regular grid on the cube: many exactly coplanar facets and collinear edge points.
    let grid: Vec<Point3> = (0..125)
        .map(|i| [(i % 5) as f64 * 0.25, (i / 5 % 5) as f64 * 0.25, (i / 25) as f64 * 0.25])
        .collect();
    assert!(close(vol(&grid), 1.0, 1e-15), "{}", vol(&grid));
}

#[test]
fn regular_tetrahedron_has_its_exact_volume() {
    // Alternate corners of a cube of side s: a regular tetrahedron of edge a = s√2.
    let s = 300.0;
    let tet = [[0.0, 0.0, 0.0], [s, s, 0.0], [s, 0.0, s], [0.0, s, s]];
    let a = s * 2f64.sqrt();
    let exact = a * a * a / (6.0 * 2f64.sqrt());
    assert!(close(vol(&tet), exact, 1e-14), "{} vs {exact}", vol(&tet));
    assert!(close(exact, s * s * s / 3.0, 1e-14)); // the same number another way
}

#[test]
fn random_points_in_a_cube_never_exceed_it_and_match_parry() {
    let mut rng = Rng::new(7);
    for trial in 0..200 {
        let n = 4 + trial % 60;
        let pts: Vec<Point3> = (0..n)
            .map(|_| [rng.uniform() * 1000.0, rng.uniform() * 1000.0, rng.uniform() * 1000.0])
            .collect();
        let v = vol(&pts);
        assert!(v > 0.0 && v <= 1e9, "trial {trial}: {v}");
        let p = parry_volume(&pts);
        assert!(close(v, p, 1e-9), "trial {trial}, {n} points: ours {v}, parry {p}");
    }
}

#[test]
fn planar_collinear_and_tiny_sets_are_flagged_with_volume_zero() {
    let square: Vec<Point3> =
        (0..20).map(|i| [(i % 5) as f64 * 10.0, (i / 5) as f64 * 7.0, 250.0]).collect();
    assert_eq!(
        convex_hull_volume(&square),
        HullVolume { volume_mm3: 0.0, degenerate: Some(Degeneracy::Coplanar) }
    );
    // A tilted plane through non-representable coefficients: still exactly coplanar points?
    // Use integer coordinates on x + 2y − z = 5 so the plane is exact.
    let tilted: Vec<Point3> = (0..30)
        .map(|i| {
            let (x, y) = ((i % 6) as f64 * 3.0, (i / 6) as f64 * 5.0);
            [x, y, x + 2.0 * y - 5.0]
        })
        .collect();
    assert_eq!(convex_hull_volume(&tilted).degenerate, Some(Degeneracy::Coplanar));
    let line: Vec<Point3> = (0..10).map(|i| [i as f64, 2.0 * i as f64, -3.0 * i as f64]).collect();
    assert_eq!(convex_hull_volume(&line).degenerate, Some(Degeneracy::Collinear));
    assert_eq!(convex_hull_volume(&[[1.0, 2.0, 3.0]; 9]).degenerate, Some(Degeneracy::Collinear));
    let three = [[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
    assert_eq!(
        convex_hull_volume(&three),
        HullVolume { volume_mm3: 0.0, degenerate: Some(Degeneracy::TooFewPoints) }
    );
    // NaN points are skipped: 8 cube corners with 5 missing leave 3 -> too few.
    let mut cube = cube_corners([0.0; 3], 1.0);
    for p in cube.iter_mut().take(5) {
        *p = [f64::NAN; 3];
    }
    assert_eq!(convex_hull_volume(&cube).degenerate, Some(Degeneracy::TooFewPoints));
    // Coplanar points plus one off the plane: a proper (thin) hull, not flagged.
    let mut thin = square.clone();
    thin.push([20.0, 10.0, 250.5]);
    let v = vol(&thin);
    assert!(close(v, 40.0 * 21.0 * 0.5 / 3.0, 1e-12), "{v}"); // pyramid: base · height / 3
}

#[test]
fn duplicates_do_not_change_the_volume() {
    let mut rng = Rng::new(11);
    let pts: Vec<Point3> = (0..30)
        .map(|_| [rng.normal() * 300.0, rng.normal() * 300.0, rng.normal() * 500.0 + 1000.0])
        .collect();
    let v = vol(&pts);
    let mut dup = pts.clone();
    dup.extend(pts.iter().step_by(3).copied());
    dup.insert(0, pts[7]);
    assert_eq!(vol(&dup).to_bits(), v.to_bits().max(vol(&dup).to_bits()).min(vol(&dup).to_bits()));
    assert!(close(vol(&dup), v, 1e-14), "{} vs {v}", vol(&dup));
}

#[test]
fn volume_is_invariant_under_rotation_and_translation() {
    let mut rng = Rng::new(3);
    let pts: Vec<Point3> = (0..40)
        .map(|_| [rng.normal() * 200.0, rng.normal() * 150.0, rng.normal() * 600.0])
        .collect();
    let v = vol(&pts);
    let axis = {
        let a: Point3 = [0.3, -0.5, 0.81];
        let n = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
        a.map(|c| c / n)
    };
    for (angle, shift) in
        [(0.7, [1000.0, -2500.0, 800.0]), (2.9, [-3.0e4, 1.0e4, 5.0]), (-1.3, [0.0; 3])]
    {
        let moved: Vec<Point3> = pts
            .iter()
            .map(|&p| {
                let r = rotate(p, axis, angle);
                [r[0] + shift[0], r[1] + shift[1], r[2] + shift[2]]
            })
            .collect();
        assert!(close(vol(&moved), v, 1e-9), "angle {angle}: {} vs {v}", vol(&moved));
    }
}

#[test]
fn tracker_equals_rebuilding_every_frame_and_reuses_hulls() {
    // 30 markers drifting smoothly, one of them missing for a stretch, one frame flattened.
    let mut rng = Rng::new(5);
    let base: Vec<Point3> = (0..30)
        .map(|_| [rng.normal() * 300.0, rng.normal() * 300.0, rng.normal() * 600.0])
        .collect();
    let phase: Vec<f64> = (0..30).map(|_| rng.uniform() * std::f64::consts::TAU).collect();
    let m = motion_from_fn(400, 120.0, 30, |i, k| {
        if (100..120).contains(&i) && k == 4 {
            return [f64::NAN; 3];
        }
        let t = i as f64 / 120.0;
        let p = base[k];
        let z = if i == 300 { 0.0 } else { p[2] * (1.0 + 0.2 * (3.0 * t + phase[k]).sin()) };
        [p[0] + 50.0 * (2.0 * t + phase[k]).sin(), p[1] + 40.0 * (1.5 * t).cos(), z]
    });
    let h = hull_volumes(&m);
    let mut scratch = HullBuilder::new();
    for i in 0..m.n_frames() {
        let valid: Vec<Point3> = m.frame(i).iter().copied().filter(|p| p[0].is_finite()).collect();
        let want = scratch.volume(&valid);
        assert_eq!(h.degenerate[i], want.degenerate, "frame {i}");
        assert!(
            close(h.volume_mm3[i], want.volume_mm3, 1e-12),
            "frame {i}: {} vs {}",
            h.volume_mm3[i],
            want.volume_mm3
        );
    }
    assert_eq!(h.flagged_frames(), vec![300]);
    assert!(h.stats.reused > 200, "{:?}", h.stats);
    assert_eq!(h.stats.reused + h.stats.repaired + h.stats.rebuilt + h.stats.degenerate, 400);
    // D: NaN at 0, where the marker set changes (100 and 120) and next to the flat frame.
    let d = &h.change_mm3_per_frame;
    for i in [0, 100, 120, 300, 301] {
        assert!(d[i].is_nan(), "D[{i}] = {}", d[i]);
    }
    assert!(d[101].is_finite() && d[200].is_finite());
    assert_eq!(d[200], (h.volume_mm3[200] - h.volume_mm3[199]).abs());
    assert_eq!(h.n_valid[110], 29);
}

#[test]
fn a_point_crossing_a_face_is_caught() {
    // A tetrahedron (all facets triangles, so its triangles are certifiable) with a marker
    // moving from inside out through the face x + y + z = 300: the reused triangles must be
    // rejected the moment the point is above that face, even by 1e-9 mm.
    let mut tracker = HullTracker::new();
    let mut pts = vec![
        [0.0, 0.0, 0.0],
        [300.0, 0.0, 0.0],
        [0.0, 300.0, 0.0],
        [0.0, 0.0, 300.0],
        [100.0, 100.0, 99.0],
    ];
    let tet = 300.0f64.powi(3) / 6.0;
    assert_eq!(tracker.frame(&pts).volume_mm3, tet);
    pts[4][2] = 99.5;
    assert_eq!(tracker.frame(&pts).volume_mm3, tet);
    assert_eq!(
        tracker.stats(),
        TrackerStats { reused: 1, repaired: 0, rebuilt: 1, degenerate: 0, repairs: 0 }
    );
    // On the face: still the tetrahedron, but certification demands *strictly* below, so
    // the hull is rebuilt (same volume).
    pts[4][2] = 100.0;
    assert_eq!(tracker.frame(&pts).volume_mm3, tet);
    assert_eq!(tracker.stats().rebuilt, 2);
    pts[4][2] = 100.0 + 1e-9;
    let v = tracker.frame(&pts).volume_mm3;
    // The added sliver: det[b−a, c−a, p−a]/6 = 90000 · 1e-9 / 6 = 1.5e-5 mm³.
    assert!(v > tet, "{v}");
    assert!((v - (tet + 1.5e-5)).abs() < 1e-8, "{v}");
    // Repaired by inserting the point into last frame's triangles (not rebuilt), and the
    // repaired triangles were certified.
    assert_eq!(tracker.stats().rebuilt, 2);
    assert_eq!(tracker.stats().repaired, 1);
    // Back inside: the point (now a hull vertex of degree 3) is removed again.
    pts[4][2] = 99.0;
    assert_eq!(tracker.frame(&pts).volume_mm3, tet);
    assert_eq!((tracker.stats().rebuilt, tracker.stats().repaired), (2, 2));
    // Exactly coplanar facets (a cube's squares) are never certified, always rebuilt.
    let cube = cube_corners([0.0; 3], 100.0);
    let mut t2 = HullTracker::new();
    for _ in 0..3 {
        assert_eq!(t2.frame(&cube).volume_mm3, 1e6);
    }
    assert_eq!(t2.stats().reused, 0);
}

#[test]
fn repairs_equal_rebuilding_on_jittering_point_clouds() {
    // Points near a sphere (many flips, points coming out and sinking in every frame),
    // jitter from tiny to large: every frame equals a from-scratch hull, and most frames
    // are repaired rather than rebuilt.
    for (seed, jitter) in [(1u64, 0.5), (2, 3.0), (3, 20.0), (4, 150.0)] {
        let mut rng = Rng::new(seed);
        let base: Vec<Point3> = (0..40)
            .map(|_| {
                let v = [rng.normal(), rng.normal(), rng.normal()];
                let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
                let r = 400.0 + 40.0 * rng.uniform();
                v.map(|c| r * c / n)
            })
            .collect();
        let mut walk = base.clone();
        let frames: Vec<Vec<Point3>> = (0..300)
            .map(|_| {
                for p in walk.iter_mut() {
                    for c in p.iter_mut() {
                        *c += jitter * rng.normal();
                    }
                }
                walk.clone()
            })
            .collect();
        let m = motion_from_fn(300, 120.0, 40, |i, k| frames[i][k]);
        let mut t = HullTracker::new();
        let worst = max_rel_diff_tracker_vs_rebuild(&m, &mut t);
        assert!(worst <= 1e-12, "seed {seed}: {worst}");
        let st = t.stats();
        assert_eq!(st.reused + st.repaired + st.rebuilt + st.degenerate, 300);
        if jitter < 10.0 {
            assert!(st.rebuilt < 60, "seed {seed}: {st:?}");
        }
    }
}

/// `pts` in both the portable and the AVX2 layout, whichever `Soa::fill` chose on this CPU.
fn soa_in_both_layouts(pts: &[Point3]) -> Soa {
    let mut soa = Soa::default();
    let keep: Vec<u32> = (0..pts.len() as u32).collect();
    assert!(soa.fill(pts, &keep, &mut Vec::new()));
    (soa.xs, soa.ys, soa.zs) = (
        pts.iter().map(|p| p[0]).collect(),
        pts.iter().map(|p| p[1]).collect(),
        pts.iter().map(|p| p[2]).collect(),
    );
    soa.wide = pts.iter().map(|p| p.map(|c| [c; 4])).collect();
    soa
}

/// Exact: every point other than the vertices of `t` strictly below its plane?
fn exactly_certified(pts: &[Point3], t: [u32; 3]) -> bool {
    let [a, b, c] = t.map(|i| pts[i as usize]);
    pts.iter().enumerate().all(|(q, &p)| t.contains(&(q as u32)) || orient_exact(a, b, c, p) < 0.0)
}

#[test]
fn fast_plane_tests_never_certify_what_the_exact_test_rejects() {
    // A 3×3×3 grid (most triples have other points exactly on their plane), far from the
    // origin (the AVX2 test's bound grows with |coordinates|) and jittered by a few ulps.
    // Every triangle, both orientations, through both fast tests: whatever a fast test
    // certifies, the exact predicate must certify too; the rest goes to `certify_slow`.
    let mut certified_exactly = 0;
    let mut rejected_exactly = 0;
    for (seed, offset, jitter) in
        [(1u64, 0.0, 0.0), (2, 1e4, 0.0), (3, 3e6, 1e-9), (4, -2e3, 1e-12)]
    {
        let mut rng = Rng::new(seed);
        let pts: Vec<Point3> = (0..23)
            .map(|i| {
                [i % 3, (i / 3) % 3, i / 9]
                    .map(|c| offset + 100.0 * c as f64 + jitter * rng.normal())
            })
            .collect();
        let soa = soa_in_both_layouts(&pts);
        let n = pts.len() as u32;
        let tris: Vec<[u32; 3]> = (0..n)
            .flat_map(|a| {
                (a + 1..n).flat_map(move |b| (b + 1..n).flat_map(move |c| [[a, b, c], [a, c, b]]))
            })
            .collect();
        let mut results = vec![];
        let mut uncertain = vec![];
        uncertain_triangles_portable(&pts, &soa, &tris, &mut uncertain, &mut vec![]);
        results.push(("portable", std::mem::take(&mut uncertain)));
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma")
        {
            // SAFETY: the CPU supports AVX2 and FMA (checked just above).
            unsafe { uncertain_triangles_avx2(&soa, &tris, &mut uncertain, &mut vec![]) };
            results.push(("avx2", uncertain));
        }
        for (k, &t) in tris.iter().enumerate() {
            let exact = exactly_certified(&pts, t);
            certified_exactly += exact as usize;
            rejected_exactly += !exact as usize;
            for (name, uncertain) in &results {
                let fast = uncertain.binary_search(&(k as u32)).is_err();
                assert!(
                    !fast || exact,
                    "{name} certified {t:?} (seed {seed}), which the exact test rejects"
                );
            }
        }
    }
    assert!(
        certified_exactly > 50 && rejected_exactly > 10_000,
        "{certified_exactly} {rejected_exactly}"
    );
}

/// Six times the volume enclosed by outward triangles: Σ det(a−o, b−o, c−o) about a point `o`
/// inside the hull (so every term is ≥ 0 and nothing cancels).
fn six_volume(pts: &[Point3], o: Point3, tris: &[[u32; 3]]) -> f64 {
    let mut six_v = 0.0;
    for &[a, b, c] in tris {
        six_v += orient_fast(o, pts[a as usize], pts[b as usize], pts[c as usize]);
    }
    six_v
}

#[test]
fn certification_sums_the_volume_of_the_hull_it_certifies() {
    // The six-fold volume the plane test returns for a hull's triangles, on both paths,
    // equals the quickhull's volume (summed another way: from the mean, by `orient_fast`).
    let mut rng = Rng::new(9);
    let pts: Vec<Point3> = (0..30)
        .map(|_| {
            [rng.normal() * 300.0 + 2500.0, rng.normal() * 200.0 - 800.0, rng.normal() * 900.0]
        })
        .collect();
    let mut b = HullBuilder::new();
    let want = b.volume(&pts).volume_mm3;
    let tris: Vec<[u32; 3]> = b.triangles().collect();
    let soa = soa_in_both_layouts(&pts);
    let (mut uncertain, mut six) = (vec![], vec![]);
    uncertain_triangles_portable(&pts, &soa, &tris, &mut uncertain, &mut six);
    let portable = six.iter().sum::<f64>() / 6.0;
    assert!(uncertain.is_empty(), "{uncertain:?}");
    assert!(close(portable, want, 1e-12), "{portable} {want}");
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma") {
        // SAFETY: the CPU supports AVX2 and FMA (checked just above).
        unsafe { uncertain_triangles_avx2(&soa, &tris, &mut uncertain, &mut six) };
        let avx2 = six.iter().sum::<f64>() / 6.0;
        assert!(uncertain.is_empty(), "{uncertain:?}");
        assert!(close(avx2, want, 1e-12), "{avx2} {want}");
    }
    assert!(close(six_volume(&pts, soa.mean, &tris) / 6.0, want, 1e-12));
}

#[test]
fn closure_check_rejects_open_and_doubled_surfaces() {
    let mut t = HullTracker::new();
    let pts = [[0.0, 0.0, 0.0], [300.0, 0.0, 0.0], [0.0, 300.0, 0.0], [0.0, 0.0, 300.0]];
    assert_eq!(t.frame(&pts).volume_mm3, 4.5e6);
    assert!(t.is_closed());
    let tri = t.prev_tris.pop().unwrap();
    assert!(!t.is_closed()); // a hole
    t.prev_tris.push(tri);
    t.prev_tris.push(tri);
    assert!(!t.is_closed()); // a triangle twice
    t.prev_tris.pop();
    let [a, b, c] = tri;
    t.prev_tris.pop();
    t.prev_tris.push([a, c, b]);
    assert!(!t.is_closed()); // a triangle turned inside out
}

fn load(relative: &str) -> Motion {
    let path = motionlab_testkit::data_path(relative);
    if relative.contains(".amc") {
        let asf = motionlab_io::asf_amc::asf_candidates(&path)
            .into_iter()
            .find(|p| p.exists())
            .expect("asf");
        motionlab_io::asf_amc::load_asf_amc(
            &path,
            &asf,
            motionlab_core::FrameRate::new(120.0).unwrap(),
        )
        .unwrap()
    } else {
        let text = motionlab_io::read::read_text(&path).unwrap();
        motionlab_io::qualisys_tsv::parse_qualisys_tsv(&text, &path, motionlab_core::Axis::Z)
            .unwrap()
    }
}

/// Exact check that `tris` bound the convex hull of `pts`: every directed edge appears once
/// and its reverse once (a closed oriented surface), and no point is strictly above any
/// triangle (Shewchuk's exact orient3d, independent of the builder's filtered predicates).
fn is_exact_hull(pts: &[Point3], tris: &[[u32; 3]]) -> bool {
    let mut edges = std::collections::HashMap::new();
    for t in tris {
        for e in 0..3 {
            *edges.entry((t[e], t[(e + 1) % 3])).or_insert(0) += 1;
        }
    }
    let closed = edges.iter().all(|(&(u, v), &n)| n == 1 && edges.get(&(v, u)) == Some(&1));
    let supporting = tris.iter().all(|t| {
        let [a, b, c] = t.map(|i| pts[i as usize]);
        pts.iter().all(|&q| orient_exact(a, b, c, q) <= 0.0)
    });
    closed && supporting
}

/// Every frame of a real recording: our triangles are exactly the hull, the tracker agrees
/// with rebuilding, and the volume equals parry3d's to 1e-9 relative.
fn agrees_with_parry_on_every_frame(relative: &str) -> HullVolumes {
    let m = load(relative);
    let h = hull_volumes(&m);
    let mut builder = HullBuilder::new();
    for i in 0..m.n_frames() {
        let valid: Vec<Point3> = m.frame(i).iter().copied().filter(|p| p[0].is_finite()).collect();
        assert_eq!(h.degenerate[i], None, "{relative} frame {i}");
        let ours = builder.volume(&valid).volume_mm3;
        assert!(
            close(ours, h.volume_mm3[i], 1e-13),
            "{relative} frame {i}: tracker {} builder {ours}",
            h.volume_mm3[i]
        );
        let tris: Vec<[u32; 3]> = builder.triangles().collect();
        assert!(is_exact_hull(&valid, &tris), "{relative} frame {i}: not the exact hull");
        let p = parry_volume(&valid);
        assert!(close(ours, p, 1e-9), "{relative} frame {i}: ours {ours}, parry {p}");
    }
    h
}

/// Largest relative difference between the tracker's volume (certification, repairs,
/// rebuilds) and a from-scratch quickhull of the frame's valid points, over every frame.
fn max_rel_diff_tracker_vs_rebuild(m: &Motion, tracker: &mut HullTracker) -> f64 {
    let mut builder = HullBuilder::new();
    let mut worst: f64 = 0.0;
    for i in 0..m.n_frames() {
        let fast = tracker.frame(m.frame(i));
        let valid: Vec<Point3> = m.frame(i).iter().copied().filter(|p| p[0].is_finite()).collect();
        let want = builder.volume(&valid);
        assert_eq!(fast.degenerate, want.degenerate, "frame {i}");
        let rel = (fast.volume_mm3 - want.volume_mm3).abs()
            / want.volume_mm3.abs().max(f64::MIN_POSITIVE);
        if want.volume_mm3 != 0.0 || fast.volume_mm3 != 0.0 {
            worst = worst.max(rel);
        }
    }
    worst
}

#[test]
fn fast_path_equals_rebuild_every_frame_on_real_takes() {
    for take in ["cmu86/86_01.amc.gz", "mct/dance1.tsv.gz", "mct/walk1.tsv.gz"] {
        let m = load(take);
        let mut fast = HullTracker::new();
        let worst = max_rel_diff_tracker_vs_rebuild(&m, &mut fast);
        let mut plain = HullTracker::without_repairs();
        let worst_plain = max_rel_diff_tracker_vs_rebuild(&m, &mut plain);
        eprintln!(
            "{take}: max relative volume difference vs rebuild every frame {worst:.3e} (without repairs {worst_plain:.3e}); stats {:?}, without repairs {:?}",
            fast.stats(),
            plain.stats()
        );
        assert!(worst <= 1e-9 && worst_plain <= 1e-9, "{take}: {worst} {worst_plain}");
    }
}

#[test]
fn portable_and_simd_paths_make_the_same_decisions_on_real_takes() {
    // The fast tests only decide what they can prove and leave the rest to the exact
    // predicate, so both paths must certify, repair and rebuild exactly the same frames; the
    // volumes (summed in another order) agree to rounding, and both equal a rebuild.
    for take in ["cmu86/86_01.amc.gz", "mct/dance1.tsv.gz"] {
        let m = load(take);
        let run = |portable: bool| {
            FORCE_PORTABLE.with(|f| f.set(portable));
            let mut t = HullTracker::new();
            let worst = max_rel_diff_tracker_vs_rebuild(&m, &mut t);
            t.reset();
            let volumes: Vec<f64> =
                (0..m.n_frames()).map(|i| t.frame(m.frame(i)).volume_mm3).collect();
            FORCE_PORTABLE.with(|f| f.set(false));
            (worst, t.stats(), volumes)
        };
        let (worst_portable, stats_portable, portable) = run(true);
        let (worst_simd, stats_simd, simd) = run(false);
        assert!(
            worst_portable <= 1e-9 && worst_simd <= 1e-9,
            "{take}: {worst_portable} {worst_simd}"
        );
        assert_eq!(stats_portable, stats_simd, "{take}");
        assert!(
            stats_portable.reused > 0 && stats_portable.repaired > 0,
            "{take}: {stats_portable:?}"
        );
        for (i, (a, b)) in portable.iter().zip(&simd).enumerate() {
            assert!(close(*a, *b, 1e-12), "{take} frame {i}: {a} {b}");
        }
    }
}

#[test]
fn interior_points_racing_outward_are_caught() {
    // A fixed outer shell and interior points that move fast, leave the hull, come back and
    // sit exactly on faces: every frame must equal a from-scratch hull.
    let mut rng = Rng::new(19);
    let shell: Vec<Point3> = (0..14)
        .map(|_| {
            let v = [rng.normal(), rng.normal(), rng.normal()];
            let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
            v.map(|c| 500.0 * c / n)
        })
        .collect();
    let inner: Vec<(Point3, Point3)> = (0..12)
        .map(|_| {
            (
                [rng.normal() * 60.0, rng.normal() * 60.0, rng.normal() * 60.0],
                [rng.normal(), rng.normal(), rng.normal()],
            )
        })
        .collect();
    let m = motion_from_fn(600, 120.0, 26, |i, k| {
        let t = i as f64 / 120.0;
        if k < 14 {
            let p = shell[k];
            let w = 1.0 + 0.05 * (t * (1.0 + k as f64)).sin();
            [p[0] * w, p[1] * w, p[2] * w]
        } else {
            let (c, d) = inner[k - 14];
            // Speeds up to ~ 1000 mm per frame at the peaks.
            let s = 700.0 * (t * (2.0 + k as f64 * 0.3)).sin().powi(3);
            if i % 97 == 0 && k == 14 {
                return shell[0]; // a duplicate of a shell vertex for one frame
            }
            [c[0] + s * d[0], c[1] + s * d[1], c[2] + s * d[2]]
        }
    });
    let mut t = HullTracker::new();
    let worst = max_rel_diff_tracker_vs_rebuild(&m, &mut t);
    assert!(worst <= 1e-12, "{worst}");
    assert!(t.stats().reused > 0, "{:?}", t.stats());
}

#[test]
fn real_cmu_skeleton_with_duplicate_joints_matches_parry() {
    // 86_01: 38 joints and end sites, several on one spot (root = lhipjoint = rhipjoint =
    // lowerback, lhand = lthumb, …). A standing adult's hull is tens of litres.
    let h = agrees_with_parry_on_every_frame("cmu86/86_01.amc.gz");
    assert_eq!(h.volume_mm3.len(), 4579);
    let median = {
        let mut v = h.volume_mm3.clone();
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    assert!((2e7..3e8).contains(&median), "median hull {median} mm³");
    assert!(h.stats.reused > h.stats.rebuilt, "{:?}", h.stats); // duplicates do not defeat re-use
}

#[test]
fn real_marker_data_with_missing_samples_matches_parry() {
    agrees_with_parry_on_every_frame("mct/dance1.tsv.gz");
    // walk1 has 27 missing samples: the hull is over the valid markers, D is NaN where the
    // set of valid markers changes, and nothing else is.
    let m = load("mct/walk1.tsv.gz");
    assert_eq!(m.missing_count(), 27);
    let h = agrees_with_parry_on_every_frame("mct/walk1.tsv.gz");
    let d = &h.change_mm3_per_frame;
    for (i, di) in d.iter().enumerate().skip(1) {
        let changed = m.frame_missing(i) != m.frame_missing(i - 1);
        assert_eq!(di.is_nan(), changed, "frame {i}");
    }
    assert!(h.n_valid.iter().any(|&n| n < 28));
}
