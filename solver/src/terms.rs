//! One container for energies that are sums of heterogeneous terms.
//!
//! A model (shell, periodic tile, cantilever, …) is a list of **terms**, each an energy on a
//! small local DOF vector `q` placed on the global DOFs by its indices, optionally shifted by
//! an affine offset: `q = x[dofs] + offset`. [`Terms`] stores them in insertion order (which is
//! the stencil order, hence the summation order of the [`crate::Assembler`]) and implements
//! [`Problem`], so adding an energy to a model is one new type and one `push`:
//!
//! - a fixed-size [`rod::Stencil<N>`] is wrapped by [`RodTerm`] (blanket impl, no code);
//! - anything else (a variable-size element, a linear load) implements [`LocalEnergy`].
//!
//! Terms are evaluated through one dynamic call each; the local vector is gathered on the
//! stack (at most [`MAX_TERM_DOFS`] entries), so evaluations do not allocate. Typed access to
//! the stored terms (changing a material, moving an anchor) is by downcast
//! ([`Terms::get_mut`], [`Terms::iter_mut_of`], [`Terms::par_iter_mut`] for parallel
//! per-step updates). Terms are `Clone` (hence [`Terms`] is), and two problems on the same
//! DOFs chain into one with [`Concat`] (e.g. a model's fixed terms followed by per-step ones).

use std::any::Any;

use rayon::prelude::*;

use crate::Problem;

/// The largest local DOF vector a term may have (checked by [`Terms::push`]).
pub const MAX_TERM_DOFS: usize = 64;

/// An energy term on a local DOF vector `q` of [`LocalEnergy::n_local`] entries (object safe).
///
/// Energies are in J; the gradient is `∂W/∂q`, the Hessian `∂²W/∂q²` (column-major,
/// symmetric). [`RodTerm`] implements it for every [`rod::Stencil<N>`]. Terms are `Clone`
/// ([`CloneTerm`] comes with it).
pub trait LocalEnergy: Any + Send + Sync + CloneTerm {
    /// Number of local DOFs `q.len()`.
    fn n_local(&self) -> usize;

    /// Energy (J) at `q` (the cheap path of line searches).
    fn local_energy(&self, q: &[f64]) -> f64;

    /// Energy (J) at `q`; writes the gradient into `grad` (`len = n_local`) and, if requested,
    /// the Hessian into `hess` (`n_local²`, column-major). Without `hess`, implementations
    /// should skip the Hessian's cost.
    fn local_eval(&self, q: &[f64], grad: &mut [f64], hess: Option<&mut [f64]>) -> f64;

    /// [`LocalEnergy::local_eval`] at `q = x[dofs] (+ offset)`. The default gathers `q` into a
    /// [`LocalVector`]; implementations may gather straight into their own storage (the same
    /// values, so the same result).
    fn eval_at(
        &self,
        x: &[f64],
        dofs: &[usize],
        offset: Option<&[f64]>,
        grad: &mut [f64],
        hess: Option<&mut [f64]>,
    ) -> f64 {
        self.local_eval(&LocalVector::gather(x, dofs, offset), grad, hess)
    }

    /// [`LocalEnergy::local_energy`] at `q = x[dofs] (+ offset)` (see [`LocalEnergy::eval_at`]).
    fn energy_at(&self, x: &[f64], dofs: &[usize], offset: Option<&[f64]>) -> f64 {
        self.local_energy(&LocalVector::gather(x, dofs, offset))
    }
}

/// Boxed copies of terms: implemented for every `Clone` [`LocalEnergy`] (nothing to write).
pub trait CloneTerm {
    /// A boxed copy of the term.
    fn clone_term(&self) -> Box<dyn LocalEnergy>;
}

impl<T: LocalEnergy + Clone> CloneTerm for T {
    fn clone_term(&self) -> Box<dyn LocalEnergy> {
        Box::new(self.clone())
    }
}

impl dyn LocalEnergy {
    /// Whether the term is a `T`.
    pub fn is<T: LocalEnergy>(&self) -> bool {
        (self as &dyn Any).is::<T>()
    }

    /// The term as a `T`, if it is one.
    pub fn downcast_ref<T: LocalEnergy>(&self) -> Option<&T> {
        (self as &dyn Any).downcast_ref()
    }

