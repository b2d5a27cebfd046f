//! Projection of small symmetric matrices onto the positive semi-definite cone.
//!
//! Newton solvers need a descent direction; the exact Hessian of a non-convex stencil (bending
//! past a fold, a contact barrier) can be indefinite. Projecting each stencil's Hessian
//! (Teran et al. 2005's per-element projection) keeps the assembled matrix SPD (up to the
//! solver's regularization) while leaving convex stencils untouched.
//!
//! Two eigensolvers, the same projection to ~1e-14 relative (both backward stable; tested):
//!
//! - [`project_spd`], cyclic Jacobi on stack arrays of the exact size: the Newton solvers'
//!   projection (`solver::Assembler`);
//! - [`project_spd_qr`], nalgebra's symmetric QR on a stack matrix of the exact size, 2.5–3.0×
//!   faster on 8–12 DOFs (`cargo bench -p rod --bench spd` measures both in one run; 3.3–4.3×
//!   while the Jacobi method ran on 32 × 32 scratch arrays with loop bounds known only at run
//!   time, which took it 1.6–1.8× longer for the same arithmetic): where many stencils are
//!   projected outside a Newton direction, as in the garment simulator's Rayleigh-β damping
//!   forms.
//!
//! Why not QR everywhere: a Newton solve that passes near a saddle is decided by rounding.
//! With QR in the Newton projection, the quasi-static plain-weave shear of
//! `sim-persistent/tests/weave_forces.rs` left the symmetric equilibrium at γ = 0.25 (where
//! the Jacobi projection converges in 6 iterations) and crept toward a lower one for 200
//! iterations, although no stencil's projection differed from the Jacobi one by more than
//! 1e-12 relative; the Newton projection keeps the Jacobi method so that validated
//! equilibria (and the chaotic yarn-parameter swarm) stay as they were.

use nalgebra::{DMatrix, SMatrix, SymmetricEigen};

/// Largest dense size the slice projection handles (stack scratch, no allocation).
pub const MAX_PROJECT_DIM: usize = 32;

/// Iteration cap of nalgebra's implicit QR (it counts one per sweep over the unreduced
/// tridiagonal block; a 32 × 32 matrix needs a few dozen). Past it the cyclic Jacobi fallback takes over.
const MAX_QR_ITERATIONS: usize = 10_000;

/// [`project_spd`] through nalgebra's [`SymmetricEigen`] (Householder tridiagonalization and
/// implicit symmetric QR with Wilkinson shifts) on a stack matrix of the exact size, 2.5–3.0×
/// faster (module documentation). Should the QR iteration not converge within its cap, the
/// Jacobi method is the fallback. A non-finite input gives a non-finite output (the solvers
/// reject it).
///
/// # Panics
/// As [`project_spd`].
pub fn project_spd_qr(h: &mut [f64], n: usize) {
    symmetrize(h, n);
    if !h.iter().all(|x| x.is_finite()) {
        h.fill(f64::NAN);
        return;
    }
    // One arm per size: nalgebra's decomposition of a stack matrix of that exact size.
    macro_rules! dispatch {
        ($($size:literal)*) => {
            match n {
                0 => {}
                $($size => {
                    let m = SMatrix::<f64, $size, $size>::from_column_slice(h);
                    match SymmetricEigen::try_new(m, f64::EPSILON, MAX_QR_ITERATIONS) {
                        Some(e) => clamp_eigenvalues(
                            h,
                            n,
                            e.eigenvalues.as_slice(),
                            e.eigenvectors.as_slice(),
                        ),
                        None => project_spd(h, n),
                    }
                })*
                _ => unreachable!("n ≤ MAX_PROJECT_DIM is asserted in `symmetrize`"),
            }
        };
    }
    dispatch!(1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16 17 18 19 20 21 22 23 24 25 26 27 28 29 30 31 32);
}

/// Projects the symmetric `n × n` matrix stored column-major in `h` onto the PSD cone in place:
/// `H ← V max(Λ, 0) Vᵀ` with `H = V Λ Vᵀ` its eigendecomposition (cyclic Jacobi, accurate to
/// a few ulps for the sizes used here). The input is symmetrized first (`(H + Hᵀ)/2`); a
/// matrix that is already PSD is returned as that symmetrized input, bit for bit.
///
/// # Panics
/// If `n > MAX_PROJECT_DIM` or `h.len() != n²` (programming errors, not input errors).
pub fn project_spd(h: &mut [f64], n: usize) {
    symmetrize(h, n);
    // A zero Hessian (an inactive contact) is its own projection.
    if h.iter().all(|&x| x == 0.0) {
        return;
    }
    // One arm per size: the Jacobi method on stack arrays of that exact size, so that its loops
    // have constant bounds (the compiler unrolls and vectorizes them; the arithmetic and its
    // order are those of the plain method).
    macro_rules! dispatch {
        ($($size:literal)*) => {
            match n {
                0 => {}
                $($size => project_spd_fixed::<$size>(h),)*
                _ => unreachable!("n ≤ MAX_PROJECT_DIM is asserted in `symmetrize`"),
            }
        };
    }
    dispatch!(1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16 17 18 19 20 21 22 23 24 25 26 27 28 29 30 31 32);
}

