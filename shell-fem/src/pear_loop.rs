//! The pear-loop bending test (seed 002 §4.3, Peirce 1930) on the 3-D shell.
//!
//! **Model assumptions.** A strip of rest length `length` (default 10 cm) and width `width`
//! (default 6 cm), its long axis along the material direction `angle`, is held at both ends by
//! clamps that grip two node columns each, so the ends point straight down (−z); the clamps
//! sit at `x = ∓d/2`, `z = 0`. The strip forms a loop hanging below the clamps under
//! **gravity** (areal density × g, along −z), with membrane energy (Eq. 1), edge-hinge bending
//! (Eq. 4) and **no contact** (neither self-contact of the loop nor contact with the clamps: the
//! loop does not touch itself for `d ≥ 0.3 cm` with vertical clamps). The first configuration
//! is a U (two vertical legs and a half circle of diameter `d`); smaller `d` are reached by
//! moving the clamps in steps, each starting from the previous equilibrium.
//!
//! Measured: loop height `h` = depth of the lowest node below the clamps, loop width `p` =
//! largest horizontal extent, aspect ratio `r = h/p`.

use faer::linalg::solvers::Solve;
use faer::sparse::SparseColMat;
use solver::{NewtonSettings, NewtonSolver};

use crate::ShellError;
use crate::elements::BendingParams;
use crate::material::Material;
use crate::shell::{FreeDofs, Gravity, Shell, ShellOptions, TriMesh, free_hessian};

/// Geometry and discretization of the pear-loop test.
#[derive(Clone, Debug, PartialEq)]
pub struct PearLoopConfig {
    /// Strip length (m). Default 0.10.
    pub length: f64,
    /// Strip width (m). Default 0.06.
    pub width: f64,
    /// Cells along the length. Default 40.
    pub nx: usize,
    /// Cells across the width. Default 4.
    pub ny: usize,
    /// Areal density (kg/m²). Default 0.2.
    pub areal_density: f64,
    /// Gravitational acceleration (m/s²). Default 9.81.
    pub g: f64,
    /// Largest clamp-distance change per step (m). Default 2 mm.
    pub max_step: f64,
    /// Newton settings. Default: `gradient_abs_tol = 1e-10`, at most 200 iterations, and the
    /// **exact (unprojected) Hessian** (`project_spd = false`): per-stencil SPD projection of
    /// the hinges made Newton converge only linearly here (about 5–10× slower in the bending
    /// fit); where the exact Hessian is indefinite the solver's diagonal-shift regularization
    /// takes over. [`PearLoop::ratio_sensitivity`] checks that an equilibrium is a stable
    /// minimum (positive definite Hessian).
    pub newton: NewtonSettings,
}

impl Default for PearLoopConfig {
    fn default() -> Self {
        Self {
            length: 0.10,
            width: 0.06,
            nx: 40,
            ny: 4,
            areal_density: 0.2,
            g: 9.81,
            max_step: 0.002,
            newton: NewtonSettings {
                gradient_abs_tol: 1e-10,
                max_iterations: 200,
                project_spd: false,
                ..NewtonSettings::default()
            },
        }
    }
}

/// One pear-loop equilibrium.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LoopShape {
    /// Inter-clamp distance `d` (m).
    pub d: f64,
    /// Loop height `h` (m).
    pub height: f64,
    /// Loop width `p` (m).
    pub width: f64,
    /// Aspect ratio `r = h/p`.
    pub ratio: f64,
}

/// A pear-loop test keeping its last equilibrium.
pub struct PearLoop {
    cfg: PearLoopConfig,
    shell: Shell,
    solver: NewtonSolver,
    /// Strip coordinate X (m) of each node and its column index.
    column: Vec<usize>,
    fixed: Vec<bool>,
    x: Vec<f64>,
    d: f64,
    dx: f64,
}

