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
    // Sort entry ids column-major; ties are identical coordinates and share a slot.
    let mut order: Vec<usize> = (0..coords.len()).collect();
    order.sort_unstable_by_key(|&e| (coords[e].1, coords[e].0));

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
    fn empty_pattern() {
        let (s, slot) = build_pattern(0, 0, &[]);
        assert_eq!(s.col_ptr(), &[0]);
        assert!(slot.is_empty());
    }
}
