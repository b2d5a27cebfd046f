//! Building a compressed-sparse-column (CSC) pattern from a list of coordinates, remembering
//! where each coordinate landed.

use faer::sparse::SymbolicSparseColMat;

/// Builds the CSC pattern of an `nrows × ncols` matrix whose nonzeros are at `coords`
/// (`(row, col)` pairs, duplicates allowed), and returns it together with `slot`, where
/// `slot[e]` is the index into the CSC value array of `coords[e]`. Duplicated coordinates share
/// a slot, so summing `values[slot[e]] += v[e]` assembles the matrix.
///
/// Every coordinate must be in range (callers validate first). The result does not depend on
/// the order of `coords` except through `slot`: rows are sorted within each column.
pub(crate) fn build_pattern(
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
        let (s, slot) = build_pattern(3, 3, &coords);
        assert_eq!(s.col_ptr(), &[0, 3, 4, 5]);
        assert_eq!(s.row_idx(), &[0, 1, 2, 1, 0]);
        assert_eq!(slot, vec![2, 0, 3, 2, 4, 1]);
    }

    #[test]
    fn slots_match_a_sorted_map_of_the_coordinates() {
        // Pseudo-random coordinates with many duplicates, on a non-square matrix.
        let (nrows, ncols) = (7, 5);
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
        let (s, slot) = build_pattern(nrows, ncols, &coords);
        // The reference: distinct coordinates in column-major order, numbered.
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
        let (s, slot) = build_pattern(0, 0, &[]);
        assert_eq!(s.col_ptr(), &[0]);
        assert!(slot.is_empty());
    }
}
