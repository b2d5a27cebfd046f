//! Fixed-pattern sparse assembly of energies that are sums of per-stencil terms.
//!
//! A [`Problem`] is an energy `E(x) = Σ_k E_k(x_{S_k})`, where stencil `k` reads the DOFs
//! `S_k = stencil_dofs(k)`. Its gradient and Hessian are sums of scattered local pieces,
//!
//! ```text
//! ∇E = Σ_k P_kᵀ ∇E_k,      ∇²E = Σ_k P_kᵀ ∇²E_k P_k,
//! ```
//!
//! with `P_k` the 0/1 matrix selecting `x_{S_k}` from `x`. Since the `S_k` never change, the
//! sparsity pattern of `∇²E` is computed once, in [`Assembler::new`], together with, for every
//! entry `(a, b)` of every local Hessian, the index of the CSC value it is added to. Each
//! [`Assembler::assemble`] then
//!
//! 1. evaluates all stencils in parallel (rayon), each into its own preallocated part of
//!    flat energy, gradient and Hessian buffers, and optionally projects each local Hessian
//!    onto the PSD cone (`rod::spd::project_spd`: negative eigenvalues clamped to zero, Teran
//!    et al. 2005);
//! 2. sums the local pieces into the gradient and the CSC values by a gather, in parallel over
//!    the outputs: every gradient entry and every CSC value has the list of the local entries
//!    that land on it (computed once, with the pattern), in stencil order, and adds them in
//!    that order.
//!
//! Step 1 touches no shared state and every sum in step 2 runs in stencil order, the order of
//! a serial scatter, so the result is bit-identical for any number of threads (and to a
//! serial scatter).
//!
//! **Storage.** The Hessian is stored as its **lower triangle** (row ≥ column) in CSC form, the
//! input sparse Cholesky (`L Lᵀ`) expects; the diagonal is always part of the pattern (so that
//! a diagonal regularization can be added in place). Local entries that fall in the strict upper
//! triangle are skipped: the local Hessians are symmetric, so their mirror image carries the same
//! value. With `T` the stored lower triangle, the full matrix is `T + Tᵀ − diag(T)`.
//!
//! **Dirichlet DOFs.** [`Assembler::with_fixed_dofs`] numbers only the free DOFs (in increasing
//! DOF order) and leaves every Hessian entry that touches a fixed DOF out of the pattern: the
//! Hessian is the free–free block `H_ff`. The gradient always has all `n_dofs` entries (the
//! fixed ones are the reaction forces).

use faer::sparse::{SparseColMat, SparseColMatRef};
use rayon::prelude::*;

use crate::SolveError;
use crate::pattern::{build_pattern, counting_sort};
use rod::spd::{MAX_PROJECT_DIM, project_spd};

/// An energy that is a sum of per-stencil terms over a DOF vector `x` (SI units throughout;
/// the gradient is `∂E/∂x`, forces are its negative).
///
/// Implementors must be [`Sync`]: stencils are evaluated concurrently from several threads.
pub trait Problem: Sync {
    /// Number of degrees of freedom (length of `x`).
    fn n_dofs(&self) -> usize;

    /// Number of stencils (energy terms).
    fn n_stencils(&self) -> usize;

    /// DOF indices of stencil `k` (fixed for the problem's lifetime; defines the sparsity
    /// pattern). Length may differ between stencils; a DOF may appear more than once.
    fn stencil_dofs(&self, k: usize) -> &[usize];

    /// Energy of stencil `k` at `x`. Writes its local gradient (`len = dofs.len()`) and, if
    /// requested, its local dense Hessian (column-major, `len²`, symmetric) into caller-owned
    /// buffers, which the caller has zeroed.
    fn eval_stencil(&self, k: usize, x: &[f64], grad: &mut [f64], hess: Option<&mut [f64]>) -> f64;

    /// Energy of stencil `k` at `x` alone (line searches). The default calls
    /// [`Problem::eval_stencil`] with a scratch gradient; override it when the energy is much
    /// cheaper than its gradient (see [`eval_rod_stencil_energy_offset`]).
    fn stencil_energy(&self, k: usize, x: &[f64]) -> f64 {
        let mut grad = vec![0.0; self.stencil_dofs(k).len()];
        self.eval_stencil(k, x, &mut grad, None)
    }

