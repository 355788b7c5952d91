//! Agglomerative clustering of a few hundred items from their pairwise distances — what the
//! state labellers (`segment_clusters`, `multistream_dp`) do with a sequence's segments — and
//! the silhouette that chooses how many clusters.
//!
//! - [`average_linkage`]: UPGMA (scipy's `linkage(method="average")`): the two clusters whose
//!   mean pairwise distance is smallest are merged, distances to the merged cluster by the
//!   Lance–Williams update `d(a∪b, k) = (|a|·d(a,k) + |b|·d(b,k)) / (|a| + |b|)`. Merges are
//!   numbered as scipy numbers them (items `0..n`, the k-th merge `n + k`); ties go to the
//!   pair of lowest cluster ids (scipy is silent on ties). O(n³) time, O(n²) memory: fine for
//!   the segments of one sequence.
//! - [`cut_to_k`], [`cut_at_distance`]: the flat clusters after the first `n − k` merges, or
//!   after every merge at or below a distance (average linkage never merges below an earlier
//!   merge, so the two agree).
//! - [`silhouette`]: scikit-learn's `silhouette_score(metric="precomputed")` — per item
//!   `(b − a) / max(a, b)` with `a` its mean distance to the rest of its cluster and `b` the
//!   smallest mean distance to another cluster, 0 for an item alone in its cluster; the mean.

use motionlab_core::{Error, ErrorKind, Merge, Result, canonical_states};

/// Checks a row-major `n × n` distance matrix: square, finite, non-negative, symmetric.
fn check(d: &[f64], n: usize) -> Result<()> {
    if d.len() != n * n {
        return Err(Error::new(
            ErrorKind::WrongValueCount,
            format!("{} distances for {n} items; expected {n} × {n}", d.len()),
        ));
    }
    for i in 0..n {
        for j in 0..n {
            let v = d[i * n + j];
            if !v.is_finite() || v < 0.0 || v != d[j * n + i] {
                return Err(Error::new(
                    ErrorKind::OutOfRange,
                    format!(
                        "distance ({i}, {j}) is {v} (its mirror {}); expected finite, ≥ 0 and symmetric",
                        d[j * n + i]
                    ),
                ));
            }
        }
    }
    Ok(())
}

/// The merges of average-linkage clustering of `n` items with distances `d` (row-major n × n).
pub fn average_linkage(d: &[f64], n: usize) -> Result<Vec<Merge>> {
    check(d, n)?;
    // Active clusters: (id, size); dist between active clusters by position.
    let mut ids: Vec<usize> = (0..n).collect();
    let mut sizes: Vec<usize> = vec![1; n];
    let mut dist: Vec<Vec<f64>> = (0..n).map(|i| d[i * n..(i + 1) * n].to_vec()).collect();
    let mut merges = Vec::with_capacity(n.saturating_sub(1));
    while ids.len() > 1 {
        let mut best: Option<(usize, usize, f64)> = None;
        for i in 0..ids.len() {
            for j in i + 1..ids.len() {
                let v = dist[i][j];
                let better = match best {
                    None => true,
                    Some((bi, bj, bv)) => {
                        v < bv
                            || (v == bv
                                && (ids[i].min(ids[j]), ids[i].max(ids[j]))
                                    < (ids[bi].min(ids[bj]), ids[bi].max(ids[bj])))
                    }
                };
                if better {
                    best = Some((i, j, v));
                }
            }
        }
        let Some((i, j, v)) = best else { break };
        let (si, sj) = (sizes[i] as f64, sizes[j] as f64);
        let size = sizes[i] + sizes[j];
        merges.push(Merge { a: ids[i].min(ids[j]), b: ids[i].max(ids[j]), distance: v, size });
        // The merged cluster takes position i; position j is removed.
        let merged: Vec<f64> =
            dist[i].iter().zip(&dist[j]).map(|(a, b)| (si * a + sj * b) / (si + sj)).collect();
        for (k, &nv) in merged.iter().enumerate() {
            if k != i && k != j {
                dist[i][k] = nv;
                dist[k][i] = nv;
            }
        }
        ids[i] = n + merges.len() - 1;
        sizes[i] = size;
        ids.remove(j);
        sizes.remove(j);
        dist.remove(j);
        for row in &mut dist {
            row.remove(j);
        }
    }
    Ok(merges)
}

