//! Node normals and the side of each yarn at a node (module documentation of
//! [`crate::output`]).

use super::OutputError;
use crate::topology::Topology;
use nalgebra::{Matrix3, SymmetricEigen};
use rod::geometry::V3;
use std::collections::VecDeque;

/// Neighbourhoods whose second covariance eigenvalue is at most this fraction of the largest
/// are collinear: their plane, hence their normal, is undetermined (module documentation).
pub const COLLINEAR_RATIO: f64 = 1e-6;

/// Where a node normal comes from (module documentation).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NormalSource {
    /// Fitted to the node and its neighbours.
    Fitted,
    /// Degenerate neighbourhood: mean of the neighbours' fitted normals.
    Neighbours,
    /// Degenerate neighbourhood without fitted neighbours: the fabric normal.
    Fabric,
}

/// Unit normals of the contact nodes, consistently oriented (module documentation).
#[derive(Clone, Debug, PartialEq)]
pub struct NodeNormals {
    /// Unit normal per node (dimensionless).
    pub normals: Vec<V3>,
    /// How each normal was obtained.
    pub sources: Vec<NormalSource>,
    /// The fabric normal `g` (unit) used for orientation and as the last fallback.
    pub fabric: V3,
}

/// Eigenvalues (ascending) and unit eigenvectors of the covariance of `points` about their
/// mean, or `None` if it cannot be computed (no points, non-finite values).
fn covariance_eigen(points: &[V3]) -> Option<([f64; 3], [V3; 3])> {
    if points.is_empty() {
        return None;
    }
    let mean = points.iter().sum::<V3>() / points.len() as f64;
    let mut m = Matrix3::<f64>::zeros();
    for p in points {
        let d = p - mean;
        m += d * d.transpose();
    }
    if !m.iter().all(|v| v.is_finite()) {
        return None;
    }
    let eig = SymmetricEigen::try_new(m, f64::EPSILON, 1000)?;
    let mut idx = [0, 1, 2];
    idx.sort_by(|&a, &b| eig.eigenvalues[a].total_cmp(&eig.eigenvalues[b]));
    let vectors = idx.map(|i| eig.eigenvectors.column(i).into_owned());
    if !vectors.iter().all(|v| v.iter().all(|c| c.is_finite())) {
        return None;
    }
    Some((idx.map(|i| eig.eigenvalues[i]), vectors))
}

/// The unit normal of the plane fitted to `points` (smallest-eigenvalue eigenvector of their
/// covariance), or `None` when they are fewer than three, not finite, or (nearly) collinear
/// ([`COLLINEAR_RATIO`]). The sign is arbitrary.
pub fn fit_plane_normal(points: &[V3]) -> Option<V3> {
    if points.len() < 3 {
        return None;
    }
    let (l, v) = covariance_eigen(points)?;
    (l[2] > 0.0 && l[1] > COLLINEAR_RATIO * l[2]).then(|| v[0].normalize())
}

/// `v` signed so that its first clearly non-zero component among (z, y, x) is positive.
fn canonical_sign(v: V3) -> V3 {
    for c in [2, 1, 0] {
        if v[c].abs() > 1e-9 {
            return if v[c] < 0.0 { -v } else { v };
        }
    }
    v
}

/// The fabric normal `g` of the finite `positions` (module documentation).
fn fabric_normal(positions: &[V3]) -> V3 {
    let finite: Vec<V3> = positions
        .iter()
        .copied()
        .filter(|p| p.iter().all(|c| c.is_finite()))
        .collect();
    if let Some(n) = fit_plane_normal(&finite) {
        return canonical_sign(n);
    }
    if let Some((l, v)) = covariance_eigen(&finite)
        && l[2] > 0.0
    {
        let d = v[2];
        let axis = [V3::z(), V3::y(), V3::x()]
            .into_iter()
            .min_by(|a, b| a.dot(&d).abs().total_cmp(&b.dot(&d).abs()))
            .unwrap_or(V3::z());
        let n = axis - axis.dot(&d) * d;
        if n.norm() > 1e-12 {
            return canonical_sign(n.normalize());
        }
    }
    V3::z()
}

/// Neighbours of every node along all yarns through it (previous and next pass), each once.
fn neighbours(topology: &Topology) -> Vec<Vec<usize>> {
    let n_nodes = topology.nodes.len();
    let mut nbrs = vec![Vec::new(); n_nodes];
    for yarn in &topology.yarns {
        for w in yarn.passes.windows(2) {
            let (a, b) = (w[0].node, w[1].node);
            if a < n_nodes && b < n_nodes && a != b {
                nbrs[a].push(b);
                nbrs[b].push(a);
            }
        }
    }
    for list in &mut nbrs {
        list.sort_unstable();
        list.dedup();
    }
    nbrs
}