    /// The largest step fraction `α_max > 0` for which `x + α dx` is admissible for every
    /// `α ∈ [0, α_max]`, e.g. free of yarn pass-through (a conservative continuous collision
    /// filter as in IPC, Li et al. 2020, §4.3). Newton's line search starts at
    /// `min(1, α_max)`. The default, `+∞`, imposes nothing.
    fn max_step(&self, x: &[f64], dx: &[f64]) -> f64 {
        let _ = (x, dx);
        f64::INFINITY
    }
}

/// Marks a local Hessian entry that is not stored (strict upper triangle or touches a fixed DOF).
const SKIP: usize = usize::MAX;

/// Stencils per parallel evaluation task.
const STENCIL_CHUNK: usize = 256;

/// Outputs (gradient entries, CSC values) per parallel gather task.
const GATHER_CHUNK: usize = 4096;

/// Index of a local entry in the flat gradient or Hessian buffers (32 bits: the gather maps
/// are the assembler's largest arrays).
type Local = u32;

/// For every output `o` (a gradient entry or a CSC value), the local entries summed into it:
/// `sources[ptr[o]..ptr[o + 1]]`, increasing (stencil order).
#[derive(Clone, Debug)]
struct Gather {
    ptr: Vec<usize>,
    sources: Vec<Local>,
}

impl Gather {
    /// The gather of `n_outputs` outputs from the map `target[local] = output` ([`SKIP`]:
    /// none), by a counting sort that keeps the local entries in increasing order.
    fn new(n_outputs: usize, target: &[usize]) -> Result<Self, SolveError> {
        if target.len() > Local::MAX as usize {
            return Err(SolveError::InvalidProblem(format!(
                "{} local derivative entries exceed the assembler's {} limit",
                target.len(),
                Local::MAX
            )));
        }
        let (ptr, sorted) = counting_sort(
            (0..target.len()).filter(|&local| target[local] != SKIP),
            n_outputs,
            |local| target[local],
        );
        let sources = sorted.into_iter().map(|local| local as Local).collect();
        Ok(Self { ptr, sources })
    }

    /// `out[o] = Σ local[sources]` in the stored order, in parallel over fixed chunks of `out`.
    fn sum_into(&self, local: &[f64], out: &mut [f64]) {
        let (ptr, sources) = (&self.ptr, &self.sources);
        out.par_chunks_mut(GATHER_CHUNK)
            .enumerate()
            .for_each(|(c, out)| {
                let first = c * GATHER_CHUNK;
                for (k, o) in out.iter_mut().enumerate() {
                    let i = first + k;
                    let mut sum = 0.0;
                    for &l in &sources[ptr[i]..ptr[i + 1]] {
                        sum += local[l as usize];
                    }
                    *o = sum;
                }
            });
    }
}

/// The result of [`Assembler::assemble`], borrowing the assembler's buffers.
#[derive(Clone, Copy, Debug)]
pub struct Assembled<'a> {
    /// Total energy `E(x)`.
    pub energy: f64,
    /// Full gradient `∂E/∂x` (length `n_dofs`, fixed DOFs included).
    pub gradient: &'a [f64],
    /// Lower triangle of the free–free Hessian block, `n_free × n_free`, in free-DOF numbering
    /// (see [`Assembler::free_index`]).
    pub hessian: SparseColMatRef<'a, usize, f64>,
}