/// The flat clusters of `n` items after the first `n_merges` merges, numbered in order of first
/// appearance.
fn flat(merges: &[Merge], n: usize, n_merges: usize) -> Vec<usize> {
    // Union–find over cluster ids 0..n+merges.
    let mut parent: Vec<usize> = (0..n + merges.len()).collect();
    fn root(parent: &mut [usize], mut x: usize) -> usize {
        while parent[x] != x {
            parent[x] = parent[parent[x]];
            x = parent[x];
        }
        x
    }
    for (k, m) in merges.iter().take(n_merges).enumerate() {
        let (ra, rb) = (root(&mut parent, m.a), root(&mut parent, m.b));
        parent[ra] = n + k;
        parent[rb] = n + k;
    }
    let roots: Vec<usize> = (0..n).map(|i| root(&mut parent, i)).collect();
    canonical_states(&roots)
}

/// `k` flat clusters (1 ≤ k ≤ n; k > n gives n) from the merges of `n` items.
pub fn cut_to_k(merges: &[Merge], n: usize, k: usize) -> Vec<usize> {
    flat(merges, n, n.saturating_sub(k.max(1)).min(merges.len()))
}

/// The flat clusters after every merge at a distance ≤ `threshold`.
pub fn cut_at_distance(merges: &[Merge], n: usize, threshold: f64) -> Vec<usize> {
    let k = merges.iter().take_while(|m| m.distance <= threshold).count();
    flat(merges, n, k)
}

/// scikit-learn's silhouette score of `labels` on distances `d` (row-major n × n). Needs
/// 2 ≤ number of clusters ≤ n − 1, as scikit-learn does.
pub fn silhouette(d: &[f64], n: usize, labels: &[usize]) -> Result<f64> {
    check(d, n)?;
    let k = labels.iter().copied().max().map_or(0, |m| m + 1);
    let used = {
        let mut u = labels.to_vec();
        u.sort_unstable();
        u.dedup();
        u.len()
    };
    if labels.len() != n || used < 2 || used > n.saturating_sub(1) {
        return Err(Error::new(
            ErrorKind::OutOfRange,
            format!("{used} clusters of {n} items; the silhouette needs 2 to n − 1 clusters"),
        ));
    }
    let mut counts = vec![0usize; k];
    for &l in labels {
        counts[l] += 1;
    }
    let mut total = 0.0;
    for i in 0..n {
        let mut sums = vec![0.0; k];
        for (j, &l) in labels.iter().enumerate() {
            sums[l] += d[i * n + j];
        }
        let own = labels[i];
        if counts[own] <= 1 {
            continue; // s = 0 for an item alone in its cluster
        }
        let a = sums[own] / (counts[own] - 1) as f64;
        let b = (0..k)
            .filter(|&c| c != own && counts[c] > 0)
            .map(|c| sums[c] / counts[c] as f64)
            .fold(f64::INFINITY, f64::min);
        let m = a.max(b);
        if m > 0.0 {
            total += (b - a) / m;
        }
    }
    Ok(total / n as f64)
}

