//! Global nearest neighbour assignment: the Hungarian method on a rectangular cost
//! matrix in which some pairs are forbidden (outside the gate).
//!
//! Among all assignments it first maximises the number of allowed pairs, then minimises
//! their total cost. Implemented with row potentials and shortest augmenting paths
//! (Kuhn-Munkres as refined by Jonker-Volgenant), O(n^2 m) for n rows and m >= n columns.

/// Cost standing for a forbidden pair inside the solver: larger than any sum of allowed
/// costs the callers produce (gated squared Mahalanobis distances).
const FORBIDDEN: f64 = 1e12;

/// Assigns rows to columns. `cost[r][c]` is `None` for a forbidden pair; every row must
/// have the same length. Returns, for each row, its column or `None`.
pub fn assign(cost: &[Vec<Option<f64>>]) -> Vec<Option<usize>> {
    let rows = cost.len();
    let cols = cost.first().map_or(0, Vec::len);
    if rows == 0 || cols == 0 {
        return vec![None; rows];
    }
    let value = |r: usize, c: usize| match cost[r].get(c).copied().flatten() {
        Some(v) if v.is_finite() => v.clamp(-1e9, 1e9),
        _ => FORBIDDEN,
    };
    let pairs = if rows <= cols {
        solve(rows, cols, value)
    } else {
        // Transpose so that rows <= columns.
        let by_col = solve(cols, rows, |c, r| value(r, c));
        let mut out = vec![None; rows];
        for (c, r) in by_col.into_iter().enumerate() {
            if let Some(r) = r {
                out[r] = Some(c);
            }
        }
        out
    };
    pairs
        .into_iter()
        .enumerate()
        .map(|(r, c)| c.filter(|&c| value_is_allowed(cost, r, c)))
        .collect()
}

fn value_is_allowed(cost: &[Vec<Option<f64>>], r: usize, c: usize) -> bool {
    matches!(cost[r].get(c).copied().flatten(), Some(v) if v.is_finite())
}

/// Minimum-cost assignment of every row (n <= m) to a distinct column.
fn solve(n: usize, m: usize, cost: impl Fn(usize, usize) -> f64) -> Vec<Option<usize>> {
    // 1-based arrays with a virtual column 0, as in the classic formulation.
    let mut u = vec![0.0; n + 1];
    let mut v = vec![0.0; m + 1];
    let mut matched_row = vec![0usize; m + 1]; // column -> row (1-based, 0 = free)
    let mut way = vec![0usize; m + 1];
    for i in 1..=n {
        matched_row[0] = i;
        let mut j0 = 0usize;
        let mut min_to = vec![f64::INFINITY; m + 1];
        let mut used = vec![false; m + 1];
        loop {
            used[j0] = true;
            let i0 = matched_row[j0];
            let mut delta = f64::INFINITY;
            let mut j1 = 0usize;
            for j in 1..=m {
                if !used[j] {
                    let cur = cost(i0 - 1, j - 1) - u[i0] - v[j];
                    if cur < min_to[j] {
                        min_to[j] = cur;
                        way[j] = j0;
                    }
                    if min_to[j] < delta {
                        delta = min_to[j];
                        j1 = j;
                    }
                }
            }
            if j1 == 0 {
                // Cannot happen with n <= m and finite costs; stop rather than loop.
                break;
            }
            for j in 0..=m {
                if used[j] {
                    u[matched_row[j]] += delta;
                    v[j] -= delta;
                } else {
                    min_to[j] -= delta;
                }
            }
            j0 = j1;
            if matched_row[j0] == 0 {
                break;
            }
        }
        // Augment along the path.
        loop {
            let j1 = way[j0];
            matched_row[j0] = matched_row[j1];
            j0 = j1;
            if j0 == 0 {
                break;
            }
        }
    }
    let mut out = vec![None; n];
    for j in 1..=m {
        if matched_row[j] > 0 {
            out[matched_row[j] - 1] = Some(j - 1);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Every partial injective assignment over allowed pairs; the best by (most pairs,
    /// least cost).
    fn brute_force(cost: &[Vec<Option<f64>>]) -> (usize, f64) {
        fn go(
            cost: &[Vec<Option<f64>>],
            r: usize,
            used: &mut Vec<bool>,
            count: usize,
            total: f64,
            best: &mut (usize, f64),
        ) {
            if r == cost.len() {
                if count > best.0 || (count == best.0 && total < best.1) {
                    *best = (count, total);
                }
                return;
            }
            go(cost, r + 1, used, count, total, best);
            for c in 0..used.len() {
                if let Some(v) = cost[r][c]
                    && !used[c]
                {
                    used[c] = true;
                    go(cost, r + 1, used, count + 1, total + v, best);
                    used[c] = false;
                }
            }
        }
        let mut best = (0, f64::INFINITY);
        let cols = cost.first().map_or(0, Vec::len);
        go(cost, 0, &mut vec![false; cols], 0, 0.0, &mut best);
        if best.0 == 0 { (0, 0.0) } else { best }
    }

    fn matrix() -> impl Strategy<Value = Vec<Vec<Option<f64>>>> {
        (1usize..6, 1usize..6).prop_flat_map(|(r, c)| {
            prop::collection::vec(
                prop::collection::vec(
                    prop_oneof![3 => (0.0..10.0f64).prop_map(Some), 1 => Just(None)],
                    c,
                ),
                r,
            )
        })
    }

    proptest! {
        #[test]
        fn matches_brute_force(cost in matrix()) {
            let a = assign(&cost);
            // A valid partial injection over allowed pairs.
            let mut seen = std::collections::BTreeSet::new();
            let mut total = 0.0;
            for (r, c) in a.iter().enumerate() {
                if let Some(c) = c {
                    prop_assert!(cost[r][*c].is_some());
                    prop_assert!(seen.insert(*c));
                    total += cost[r][*c].unwrap_or(0.0);
                }
            }
            let (best_count, best_total) = brute_force(&cost);
            prop_assert_eq!(seen.len(), best_count);
            prop_assert!((total - best_total).abs() < 1e-6, "{} vs {}", total, best_total);
        }
    }

    #[test]
    fn empty_and_degenerate_inputs() {
        assert_eq!(assign(&[]), Vec::<Option<usize>>::new());
        assert_eq!(assign(&[vec![], vec![]]), vec![None, None]);
        assert_eq!(assign(&[vec![None, None]]), vec![None]);
        assert_eq!(assign(&[vec![Some(f64::NAN), Some(1.0)]]), vec![Some(1)]);
    }
}