    /// The term as a mutable `T`, if it is one.
    pub fn downcast_mut<T: LocalEnergy>(&mut self) -> Option<&mut T> {
        (self as &mut dyn Any).downcast_mut()
    }
}

/// `q_i = x[dofs_i] (+ offset_i)` as a fixed-size vector (the bits of [`LocalVector::gather`]).
fn gather_fixed<const N: usize>(
    x: &[f64],
    dofs: &[usize],
    offset: Option<&[f64]>,
) -> nalgebra::SVector<f64, N> {
    debug_assert_eq!(dofs.len(), N);
    match offset {
        Some(o) => nalgebra::SVector::from_fn(|i, _| x[dofs[i]] + o[i]),
        None => nalgebra::SVector::from_fn(|i, _| x[dofs[i]]),
    }
}

/// A [`rod::Stencil<N>`] as a [`LocalEnergy`]: `q` is converted to the stencil's fixed-size
/// vector. Derefs to the stencil.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RodTerm<S, const N: usize>(pub S);

impl<S, const N: usize> std::ops::Deref for RodTerm<S, N> {
    type Target = S;
    fn deref(&self) -> &S {
        &self.0
    }
}

impl<S, const N: usize> std::ops::DerefMut for RodTerm<S, N> {
    fn deref_mut(&mut self) -> &mut S {
        &mut self.0
    }
}

impl<S, const N: usize> RodTerm<S, N> {
    fn eval_fixed(
        stencil: &S,
        q: &nalgebra::SVector<f64, N>,
        grad: &mut [f64],
        hess: Option<&mut [f64]>,
    ) -> f64
    where
        S: rod::Stencil<N>,
    {
        match hess {
            Some(h) => {
                let e = stencil.eval(q);
                grad.copy_from_slice(e.gradient.as_slice());
                h.copy_from_slice(e.hessian.as_slice());
                e.energy
            }
            None => {
                let (energy, gradient) = stencil.energy_and_gradient(q);
                grad.copy_from_slice(gradient.as_slice());
                energy
            }
        }
    }
}

impl<S, const N: usize> LocalEnergy for RodTerm<S, N>
where
    S: rod::Stencil<N> + Clone + Send + Sync + 'static,
{
    fn n_local(&self) -> usize {
        N
    }

    fn local_energy(&self, q: &[f64]) -> f64 {
        self.0.energy(&nalgebra::SVector::from_column_slice(q))
    }

    fn local_eval(&self, q: &[f64], grad: &mut [f64], hess: Option<&mut [f64]>) -> f64 {
        Self::eval_fixed(
            &self.0,
            &nalgebra::SVector::from_column_slice(q),
            grad,
            hess,
        )
    }

    fn eval_at(
        &self,
        x: &[f64],
        dofs: &[usize],
        offset: Option<&[f64]>,
        grad: &mut [f64],
        hess: Option<&mut [f64]>,
    ) -> f64 {
        Self::eval_fixed(&self.0, &gather_fixed(x, dofs, offset), grad, hess)
    }

    fn energy_at(&self, x: &[f64], dofs: &[usize], offset: Option<&[f64]>) -> f64 {
        self.0.energy(&gather_fixed(x, dofs, offset))
    }
}

/// A local DOF vector on the stack (at most [`MAX_TERM_DOFS`] entries); derefs to a slice.
#[derive(Clone, Copy, Debug)]
pub struct LocalVector {
    values: [f64; MAX_TERM_DOFS],
    len: usize,
}

impl LocalVector {
    /// `q_i = x[dofs_i] (+ offset_i)`; no addition at all without an offset, so `q` holds the
    /// DOFs' exact bits.
    pub fn gather(x: &[f64], dofs: &[usize], offset: Option<&[f64]>) -> Self {
        assert!(
            dofs.len() <= MAX_TERM_DOFS,
            "a term has at most {MAX_TERM_DOFS} DOFs"
        );
        let mut values = [0.0; MAX_TERM_DOFS];
        match offset {
            Some(o) => {
                debug_assert_eq!(o.len(), dofs.len());
                for ((q, &d), o) in values.iter_mut().zip(dofs).zip(o) {
                    *q = x[d] + o;
                }
            }
            None => {
                for (q, &d) in values.iter_mut().zip(dofs) {
                    *q = x[d];
                }
            }
        }
        Self {
            values,
            len: dofs.len(),
        }
    }
}

impl std::ops::Deref for LocalVector {
    type Target = [f64];
    fn deref(&self) -> &[f64] {
        &self.values[..self.len]
    }
}