/// [`project_spd`] of a symmetrized `N × N` matrix.
fn project_spd_fixed<const N: usize>(h: &mut [f64]) {
    // Column-major: `a[j][i]` is row i of column j.
    let mut a = [[0.0; N]; N];
    let mut v = [[0.0; N]; N];
    for (j, column) in a.iter_mut().enumerate() {
        column.copy_from_slice(&h[N * j..N * (j + 1)]);
        v[j][j] = 1.0;
    }
    jacobi_eigen(&mut a, &mut v);
    let values: [f64; N] = std::array::from_fn(|i| a[i][i]);
    clamp_eigenvalues(h, N, &values, v.as_flattened());
}

/// `H ← (H + Hᵀ)/2` in place, after checking the buffer.
fn symmetrize(h: &mut [f64], n: usize) {
    assert!(
        n <= MAX_PROJECT_DIM,
        "project_spd: n = {n} > {MAX_PROJECT_DIM}"
    );
    assert_eq!(h.len(), n * n, "project_spd: buffer is not n×n");
    for j in 0..n {
        for i in 0..j {
            let s = 0.5 * (h[i + n * j] + h[j + n * i]);
            h[i + n * j] = s;
            h[j + n * i] = s;
        }
    }
}

/// `H ← Σ_k max(λ_k, 0) v_k v_kᵀ` from the eigenvalues `values` and the column-major
/// eigenvectors `vectors` of the symmetric `H`, entry by entry as `Σ_k (v_ik λ_k) v_jk` (the
/// arithmetic the Jacobi projection always used, so its results stay bit for bit); leaves `H`
/// as it is when no eigenvalue is negative.
fn clamp_eigenvalues(h: &mut [f64], n: usize, values: &[f64], vectors: &[f64]) {
    if values.iter().all(|&l| l >= 0.0) {
        return;
    }
    for j in 0..n {
        for i in 0..n {
            let mut s = 0.0;
            for (k, &lambda) in values.iter().enumerate() {
                if lambda > 0.0 {
                    s += vectors[i + n * k] * lambda * vectors[j + n * k];
                }
            }
            h[i + n * j] = s;
        }
    }
}

/// Fixed-size convenience wrapper of [`project_spd`].
pub fn project_spd_matrix<const N: usize>(h: &mut SMatrix<f64, N, N>) {
    project_spd(h.as_mut_slice(), N);
}

/// Eigenvalues of a symmetric `n × n` column-major matrix, ascending (used by tests and
/// diagnostics; nalgebra's symmetric QR on a heap matrix).
pub fn symmetric_eigenvalues(h: &[f64], n: usize) -> Vec<f64> {
    let mut e: Vec<f64> = DMatrix::from_column_slice(n, n, h)
        .symmetric_eigenvalues()
        .iter()
        .copied()
        .collect();
    e.sort_by(f64::total_cmp);
    e
}

/// Cyclic Jacobi ([`project_spd`]) on the column-major `a` (`a[j][i]`: row i of column j):
/// on return `a` is diagonal (eigenvalues) and the columns of `v` are the eigenvectors. Sweeps
/// until the off-diagonal mass is below `ε²·‖A‖²` (at most 64 sweeps, far more than the ~6–10
/// a 12 × 12 matrix needs).
fn jacobi_eigen<const N: usize>(a: &mut [[f64; N]; N], v: &mut [[f64; N]; N]) {
    let frob2: f64 = a.as_flattened().iter().map(|x| x * x).sum();
    for _sweep in 0..64 {
        let mut off = 0.0;
        for (j, column) in a.iter().enumerate() {
            for x in &column[..j] {
                off += x * x;
            }
        }
        if off <= f64::EPSILON * f64::EPSILON * frob2 {
            return;
        }
        for p in 0..N {
            for q in (p + 1)..N {
                let apq = a[q][p];
                if apq == 0.0 {
                    continue;
                }
                let app = a[p][p];
                let aqq = a[q][q];
                // Rotation angle that annihilates a_pq (Golub & Van Loan, Alg. 8.4.2).
                let tau = (aqq - app) / (2.0 * apq);
                let t = tau.signum() / (tau.abs() + (1.0 + tau * tau).sqrt());
                let t = if tau == 0.0 { 1.0 } else { t };
                let c = 1.0 / (1.0 + t * t).sqrt();
                let s = t * c;
                // Columns p and q, then rows p and q, then the eigenvector columns.
                rotate(a, p, q, c, s);
                for column in a.iter_mut() {
                    let (apk, aqk) = (column[p], column[q]);
                    column[p] = c * apk - s * aqk;
                    column[q] = s * apk + c * aqk;
                }
                rotate(v, p, q, c, s);
            }
        }
    }
}

