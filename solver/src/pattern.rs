//! Building a compressed-sparse-column (CSC) pattern from a list of coordinates, remembering
//! where each coordinate landed.

use faer::sparse::SymbolicSparseColMat;

/// Largest `nrows × ncols` for which [`build_pattern`] marks the coordinates in a dense table
/// (8 bytes an entry: 512 KiB) when the table is also no larger than a few times the list.
const DENSE_TABLE_LIMIT: usize = 1 << 16;

/// Builds the CSC pattern of an `nrows × ncols` matrix whose nonzeros are at `coords`
/// (`(row, col)` pairs, duplicates allowed), and returns it together with `slot`, where
/// `slot[e]` is the index into the CSC value array of `coords[e]`. Duplicated coordinates share
/// a slot, so summing `values[slot[e]] += v[e]` assembles the matrix.
///
/// Every coordinate must be in range (callers validate first). The result does not depend on
/// the order of `coords` except through `slot`: rows are sorted within each column.
///
/// Two methods, the same result: a matrix with no more cells than a few times its coordinates
/// (a periodic tile's Hessian and KKT matrix: 128–256 columns, every stencil's local entries)
/// is marked in a dense table and numbered by one column-major sweep; any other (a garment's)
/// is sorted by two counting sorts. On the periodic tiles the dense table took a solve's setup
/// from 15 to 10 % of the yarn-fit objective's time (`sim-periodic`'s fit objective, *Where a
/// Newton iteration goes*).
pub(crate) fn build_pattern(
    nrows: usize,
    ncols: usize,
    coords: &[(usize, usize)],
) -> (SymbolicSparseColMat<usize>, Vec<usize>) {
    let cells = nrows.saturating_mul(ncols);
    if cells <= DENSE_TABLE_LIMIT && cells <= 4 * coords.len() {
        build_pattern_dense(nrows, ncols, coords)
    } else {
        build_pattern_sorted(nrows, ncols, coords)
    }
}

/// [`build_pattern`] through a dense `nrows × ncols` table of slots.
fn build_pattern_dense(
    nrows: usize,
    ncols: usize,
    coords: &[(usize, usize)],
) -> (SymbolicSparseColMat<usize>, Vec<usize>) {
    const ABSENT: usize = usize::MAX;
    // Column-major: cell `row + nrows · col`; marked cells hold 0 until numbered.
    let mut table = vec![ABSENT; nrows * ncols];
    for &(row, col) in coords {
        table[row + nrows * col] = 0;
    }
    let mut col_ptr = vec![0usize; ncols + 1];
    let mut row_idx = Vec::new();
    for col in 0..ncols {
        for (row, cell) in table[nrows * col..nrows * (col + 1)].iter_mut().enumerate() {
            if *cell != ABSENT {
                *cell = row_idx.len();
                row_idx.push(row);
            }
        }
        col_ptr[col + 1] = row_idx.len();
    }
    let slot = coords
        .iter()
        .map(|&(row, col)| table[row + nrows * col])
        .collect();
    let symbolic = SymbolicSparseColMat::new_checked(nrows, ncols, col_ptr, None, row_idx);
    (symbolic, slot)
}

/// [`build_pattern`] through two counting sorts.
fn build_pattern_sorted(
    nrows: usize,
    ncols: usize,
    coords: &[(usize, usize)],
) -> (SymbolicSparseColMat<usize>, Vec<usize>) {
    // Entry ids column-major, rows ascending within a column: a stable counting sort by row,
    // then one by column (linear in the entries; ties are identical coordinates and share a
    // slot, so their order does not matter).
    let (_, by_row) = counting_sort(0..coords.len(), nrows, |e| coords[e].0);
    let (_, order) = counting_sort(by_row.iter().copied(), ncols, |e| coords[e].1);

    let mut col_ptr = vec![0usize; ncols + 1];
    let mut row_idx = Vec::new();
    let mut slot = vec![0usize; coords.len()];
    let mut previous = None;
    for &e in &order {
        let (row, col) = coords[e];
        if previous != Some((row, col)) {
            row_idx.push(row);
            col_ptr[col + 1] += 1;
            previous = Some((row, col));
        }
        slot[e] = row_idx.len() - 1;
    }
    for j in 0..ncols {
        col_ptr[j + 1] += col_ptr[j];
    }
    let symbolic = SymbolicSparseColMat::new_checked(nrows, ncols, col_ptr, None, row_idx);
    (symbolic, slot)
}