impl std::ops::DerefMut for LocalVector {
    fn deref_mut(&mut self) -> &mut [f64] {
        &mut self.values[..self.len]
    }
}

/// Terms with their DOF indices and optional affine offsets: the energy
/// `E(x) = Σ_k W_k(x[dofs_k] + offset_k)` as a [`Problem`] (stencil `k` = term `k`, in
/// insertion order).
pub struct Terms {
    n_dofs: usize,
    terms: Vec<Box<dyn LocalEnergy>>,
    /// DOFs of term `k`: `dofs[ranges[k]..ranges[k + 1]]`.
    ranges: Vec<usize>,
    dofs: Vec<usize>,
    /// Offsets parallel to `dofs`; empty while no term has one (then `q = x[dofs]` exactly).
    offsets: Vec<f64>,
}

impl Clone for Terms {
    fn clone(&self) -> Self {
        Self {
            n_dofs: self.n_dofs,
            terms: self.terms.iter().map(|t| t.clone_term()).collect(),
            ranges: self.ranges.clone(),
            dofs: self.dofs.clone(),
            offsets: self.offsets.clone(),
        }
    }
}

impl std::fmt::Debug for Terms {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Terms")
            .field("n_dofs", &self.n_dofs)
            .field("n_terms", &self.terms.len())
            .finish_non_exhaustive()
    }
}

impl Terms {
    /// An empty container over `n_dofs` global DOFs.
    pub fn new(n_dofs: usize) -> Self {
        Self {
            n_dofs,
            terms: Vec::new(),
            ranges: vec![0],
            dofs: Vec::new(),
            offsets: Vec::new(),
        }
    }

    /// Appends `term` on the global DOFs `dofs` and returns its index. DOFs `≥ n_dofs` are
    /// reported by the [`crate::Assembler`] (`InvalidProblem`).
    ///
    /// # Panics
    /// If `dofs.len()` differs from `term.n_local()` or exceeds [`MAX_TERM_DOFS`] (a
    /// programming error: both are fixed by the term's type).
    pub fn push(&mut self, term: impl LocalEnergy, dofs: &[usize]) -> usize {
        assert_eq!(term.n_local(), dofs.len(), "term and DOF list sizes differ");
        assert!(
            dofs.len() <= MAX_TERM_DOFS,
            "a term has at most {MAX_TERM_DOFS} DOFs"
        );
        self.terms.push(Box::new(term));
        self.dofs.extend_from_slice(dofs);
        self.ranges.push(self.dofs.len());
        if !self.offsets.is_empty() {
            self.offsets.resize(self.dofs.len(), 0.0);
        }
        self.terms.len() - 1
    }

    /// Appends a [`rod::Stencil<N>`] (wrapped in [`RodTerm`]) on `dofs`; returns its index.
    pub fn push_stencil<S, const N: usize>(&mut self, stencil: S, dofs: [usize; N]) -> usize
    where
        S: rod::Stencil<N> + Clone + Send + Sync + 'static,
    {
        self.push(RodTerm(stencil), &dofs)
    }

    /// Number of global DOFs.
    pub fn n_dofs(&self) -> usize {
        self.n_dofs
    }

    /// Number of terms.
    pub fn len(&self) -> usize {
        self.terms.len()
    }

    /// Whether there are no terms.
    pub fn is_empty(&self) -> bool {
        self.terms.is_empty()
    }

    /// Term `k`.
    pub fn term(&self, k: usize) -> &dyn LocalEnergy {
        &*self.terms[k]
    }

    /// Term `k`, mutably (its type and DOFs stay; downcast to change it).
    pub fn term_mut(&mut self, k: usize) -> &mut dyn LocalEnergy {
        &mut *self.terms[k]
    }

    /// Global DOFs of term `k`.
    pub fn dofs(&self, k: usize) -> &[usize] {
        &self.dofs[self.ranges[k]..self.ranges[k + 1]]
    }

    /// Affine offset of term `k` (`None` while no term has an offset).
    pub fn offset(&self, k: usize) -> Option<&[f64]> {
        (!self.offsets.is_empty()).then(|| &self.offsets[self.ranges[k]..self.ranges[k + 1]])
    }

