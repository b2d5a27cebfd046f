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
//! answer is a small non-negative least-squares problem ([`CompressionSystem::nnls`]):
//! up to [`ENUMERATED_CONTACTS`] contacts (every stack of a knit or a weave) by enumerating
//! the active sets (exact, with no iterations or tolerances), and for taller stacks as a QP
//! through clarabel ([`solver::qp::nonnegative_least_squares`]), with no limit on the stack
//! size. Eq. 4 and the exact answer are both kept so they can be compared.
//!
//! **At the nodes of a simulation** ([`CompressionEstimator`]), for every node with `n ≥ 2`
//! yarns:
//!
//! - *Stack order.* Yarn `i` of Eq. 3 is the `i`-th layer of the node's stack from the back
//!   (slot order only for weave crossings), see *Stacks* below.
//! - *Normals.* A plane is fitted to the node and its neighbours along all its yarns (the
//!   eigenvector of the smallest eigenvalue of their covariance, §4.3). Its normal is
//!   oriented towards the fabric's material front `ĉ × ŵ` (course direction × wale
//!   direction at the node, from the neighbouring contacts; for a weave: weft direction ×
//!   warp direction), and then `nᵢ = ±` that normal: `+` if yarn `i + 1` lies in front of
//!   yarn `i`. Who lies in front is topology: at a weave crossing the warp iff
//!   [`crate::topology::Crossing::warp_over`]; at a knit stitch contact the upper row's
//!   yarn (the legs that were pulled through the loop below from the back) for a knit
//!   stitch and the lower row's yarn (the head) for a purl (the purl is the knit seen from
//!   the back). All `nᵢ` of a node are equal (one fitted plane), so `uᵢ = ±nᵢ`.
//! - *Forces* `Fᵢ` (N): minus the position gradient, at the node, of the terms that belong
//!   to yarn `i` — its stretch segments and its bending stencils, plus stitch wrapping for
//!   knits (§4.3). A wrapping pair couples two yarns; its force on a node is given to the
//!   yarn pass of the pair's wing that ends at that node (the wing `q₀q₄` carries the forces
//!   on `q₀` and `q₄`, the wing `q₁q₃` those on `q₁` and `q₃`; [`super::wrapping::wrap_wings`]:
//!   the heads a decrease stacks join the same two nodes, so the wing's own pass is kept). Gravity
//!   is left out, as in the paper (stretch and bending, plus wrapping): the weight of the
//!   yarn next to a node (`ρ g ℓ ≈ 5e-5 N` for the Table 1 sweater yarn and a 3 mm segment)
//!   is not a contact force between the stacked yarns and is small against the ≈ 1 mN yarn
//!   forces. Friction and stitch-length springs act on sliding coordinates only; other
//!   terms (contact, obstacles, inertia, damping) are left out.
//! - *Crimp offset* ([`crate::params::CompressionSettings::crimp_offset`]). "Due to yarn
//!   volume, the central axes of yarns in contact are separated by a certain distance,
//!   which is not present in our model […] we offset nodes along the contact normal"
//!   (§4.3): for the stretch forces only, yarn `i` of an `n`-stack sits at
//!   `x + R (2i − n + 1) n̂` (two yarns: `x ∓ R n̂`), at this node and at every stacked
//!   neighbour. The offset turns the stretch force, not its magnitude: the tension
//!   `T = ψ'(ε)` comes from the real segment, the direction from the offset one (offsetting
//!   the nodes themselves would lengthen the segments and invent strain). A flat plain
//!   weave under tension is then compressed, a slack one is not.
//! - *Solve.* Eq. 3 for the stack, then Eq. 4 or NNLS
//!   ([`crate::params::CompressionSettings::solver`]); both are always computed
//!   ([`NodeCompression`]) so they can be compared. On two-yarn nodes (simple stitches,
//!   crossings) they agree exactly; they can differ on the stacked nodes of decreases.
//! - *Stacks.* Knit stacks come from [`Topology::knit_stacks`]: the upper leg in front of the
//!   heads for a knit-type stitch, behind them for a purl-type one, the heads of a decrease
//!   in its stacking order; the contact between two stacked heads is *parallel* (§4.4).
//! - *Slip force* of yarn `i`'s sliding coordinate: `μ (λᵢ₋₁ + λᵢ)` over the non-parallel
//!   contacts that press on it (one contact for two yarns) — [`slip_forces`]; a parallel
//!   contact's `μ λᵢ` bounds the pair spring of [`super::friction::ParallelSpring`]. The
//!   simulator evaluates it *lagged*, at the state at the start of each step
//!   ([`crate::integrator`]).

