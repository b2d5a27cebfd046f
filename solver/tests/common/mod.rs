//! Small test problems shared by the integration tests.
#![allow(dead_code)]

use faer::sparse::SparseColMatRef;
use solver::Problem;

/// Deterministic xorshift64* generator (no dependency, seedable).
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Self(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1)
    }
    /// Uniform in [0, 1).
    pub fn uniform(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 / (1u64 << 53) as f64
    }
    /// Uniform in [lo, hi).
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.uniform()
    }
    /// Uniform integer in [0, n).
    pub fn index(&mut self, n: usize) -> usize {
        ((self.uniform() * n as f64) as usize).min(n - 1)
    }
}

/// Linear springs on a line: `E = Σ_e ½ k_e (x_b − x_a − L_e)²` (N/m, m).
pub struct LinearChain {
    pub edges: Vec<[usize; 2]>,
    pub k: Vec<f64>,
    pub rest: Vec<f64>,
}

impl LinearChain {
    pub fn uniform(n_points: usize, k: f64, rest: f64) -> Self {
        Self {
            edges: (0..n_points - 1).map(|i| [i, i + 1]).collect(),
            k: vec![k; n_points - 1],
            rest: vec![rest; n_points - 1],
        }
    }
}

impl Problem for LinearChain {
    fn n_dofs(&self) -> usize {
        self.edges.len() + 1
    }
    fn n_stencils(&self) -> usize {
        self.edges.len()
    }
    fn stencil_dofs(&self, k: usize) -> &[usize] {
        &self.edges[k]
    }
    fn eval_stencil(&self, e: usize, x: &[f64], grad: &mut [f64], hess: Option<&mut [f64]>) -> f64 {
        let [a, b] = self.edges[e];
        let k = self.k[e];
        let s = x[b] - x[a] - self.rest[e];
        grad[0] = -k * s;
        grad[1] = k * s;
        if let Some(h) = hess {
            h.copy_from_slice(&[k, -k, -k, k]);
        }
        0.5 * k * s * s
    }
}

/// Nonlinear springs between 3D points plus a constant load on every point:
/// `E = Σ_e ½ k (|x_b − x_a| − L_e)² − Σ_p f · x_p`. DOFs `3p..3p+3` are point `p`.
/// Stencils `0..edges.len()` are springs (6 DOFs), then one 3-DOF load stencil per point.
pub struct SpringNet {
    pub n_points: usize,
    pub k: f64,
    pub edges: Vec<[usize; 6]>,
    pub rest: Vec<f64>,
    pub load: [f64; 3],
    point_dofs: Vec<[usize; 3]>,
}

impl SpringNet {
    pub fn new(
        n_points: usize,
        k: f64,
        pairs: &[(usize, usize)],
        rest: Vec<f64>,
        load: [f64; 3],
    ) -> Self {
        let edges = pairs
            .iter()
            .map(|&(a, b)| [3 * a, 3 * a + 1, 3 * a + 2, 3 * b, 3 * b + 1, 3 * b + 2])
            .collect();
        let point_dofs = (0..n_points)
            .map(|p| [3 * p, 3 * p + 1, 3 * p + 2])
            .collect();
        Self {
            n_points,
            k,
            edges,
            rest,
            load,
            point_dofs,
        }
    }
}