    /// Mutable affine offset of term `k`; the first call gives every term a zero offset.
    pub fn offset_mut(&mut self, k: usize) -> &mut [f64] {
        if self.offsets.is_empty() {
            self.offsets = vec![0.0; self.dofs.len()];
        }
        &mut self.offsets[self.ranges[k]..self.ranges[k + 1]]
    }

    /// Term `k` as a `T`, if it is one.
    pub fn get<T: LocalEnergy>(&self, k: usize) -> Option<&T> {
        (&*self.terms[k] as &dyn Any).downcast_ref()
    }

    /// Term `k` as a mutable `T`, if it is one.
    pub fn get_mut<T: LocalEnergy>(&mut self, k: usize) -> Option<&mut T> {
        (&mut *self.terms[k] as &mut dyn Any).downcast_mut()
    }

    /// Every term of type `T` with its index, in order.
    pub fn iter_of<T: LocalEnergy>(&self) -> impl Iterator<Item = (usize, &T)> {
        self.terms
            .iter()
            .enumerate()
            .filter_map(|(k, t)| Some((k, (&**t as &dyn Any).downcast_ref::<T>()?)))
    }

    /// Every term of type `T`, mutably, with its index, in order.
    pub fn iter_mut_of<T: LocalEnergy>(&mut self) -> impl Iterator<Item = (usize, &mut T)> {
        self.terms
            .iter_mut()
            .enumerate()
            .filter_map(|(k, t)| Some((k, (&mut **t as &mut dyn Any).downcast_mut::<T>()?)))
    }

    /// Every term of type `T`, mutably, with its index and global DOFs, in order.
    pub fn iter_mut_with_dofs_of<T: LocalEnergy>(
        &mut self,
    ) -> impl Iterator<Item = (usize, &mut T, &[usize])> {
        let (dofs, ranges) = (&self.dofs, &self.ranges);
        self.terms.iter_mut().enumerate().filter_map(move |(k, t)| {
            let term = (&mut **t as &mut dyn Any).downcast_mut::<T>()?;
            Some((k, term, &dofs[ranges[k]..ranges[k + 1]]))
        })
    }

    /// Every term, mutably, in order, as a parallel iterator (per-step updates of many
    /// independent terms; downcast each with [`LocalEnergy`]'s `downcast_mut`).
    pub fn par_iter_mut(
        &mut self,
    ) -> impl IndexedParallelIterator<Item = &mut (dyn LocalEnergy + 'static)> {
        self.terms.par_iter_mut().map(|t| &mut **t)
    }

    /// Removes every term from index `len` on (nothing if there are not more).
    pub fn truncate(&mut self, len: usize) {
        if len >= self.terms.len() {
            return;
        }
        self.terms.truncate(len);
        self.ranges.truncate(len + 1);
        self.dofs.truncate(self.ranges[len]);
        if !self.offsets.is_empty() {
            self.offsets.truncate(self.dofs.len());
        }
    }

    /// Moves every term of `other` (same number of global DOFs) to the end of `self`, in
    /// order.
    ///
    /// # Panics
    /// If the two containers have different numbers of DOFs.
    pub fn append(&mut self, other: Terms) {
        assert_eq!(self.n_dofs, other.n_dofs, "appended terms on other DOFs");
        if !other.offsets.is_empty() && self.offsets.is_empty() {
            self.offsets = vec![0.0; self.dofs.len()];
        }
        let base = self.dofs.len();
        self.dofs.extend_from_slice(&other.dofs);
        self.ranges
            .extend(other.ranges[1..].iter().map(|r| base + r));
        if !self.offsets.is_empty() {
            match other.offsets.is_empty() {
                true => self.offsets.resize(self.dofs.len(), 0.0),
                false => self.offsets.extend_from_slice(&other.offsets),
            }
        }
        self.terms.extend(other.terms);
    }

    /// The local vector `q = x[dofs] + offset` of term `k`.
    pub fn gather(&self, k: usize, x: &[f64]) -> LocalVector {
        LocalVector::gather(x, self.dofs(k), self.offset(k))
    }
}

impl Problem for Terms {
    fn n_dofs(&self) -> usize {
        self.n_dofs
    }

    fn n_stencils(&self) -> usize {
        self.terms.len()
    }

    fn stencil_dofs(&self, k: usize) -> &[usize] {
        self.dofs(k)
    }

    fn eval_stencil(&self, k: usize, x: &[f64], grad: &mut [f64], hess: Option<&mut [f64]>) -> f64 {
        self.terms[k].eval_at(x, self.dofs(k), self.offset(k), grad, hess)
    }