use crate::forces::wrapping::StitchWrap;
use crate::forces::{Potential, TermKind};
use crate::params::{CompressionSettings, CompressionSolver};
use crate::state::{DofMap, gather};
use crate::topology::{FabricKind, KnitMap, Side, Topology};
use nalgebra::{DMatrix, DVector, Matrix3};
use rayon::prelude::*;
use rod::Stencil;
use rod::bending::AngleBending;
use rod::geometry::V3;
use rod::stretch::SlidingSegment;

/// Stacks of up to this many contacts are solved by enumerating their `2^m` active sets
/// ([`CompressionSystem::nnls_enumerated`]), taller ones as a QP
/// ([`CompressionSystem::nnls_qp`]).
pub const ENUMERATED_CONTACTS: usize = 4;

/// The most contacts [`CompressionSystem::nnls_enumerated`] enumerates (`2^12` active sets),
/// for comparisons with the QP.
pub const MAX_ENUMERATED_CONTACTS: usize = 12;

/// A stack that cannot be set up.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum CompressionError {
    /// Fewer than 2 yarns, mismatched lengths, or a zero/non-finite normal or compression
    /// direction; or the QP of a tall stack failed.
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
        if m == 0 || forces.len() != m + 1 {
            return bad(format!(
                "{} normals and {} forces (need at least one normal and one more force)",
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

    /// The exact minimizer of `½ |A λ + b|²` subject to `λ ≥ 0` (N): by enumeration up to
    /// [`ENUMERATED_CONTACTS`] contacts, as a QP above (module documentation).
    pub fn nnls(&self) -> Result<DVector<f64>, CompressionError> {
        match self.a.ncols() {
            m if m <= ENUMERATED_CONTACTS => Ok(self.nnls_enumerated().expect("small stack")),
            _ => self.nnls_qp(),
        }
    }

    /// [`CompressionSystem::nnls`] as a QP through clarabel, for any number of contacts.
    pub fn nnls_qp(&self) -> Result<DVector<f64>, CompressionError> {
        solver::qp::nonnegative_least_squares(&self.a, &self.b)
            .map_err(|e| CompressionError::Invalid(format!("the compression QP failed: {e}")))
    }

    /// [`CompressionSystem::nnls`] by enumeration: the best of the unconstrained
    /// least-squares solutions on every subset of free contacts whose values are
    /// non-negative (the optimum's own free set is among them; `λ = 0` is the empty set).
    /// `None` above [`MAX_ENUMERATED_CONTACTS`] contacts.
    pub fn nnls_enumerated(&self) -> Option<DVector<f64>> {
        let m = self.a.ncols();
        if m > MAX_ENUMERATED_CONTACTS {
            return None;
        }
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
        Some(best.1)
    }
}

/// The compression at one stacked node, by both solvers.
#[derive(Clone, Debug, PartialEq)]
pub struct NodeCompression {
    /// Node index.
    pub node: usize,
    /// The stack back to front as slots: yarn `i` of Eq. 3 is slot `layers[i]`.
    pub layers: Vec<usize>,
    /// Per contact `i` (layers `i`, `i + 1`): whether the two yarns are parallel (§4.4).
    pub parallel: Vec<bool>,
    /// Contact normals `nᵢ` (yarn `i` → `i + 1`, unit).
    pub normals: Vec<V3>,
    /// Yarn forces `Fᵢ` on the node (N), one per layer.
    pub forces: Vec<V3>,
    /// λ of Eq. 4 (N), one per contact.
    pub closed_form: DVector<f64>,
    /// λ of the exact NNLS (N), one per contact.
    pub nnls: DVector<f64>,
}

impl NodeCompression {
    /// λ (N) by `solver`.
    pub fn lambda(&self, solver: CompressionSolver) -> &DVector<f64> {
        match solver {
            CompressionSolver::ClosedForm => &self.closed_form,
            CompressionSolver::Nnls => &self.nnls,
        }
    }

    /// The compression (N) pressing on the yarn of `slot` through its non-parallel contacts:
    /// `λᵢ₋₁ + λᵢ` over the contacts on either side of its layer `i` that join
    /// non-parallel yarns (the friction bound of its own spring, §4.4).
    pub fn slot_compression(&self, slot: usize, solver: CompressionSolver) -> f64 {
        let l = self.lambda(solver);
        let Some(i) = self.layers.iter().position(|&s| s == slot) else {
            return 0.0;
        };
        let below = if i > 0 && !self.parallel[i - 1] {
            l[i - 1]
        } else {
            0.0
        };
        let above = if i < l.len() && !self.parallel[i] {
            l[i]
        } else {
            0.0
        };
        below + above
    }
}

/// One stacked node of [`CompressionEstimator`].
#[derive(Clone, Debug, PartialEq)]
struct StackNode {
    node: usize,
    /// The plane-fit points besides the node: its neighbours along all its yarns.
    neighbours: Vec<usize>,
    /// Material front `(course₊, course₋, wale₊, wale₋)`: node sets whose centroid
    /// differences give the course and wale directions.
    front: [Vec<usize>; 4],
    /// The stack back to front, as slots.
    layers: Vec<usize>,
    /// Per contact: whether its two yarns are parallel.
    parallel: Vec<bool>,
}

/// Compression estimation at the stacked nodes of a fabric (module documentation).
#[derive(Clone, Debug, PartialEq)]
pub struct CompressionEstimator {
    stacks: Vec<StackNode>,
    /// Index into `stacks` of every node (`None` for one-yarn nodes).
    stack_of_node: Vec<Option<usize>>,
    /// `(node, slot)` of every sliding-coordinate DOF, `node` of every position DOF
    /// (`slot = usize::MAX`).
    owner: Vec<(usize, usize)>,
    /// Yarn of each `(node, slot)`: `topology.nodes[n].passes[s].yarn`, flattened per node.
    yarn_slots: Vec<Vec<(usize, usize)>>,
    /// Per yarn: its node sequence.
    yarn_nodes: Vec<Vec<usize>>,
    /// The wing passes of every wrapping pair in the order the wrapping terms are built
    /// ([`super::wrapping::wrap_wings`]).
    wings: Vec<[[(usize, usize); 2]; 2]>,
}

impl CompressionEstimator {
    /// The stacked nodes of `topology` with their plane-fit neighbours, material-front
    /// stencils and front/back order. Errors for nodes of more than two yarns in a knit or
    /// weave topology without an order rule, or for a two-yarn node that is neither a
    /// weave crossing nor on a stitch contact.
    pub fn new(topology: &Topology, dofs: &DofMap) -> Result<Self, CompressionError> {
        let bad = |s: String| Err(CompressionError::Invalid(s));
        let mut owner = vec![(usize::MAX, usize::MAX); dofs.n_dofs()];
        for (n, node) in topology.nodes.iter().enumerate() {
            for k in 0..3 {
                owner[dofs.x(n) + k] = (n, usize::MAX);
            }
            for s in 0..node.passes.len() {
                owner[dofs.u(n, s)] = (n, s);
            }
        }
        let yarn_nodes: Vec<Vec<usize>> = topology
            .yarns
            .iter()
            .map(|y| y.passes.iter().map(|p| p.node).collect())
            .collect();
        let yarn_slots: Vec<Vec<(usize, usize)>> = topology
            .nodes
            .iter()
            .map(|n| n.passes.iter().map(|p| (p.yarn, p.index)).collect())
            .collect();
        // Back-to-front order per stacked node from the topology.
        let mut order: Vec<Option<(Vec<usize>, Vec<bool>)>> = topology.knit_stacks();
        for c in &topology.crossings {
            let passes = &topology.nodes[c.node].passes;
            // Slot 0 is the weft (yarns 0..wefts), slot 1 the warp.
            let warp_slot = usize::from(passes.len() == 2 && passes[1].yarn > passes[0].yarn);
            let top = if c.warp_over {
                warp_slot
            } else {
                1 - warp_slot
            };
            order[c.node] = Some((vec![top, 1 - top], vec![false]));
        }
        let mut stacks = Vec::new();
        let mut stack_of_node = vec![None; topology.nodes.len()];
        for (n, node) in topology.nodes.iter().enumerate() {
            if node.passes.len() < 2 {
                continue;
            }
            let Some((front_to_back, parallel)) = order[n].take() else {
                return bad(format!(
                    "node {n} has {} yarns but is neither a crossing nor a stitch-contact node",
                    node.passes.len()
                ));
            };
            if front_to_back.len() != node.passes.len() {
                return bad(format!(
                    "node {n}: {} yarn passes but a stack of {}",
                    node.passes.len(),
                    front_to_back.len()
                ));
            }
            let layers: Vec<usize> = front_to_back.into_iter().rev().collect();
            let parallel: Vec<bool> = parallel.into_iter().rev().collect();
            let mut neighbours = Vec::new();
            for p in &node.passes {
                let list = &yarn_nodes[p.yarn];
                for j in [p.index.wrapping_sub(1), p.index + 1] {
                    if let Some(&m) = list.get(j)
                        && !neighbours.contains(&m)
                    {
                        neighbours.push(m);
                    }
                }
            }
            let front = front_stencil(topology, n)
                .ok_or_else(|| CompressionError::Invalid(format!("node {n}: no material front")))?;
            stack_of_node[n] = Some(stacks.len());
            stacks.push(StackNode {
                node: n,
                neighbours,
                front,
                layers,
                parallel,
            });
        }
        let wings = topology
            .stitch_contacts
            .iter()
            .flat_map(|sc| super::wrapping::wrap_wings(topology, sc))
            .collect();
        Ok(Self {
            wings,
            stacks,
            stack_of_node,
            owner,
            yarn_slots,
            yarn_nodes,
        })
    }

    /// Number of stacked nodes.
    pub fn n_stacks(&self) -> usize {
        self.stacks.len()
    }

    /// The yarn joining nodes `a` and `b` by one segment, and its slots at `a` and `b`.
    fn joining_yarn(&self, a: usize, b: usize) -> Option<(usize, usize)> {
        for (sa, &(y, i)) in self.yarn_slots[a].iter().enumerate() {
            let list = &self.yarn_nodes[y];
            let next = list.get(i + 1) == Some(&b);
            let prev = i > 0 && list[i - 1] == b;
            if next || prev {
                let j = if next { i + 1 } else { i - 1 };
                let sb = self.yarn_slots[b].iter().position(|&p| p == (y, j))?;
                return Some((sa, sb));
            }
        }
        None
    }

    /// Compression at every stacked node at coordinates `q`, with the force terms `terms`
    /// (normally the simulator's static terms), yarn radius `radius` (m; crimp offset).
    pub fn estimate(
        &self,
        terms: &Potential,
        q: &[f64],
        dofs: &DofMap,
        radius: f64,
        settings: &CompressionSettings,
    ) -> Result<Vec<NodeCompression>, CompressionError> {
        let pos = |n: usize| dofs.position(q, n);
        // Normals.
        let normals: Vec<V3> = self
            .stacks
            .par_iter()
            .map(|st| {
                let mut pts = vec![pos(st.node)];
                pts.extend(st.neighbours.iter().map(|&m| pos(m)));
                let c = pts.iter().sum::<V3>() / pts.len() as f64;
                let cov: Matrix3<f64> = pts.iter().map(|p| (p - c) * (p - c).transpose()).sum();
                let eig = cov.symmetric_eigen();
                let k = eig.eigenvalues.imin();
                let mut nrm: V3 = eig.eigenvectors.column(k).into_owned();
                let centroid =
                    |set: &Vec<usize>| set.iter().map(|&m| pos(m)).sum::<V3>() / set.len() as f64;
                let [cp, cm, wp, wm] = &st.front;
                let front = (centroid(cp) - centroid(cm)).cross(&(centroid(wp) - centroid(wm)));
                if nrm.dot(&front) < 0.0 {
                    nrm = -nrm;
                }
                nrm
            })
            .collect();
        // Layer (back to front) of (node, slot).
        let layer = |n: usize, slot: usize| -> Option<(usize, usize)> {
            let k = self.stack_of_node[n]?;
            let i = self.stacks[k].layers.iter().position(|&s| s == slot)?;
            Some((k, i))
        };
        // Crimp offset of (node, slot): layer i of an n-stack at x + R (2i − n + 1) n̂.
        let offset = |n: usize, slot: usize| -> V3 {
            match layer(n, slot) {
                Some((k, i)) if settings.crimp_offset => {
                    let m = self.yarn_slots[n].len() as f64;
                    radius * (2.0 * i as f64 - m + 1.0) * normals[k]
                }
                _ => V3::zeros(),
            }
        };
        let block = |g: &[f64], i: usize| V3::new(g[i], g[i + 1], g[i + 2]);
        // The wings are matched to the wrapping terms in order: each one's ordinal.
        let mut wrap_ordinal = vec![0; terms.len()];
        let mut wraps = 0;
        for (k, ordinal) in wrap_ordinal.iter_mut().enumerate() {
            if terms.kind(k) == TermKind::Wrapping {
                *ordinal = wraps;
                wraps += 1;
            }
        }
        // The force of term `k` on each (node, slot) it touches, through `emit`.
        let contributions = |k: usize, emit: &mut dyn FnMut(usize, usize, V3)| {
            let d = terms.dofs(k);
            match terms.kind(k) {
                TermKind::Stretch => {
                    let s = terms.get::<SlidingSegment, 8>(k).expect("stretch stencil");
                    let d: &[usize; 8] = d.try_into().expect("8 DOFs");
                    let local = gather(q, d);
                    let (_, g) = s.energy_and_gradient(&local);
                    let ends = [self.owner[d[3]], self.owner[d[7]]];
                    if !settings.crimp_offset {
                        for (e, &(n, slot)) in ends.iter().enumerate() {
                            emit(n, slot, block(g.as_slice(), 4 * e));
                        }
                        return;
                    }
                    // The tension from the real segment, its direction from the offset one.
                    let x = |e: usize| V3::new(local[4 * e], local[4 * e + 1], local[4 * e + 2]);
                    let t = (x(1) - x(0)).normalize();
                    let tension = block(g.as_slice(), 4).dot(&t);
                    let [(n0, s0), (n1, s1)] = ends;
                    let off = (x(1) + offset(n1, s1) - x(0) - offset(n0, s0)).normalize();
                    emit(n0, s0, -tension * off);
                    emit(n1, s1, tension * off);
                }
                TermKind::Bending => {
                    let s = terms.get::<AngleBending, 12>(k).expect("bending stencil");
                    let d: &[usize; 12] = d.try_into().expect("12 DOFs");
                    let (_, g) = s.energy_and_gradient(&gather(q, d));
                    for e in 0..3 {
                        let (n, slot) = self.owner[d[4 * e + 3]];
                        emit(n, slot, block(g.as_slice(), 4 * e));
                    }
                }
                TermKind::Wrapping => {
                    let s = terms.get::<StitchWrap, 12>(k).expect("wrapping stencil");
                    let d: &[usize; 12] = d.try_into().expect("12 DOFs");
                    let (_, g) = s.energy_and_gradient(&gather(q, d));
                    let node = |k: usize| self.owner[d[3 * k]].0;
                    // The wings' own passes when this term is the next one built from the
                    // stitch contacts; else (terms built otherwise) the yarn joining the nodes.
                    let own = self.wings.get(wrap_ordinal[k]).filter(|w| {
                        [w[0][0].0, w[1][0].0, w[0][1].0, w[1][1].0]
                            == [node(0), node(1), node(2), node(3)]
                    });
                    // Wings (q₀, q₄) and (q₁, q₃): blocks (0, 2) and (1, 3).
                    for (w, (a, b)) in [(0, 2), (1, 3)].into_iter().enumerate() {
                        let slots = match own {
                            Some(wings) => Some((wings[w][0].1, wings[w][1].1)),
                            None => self.joining_yarn(node(a), node(b)),
                        };
                        if let Some((sa, sb)) = slots {
                            emit(node(a), sa, block(g.as_slice(), 3 * a));
                            emit(node(b), sb, block(g.as_slice(), 3 * b));
                        }
                    }
                }
                _ => {}
            }
        };
        // The stencils' gradients in parallel over fixed blocks of terms; their sums in term
        // order, so the result does not depend on the threads.
        const BLOCK: usize = 1024;
        let blocks: Vec<Vec<(usize, usize, V3)>> = (0..terms.len().div_ceil(BLOCK))
            .into_par_iter()
            .map(|b| {
                let mut out = Vec::new();
                for k in b * BLOCK..terms.len().min((b + 1) * BLOCK) {
                    contributions(k, &mut |n, slot, g| out.push((n, slot, g)));
                }
                out
            })
            .collect();
        let mut forces: Vec<Vec<V3>> = self
            .stacks
            .iter()
            .map(|st| vec![V3::zeros(); self.yarn_slots[st.node].len()])
            .collect();
        for (n, slot, g) in blocks.into_iter().flatten() {
            if let Some((k, i)) = layer(n, slot) {
                forces[k][i] -= g;
            }
        }
        self.stacks
            .par_iter()
            .zip(normals)
            .zip(forces)
            .map(|((st, n), f)| {
                let normals = vec![n; f.len() - 1];
                let sys = CompressionSystem::new(&normals, &f)?;
                let closed_form = sys.closed_form().ok_or_else(|| {
                    CompressionError::Invalid(format!("node {}: singular AᵀA", st.node))
                })?;
                Ok(NodeCompression {
                    node: st.node,
                    layers: st.layers.clone(),
                    parallel: st.parallel.clone(),
                    nnls: sys.nnls()?,
                    closed_form,
                    normals,
                    forces: f,
                })
            })
            .collect()
    }
}

/// Slip force (N) of every DOF: `μ (λᵢ₋₁ + λᵢ)` (module documentation) for the sliding
/// coordinates of the stacked nodes of `estimates`, 0 elsewhere.
pub fn slip_forces(
    estimates: &[NodeCompression],
    dofs: &DofMap,
    friction_coefficient: f64,
    solver: CompressionSolver,
) -> Vec<f64> {
    let mut out = vec![0.0; dofs.n_dofs()];
    for e in estimates {
        for slot in 0..e.forces.len() {
            out[dofs.u(e.node, slot)] = friction_coefficient * e.slot_compression(slot, solver);
        }
        // A parallel pair's bound at its far coordinate (crate::forces::friction_springs).
        let front_to_back: Vec<usize> = e.layers.iter().rev().copied().collect();
        let parallel: Vec<bool> = e.parallel.iter().rev().copied().collect();
        let (_, pairs) = super::friction_springs(&front_to_back, &parallel);
        let lambda = e.lambda(solver);
        let layer = |slot: usize| e.layers.iter().position(|&s| s == slot);
        for [a, b] in pairs {
            // Both slots come from this stack's layers (friction_springs).
            if let (Some(ia), Some(ib)) = (layer(a), layer(b)) {
                out[dofs.u(e.node, b)] = friction_coefficient * lambda[ia.min(ib)];
            }
        }
    }
    out
}

/// Node sets `(course₊, course₋, wale₊, wale₋)` of the material front at `node` (module
/// documentation), or `None` for a topology without a grid.
fn front_stencil(topology: &Topology, node: usize) -> Option<[Vec<usize>; 4]> {
    match &topology.kind {
        FabricKind::Knit(_) => topology.knit.as_ref().map(|m| knit_front(m, node)),
        FabricKind::Weave { warps, wefts, .. } => {
            let (i, j) = (node % warps, node / warps);
            let at = |i: usize, j: usize| vec![j * warps + i];
            Some([
                at((i + 1).min(warps - 1), j),
                at(i.saturating_sub(1), j),
                at(i, (j + 1).min(wefts - 1)),
                at(i, j.saturating_sub(1)),
            ])
        }
    }
}

/// The material front stencil of a knit node: course from the left to the right contact of
/// its cell, wale from the same contact of the cell below to the cell above along the wale
/// ([`crate::topology::Cell::up`], `down`; the cell itself at the cast-on and bind-off).
fn knit_front(map: &KnitMap, node: usize) -> [Vec<usize>; 4] {
    let (b, c, side, _) = map.sites[node];
    let contact = |at: (usize, usize), side: Side| map.cell(at).nodes[side as usize].to_vec();
    let cell = map.cell((b, c));
    [
        contact((b, c), Side::Right),
        contact((b, c), Side::Left),
        contact(cell.up, side),
        contact(cell.down, side),
    ]
}