impl Problem for SpringNet {
    fn n_dofs(&self) -> usize {
        3 * self.n_points
    }
    fn n_stencils(&self) -> usize {
        self.edges.len() + self.n_points
    }
    fn stencil_dofs(&self, s: usize) -> &[usize] {
        if s < self.edges.len() {
            &self.edges[s]
        } else {
            &self.point_dofs[s - self.edges.len()]
        }
    }
    fn eval_stencil(&self, s: usize, x: &[f64], grad: &mut [f64], hess: Option<&mut [f64]>) -> f64 {
        if s >= self.edges.len() {
            let d = self.point_dofs[s - self.edges.len()];
            let mut e = 0.0;
            for c in 0..3 {
                grad[c] = -self.load[c];
                e -= self.load[c] * x[d[c]];
            }
            return e; // Hessian zero
        }
        let dofs = self.edges[s];
        let d: [f64; 3] = std::array::from_fn(|c| x[dofs[3 + c]] - x[dofs[c]]);
        let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        let u = d.map(|v| v / l);
        let ext = l - self.rest[s];
        for c in 0..3 {
            grad[c] = -self.k * ext * u[c];
            grad[3 + c] = self.k * ext * u[c];
        }
        if let Some(h) = hess {
            // K = k [u uᵀ + (1 − L/l)(I − u uᵀ)]; local Hessian [K −K; −K K].
            let ratio = 1.0 - self.rest[s] / l;
            for j in 0..3 {
                for i in 0..3 {
                    let eye = if i == j { 1.0 } else { 0.0 };
                    let kij = self.k * (u[i] * u[j] + ratio * (eye - u[i] * u[j]));
                    h[i + 6 * j] = kij;
                    h[(i + 3) + 6 * (j + 3)] = kij;
                    h[(i + 3) + 6 * j] = -kij;
                    h[i + 6 * (j + 3)] = -kij;
                }
            }
        }
        0.5 * self.k * ext * ext
    }
}

/// `E = Σ_k ½ x_Sᵀ A_k x_S − b_kᵀ x_S` with dense symmetric `A_k` (column-major).
pub struct Quadratic {
    pub n: usize,
    pub dofs: Vec<Vec<usize>>,
    pub a: Vec<Vec<f64>>,
    pub b: Vec<Vec<f64>>,
}

impl Quadratic {
    /// Random stencils of 1..=max_len DOFs (repeats allowed), each `A_k = M Mᵀ + shift I`.
    pub fn random(rng: &mut Rng, n: usize, n_stencils: usize, max_len: usize, shift: f64) -> Self {
        let mut q = Self {
            n,
            dofs: vec![],
            a: vec![],
            b: vec![],
        };
        for _ in 0..n_stencils {
            let m = 1 + rng.index(max_len);
            let dofs: Vec<usize> = (0..m).map(|_| rng.index(n)).collect();
            let mm: Vec<f64> = (0..m * m).map(|_| rng.range(-1.0, 1.0)).collect();
            let mut a = vec![0.0; m * m];
            for j in 0..m {
                for i in 0..m {
                    a[i + m * j] = (0..m).map(|k| mm[i + m * k] * mm[j + m * k]).sum::<f64>()
                        + if i == j { shift } else { 0.0 };
                }
            }
            q.b.push((0..m).map(|_| rng.range(-1.0, 1.0)).collect());
            q.dofs.push(dofs);
            q.a.push(a);
        }
        q
    }

    /// Dense Hessian `Σ_k P_kᵀ A_k P_k` and gradient at `x`, by direct accumulation.
    pub fn dense(&self, x: &[f64]) -> (Vec<Vec<f64>>, Vec<f64>) {
        let mut h = vec![vec![0.0; self.n]; self.n];
        let mut g = vec![0.0; self.n];
        for (k, dofs) in self.dofs.iter().enumerate() {
            let m = dofs.len();
            for a in 0..m {
                g[dofs[a]] -= self.b[k][a];
                for b in 0..m {
                    h[dofs[a]][dofs[b]] += self.a[k][a + m * b];
                    g[dofs[a]] += self.a[k][a + m * b] * x[dofs[b]];
                }
            }
        }
        (h, g)
    }
}