    fn stencil_energy(&self, k: usize, x: &[f64]) -> f64 {
        self.terms[k].energy_at(x, self.dofs(k), self.offset(k))
    }
}

/// Two problems on the same DOFs as one: the stencils of `first`, then those of `second`
/// (so the sums run in that order), e.g. a model's fixed terms followed by the per-step
/// terms of an implicit time step.
#[derive(Clone, Copy, Debug)]
pub struct Concat<'a, A: ?Sized, B: ?Sized> {
    first: &'a A,
    second: &'a B,
    n_first: usize,
}

impl<'a, A: Problem + ?Sized, B: Problem + ?Sized> Concat<'a, A, B> {
    /// `first` followed by `second`.
    ///
    /// # Panics
    /// If the two problems have different numbers of DOFs.
    pub fn new(first: &'a A, second: &'a B) -> Self {
        assert_eq!(
            first.n_dofs(),
            second.n_dofs(),
            "concatenated problems on other DOFs"
        );
        Self {
            first,
            second,
            n_first: first.n_stencils(),
        }
    }

    /// The first problem.
    pub fn first(&self) -> &'a A {
        self.first
    }

    /// The second problem.
    pub fn second(&self) -> &'a B {
        self.second
    }
}

impl<A: Problem + ?Sized, B: Problem + ?Sized> Problem for Concat<'_, A, B> {
    fn n_dofs(&self) -> usize {
        self.first.n_dofs()
    }

    fn n_stencils(&self) -> usize {
        self.n_first + self.second.n_stencils()
    }

    fn stencil_dofs(&self, k: usize) -> &[usize] {
        match k.checked_sub(self.n_first) {
            None => self.first.stencil_dofs(k),
            Some(j) => self.second.stencil_dofs(j),
        }
    }

    fn eval_stencil(&self, k: usize, x: &[f64], grad: &mut [f64], hess: Option<&mut [f64]>) -> f64 {
        match k.checked_sub(self.n_first) {
            None => self.first.eval_stencil(k, x, grad, hess),
            Some(j) => self.second.eval_stencil(j, x, grad, hess),
        }
    }

    fn stencil_energy(&self, k: usize, x: &[f64]) -> f64 {
        match k.checked_sub(self.n_first) {
            None => self.first.stencil_energy(k, x),
            Some(j) => self.second.stencil_energy(j, x),
        }
    }

    fn max_step(&self, x: &[f64], dx: &[f64]) -> f64 {
        self.first.max_step(x, dx).min(self.second.max_step(x, dx))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Assembler;
    use nalgebra::{SMatrix, SVector};
    use rod::Evaluation;
    use rod::stretch::{Segment, StretchLaw};

    /// `W = ½ qᵀ A q + bᵀ q` with `A` symmetric.
    #[derive(Clone, Copy)]
    struct Quadratic2 {
        a: [f64; 3],
        b: [f64; 2],
    }

    impl rod::Stencil<2> for Quadratic2 {
        fn energy(&self, q: &SVector<f64, 2>) -> f64 {
            self.eval(q).energy
        }
        fn eval(&self, q: &SVector<f64, 2>) -> Evaluation<2> {
            let a = SMatrix::<f64, 2, 2>::new(self.a[0], self.a[1], self.a[1], self.a[2]);
            let b = SVector::<f64, 2>::from(self.b);
            Evaluation {
                energy: 0.5 * q.dot(&(a * q)) + b.dot(q),
                gradient: a * q + b,
                hessian: a,
            }
        }
    }

    /// A linear load `W = c q` written directly against [`LocalEnergy`].
    #[derive(Clone)]
    struct Linear(f64);

    impl LocalEnergy for Linear {
        fn n_local(&self) -> usize {
            1
        }
        fn local_energy(&self, q: &[f64]) -> f64 {
            self.0 * q[0]
        }
        fn local_eval(&self, q: &[f64], grad: &mut [f64], _: Option<&mut [f64]>) -> f64 {
            grad[0] = self.0;
            self.0 * q[0]
        }
    }

    /// Truncating keeps the first terms with their DOFs and drops the rest; appending after
    /// it continues the DOF lists where they were cut.
    #[test]
    fn truncate_drops_the_tail() {
        let mut t = Terms::new(3);
        t.push(Linear(1.0), &[0]);
        t.push(Linear(2.0), &[1]);
        t.push(Linear(3.0), &[2]);
        t.truncate(5);
        assert_eq!(t.len(), 3);
        t.truncate(1);
        assert_eq!(t.len(), 1);
        assert_eq!(t.dofs(0), &[0]);
        t.push(Linear(4.0), &[2]);
        assert_eq!(t.dofs(1), &[2]);
        let x = [1.0, 10.0, 100.0];
        let e: f64 = (0..t.len()).map(|k| t.stencil_energy(k, &x)).sum();
        assert_eq!(e, 1.0 + 400.0);
    }

    fn segment() -> Segment {
        Segment {
            rest_length: 0.7,
            law: StretchLaw::Linear { k: 3.0 },
        }
    }

    fn two_terms() -> Terms {
        let mut terms = Terms::new(7);
        terms.push_stencil(segment(), [0, 1, 2, 4, 5, 6]);
        terms.push_stencil(
            Quadratic2 {
                a: [2.0, 0.5, 1.5],
                b: [0.3, -0.2],
            },
            [6, 3],
        );
        terms.push(Linear(-0.4), &[2]);
        terms
    }

    fn x0() -> Vec<f64> {
        vec![0.1, -0.2, 0.05, 0.4, 0.9, 0.3, -0.1]
    }

    #[test]
    fn sums_the_terms_energy_gradient_and_hessian() {
        let terms = two_terms();
        let x = x0();
        let seg = SVector::<f64, 6>::from_fn(|i, _| x[[0, 1, 2, 4, 5, 6][i]]);
        let quad = SVector::<f64, 2>::new(x[6], x[3]);
        let (es, eq) = (
            rod::Stencil::eval(&segment(), &seg),
            rod::Stencil::eval(
                &two_terms().get::<RodTerm<Quadratic2, 2>>(1).unwrap().0,
                &quad,
            ),
        );
        let mut asm = Assembler::new(&terms).unwrap();
        let out = asm.assemble(&terms, &x, false).unwrap();
        assert_eq!(out.energy, es.energy + eq.energy + -0.4 * x[2]);
        let mut g = vec![0.0; 7];
        for (i, &d) in [0, 1, 2, 4, 5, 6].iter().enumerate() {
            g[d] += es.gradient[i];
        }
        g[6] += eq.gradient[0];
        g[3] += eq.gradient[1];
        g[2] += -0.4;
        assert_eq!(out.gradient, g.as_slice());
        // The (6, 3) entry comes from the quadratic only; (6, 6) from both.
        let h = dense(out.hessian);
        assert_eq!(h[(6, 3)], eq.hessian[(0, 1)]);
        assert_eq!(h[(6, 6)], es.hessian[(5, 5)] + eq.hessian[(0, 0)]);
        assert_eq!(asm.energy(&terms, &x).unwrap(), out_energy(&terms, &x));
    }

    fn out_energy(terms: &Terms, x: &[f64]) -> f64 {
        (0..terms.len()).map(|k| terms.stencil_energy(k, x)).sum()
    }

    #[test]
    fn offsets_shift_the_local_vector_and_typed_access_works() {
        let mut terms = two_terms();
        let x = x0();
        let plain = terms.stencil_energy(0, &x);
        terms
            .offset_mut(0)
            .copy_from_slice(&[0.0, 0.0, 0.0, 0.1, 0.0, 0.0]);
        let mut shifted = x.clone();
        shifted[4] += 0.1;
        assert_eq!(terms.offset(2), Some([0.0].as_slice()));
        assert_ne!(terms.stencil_energy(0, &x), plain);
        terms.offset_mut(0).fill(0.0);
        terms.offset_mut(0)[3] = 0.1;
        assert_eq!(
            terms.stencil_energy(0, &x),
            two_terms().stencil_energy(0, &shifted)
        );
        for (_, s) in terms.iter_mut_of::<RodTerm<Segment, 6>>() {
            s.rest_length = 0.8;
        }
        assert_eq!(
            terms.get::<RodTerm<Segment, 6>>(0).unwrap().rest_length,
            0.8
        );
        assert!(terms.get::<Linear>(0).is_none());
        assert_eq!(
            terms
                .iter_of::<Linear>()
                .map(|(k, _)| k)
                .collect::<Vec<_>>(),
            [2]
        );
    }

    #[test]
    fn clone_append_and_mutable_access_keep_terms_and_dofs() {
        let x = x0();
        let whole = two_terms();
        let mut first = Terms::new(7);
        first.push_stencil(segment(), [0, 1, 2, 4, 5, 6]);
        let mut rest = Terms::new(7);
        rest.push_stencil(
            Quadratic2 {
                a: [2.0, 0.5, 1.5],
                b: [0.3, -0.2],
            },
            [6, 3],
        );
        rest.push(Linear(-0.4), &[2]);
        rest.offset_mut(1)[0] = 0.25;
        let copy = first.clone();
        first.append(rest.clone());
        assert_eq!(first.len(), 3);
        assert_eq!(copy.len(), 1);
        for k in 0..3 {
            assert_eq!(first.dofs(k), whole.dofs(k));
        }
        assert_eq!(first.offset(0), Some([0.0; 6].as_slice()));
        assert_eq!(first.offset(2), Some([0.25].as_slice()));
        assert_eq!(first.stencil_energy(0, &x), whole.stencil_energy(0, &x));
        assert_eq!(first.stencil_energy(2, &x), -0.4 * (x[2] + 0.25));
        // Concat: the same stencils in the same order as the appended container.
        let chained = Concat::new(&copy, &rest);
        assert_eq!(chained.n_stencils(), 3);
        for k in 0..3 {
            assert_eq!(chained.stencil_dofs(k), first.dofs(k));
            assert_eq!(chained.stencil_energy(k, &x), first.stencil_energy(k, &x));
        }
        let mut asm = Assembler::new(&chained).unwrap();
        let a = asm.assemble(&chained, &x, true).unwrap().gradient.to_vec();
        let mut asm = Assembler::new(&first).unwrap();
        assert_eq!(
            asm.assemble(&first, &x, true).unwrap().gradient,
            a.as_slice()
        );
        // Mutable access, with DOFs and in parallel.
        for (k, s, d) in first.iter_mut_with_dofs_of::<RodTerm<Segment, 6>>() {
            assert_eq!((k, d), (0, [0, 1, 2, 4, 5, 6].as_slice()));
            s.rest_length = 0.9;
        }
        first.par_iter_mut().for_each(|t| {
            if let Some(l) = t.downcast_mut::<Linear>() {
                l.0 = 1.0;
            }
        });
        assert!(first.term(2).is::<Linear>());
        assert_eq!(first.term(2).downcast_ref::<Linear>().unwrap().0, 1.0);
        assert_eq!(copy.get::<RodTerm<Segment, 6>>(0).unwrap().rest_length, 0.7);
        assert_eq!(
            first.get::<RodTerm<Segment, 6>>(0).unwrap().rest_length,
            0.9
        );
    }

    /// Finite-difference check of the assembled container through `rod::fd`.
    #[test]
    fn container_derivatives_match_finite_differences() {
        let terms = two_terms();
        let x = SVector::<f64, 7>::from_column_slice(&x0());
        rod::fd::assert_stencil_derivatives(&Whole(&terms), &x, 1.0);
    }

    /// The full symmetric matrix of an assembled lower triangle.
    fn dense(lower: faer::sparse::SparseColMatRef<'_, usize, f64>) -> SMatrix<f64, 7, 7> {
        let mut h = SMatrix::<f64, 7, 7>::zeros();
        let (ptr, rows, vals) = (
            lower.symbolic().col_ptr(),
            lower.symbolic().row_idx(),
            lower.val(),
        );
        for c in 0..7 {
            for i in ptr[c]..ptr[c + 1] {
                h[(rows[i], c)] = vals[i];
                h[(c, rows[i])] = vals[i];
            }
        }
        h
    }

    /// The whole container as one 7-DOF stencil (for `rod::fd`).
    struct Whole<'a>(&'a Terms);

    impl rod::Stencil<7> for Whole<'_> {
        fn energy(&self, q: &SVector<f64, 7>) -> f64 {
            out_energy(self.0, q.as_slice())
        }
        fn eval(&self, q: &SVector<f64, 7>) -> Evaluation<7> {
            let mut asm = Assembler::new(self.0).unwrap();
            let out = asm.assemble(self.0, q.as_slice(), false).unwrap();
            let hessian = dense(out.hessian);
            Evaluation {
                energy: out.energy,
                gradient: SVector::from_column_slice(out.gradient),
                hessian,
            }
        }
    }
}
