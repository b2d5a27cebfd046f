//! Fixed quadratic forms: the inertia and Rayleigh-damping terms of the implicit step
//! ([`crate::integrator`]).
//!
//! `V = ½ (q − c)ᵀ A (q − c)` with a symmetric matrix `A` and centre `c` that the integrator
//! sets once per time step:
//!
//! - inertia with mass damping: `A = (1/h² + α/h) M_seg(qₙ)`, `c = (q̂ + α h qₙ)/(1 + α h)`,
//!   `q̂ = qₙ + h vₙ` (per segment, `M_seg` from [`crate::state::segment_mass_matrix`]);
//! - stiffness damping: `A = (β/h) K⁺(qₙ)`, `c = qₙ`, with `K⁺` the PSD projection of an
//!   elastic stencil's Hessian at the start of the step (so damping never adds energy).

use super::crossing_shear::CrossingShear;
use super::friction::{AnchoredSpring, ParallelSpring};
use super::stitch_length::StitchLength;
use super::wrapping::StitchWrap;
use super::{Potential, TermKind};
use nalgebra::{SMatrix, SVector};
use rod::bending::AngleBending;
use rod::stretch::SlidingSegment;
use rod::{Evaluation, Stencil};
use solver::{LocalEnergy, RodTerm};

/// `V = ½ (q − c)ᵀ A (q − c)` on `N` DOFs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Quadratic<const N: usize> {
    /// The symmetric matrix A (J per DOF unit²).
    pub matrix: SMatrix<f64, N, N>,
    /// The centre c (DOF units).
    pub center: SVector<f64, N>,
}

impl<const N: usize> Quadratic<N> {
    /// The zero form (no energy) centred at the origin.
    pub fn zero() -> Self {
        Self {
            matrix: SMatrix::zeros(),
            center: SVector::zeros(),
        }
    }
}

impl<const N: usize> Stencil<N> for Quadratic<N> {
    fn energy(&self, q: &SVector<f64, N>) -> f64 {
        let d = q - self.center;
        0.5 * d.dot(&(self.matrix * d))
    }

    fn eval(&self, q: &SVector<f64, N>) -> Evaluation<N> {
        let d = q - self.center;
        let g = self.matrix * d;
        Evaluation {
            energy: 0.5 * d.dot(&g),
            gradient: g,
            hessian: self.matrix,
        }
    }
}

/// How a Rayleigh-β damping form (a `Quadratic<N>` term of the step) follows the elastic
/// term it damps: `(β/h) K⁺(q)` centred at `q`, with `K⁺` the Hessian of the elastic term,
/// PSD-projected where it can be indefinite.
#[derive(Clone, Copy, Debug)]
pub struct DampingSource {
    /// Index of the damped elastic term.
    pub term: usize,
    fill: FillFn,
    recentre: Option<RecentreFn>,
}

/// Overwrites a damping form (`target`) with `factor · K⁺` of the elastic term `source` at
/// `q[dofs]`, centred there.
type FillFn = fn(&dyn LocalEnergy, &[usize], &[f64], f64, &mut dyn LocalEnergy);

/// Moves a damping form's centre to `q[dofs]` and rescales its matrix by the factor, if any.
type RecentreFn = fn(&mut dyn LocalEnergy, &[usize], &[f64], Option<f64>);

/// `PROJECT`: whether the Hessian can be indefinite (the Eq. 5 and Eq. 6 springs have
/// constant PSD Hessians, so their costly eigen-projection is skipped).
fn fill<S, const N: usize, const PROJECT: bool>(
    source: &dyn LocalEnergy,
    dofs: &[usize],
    q: &[f64],
    factor: f64,
    target: &mut dyn LocalEnergy,
) where
    S: Stencil<N> + Clone + Send + Sync + 'static,
{
    let s = source
        .downcast_ref::<RodTerm<S, N>>()
        .expect("damping source of its stencil type");
    let out = target
        .downcast_mut::<RodTerm<Quadratic<N>, N>>()
        .expect("damping form of the source's size");
    let local = SVector::<f64, N>::from_fn(|i, _| q[dofs[i]]);
    let mut h = s.eval(&local).hessian;
    if PROJECT {
        // The fast eigensolver: these forms are refilled for every stencil of the garment.
        rod::spd::project_spd_qr(h.as_mut_slice(), N);
    }
    out.matrix = factor * h;
    out.center = local;
}

fn recentre<const N: usize>(
    target: &mut dyn LocalEnergy,
    dofs: &[usize],
    q: &[f64],
    rescale: Option<f64>,
) {
    let form = target
        .downcast_mut::<RodTerm<Quadratic<N>, N>>()
        .expect("damping form of the source's size");
    form.center = SVector::from_fn(|i, _| q[dofs[i]]);
    if let Some(r) = rescale {
        form.matrix *= r;
    }
}

impl DampingSource {
    /// Appends to `step` the damping form of the elastic term `k` of `elastic` at `q`,
    /// scaled by `factor`, and returns how to update it; `None` (and nothing appended) for
    /// terms that are not elastic (gravity, contacts, obstacles, inertia, damping).
    pub fn push_form(
        elastic: &Potential,
        k: usize,
        q: &[f64],
        factor: f64,
        step: &mut Potential,
    ) -> Option<Self> {
        fn make<S, const N: usize, const PROJECT: bool>(
            term: usize,
            recentred: bool,
            dofs: &[usize],
            step: &mut Potential,
        ) -> DampingSource
        where
            S: Stencil<N> + Clone + Send + Sync + 'static,
        {
            let d: [usize; N] = dofs.try_into().expect("stencil size");
            step.push(TermKind::Damping, Quadratic::<N>::zero(), d);
            DampingSource {
                term,
                fill: fill::<S, N, PROJECT>,
                recentre: recentred.then_some(recentre::<N> as RecentreFn),
            }
        }
        let d = elastic.dofs(k);
        // Lagged crossing-shear forms are refilled, never recentred (as they always were).
        let source = match elastic.kind(k) {
            TermKind::Stretch => make::<SlidingSegment, 8, true>(k, true, d, step),
            TermKind::Bending => make::<AngleBending, 12, true>(k, true, d, step),
            TermKind::Wrapping => make::<StitchWrap, 12, true>(k, true, d, step),
            TermKind::CrossingShear => make::<CrossingShear, 9, true>(k, false, d, step),
            TermKind::StitchLength => make::<StitchLength, 2, false>(k, true, d, step),
            TermKind::Friction => make::<AnchoredSpring, 1, false>(k, true, d, step),
            TermKind::ParallelFriction => make::<ParallelSpring, 2, false>(k, true, d, step),
            _ => return None,
        };
        let form = step.len() - 1;
        source.update(elastic, q, factor, None, step.term_mut(form));
        Some(source)
    }

    /// Updates the damping form `target` at `q`: refilled with `factor · K⁺(q)` when
    /// `lagged` is `None`, else (if the form supports it) only recentred at `q` and rescaled
    /// by `lagged`'s factor (if any). Returns whether the form was refilled.
    pub fn update(
        &self,
        elastic: &Potential,
        q: &[f64],
        factor: f64,
        lagged: Option<Option<f64>>,
        target: &mut dyn LocalEnergy,
    ) -> bool {
        let dofs = elastic.dofs(self.term);
        match (lagged, self.recentre) {
            (Some(rescale), Some(recentre)) => {
                recentre(target, dofs, q, rescale);
                false
            }
            _ => {
                (self.fill)(elastic.terms().term(self.term), dofs, q, factor, target);
                true
            }
        }
    }
}
