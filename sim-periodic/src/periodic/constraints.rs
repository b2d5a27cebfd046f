//! The linear constraints `C ũ = d` of a tile problem: zero mean fluctuation, no yarn sliding
//! (seed 004 Eq. 3) and no twist drift.

use super::{PeriodicError, PeriodicTile};
use nalgebra::Vector3;
use solver::LinearConstraints;

impl PeriodicTile<'_> {
    /// The linear constraints `C ũ = 0` (zero mean fluctuation; no sliding, seed 004 Eq. 3).
    pub fn constraints(&self) -> Result<LinearConstraints, PeriodicError> {
        let n = self.tile.n_vertices();
        let mut triplets = Vec::new();
        for v in 0..n {
            for c in 0..3 {
                triplets.push((c, 3 * v + c, 1.0 / n as f64));
            }
        }
        let mut rows = 3;
        let f3 = self.coarse.f3();
        for lp in self.topology.loops() {
            // The start vertex of the first edge that crosses the tile boundary stays on it.
            let Some(&e) = lp.iter().find(|&&e| self.tile.edges[e].shift != [0, 0]) else {
                return Err(PeriodicError::Invalid(format!(
                    "yarn loop starting at edge {} never crosses the tile boundary",
                    lp[0]
                )));
            };
            let edge = self.tile.edges[e];
            let normal = if edge.shift[0] != 0 {
                Vector3::x()
            } else {
                Vector3::y()
            };
            let fnormal = f3 * normal;
            for c in 0..3 {
                if fnormal[c] != 0.0 {
                    triplets.push((rows, 3 * edge.v1, fnormal[c]));
                }
            }
            rows += 1;
        }
        let mut rhs = vec![0.0; rows];
        // No twist drift: the mean twist angle of every loop stays at the tile's.
        let mut twist_of_edge = vec![0.0; n];
        for v in 0..n {
            twist_of_edge[self.topology.outgoing(v)] = self.tile.twists[v];
        }
        for lp in self.topology.loops() {
            let w = 1.0 / lp.len() as f64;
            for &e in &lp {
                triplets.push((rows, 3 * n + e, w));
            }
            rhs.push(w * lp.iter().map(|&e| twist_of_edge[e]).sum::<f64>());
            rows += 1;
        }
        Ok(LinearConstraints::new(4 * n, &triplets, &rhs)?)
    }
}
