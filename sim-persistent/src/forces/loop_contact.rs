//! Contact between adjacent loops (seed 000 §4: "for gravity, yarn stretch and contact
//! between adjacent loops we use exactly the original formulations for woven cloth \[6\]").
//!
//! Persistent contacts keep yarns that cross each other together, but nothing keeps two
//! yarn pieces that merely lie side by side — neighbouring legs of adjacent loops, the two
//! legs of one loop where they go through the loop below — from passing through each other.
//! Like the contact between parallel yarns of woven cloth (ref. 6, Cirio et al. 2014), we
//! add a one-sided penalty on the distance `d = ‖x_b − x_a‖` between two nodes that lie on
//! such neighbouring yarn pieces, active below the contact distance `D = 2R`:
//!
//! ```text
//! V = k_c/3 · p³,     p = max(0, D − d)
//! ```
//!
//! (`k_c` in N/m², [`crate::params::YarnParams::loop_contact_stiffness`]). The cube makes
//! `V`, its gradient `−k_c p² n̂` and its Hessian continuous at the onset `d = D` (C²,
//! friendly to Newton), and the force grows quadratically with the penetration. Ref. 6's
//! exact penalty is not reproduced here (we could not consult it); this is our choice.
//!
//! **Persistent candidate pairs** ([`candidate_pairs`]; no collision detection). Knits
//! only. Along each interior row boundary `b ∈ 1..H` the stitch contacts sit in the order
//! left leg, right leg of column 0, left leg of column 1, … (the cells of
//! [`crate::topology::KnitMap`]; knitted in the round, the last closes on the first); two consecutive contacts are
//! the two legs of one loop where they pass through the loop below (left, right contact of
//! column `c`), or the right leg of loop `c` and the left leg of loop `c + 1` (adjacent
//! wales). Each of the four pairs of their nodes (`lo`/`hi` × `lo`/`hi`) that is not
//! joined by a yarn segment is a candidate (a segment already holds its ends apart through
//! stretch): three per gap, since the head of the loop below joins `hi`–`hi` within a
//! column and the sinker joins `lo`–`lo` between columns. In the default layout (loop
//! width 3 mm, R = 0.75 mm) the candidates are 1.59 mm (`lo`–`hi`) and 2.03 mm apart,
//! just outside 2R = 1.5 mm: the penalty switches on when a swatch compresses in width
//! (rib) or a loop narrows. The cast-on and bind-off boundaries are left out: there the
//! pairs that the head or sinker joins everywhere else are unjoined, and 0.97 mm apart in
//! the layout (the same relation as inside, where the segment keeps them apart). Weaves get
//! no candidates: their neighbouring parallel yarns meet at crossings, whose shear and
//! jamming are the weave's own term.
//!
//! **Effect, measured** (Table 1 sweater yarn, free swatches settled as in the curl tests,
//! 0.3 s): garter 8 × 5 side curls +1.27/+1.21 rad without, +0.45/+0.86 with the term;
//! stockinette 8 × 4 −4.25/−4.25 without, −2.12/−0.70 with; the fraction of collapsed
//! wrapping wings (see [`super::wrapping`]) barely changes (garter boundaries 1–4: 6, 14,
//! 12, 10 of 30 without, 9, 13, 13, 7 with). So it is off by default
//! ([`super::ForceSet::loop_contact`]). A swatch squeezed to 85 % of its width is pushed
//! back apart (tested); squeezed to 70 % (penetrations ≈ 0.5 mm, forces ≈ 1 N) the first
//! Newton solves fail even with step halving: `k_c` is uncalibrated. Loop-contact terms
//! get no Rayleigh-β damping form.
//!
//! **Degenerate pair.** At `d = 0` the direction is undefined; the stencil returns the
//! energy with zero gradient and Hessian there (a measure-zero set that Newton does not
//! reach from a valid state).