/// Columns `p < q` of `m` ← `(c m_p − s m_q, s m_p + c m_q)`.
fn rotate<const N: usize>(m: &mut [[f64; N]; N], p: usize, q: usize, c: f64, s: f64) {
    let (left, right) = m.split_at_mut(q);
    for (x, y) in left[p].iter_mut().zip(right[0].iter_mut()) {
        let (xp, xq) = (*x, *y);
        *x = c * xp - s * xq;
        *y = s * xp + c * xq;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Uniform numbers in [−½, ½) from a xorshift64 stream.
    fn xorshift(mut seed: u64) -> impl FnMut() -> f64 {
        move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        }
    }

    /// A symmetric `n × n` matrix (column-major) of the stream's numbers, column by column.
    fn random_symmetric(rnd: &mut impl FnMut() -> f64, n: usize) -> Vec<f64> {
        let mut h = vec![0.0; n * n];
        for j in 0..n {
            for i in 0..=j {
                let x = rnd();
                h[i + n * j] = x;
                h[j + n * i] = x;
            }
        }
        h
    }

    #[test]
    fn psd_input_is_unchanged() {
        let mut h = [4.0, 1.0, 0.0, 1.0, 3.0, 0.5, 0.0, 0.5, 2.0];
        let before = h;
        project_spd(&mut h, 3);
        assert_eq!(h, before);
    }

    #[test]
    fn indefinite_input_gets_clamped_eigenvalues() {
        // diag(2, -3) rotated by 30°.
        let (c, s) = (30f64.to_radians().cos(), 30f64.to_radians().sin());
        let r = nalgebra::Matrix2::new(c, -s, s, c);
        let d = nalgebra::Matrix2::new(2.0, 0.0, 0.0, -3.0);
        let mut h = r * d * r.transpose();
        project_spd_matrix(&mut h);
        let expected = r * nalgebra::Matrix2::new(2.0, 0.0, 0.0, 0.0) * r.transpose();
        assert!((h - expected).norm() < 1e-14, "{h} vs {expected}");
        let e = symmetric_eigenvalues(h.as_slice(), 2);
        assert!(e[0].abs() < 1e-14 && (e[1] - 2.0).abs() < 1e-14);
    }

    #[test]
    fn random_12x12_projection_is_psd_and_idempotent() {
        let n = 12;
        let mut h = random_symmetric(&mut xorshift(0x2545_f491_4f6c_dd1d), n);
        let before = symmetric_eigenvalues(&h, n);
        assert!(before[0] < 0.0, "test matrix should be indefinite");
        project_spd(&mut h, n);
        let after = symmetric_eigenvalues(&h, n);
        assert!(after[0] > -1e-14, "min eigenvalue {}", after[0]);
        // Positive eigenvalues survive.
        let pos_before: Vec<f64> = before.iter().copied().filter(|&x| x > 0.0).collect();
        let pos_after: Vec<f64> = after.iter().copied().filter(|&x| x > 1e-12).collect();
        assert_eq!(pos_before.len(), pos_after.len());
        for (a, b) in pos_before.iter().zip(&pos_after) {
            assert!((a - b).abs() < 1e-13);
        }
        let once = h.clone();
        project_spd(&mut h, n);
        for (a, b) in once.iter().zip(&h) {
            assert!((a - b).abs() < 1e-14);
        }
    }

    #[test]
    fn symmetric_qr_and_cyclic_jacobi_agree_on_every_size() {
        let mut rnd = xorshift(0x9e37_79b9_7f4a_7c15);
        for n in 1..=MAX_PROJECT_DIM {
            let h = random_symmetric(&mut rnd, n);
            let (mut qr, mut jacobi) = (h.clone(), h.clone());
            project_spd_qr(&mut qr, n);
            project_spd(&mut jacobi, n);
            let scale = h.iter().map(|x| x * x).sum::<f64>().sqrt();
            let diff = qr
                .iter()
                .zip(&jacobi)
                .map(|(a, b)| (a - b) * (a - b))
                .sum::<f64>();
            assert!(
                diff.sqrt() <= 1e-13 * scale,
                "n = {n}: ‖Δ‖ = {:e}",
                diff.sqrt()
            );
            assert!(symmetric_eigenvalues(&qr, n)[0] > -1e-13 * scale, "n = {n}");
        }
    }

    #[test]
    fn non_finite_input_gives_non_finite_output() {
        let mut h = [1.0, f64::NAN, f64::NAN, 2.0];
        project_spd_qr(&mut h, 2);
        assert!(h.iter().all(|x| x.is_nan()));
        let mut h = [f64::INFINITY, 0.0, 0.0, -1.0];
        project_spd_qr(&mut h, 2);
        assert!(h.iter().all(|x| !x.is_finite()));
    }
}