impl Problem for Quadratic {
    fn n_dofs(&self) -> usize {
        self.n
    }
    fn n_stencils(&self) -> usize {
        self.dofs.len()
    }
    fn stencil_dofs(&self, k: usize) -> &[usize] {
        &self.dofs[k]
    }
    fn eval_stencil(&self, k: usize, x: &[f64], grad: &mut [f64], hess: Option<&mut [f64]>) -> f64 {
        let dofs = &self.dofs[k];
        let m = dofs.len();
        let a = &self.a[k];
        let mut e = 0.0;
        for i in 0..m {
            let ax: f64 = (0..m).map(|j| a[i + m * j] * x[dofs[j]]).sum();
            grad[i] = ax - self.b[k][i];
            e += x[dofs[i]] * (0.5 * ax - self.b[k][i]);
        }
        if let Some(h) = hess {
            h.copy_from_slice(a);
        }
        e
    }
}

/// Strictly convex, strongly nonlinear: `E = Σ_i cosh(x_{i+1} − x_i − c) + Σ_i cosh(x_i − a_i)`.
pub struct CoshChain {
    pub n: usize,
    pub c: f64,
    pub anchors: Vec<f64>,
    pairs: Vec<[usize; 2]>,
    singles: Vec<[usize; 1]>,
}

impl CoshChain {
    pub fn new(n: usize, c: f64, anchors: Vec<f64>) -> Self {
        Self {
            n,
            c,
            anchors,
            pairs: (0..n - 1).map(|i| [i, i + 1]).collect(),
            singles: (0..n).map(|i| [i]).collect(),
        }
    }
}

impl Problem for CoshChain {
    fn n_dofs(&self) -> usize {
        self.n
    }
    fn n_stencils(&self) -> usize {
        2 * self.n - 1
    }
    fn stencil_dofs(&self, k: usize) -> &[usize] {
        if k < self.n - 1 {
            &self.pairs[k]
        } else {
            &self.singles[k - (self.n - 1)]
        }
    }
    fn eval_stencil(&self, k: usize, x: &[f64], grad: &mut [f64], hess: Option<&mut [f64]>) -> f64 {
        if k < self.n - 1 {
            let t = x[k + 1] - x[k] - self.c;
            grad[0] = -t.sinh();
            grad[1] = t.sinh();
            if let Some(h) = hess {
                let c = t.cosh();
                h.copy_from_slice(&[c, -c, -c, c]);
            }
            t.cosh()
        } else {
            let i = k - (self.n - 1);
            let t = x[i] - self.anchors[i];
            grad[0] = t.sinh();
            if let Some(h) = hess {
                h[0] = t.cosh();
            }
            t.cosh()
        }
    }
}

/// Non-convex: `E = Σ_i (x_i² − 1)² + Σ_i ½ κ (x_{i+1} − x_i)²`.
pub struct DoubleWell {
    pub n: usize,
    pub kappa: f64,
    pairs: Vec<[usize; 2]>,
    singles: Vec<[usize; 1]>,
}

impl DoubleWell {
    pub fn new(n: usize, kappa: f64) -> Self {
        Self {
            n,
            kappa,
            pairs: (0..n - 1).map(|i| [i, i + 1]).collect(),
            singles: (0..n).map(|i| [i]).collect(),
        }
    }

    pub fn gradient(&self, x: &[f64]) -> Vec<f64> {
        let mut g: Vec<f64> = x.iter().map(|&v| 4.0 * v * (v * v - 1.0)).collect();
        for i in 0..self.n - 1 {
            let d = self.kappa * (x[i + 1] - x[i]);
            g[i] -= d;
            g[i + 1] += d;
        }
        g
    }
}

impl Problem for DoubleWell {
    fn n_dofs(&self) -> usize {
        self.n
    }
    fn n_stencils(&self) -> usize {
        2 * self.n - 1
    }
    fn stencil_dofs(&self, k: usize) -> &[usize] {
        if k < self.n - 1 {
            &self.pairs[k]
        } else {
            &self.singles[k - (self.n - 1)]
        }
    }
    fn eval_stencil(&self, k: usize, x: &[f64], grad: &mut [f64], hess: Option<&mut [f64]>) -> f64 {
        if k < self.n - 1 {
            let d = x[k + 1] - x[k];
            grad[0] = -self.kappa * d;
            grad[1] = self.kappa * d;
            if let Some(h) = hess {
                h.copy_from_slice(&[self.kappa, -self.kappa, -self.kappa, self.kappa]);
            }
            0.5 * self.kappa * d * d
        } else {
            let v = x[k - (self.n - 1)];
            grad[0] = 4.0 * v * (v * v - 1.0);
            if let Some(h) = hess {
                h[0] = 12.0 * v * v - 4.0;
            }
            (v * v - 1.0).powi(2)
        }
    }
}