/// `ids` stably sorted by `key(id) < buckets` (a counting sort), with the bucket offsets:
/// bucket `b` is `sorted[ptr[b]..ptr[b + 1]]`. Returns `(ptr, sorted)`.
pub(crate) fn counting_sort(
    ids: impl IntoIterator<Item = usize> + Clone,
    buckets: usize,
    key: impl Fn(usize) -> usize,
) -> (Vec<usize>, Vec<usize>) {
    let mut ptr = vec![0usize; buckets + 1];
    for id in ids.clone() {
        ptr[key(id) + 1] += 1;
    }
    for b in 0..buckets {
        ptr[b + 1] += ptr[b];
    }
    let mut next = ptr.clone();
    let mut sorted = vec![0usize; ptr[buckets]];
    for id in ids {
        let k = key(id);
        sorted[next[k]] = id;
        next[k] += 1;
    }
    (ptr, sorted)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn duplicates_share_slots_and_rows_are_sorted() {
        let coords = [(2, 0), (0, 0), (1, 1), (2, 0), (0, 2), (1, 0)];
        for (s, slot) in [
            build_pattern_dense(3, 3, &coords),
            build_pattern_sorted(3, 3, &coords),
        ] {
            assert_eq!(s.col_ptr(), &[0, 3, 4, 5]);
            assert_eq!(s.row_idx(), &[0, 1, 2, 1, 0]);
            assert_eq!(slot, vec![2, 0, 3, 2, 4, 1]);
        }
    }

    #[test]
    fn slots_match_a_sorted_map_of_the_coordinates() {
        // Pseudo-random coordinates with many duplicates: a small matrix (dense table) and a
        // large, sparse one (counting sorts).
        for (nrows, ncols) in [(7, 5), (900, 700)] {
            let mut state = 12345u64;
            let coords: Vec<(usize, usize)> = (0..300)
                .map(|_| {
                    state = state
                        .wrapping_mul(6364136223846793005)
                        .wrapping_add(1442695040888963407);
                    let r = (state >> 33) as usize;
                    (r % nrows, (r / nrows) % ncols)
                })
                .collect();
            let dense = build_pattern_dense(nrows, ncols, &coords);
            let sorted = build_pattern_sorted(nrows, ncols, &coords);
            for (s, slot) in [&dense, &sorted] {
                check_against_map(&coords, s, slot);
            }
            // The same pattern bit for bit, whichever method `build_pattern` picks.
            assert_eq!(dense.0.col_ptr(), sorted.0.col_ptr());
            assert_eq!(dense.0.row_idx(), sorted.0.row_idx());
            assert_eq!(dense.1, sorted.1);
        }
    }

    /// Asserts that `(s, slot)` is the pattern of `coords`: distinct coordinates column-major,
    /// numbered in order.
    fn check_against_map(
        coords: &[(usize, usize)],
        s: &SymbolicSparseColMat<usize>,
        slot: &[usize],
    ) {
        let distinct: std::collections::BTreeMap<(usize, usize), usize> = coords
            .iter()
            .map(|&(r, c)| (c, r))
            .collect::<std::collections::BTreeSet<_>>()
            .into_iter()
            .enumerate()
            .map(|(i, k)| (k, i))
            .collect();
        assert_eq!(s.row_idx().len(), distinct.len());
        for (e, &(r, c)) in coords.iter().enumerate() {
            assert_eq!(slot[e], distinct[&(c, r)]);
            assert_eq!(s.row_idx()[slot[e]], r);
            assert!(s.col_ptr()[c] <= slot[e] && slot[e] < s.col_ptr()[c + 1]);
        }
    }

    #[test]
    fn empty_pattern() {
        for (s, slot) in [
            build_pattern_dense(0, 0, &[]),
            build_pattern_sorted(0, 0, &[]),
        ] {
            assert_eq!(s.col_ptr(), &[0]);
            assert!(slot.is_empty());
        }
    }
}