/// The number of clusters by the silhouette rule the labellers document: with `n ≤ 2` items
/// each is its own cluster; otherwise the `k` in `2..=min(max_k, n − 1)` whose average-linkage
/// cut has the largest silhouette (the smallest such `k` among equal scores).
pub fn k_by_silhouette(d: &[f64], n: usize, merges: &[Merge], max_k: usize) -> Result<usize> {
    if n <= 2 {
        return Ok(n);
    }
    let mut best = (2, f64::NEG_INFINITY);
    for k in 2..=max_k.min(n - 1).max(2) {
        let s = silhouette(d, n, &cut_to_k(merges, n, k))?;
        if s > best.1 {
            best = (k, s);
        }
    }
    Ok(best.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn matrix(points: &[f64]) -> Vec<f64> {
        let n = points.len();
        (0..n * n).map(|k| (points[k / n] - points[k % n]).abs()).collect()
    }

    /// Points 0, 1, 5, 6, 20 on a line. Average linkage by hand: {0,1} at 1, {5,6} at 1
    /// (ids 5 and 6), then {0,1}∪{5,6} at mean(5,6,4,5) = 5, then with 20 at
    /// mean(20,19,15,14) = 17 — scipy's `linkage([[0],[1],[5],[6],[20]], "average")` gives
    /// [[0,1,1,2],[2,3,1,2],[5,6,5,4],[4,7,17,5]].
    #[test]
    fn average_linkage_known_answer() {
        let d = matrix(&[0.0, 1.0, 5.0, 6.0, 20.0]);
        let m = average_linkage(&d, 5).unwrap();
        let got: Vec<(usize, usize, f64, usize)> =
            m.iter().map(|m| (m.a, m.b, m.distance, m.size)).collect();
        assert_eq!(got, vec![(0, 1, 1.0, 2), (2, 3, 1.0, 2), (5, 6, 5.0, 4), (4, 7, 17.0, 5)]);
        assert_eq!(cut_to_k(&m, 5, 3), vec![0, 0, 1, 1, 2]);
        assert_eq!(cut_to_k(&m, 5, 1), vec![0; 5]);
        assert_eq!(cut_to_k(&m, 5, 9), vec![0, 1, 2, 3, 4]);
        assert_eq!(cut_at_distance(&m, 5, 4.9), vec![0, 0, 1, 1, 2]);
        assert_eq!(cut_at_distance(&m, 5, 5.0), vec![0, 0, 0, 0, 1]);
    }

    /// sklearn: silhouette_score(D, [0,0,1,1,2], metric="precomputed") on the points above:
    /// item 0: a = 1, b = min(mean(5,6), 20) = 5.5 → 0.8181…; item 1: a 1, b min(4.5, 19)
    /// → 0.7778; item 2: a 1, b min(4.5, 15) → 0.7778; item 3: a 1, b min(5.5, 14) → 0.8182;
    /// item 4 alone → 0. Mean = (2·(4.5/5.5) + 2·(3.5/4.5)) / 5.
    #[test]
    fn silhouette_known_answer_and_k_choice() {
        let d = matrix(&[0.0, 1.0, 5.0, 6.0, 20.0]);
        let s = silhouette(&d, 5, &[0, 0, 1, 1, 2]).unwrap();
        let want = (2.0 * (4.5 / 5.5) + 2.0 * (3.5 / 4.5)) / 5.0;
        assert!((s - want).abs() < 1e-12, "{s} vs {want}");
        assert!(silhouette(&d, 5, &[0; 5]).is_err());
        // Three tight groups far apart: k = 3.
        let d = matrix(&[0.0, 0.1, 0.2, 10.0, 10.1, 20.0, 20.2, 20.1]);
        let m = average_linkage(&d, 8).unwrap();
        assert_eq!(k_by_silhouette(&d, 8, &m, 6).unwrap(), 3);
        assert_eq!(cut_to_k(&m, 8, 3), vec![0, 0, 0, 1, 1, 2, 2, 2]);
        // Two items: each its own cluster.
        assert_eq!(k_by_silhouette(&matrix(&[0.0, 1.0]), 2, &[], 5).unwrap(), 2);
    }

    #[test]
    fn bad_distances_are_refused() {
        assert!(average_linkage(&[0.0, 1.0, 2.0, 0.0], 2).is_err(), "asymmetric");
        assert!(average_linkage(&[0.0, f64::NAN, f64::NAN, 0.0], 2).is_err());
        assert!(average_linkage(&[0.0; 3], 2).is_err());
    }
}