/// Dense copy of a sparse matrix (entries not in the pattern are zero).
pub fn to_dense(m: SparseColMatRef<'_, usize, f64>) -> Vec<Vec<f64>> {
    let mut d = vec![vec![0.0; m.ncols()]; m.nrows()];
    let sym = m.symbolic();
    for j in 0..m.ncols() {
        let range = sym.col_range(j);
        for (&i, &v) in sym.row_idx()[range.clone()].iter().zip(&m.val()[range]) {
            d[i][j] += v;
        }
    }
    d
}

/// Asserts `|a − b| ≤ tol · max(1, |b|)` entrywise.
pub fn assert_close(a: &[f64], b: &[f64], tol: f64, what: &str) {
    assert_eq!(a.len(), b.len(), "{what}: length");
    for (i, (x, y)) in a.iter().zip(b).enumerate() {
        assert!(
            (x - y).abs() <= tol * y.abs().max(1.0),
            "{what}[{i}]: {x} vs {y}"
        );
    }
}

/// A `cols × rows` grid of nonlinear springs (spacing and rest length 0.1 m, k = 50 N/m)
/// hanging under a load of 0.5 N per point, with its top row clamped: returns the net, a start
/// configuration (the flat grid, slightly perturbed out of plane) and the Dirichlet mask.
pub fn hanging_net(cols: usize, rows: usize) -> (SpringNet, Vec<f64>, Vec<bool>) {
    let id = |i: usize, j: usize| i + cols * j;
    let mut pairs = vec![];
    for j in 0..rows {
        for i in 0..cols {
            if i + 1 < cols {
                pairs.push((id(i, j), id(i + 1, j)));
            }
            if j + 1 < rows {
                pairs.push((id(i, j), id(i, j + 1)));
            }
        }
    }
    let h = 0.1;
    let net = SpringNet::new(
        cols * rows,
        50.0,
        &pairs,
        vec![h; pairs.len()],
        [0.0, 0.0, -0.5],
    );
    let mut x = vec![0.0; net.n_dofs()];
    for j in 0..rows {
        for i in 0..cols {
            let p = id(i, j);
            x[3 * p] = h * i as f64;
            x[3 * p + 1] = 0.001 * (i * j) as f64;
            x[3 * p + 2] = -h * j as f64;
        }
    }
    let mut fixed = vec![false; net.n_dofs()];
    for i in 0..cols {
        fixed[3 * id(i, 0)..3 * id(i, 0) + 3].fill(true);
    }
    (net, x, fixed)
}

/// A random SPD quadratic in which every DOF carries a positive diagonal term.
pub fn spd_quadratic(seed: u64, n: usize) -> Quadratic {
    let mut rng = Rng::new(seed);
    let mut q = Quadratic::random(&mut rng, n, 3 * n, 4, 0.0);
    for i in 0..n {
        q.dofs.push(vec![i]);
        q.a.push(vec![0.5]);
        q.b.push(vec![rng.range(-1.0, 1.0)]);
    }
    q
}

/// Dense solve of `A x = b` (nalgebra LU) for reference solutions.
pub fn dense_solve(a: &[Vec<f64>], rhs: &[f64]) -> Vec<f64> {
    let n = rhs.len();
    let a = nalgebra::DMatrix::from_fn(n, n, |i, j| a[i][j]);
    let b = nalgebra::DVector::from_column_slice(rhs);
    a.lu()
        .solve(&b)
        .expect("reference system is nonsingular")
        .iter()
        .copied()
        .collect()
}
