//! The conservative continuous collision filter ([`solver::Problem::max_step`]).

use super::PeriodicTile;
use nalgebra::Vector3;
use rod::contact::closest_points;

/// The filter's `η`: a pair may close by at most this fraction of its distance in one step.
pub(super) const COLLISION_ETA: f64 = 0.9;

impl PeriodicTile<'_> {
    /// Conservative continuous collision filter: a point of an edge moves by at most the larger
    /// move of its two end vertices (`|R Δũ| = |Δũ|`, frames are orthonormal), so a pair at
    /// distance `d` whose ends move by at most `m_a` and `m_b` stays at least `(1 − η) d`
    /// apart for `α ≤ η d / (m_a + m_b)`, `η = 0.9`. Without this, a long Newton step or an
    /// extrapolated warm start can carry a yarn through another (the barrier is only sampled
    /// at quadrature points), after which Newton converges to a topologically wrong state.
    pub(super) fn collision_step(&self, x: &[f64], dx: &[f64]) -> f64 {
        let moves: Vec<f64> = (0..self.tile.n_vertices())
            .map(|v| Vector3::new(dx[3 * v], dx[3 * v + 1], dx[3 * v + 2]).norm())
            .collect();
        let edge_move = |e: usize| {
            let edge = self.tile.edges[e];
            moves[edge.v0].max(moves[edge.v1])
        };
        self.pair_segments(x)
            .map(|(p, [a0, a1, b0, b1])| {
                let m = edge_move(p.a) + edge_move(p.b);
                let d = closest_points(&a0, &a1, &b0, &b1).2;
                if m > 0.0 {
                    COLLISION_ETA * d / m
                } else {
                    f64::INFINITY
                }
            })
            .fold(f64::INFINITY, f64::min)
    }
}