/// Assembles energy, gradient and sparse Hessian of a [`Problem`] into a sparsity pattern that
/// is computed once. See the [module documentation](self) for the algorithm.
#[derive(Clone, Debug)]
pub struct Assembler {
    n_dofs: usize,
    /// `free_index[dof]`: the DOF's row/column in the Hessian, `None` if fixed.
    free_index: Vec<Option<usize>>,
    n_free: usize,
    /// DOFs of stencil `k`: `stencil_dofs[stencil_offsets[k]..stencil_offsets[k + 1]]`.
    stencil_offsets: Vec<usize>,
    stencil_dofs: Vec<usize>,
    /// Local Hessian entry `a + m b` of stencil `k` is `hess[hess_offsets[k] + a + m b]`.
    hess_offsets: Vec<usize>,
    /// How the gradient entries gather the local gradients.
    grad_gather: Gather,
    /// How the CSC values gather the local Hessian entries.
    hess_gather: Gather,
    /// CSC value index of the diagonal entry of each free DOF.
    diag_slots: Vec<usize>,
    max_stencil_len: usize,
    /// Per-stencil outputs of the last evaluation: energies, local gradients (laid out as
    /// `stencil_dofs`) and local Hessians (laid out by `hess_offsets`).
    energies: Vec<f64>,
    local_grads: Vec<f64>,
    local_hess: Vec<f64>,
    energy: f64,
    energy_abs_sum: f64,
    gradient: Vec<f64>,
    hessian: SparseColMat<usize, f64>,
    /// Hessians assembled so far (tells a back end that the matrix changed).
    hessian_count: u64,
}

impl Assembler {
    /// Builds the sparsity pattern of the full Hessian of `problem` (no fixed DOFs).
    pub fn new<P: Problem + ?Sized>(problem: &P) -> Result<Self, SolveError> {
        Self::with_fixed_dofs(problem, &vec![false; problem.n_dofs()])
    }

    /// Builds the sparsity pattern of the free–free Hessian block, where `fixed[dof]` marks the
    /// Dirichlet DOFs (`fixed.len() == n_dofs`).
    pub fn with_fixed_dofs<P: Problem + ?Sized>(
        problem: &P,
        fixed: &[bool],
    ) -> Result<Self, SolveError> {
        let n_dofs = problem.n_dofs();
        check_len("fixed-DOF mask", n_dofs, fixed.len())?;
        let mut free_index = vec![None; n_dofs];
        let mut n_free = 0;
        for (dof, &is_fixed) in fixed.iter().enumerate() {
            if !is_fixed {
                free_index[dof] = Some(n_free);
                n_free += 1;
            }
        }

        // Copy the stencils' DOF lists (to detect later changes and for the gradient scatter).
        let n_stencils = problem.n_stencils();
        let mut stencil_offsets = Vec::with_capacity(n_stencils + 1);
        let mut stencil_dofs = Vec::new();
        stencil_offsets.push(0);
        for k in 0..n_stencils {
            let dofs = problem.stencil_dofs(k);
            if let Some(&bad) = dofs.iter().find(|&&d| d >= n_dofs) {
                return Err(SolveError::InvalidProblem(format!(
                    "stencil {k} references DOF {bad}, but the problem has {n_dofs} DOFs"
                )));
            }
            stencil_dofs.extend_from_slice(dofs);
            stencil_offsets.push(stencil_dofs.len());
        }

        // Coordinates of the stored entries: every free diagonal first, then each stencil's
        // local entries that land in the free–free lower triangle. `hess_target` temporarily
        // holds indices into `coords`, replaced by CSC value indices below.
        // Sized up front (growing them took a tenth of this function on the periodic tiles):
        // a stencil of `l` DOFs has `l²` local entries, `l (l + 1) / 2` in the lower triangle.
        let lengths = stencil_offsets.windows(2).map(|w| w[1] - w[0]);
        let local_entries: usize = lengths.clone().map(|l| l * l).sum();
        let lower_entries: usize = lengths.map(|l| l * (l + 1) / 2).sum();
        let mut coords: Vec<(usize, usize)> = Vec::with_capacity(n_free + lower_entries);
        coords.extend((0..n_free).map(|i| (i, i)));
        let mut hess_offsets = Vec::with_capacity(n_stencils + 1);
        let mut hess_target = Vec::with_capacity(local_entries);
        hess_offsets.push(0);
        for k in 0..n_stencils {
            let dofs = &stencil_dofs[stencil_offsets[k]..stencil_offsets[k + 1]];
            for &col_dof in dofs {
                for &row_dof in dofs {
                    let target = match (free_index[row_dof], free_index[col_dof]) {
                        (Some(row), Some(col)) if row >= col => {
                            coords.push((row, col));
                            coords.len() - 1
                        }
                        _ => SKIP,
                    };
                    hess_target.push(target);
                }
            }
            hess_offsets.push(hess_target.len());
        }
        let (symbolic, slot_of) = build_pattern(n_free, n_free, &coords);
        for t in hess_target.iter_mut().filter(|t| **t != SKIP) {
            *t = slot_of[*t];
        }
        let diag_slots = slot_of[..n_free].to_vec();
        let nnz = symbolic.row_idx().len();
        let hess_gather = Gather::new(nnz, &hess_target)?;
        let grad_gather = Gather::new(n_dofs, &stencil_dofs)?;
        let max_stencil_len = (0..n_stencils)
            .map(|k| stencil_offsets[k + 1] - stencil_offsets[k])
            .max()
            .unwrap_or(0);

        Ok(Self {
            n_dofs,
            free_index,
            n_free,
            energies: vec![0.0; n_stencils],
            local_grads: vec![0.0; stencil_dofs.len()],
            local_hess: vec![0.0; hess_target.len()],
            stencil_offsets,
            stencil_dofs,
            hess_offsets,
            grad_gather,
            hess_gather,
            diag_slots,
            max_stencil_len,
            energy: 0.0,
            energy_abs_sum: 0.0,
            gradient: vec![0.0; n_dofs],
            hessian: SparseColMat::new(symbolic, vec![0.0; nnz]),
            hessian_count: 0,
        })
    }