/// Fitted, consistently oriented node normals with fallbacks (module documentation).
/// `positions` has one entry per node of `topology` (checked).
pub fn node_normals(topology: &Topology, positions: &[V3]) -> Result<NodeNormals, OutputError> {
    let n_nodes = topology.nodes.len();
    if positions.len() != n_nodes {
        return Err(OutputError::Invalid(format!(
            "{} positions for {n_nodes} nodes",
            positions.len()
        )));
    }
    let finite = |p: &V3| p.iter().all(|c| c.is_finite());
    let nbrs = neighbours(topology);
    let fitted: Vec<Option<V3>> = (0..n_nodes)
        .map(|n| {
            if !finite(&positions[n]) {
                return None;
            }
            let mut pts = vec![positions[n]];
            pts.extend(nbrs[n].iter().map(|&m| positions[m]).filter(finite));
            fit_plane_normal(&pts)
        })
        .collect();
    let g = fabric_normal(positions);
    // Breadth-first orientation from seeds in order of alignment with g.
    let mut seeds: Vec<usize> = (0..n_nodes).filter(|&n| fitted[n].is_some()).collect();
    let align = |n: usize| fitted[n].map_or(0.0, |v| v.dot(&g).abs());
    seeds.sort_by(|&a, &b| align(b).total_cmp(&align(a)).then(a.cmp(&b)));
    let mut oriented: Vec<Option<V3>> = vec![None; n_nodes];
    let mut reference: Vec<Option<V3>> = vec![None; n_nodes];
    let mut queue = VecDeque::new();
    for seed in seeds {
        if reference[seed].is_some() {
            continue;
        }
        let v = fitted[seed].unwrap_or(g);
        let v = if v.dot(&g) < 0.0 { -v } else { v };
        oriented[seed] = Some(v);
        reference[seed] = Some(v);
        queue.push_back(seed);
        while let Some(u) = queue.pop_front() {
            let r = reference[u].unwrap_or(g);
            for &m in &nbrs[u] {
                if reference[m].is_some() {
                    continue;
                }
                match fitted[m] {
                    Some(v) => {
                        let v = if v.dot(&r) < 0.0 { -v } else { v };
                        oriented[m] = Some(v);
                        reference[m] = Some(v);
                    }
                    None => reference[m] = Some(r),
                }
                queue.push_back(m);
            }
        }
    }
    let mut normals = Vec::with_capacity(n_nodes);
    let mut sources = Vec::with_capacity(n_nodes);
    for n in 0..n_nodes {
        if let Some(v) = oriented[n] {
            normals.push(v);
            sources.push(NormalSource::Fitted);
            continue;
        }
        let mean: V3 = nbrs[n].iter().filter_map(|&m| oriented[m]).sum();
        if mean.norm() > 1e-9 {
            normals.push(mean.normalize());
            sources.push(NormalSource::Neighbours);
        } else {
            let r = reference[n].unwrap_or(g);
            normals.push(if g.dot(&r) < 0.0 { -g } else { g });
            sources.push(NormalSource::Fabric);
        }
    }
    Ok(NodeNormals {
        normals,
        sources,
        fabric: g,
    })
}

/// Side factor `k` of every node slot, `sides[node][slot]`: the pass is offset by `k R n̂`
/// (module documentation: weave crossings by which yarn is on top, stitch contacts by
/// knit/purl, one-yarn nodes not at all).
pub fn offset_sides(topology: &Topology) -> Vec<Vec<f64>> {
    let mut sides: Vec<Vec<f64>> = topology
        .nodes
        .iter()
        .map(|node| {
            let m = node.passes.len();
            if m < 2 {
                vec![0.0; m]
            } else {
                (0..m).map(|s| (2 * s) as f64 - (m - 1) as f64).collect()
            }
        })
        .collect();
    // Weave crossings: yarn `j` is weft `j` (Topology::weave); the other yarn is the warp.
    for c in &topology.crossings {
        let warp_side = if c.warp_over { 1.0 } else { -1.0 };
        if let Some(node) = topology.nodes.get(c.node)
            && node.passes.len() >= 2
        {
            for (s, p) in node.passes.iter().enumerate() {
                sides[c.node][s] = if p.yarn == c.weft {
                    -warp_side
                } else {
                    warp_side
                };
            }
        }
    }
    // Stitch contacts: front to back, `m − 1, m − 3, …, −(m − 1)` (two yarns: ±1).
    for (node, stack) in topology.knit_stacks().into_iter().enumerate() {
        if let Some((slots, _)) = stack
            && slots.len() >= 2
        {
            let m = slots.len();
            for (i, s) in slots.into_iter().enumerate() {
                sides[node][s] = (m - 1) as f64 - 2.0 * i as f64;
            }
        }
    }
    sides
}