impl PearLoop {
    /// Builds the strip at inter-clamp distance `d0` (m) from a U-shaped start.
    pub fn new(
        cfg: &PearLoopConfig,
        material: Material,
        bending: BendingParams,
        angle: f64,
        d0: f64,
    ) -> Result<Self, ShellError> {
        if cfg.nx < 8 || cfg.ny == 0 || d0.is_nan() || d0 <= 0.0 {
            return Err(ShellError::InvalidInput(format!(
                "pear loop needs nx ≥ 8, ny ≥ 1 and d > 0 (got {}, {}, {d0})",
                cfg.nx, cfg.ny
            )));
        }
        let strip = TriMesh::rectangle(cfg.length, cfg.width, cfg.nx, cfg.ny)?;
        let (sn, cs) = angle.sin_cos();
        let material_mesh = TriMesh {
            rest: strip
                .rest
                .iter()
                .map(|p| [p[0] * cs - p[1] * sn, p[0] * sn + p[1] * cs])
                .collect(),
            triangles: strip.triangles.clone(),
        };
        let opts = ShellOptions {
            dim: 3,
            bending: Some(bending),
            gravity: Some(Gravity {
                areal_density: cfg.areal_density,
                g: cfg.g,
            }),
        };
        let shell = Shell::new(&material_mesh, material, opts)?;
        let dx = cfg.length / cfg.nx as f64;
        let column: Vec<usize> = strip
            .rest
            .iter()
            .map(|p| (p[0] / dx).round() as usize)
            .collect();
        let fixed: Vec<bool> = (0..3 * column.len())
            .map(|k| {
                let c = column[k / 3];
                c <= 1 || c + 1 >= cfg.nx
            })
            .collect();
        let solver = NewtonSolver::new(&shell, &fixed)?;
        let bending_ok = [bending.weft, bending.bias, bending.warp]
            .iter()
            .all(|k| k.is_finite() && *k > 0.0);
        if !bending_ok {
            return Err(ShellError::InvalidInput(format!(
                "bending stiffnesses must be finite and > 0, got {bending:?}"
            )));
        }
        let mut this = Self {
            cfg: cfg.clone(),
            shell,
            solver,
            column,
            fixed,
            x: Vec::new(),
            d: d0,
            dx,
        };
        // U shape: legs of length ℓ down from the clamps, half circle of radius d/2 below.
        let r = 0.5 * d0;
        let leg = 0.5 * (cfg.length - std::f64::consts::PI * r);
        if leg < 2.0 * dx {
            return Err(ShellError::InvalidInput(format!(
                "d = {d0} m is too large for a loop of length {} m",
                cfg.length
            )));
        }
        this.x = vec![0.0; 3 * strip.rest.len()];
        for (v, p) in strip.rest.iter().enumerate() {
            let s = p[0];
            let (x, z) = if s <= leg {
                (-r, -s)
            } else if s >= cfg.length - leg {
                (r, -(cfg.length - s))
            } else {
                let phi = (s - leg) / r; // 0 … π along the half circle
                (-r * phi.cos(), -leg - r * phi.sin())
            };
            this.x[3 * v] = x;
            this.x[3 * v + 1] = p[1];
            this.x[3 * v + 2] = z;
        }
        this.solve_here()?;
        Ok(this)
    }

    fn place_clamps(&mut self) {
        for v in 0..self.column.len() {
            let c = self.column[v];
            let (x, z) = match c {
                0 => (-0.5 * self.d, 0.0),
                1 => (-0.5 * self.d, -self.dx),
                c if c == self.cfg.nx => (0.5 * self.d, 0.0),
                c if c + 1 == self.cfg.nx => (0.5 * self.d, -self.dx),
                _ => continue,
            };
            self.x[3 * v] = x;
            self.x[3 * v + 2] = z;
        }
    }

    fn solve_here(&mut self) -> Result<(), ShellError> {
        self.place_clamps();
        let backup = self.x.clone();
        match self
            .solver
            .minimize(&self.shell, &mut self.x, &self.cfg.newton)
        {
            Ok(_) if self.x.iter().all(|v| v.is_finite()) => Ok(()),
            r => {
                self.x = backup;
                Err(ShellError::NotConverged {
                    s: self.d,
                    detail: format!(
                        "pear loop at d = {:.4} m: {}",
                        self.d,
                        r.err()
                            .map_or("non-finite positions".into(), |e| e.to_string())
                    ),
                })
            }
        }
    }

    /// Moves the clamps to distance `d` (m) in steps of at most `max_step`, re-equilibrating.
    pub fn solve_to(&mut self, d: f64) -> Result<LoopShape, ShellError> {
        if d.is_nan() || d <= 0.0 {
            return Err(ShellError::InvalidInput(format!(
                "clamp distance must be > 0, got {d}"
            )));
        }
        while self.d != d {
            let step = (d - self.d).clamp(-self.cfg.max_step, self.cfg.max_step);
            let target = if step == d - self.d { d } else { self.d + step };
            // Shift the loop's x so the new clamps are met halfway: scale x by the ratio.
            let ratio = target / self.d;
            for v in 0..self.column.len() {
                self.x[3 * v] *= ratio;
            }
            self.d = target;
            self.solve_here()?;
        }
        Ok(self.shape())
    }

    /// Shape of the current equilibrium.
    pub fn shape(&self) -> LoopShape {
        let n = self.column.len();
        let zmin = (0..n)
            .map(|v| self.x[3 * v + 2])
            .fold(f64::INFINITY, f64::min);
        let xmin = (0..n).map(|v| self.x[3 * v]).fold(f64::INFINITY, f64::min);
        let xmax = (0..n)
            .map(|v| self.x[3 * v])
            .fold(f64::NEG_INFINITY, f64::max);
        let (height, width) = (-zmin, xmax - xmin);
        LoopShape {
            d: self.d,
            height,
            width,
            ratio: height / width,
        }
    }

    /// Current node positions (m).
    pub fn positions(&self) -> &[f64] {
        &self.x
    }

    /// Current inter-clamp distance `d` (m).
    pub fn distance(&self) -> f64 {
        self.d
    }