    /// Number of DOFs of the problem.
    pub fn n_dofs(&self) -> usize {
        self.n_dofs
    }

    /// Number of free (non-Dirichlet) DOFs: the Hessian's dimension.
    pub fn n_free(&self) -> usize {
        self.n_free
    }

    /// Row/column of `dof` in the Hessian, or `None` if it is fixed (or out of range).
    pub fn free_index(&self, dof: usize) -> Option<usize> {
        self.free_index.get(dof).copied().flatten()
    }

    /// Energy, gradient and Hessian at `x`. With `project_spd`, every local Hessian is projected
    /// onto the PSD cone before the scatter, so the assembled Hessian is positive semi-definite.
    ///
    /// Errors if `x` has the wrong length, if the problem's stencils changed, or if projection
    /// is requested for a stencil with more than 32 DOFs.
    pub fn assemble<P: Problem + ?Sized>(
        &mut self,
        problem: &P,
        x: &[f64],
        project_spd: bool,
    ) -> Result<Assembled<'_>, SolveError> {
        self.check_inputs(problem, x)?;
        if project_spd && self.max_stencil_len > MAX_PROJECT_DIM {
            return Err(SolveError::InvalidProblem(format!(
                "SPD projection supports stencils of at most {MAX_PROJECT_DIM} DOFs, found {}",
                self.max_stencil_len
            )));
        }
        self.evaluate(problem, x, Some(project_spd));
        self.gather_gradient();
        self.hess_gather
            .sum_into(&self.local_hess, self.hessian.val_mut());
        self.hessian_count += 1;
        Ok(Assembled {
            energy: self.energy,
            gradient: &self.gradient,
            hessian: self.hessian.as_ref(),
        })
    }

    /// Energy and full gradient at `x` (no Hessian).
    pub fn gradient<P: Problem + ?Sized>(
        &mut self,
        problem: &P,
        x: &[f64],
    ) -> Result<(f64, &[f64]), SolveError> {
        self.check_inputs(problem, x)?;
        self.evaluate(problem, x, None);
        self.gather_gradient();
        Ok((self.energy, &self.gradient))
    }

    /// Energy at `x` only (the cheap evaluation line searches need). Stencils are evaluated in
    /// parallel (fixed chunks) and summed serially in stencil order, so the result is
    /// thread-count independent.
    pub fn energy<P: Problem + ?Sized>(
        &mut self,
        problem: &P,
        x: &[f64],
    ) -> Result<f64, SolveError> {
        self.check_inputs(problem, x)?;
        self.energies
            .par_chunks_mut(STENCIL_CHUNK)
            .enumerate()
            .for_each(|(c, energies)| {
                for (i, e) in energies.iter_mut().enumerate() {
                    *e = problem.stencil_energy(c * STENCIL_CHUNK + i, x);
                }
            });
        self.sum_energies();
        Ok(self.energy)
    }

    /// `Σ_k |E_k|` from the most recent evaluation: the scale of the rounding error in the
    /// computed total energy (used to tell real energy decreases from rounding noise).
    pub fn energy_abs_sum(&self) -> f64 {
        self.energy_abs_sum
    }

    /// The Hessian (lower triangle of the free–free block) from the most recent
    /// [`assemble`](Self::assemble).
    pub fn hessian(&self) -> SparseColMatRef<'_, usize, f64> {
        self.hessian.as_ref()
    }

    /// How many Hessians [`assemble`](Self::assemble) has built: changes whenever the
    /// Hessian does (the in-place shifts of [`Self::hessian_values_and_diagonal`] are
    /// restored by their users).
    pub(crate) fn hessian_count(&self) -> u64 {
        self.hessian_count
    }

    /// Mutable Hessian values and the value index of every free diagonal entry, for in-place
    /// regularization by the solvers.
    pub(crate) fn hessian_values_and_diagonal(&mut self) -> (&mut [f64], &[usize]) {
        (self.hessian.val_mut(), &self.diag_slots)
    }

    /// `max_i |H_ii|` over the free diagonal of the assembled Hessian, or 1 if that is zero or
    /// not finite: the scale of the solvers' regularizing shifts.
    pub(crate) fn diagonal_scale(&self) -> f64 {
        let values = self.hessian.val();
        let s = self
            .diag_slots
            .iter()
            .map(|&d| values[d].abs())
            .fold(0.0, f64::max);
        if s > 0.0 && s.is_finite() { s } else { 1.0 }
    }

    /// The full gradient from the most recent evaluation.
    pub(crate) fn last_gradient(&self) -> &[f64] {
        &self.gradient
    }

    /// Validates `x` and that `problem` still has the stencils the pattern was built for.
    fn check_inputs<P: Problem + ?Sized>(&self, problem: &P, x: &[f64]) -> Result<(), SolveError> {
        check_len("x", self.n_dofs, x.len())?;
        let n_stencils = self.energies.len();
        if problem.n_dofs() != self.n_dofs || problem.n_stencils() != n_stencils {
            return Err(SolveError::PatternChanged(format!(
                "built for {} DOFs / {} stencils, got {} / {}",
                self.n_dofs,
                n_stencils,
                problem.n_dofs(),
                problem.n_stencils()
            )));
        }
        // Serial: a comparison of a few thousand indices, far cheaper than waking the pool.
        let changed = (0..n_stencils).position(|k| {
            problem.stencil_dofs(k)
                != &self.stencil_dofs[self.stencil_offsets[k]..self.stencil_offsets[k + 1]]
        });
        match changed {
            Some(k) => Err(SolveError::PatternChanged(format!(
                "DOFs of stencil {k} changed"
            ))),
            None => Ok(()),
        }
    }

    /// Evaluates every stencil into its own part of the flat buffers, in parallel over fixed
    /// chunks of stencils. `hessian`: `None` for energy and gradient only, `Some(project_spd)`
    /// to also compute (and optionally project) the Hessian.
    fn evaluate<P: Problem + ?Sized>(&mut self, problem: &P, x: &[f64], hessian: Option<bool>) {
        // Split the flat buffers at the chunk boundaries.
        let n_stencils = self.energies.len();
        let (so, ho) = (&self.stencil_offsets, &self.hess_offsets);
        let mut tasks = Vec::with_capacity(n_stencils.div_ceil(STENCIL_CHUNK));
        let (mut energies, mut grads, mut hess) = (
            &mut self.energies[..],
            &mut self.local_grads[..],
            &mut self.local_hess[..],
        );
        for first in (0..n_stencils).step_by(STENCIL_CHUNK) {
            let end = (first + STENCIL_CHUNK).min(n_stencils);
            let (e, e_rest) = energies.split_at_mut(end - first);
            let (g, g_rest) = grads.split_at_mut(so[end] - so[first]);
            let (h, h_rest) = hess.split_at_mut(ho[end] - ho[first]);
            tasks.push((first, e, g, h));
            (energies, grads, hess) = (e_rest, g_rest, h_rest);
        }
        tasks
            .into_par_iter()
            .for_each(|(first, energies, grads, hess)| {
                for (i, energy) in energies.iter_mut().enumerate() {
                    let k = first + i;
                    let grad = &mut grads[so[k] - so[first]..so[k + 1] - so[first]];
                    grad.fill(0.0);
                    *energy = match hessian {
                        None => problem.eval_stencil(k, x, grad, None),
                        Some(project) => {
                            let h = &mut hess[ho[k] - ho[first]..ho[k + 1] - ho[first]];
                            h.fill(0.0);
                            let e = problem.eval_stencil(k, x, grad, Some(&mut *h));
                            if project {
                                // Sizes are checked in `assemble` (rod asserts n ≤ MAX_PROJECT_DIM).
                                project_spd(h, grad.len());
                            }
                            e
                        }
                    };
                }
            });
    }

    /// Serial, stencil-ordered sum of the stencil energies.
    fn sum_energies(&mut self) {
        self.energy = self.energies.iter().sum();
        self.energy_abs_sum = self.energies.iter().map(|e| e.abs()).sum();
    }

    /// The total energy and the gradient gathered from the local gradients.
    fn gather_gradient(&mut self) {
        self.sum_energies();
        self.grad_gather
            .sum_into(&self.local_grads, &mut self.gradient);
    }
}