use crate::topology::{Construction, Side, Topology};
use nalgebra::{Matrix3, SMatrix, SVector};
use rod::geometry::V3;
use rod::{Evaluation, Stencil};
use std::collections::HashSet;

/// The one-sided cubic penalty between two nodes. DOFs `(x_a, x_b)` (6).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LoopContact {
    /// Stiffness `k_c` (N/m²).
    pub stiffness: f64,
    /// Contact distance `D` (m), normally `2R`.
    pub distance: f64,
}

impl LoopContact {
    /// `(p, d, n̂)`: penetration, distance and unit direction `a → b` at `q`.
    fn geometry(&self, q: &SVector<f64, 6>) -> (f64, f64, V3) {
        let r = V3::new(q[3] - q[0], q[4] - q[1], q[5] - q[2]);
        let d = r.norm();
        let n = if d > 0.0 { r / d } else { V3::zeros() };
        ((self.distance - d).max(0.0), d, n)
    }
}

impl Stencil<6> for LoopContact {
    fn energy(&self, q: &SVector<f64, 6>) -> f64 {
        let (p, _, _) = self.geometry(q);
        self.stiffness * p * p * p / 3.0
    }

    fn eval(&self, q: &SVector<f64, 6>) -> Evaluation<6> {
        let (p, d, n) = self.geometry(q);
        let k = self.stiffness;
        let mut gradient = SVector::<f64, 6>::zeros();
        let mut hessian = SMatrix::<f64, 6, 6>::zeros();
        if p > 0.0 && d > 0.0 {
            // dV/dd = −k p², d²V/dd² = 2 k p; ∂d/∂r = n̂, ∂²d/∂r² = (I − n̂n̂ᵀ)/d.
            let g = -k * p * p * n;
            let nn = n * n.transpose();
            let hr: Matrix3<f64> = 2.0 * k * p * nn - k * p * p / d * (Matrix3::identity() - nn);
            gradient.fixed_rows_mut::<3>(0).copy_from(&(-g));
            gradient.fixed_rows_mut::<3>(3).copy_from(&g);
            hessian.fixed_view_mut::<3, 3>(0, 0).copy_from(&hr);
            hessian.fixed_view_mut::<3, 3>(3, 3).copy_from(&hr);
            hessian.fixed_view_mut::<3, 3>(0, 3).copy_from(&(-hr));
            hessian.fixed_view_mut::<3, 3>(3, 0).copy_from(&(-hr));
        }
        Evaluation {
            energy: k * p * p * p / 3.0,
            gradient,
            hessian,
        }
    }
}

/// The persistent candidate node pairs `(a, b)`, `a < b`, of the module documentation
/// (knits; none for weaves), in boundary, column, side order.
pub fn candidate_pairs(topology: &Topology) -> Vec<[usize; 2]> {
    let Some(map) = &topology.knit else {
        return Vec::new();
    };
    let joined: HashSet<(usize, usize)> = topology
        .segments()
        .map(|(y, i)| {
            let p = &topology.yarns[y].passes;
            let (a, b) = (p[i].node, p[i + 1].node);
            (a.min(b), a.max(b))
        })
        .collect();
    let round = map.construction == Construction::Round;
    let mut pairs = Vec::new();
    let mut seen = HashSet::new();
    let h = map.boundaries.len() - 1;
    for cells in &map.boundaries[1..h] {
        let mut contacts: Vec<[usize; 2]> = cells
            .iter()
            .flat_map(|c| [c.nodes[Side::Left as usize], c.nodes[Side::Right as usize]])
            .collect();
        // Round: the last loop of a round is the neighbour of its first.
        if round && let Some(&first) = contacts.first() {
            contacts.push(first);
        }
        for win in contacts.windows(2) {
            for a in win[0] {
                for z in win[1] {
                    let key = (a.min(z), a.max(z));
                    if a != z && !joined.contains(&key) && seen.insert(key) {
                        pairs.push([key.0, key.1]);
                    }
                }
            }
        }
    }
    pairs
}