    /// Replaces the bending stiffnesses (the current positions are kept, not re-equilibrated:
    /// call [`PearLoop::equilibrate`] or [`PearLoop::solve_to`]).
    pub fn set_bending(&mut self, bending: BendingParams) -> Result<(), ShellError> {
        if !bending.to_array().iter().all(|k| k.is_finite() && *k > 0.0) {
            return Err(ShellError::InvalidInput(format!(
                "bending stiffnesses must be finite and > 0, got {bending:?}"
            )));
        }
        self.shell.set_bending(bending);
        Ok(())
    }

    /// Sets the clamp distance and node positions (e.g. a stored equilibrium, as a warm start)
    /// without solving.
    pub fn set_state(&mut self, d: f64, x: &[f64]) -> Result<(), ShellError> {
        if x.len() != self.x.len()
            || !(d.is_finite() && d > 0.0)
            || !x.iter().all(|v| v.is_finite())
        {
            return Err(ShellError::InvalidInput(format!(
                "pear-loop state needs {} finite positions and d > 0 (got {} positions, d = {d})",
                self.x.len(),
                x.len()
            )));
        }
        self.x.copy_from_slice(x);
        self.d = d;
        Ok(())
    }

    /// Re-solves the equilibrium at the current clamp distance from the current positions.
    pub fn equilibrate(&mut self) -> Result<LoopShape, ShellError> {
        self.solve_here()?;
        Ok(self.shape())
    }

    /// Sensitivities `dr/dk_j` of the aspect ratio of the current equilibrium with respect to
    /// `k_θ,weft`, `k_θ,bias`, `k_θ,warp` (1/(N·m)), by implicit differentiation: at
    /// equilibrium `g_f(x, k) = 0`, so `dr/dk_j = −λᵀ ∂g_f/∂k_j` with `H_ff λ = ∂r/∂x_f`
    /// (exact, unprojected Hessian of the free DOFs; one sparse Cholesky, one solve). Errors if
    /// that Hessian is not positive definite (the equilibrium is not a stable minimum).
    ///
    /// `r = h/p` is measured on extreme nodes (lowest node, left- and rightmost node), so it is
    /// piecewise smooth in `k`: the derivative is that of the current extreme nodes (exact
    /// wherever the extreme nodes do not change).
    pub fn ratio_sensitivity(&self) -> Result<[f64; 3], ShellError> {
        let n = self.x.len();
        let nv = n / 3;
        let free = FreeDofs::new(&self.fixed[..n]);
        let (free_index, nf) = (&free.index, free.n);
        let triplets = free_hessian(&self.shell, &self.x, &free, |_, _, _| {});
        // ∂r/∂x for r = h/p, h = −z_low, p = x_right − x_left (same extreme nodes as `shape`).
        let arg = |key: &dyn Fn(usize) -> f64| {
            (0..nv).fold(0, |best, v| if key(v) < key(best) { v } else { best })
        };
        let low = arg(&|v| self.x[3 * v + 2]);
        let left = arg(&|v| self.x[3 * v]);
        let right = arg(&|v| -self.x[3 * v]);
        let shape = self.shape();
        let (h, p) = (shape.height, shape.width);
        let mut dr_dx = vec![0.0; n];
        dr_dx[3 * low + 2] += -1.0 / p;
        dr_dx[3 * right] += -h / (p * p);
        dr_dx[3 * left] += h / (p * p);
        let h_ff = SparseColMat::<usize, f64>::try_new_from_triplets(nf, nf, &triplets)
            .map_err(|e| ShellError::Linear(format!("pear-loop Hessian assembly: {e:?}")))?;
        // Cholesky doubles as the stability check: an equilibrium whose Hessian is not
        // positive definite is not a stable loop (Newton runs on the exact Hessian).
        let llt = h_ff.sp_cholesky(faer::Side::Lower).map_err(|e| {
            ShellError::Linear(format!(
                "pear loop at d = {} m is not a stable equilibrium (Hessian not positive definite: {e:?})",
                self.d
            ))
        })?;
        let mut lambda = faer::Mat::<f64>::zeros(nf, 1);
        for d in 0..n {
            if free_index[d] != usize::MAX {
                lambda[(free_index[d], 0)] = dr_dx[d];
            }
        }
        llt.solve_in_place(lambda.as_mut());
        let mut out = [0.0; 3];
        for (j, o) in out.iter_mut().enumerate() {
            let gj = self.shell.bending_gradient_unit(&self.x, j);
            let mut acc = 0.0;
            for d in 0..n {
                if free_index[d] != usize::MAX {
                    acc += lambda[(free_index[d], 0)] * gj[d];
                }
            }
            *o = -acc;
        }
        if !out.iter().all(|v| v.is_finite()) {
            return Err(ShellError::Linear(format!(
                "non-finite pear-loop sensitivities at d = {} m (singular Hessian?)",
                self.d
            )));
        }
        Ok(out)
    }
}