/// `Err(DimensionMismatch)` unless `got == expected`.
pub(crate) fn check_len(what: &'static str, expected: usize, got: usize) -> Result<(), SolveError> {
    if got == expected {
        Ok(())
    } else {
        Err(SolveError::DimensionMismatch {
            what,
            expected,
            got,
        })
    }
}

/// Evaluates a fixed-size [`rod::Stencil`] for [`Problem::eval_stencil`]: gathers its local
/// DOF vector `q = x[dofs]`, and writes the local gradient and (if requested) Hessian into the
/// caller's buffers. Every problem built from `rod` stencils uses this instead of writing its
/// own gather/scatter code.
pub fn eval_rod_stencil<const N: usize>(
    stencil: &impl rod::Stencil<N>,
    dofs: &[usize],
    x: &[f64],
    grad: &mut [f64],
    hess: Option<&mut [f64]>,
) -> f64 {
    eval_rod_stencil_offset(stencil, dofs, &[0.0; N], x, grad, hess)
}

/// Like [`eval_rod_stencil`] with an affine part: the stencil sees `q = x[dofs] + offset`.
/// Used when the DOFs are fluctuations about a prescribed map (periodic tiles: positions
/// `F X + ũ` with `ũ` the DOFs and `F X` the offset); `∂q/∂x = I`, so the stencil's gradient
/// and Hessian are the problem's.
pub fn eval_rod_stencil_offset<const N: usize>(
    stencil: &impl rod::Stencil<N>,
    dofs: &[usize],
    offset: &[f64],
    x: &[f64],
    grad: &mut [f64],
    hess: Option<&mut [f64]>,
) -> f64 {
    debug_assert_eq!(dofs.len(), N);
    debug_assert_eq!(offset.len(), N);
    let q = nalgebra::SVector::<f64, N>::from_fn(|i, _| x[dofs[i]] + offset[i]);
    match hess {
        Some(h) => {
            let e = stencil.eval(&q);
            grad.copy_from_slice(e.gradient.as_slice());
            h.copy_from_slice(e.hessian.as_slice());
            e.energy
        }
        None => {
            let (energy, gradient) = stencil.energy_and_gradient(&q);
            grad.copy_from_slice(gradient.as_slice());
            energy
        }
    }
}

/// The energy alone of [`eval_rod_stencil_offset`]'s stencil, for
/// [`Problem::stencil_energy`].
pub fn eval_rod_stencil_energy_offset<const N: usize>(
    stencil: &impl rod::Stencil<N>,
    dofs: &[usize],
    offset: &[f64],
    x: &[f64],
) -> f64 {
    debug_assert_eq!(dofs.len(), N);
    debug_assert_eq!(offset.len(), N);
    stencil.energy(&nalgebra::SVector::<f64, N>::from_fn(|i, _| {
        x[dofs[i]] + offset[i]
    }))
}
