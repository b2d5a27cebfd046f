//! Compression estimation at stacked contacts (seed 000 §4.3, Eqs. 3–4; physics notes).
//!
//! Persistent contacts have no DoFs normal to the contact, so the normal (compression)
//! forces cannot come from a potential. For a node with `n` stacked yarns and `n − 1`
//! pairwise contacts, with contact normal `nᵢ` pointing from yarn `i` to yarn `i + 1` and
//! normal force `λᵢ nᵢ` (`λᵢ ≥ 0`: yarns push, never pull), equilibrium along each yarn's
//! compression direction `uᵢ` (the normalized average of its contact normals; the first and
//! last yarn have one) asks the net forces
//!
//! ```text
//! fᵢ = uᵢᵀ (Fᵢ + λᵢ₋₁ nᵢ₋₁ − λᵢ nᵢ)                                   (Eq. 3)
//! ```
//!
//! to vanish, with `Fᵢ` all other forces of yarn `i` on the node. Stacking them,
//! `f = A λ + b`, and λ is chosen as `argmin ½ fᵀf` subject to `λ ≥ 0`. The paper's closed form
//!
//! ```text
//! λ = (AᵀA)⁻¹ max(0, −Aᵀb)                                            (Eq. 4)
//! ```
//!
//! is exact only when the constraints decouple (two yarns, or `AᵀA` diagonal); the exact
//! answer is a tiny non-negative least-squares problem, solved here by enumerating the
//! active sets ([`CompressionSystem::nnls`]). Both are kept so they can be compared.
//!
//! Status: the solvers and the system of Eq. 3 are implemented and tested; estimating the
//! normals (plane fit with crimp offsets) and gathering `Fᵢ` at the nodes of a running
//! simulation, which would give friction its Coulomb bound `μ λ` (Eq. 5), is future work.

use nalgebra::{DMatrix, DVector};
use rod::geometry::V3;

/// Largest number of contacts in a stack that [`CompressionSystem::nnls`] enumerates
/// (`2^12` active sets).
pub const MAX_STACK_CONTACTS: usize = 12;

/// A stack that cannot be set up.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum CompressionError {
    /// Fewer than 2 yarns, more than [`MAX_STACK_CONTACTS`] contacts, mismatched lengths,
    /// or a zero/non-finite normal or compression direction.
    #[error("invalid stacked contact: {0}")]
    Invalid(String),
}

/// `f = A λ + b` of Eq. 3 for one stacked contact node.
#[derive(Clone, Debug, PartialEq)]
pub struct CompressionSystem {
    /// `n × (n − 1)`: `A[i, i−1] = uᵢ·nᵢ₋₁`, `A[i, i] = −uᵢ·nᵢ` (unitless).
    pub a: DMatrix<f64>,
    /// `bᵢ = uᵢ·Fᵢ` (N).
    pub b: DVector<f64>,
}

impl CompressionSystem {
    /// Eq. 3 from the `n − 1` unit contact normals (yarn `i` → `i + 1`) and the `n` yarn
    /// forces `Fᵢ` (N) on the node.
    pub fn new(normals: &[V3], forces: &[V3]) -> Result<Self, CompressionError> {
        let m = normals.len();
        let bad = |s: String| Err(CompressionError::Invalid(s));
        if m == 0 || m > MAX_STACK_CONTACTS || forces.len() != m + 1 {
            return bad(format!(
                "{} normals and {} forces (need 1 to {MAX_STACK_CONTACTS} normals and one more force)",
                m,
                forces.len()
            ));
        }
        let unit = |v: V3, what: &str| -> Result<V3, CompressionError> {
            let l = v.norm();
            if l.is_finite() && l > 0.0 {
                Ok(v / l)
            } else {
                Err(CompressionError::Invalid(format!(
                    "{what} is zero or not finite"
                )))
            }
        };
        let normals: Vec<V3> = normals
            .iter()
            .map(|v| unit(*v, "a contact normal"))
            .collect::<Result<_, _>>()?;
        if !forces.iter().all(|f| f.iter().all(|c| c.is_finite())) {
            return bad("a yarn force is not finite".into());
        }
        let n = m + 1;
        let mut a = DMatrix::zeros(n, m);
        let mut b = DVector::zeros(n);
        for i in 0..n {
            let below = (i > 0).then(|| normals[i - 1]);
            let above = (i < m).then(|| normals[i]);
            let sum = below.unwrap_or_else(V3::zeros) + above.unwrap_or_else(V3::zeros);
            let u = unit(sum, "a compression direction (opposite contact normals)")?;
            if let Some(nb) = below {
                a[(i, i - 1)] = u.dot(&nb);
            }
            if let Some(na) = above {
                a[(i, i)] = -u.dot(&na);
            }
            b[i] = u.dot(&forces[i]);
        }
        Ok(Self { a, b })
    }

    /// The objective `½ |A λ + b|²` (N²).
    pub fn objective(&self, lambda: &DVector<f64>) -> f64 {
        0.5 * (&self.a * lambda + &self.b).norm_squared()
    }

    /// Eq. 4: `λ = (AᵀA)⁻¹ max(0, −Aᵀb)` (N). With roughly aligned normals
    /// (`uᵢ·nⱼ > 0`) `AᵀA` has non-positive off-diagonal entries, its inverse is non-negative
    /// and so is λ; but for three or more yarns λ is generally not the constrained optimum
    /// (see the crate's compression tests). `None` if `AᵀA` is singular.
    pub fn closed_form(&self) -> Option<DVector<f64>> {
        let ata = self.a.transpose() * &self.a;
        let rhs = (-(self.a.transpose() * &self.b)).map(|v| v.max(0.0));
        ata.cholesky().map(|c| c.solve(&rhs))
    }

    /// The exact minimizer of `½ |A λ + b|²` subject to `λ ≥ 0` (N): the best of the
    /// unconstrained least-squares solutions on every subset of free contacts whose values
    /// are non-negative (the optimum's own free set is among them; `λ = 0` is the empty set).
    pub fn nnls(&self) -> DVector<f64> {
        let m = self.a.ncols();
        let zero = DVector::zeros(m);
        let mut best = (self.objective(&zero), zero);
        for mask in 1u32..(1 << m) {
            let free: Vec<usize> = (0..m).filter(|j| mask & (1 << j) != 0).collect();
            let sub = self.a.select_columns(&free);
            let Some(chol) = (sub.transpose() * &sub).cholesky() else {
                continue;
            };
            let x = chol.solve(&(-(sub.transpose() * &self.b)));
            if x.iter().any(|v| *v < 0.0) {
                continue;
            }
            let mut lambda = DVector::zeros(m);
            for (k, &j) in free.iter().enumerate() {
                lambda[j] = x[k];
            }
            let obj = self.objective(&lambda);
            if obj < best.0 {
                best = (obj, lambda);
            }
        }
        best.1
    }
}
