//! The virtual stretch test of seed 002 §4.3 on a planar membrane swatch, with load stepping,
//! warm starts and implicit-differentiation sensitivities of its outputs.
//!
//! **Model assumptions.** A `length × width` swatch (default 10 cm × 6 cm free length) lies in
//! the plane; its long axis (the pull direction) is the material direction at `angle` from the
//! weft (0 weft, π/4 bias, π/2 warp). The two short ends are clamped; the long sides are free.
//! The swatch is a **planar membrane** (2 DOFs per node): in-plane equilibrium only, as the
//! paper's in-plane fit assumes (out-of-plane curling/buckling, Fig. 7, is not modelled; the
//! membrane cannot wrinkle, so compressive stretches stay in plane). Outputs:
//!
//! - `s = l/l̄ − 1` the imposed clamp-to-clamp stretch;
//! - `f_s` (N) the total x-reaction force on the moving clamp, `Σ ∂E/∂x_i` over its nodes;
//! - `c = 1 − w/w̄` the orthogonal compression at mid-length, `w` the y-distance of the two
//!   free-edge nodes at `x = l̄/2`.
//!
//! [`Clamp::Fixed`] holds both DOFs of the end nodes (real clamps); [`Clamp::Sliding`] holds only
//! their x (frictionless clamps, used to compare with the uniform model of Eq. 3), plus the y of
//! one corner to remove the free translation.

use faer::linalg::solvers::Solve;
use faer::sparse::SparseColMat;
use serde::{Deserialize, Serialize};
use solver::{MarchError, MarchSettings, NewtonSettings, NewtonSolver, Problem, StepError, march};

use crate::ShellError;
use crate::material::{InPlaneParams, Material};
use crate::shell::{FreeDofs, Shell, ShellOptions, TriMesh, free_hessian};

/// How the end nodes are held.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Clamp {
    /// Both DOFs of every end node prescribed (no slip).
    Fixed,
    /// Only the x DOF prescribed (frictionless sliding clamps).
    Sliding,
}

/// Why one load step of [`StretchTest::solve_to`] failed (for [`solver::march`]).
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
struct StepFailure(String);

/// Geometry, discretization and solver settings of the stretch test.
#[derive(Clone, Debug, PartialEq)]
pub struct SwatchConfig {
    /// Free length between the clamps `l̄` (m). Default 0.10.
    pub length: f64,
    /// Width `w̄` (m). Default 0.06.
    pub width: f64,
    /// Cells along the length (must be even, so that a node column sits at mid-length).
    /// Default 20.
    pub nx: usize,
    /// Cells across the width. Default 12.
    pub ny: usize,
    /// Uniform 1 → 4 subdivisions applied to the base mesh. Default 0.
    pub subdivisions: usize,
    /// Clamp type. Default [`Clamp::Fixed`].
    pub clamp: Clamp,
    /// Largest stretch increment per load step. Default 0.1.
    pub max_step: f64,
    /// Number of times a failed load step is halved before giving up. Default 6.
    pub max_halvings: usize,
    /// Newton settings of each load step. Default: `solver` defaults with
    /// `gradient_abs_tol = 1e-9` N.
    pub newton: NewtonSettings,
}

impl Default for SwatchConfig {
    fn default() -> Self {
        Self {
            length: 0.10,
            width: 0.06,
            nx: 20,
            ny: 12,
            subdivisions: 0,
            clamp: Clamp::Fixed,
            max_step: 0.1,
            max_halvings: 6,
            newton: NewtonSettings {
                gradient_abs_tol: 1e-9,
                ..NewtonSettings::default()
            },
        }
    }
}

/// Output of one equilibrium of the stretch test.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct StretchPoint {
    /// Imposed stretch `s` (dimensionless).
    pub s: f64,
    /// Clamp force `f_s` (N).
    pub force: f64,
    /// Mid-length orthogonal compression `c` (dimensionless).
    pub compression: f64,
    /// Newton iterations spent reaching this point from the previous one.
    pub iterations: usize,
}

/// Derivatives of `f_s` and `c` with respect to the in-plane parameters (order of
/// [`InPlaneParams::to_array`]; zero for parameters the model does not use).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sensitivity {
    /// `∂f_s/∂p_k` (N per unit parameter).
    pub force: [f64; InPlaneParams::LEN],
    /// `∂c/∂p_k` (per unit parameter).
    pub compression: [f64; InPlaneParams::LEN],
}

/// A stretch test that keeps its last equilibrium as a warm start for the next stretch.
pub struct StretchTest {
    cfg: SwatchConfig,
    material: Material,
    shell: Shell,
    fixed: Vec<bool>,
    solver: NewtonSolver,
    /// Swatch-frame rest positions (m).
    rest: Vec<[f64; 2]>,
    right: Vec<usize>,
    mid_bottom: usize,
    mid_top: usize,
    x: Vec<f64>,
    s: f64,
    angle: f64,
}

impl StretchTest {
    /// Builds the swatch for pulling along the material direction `angle` (rad from the weft).
    pub fn new(cfg: &SwatchConfig, material: Material, angle: f64) -> Result<Self, ShellError> {
        if !cfg.nx.is_multiple_of(2) {
            return Err(ShellError::InvalidInput(format!(
                "nx must be even (a node column at mid-length), got {}",
                cfg.nx
            )));
        }
        if cfg.max_step.is_nan() || cfg.max_step <= 0.0 {
            return Err(ShellError::InvalidInput("max_step must be > 0".into()));
        }
        let mut mesh = TriMesh::rectangle(cfg.length, cfg.width, cfg.nx, cfg.ny)?;
        for _ in 0..cfg.subdivisions {
            mesh = mesh.subdivide();
        }
        let rest = mesh.rest.clone();
        // Swatch x-axis = material direction u = (cos φ, sin φ); y-axis = v = (−sin φ, cos φ).
        let (sn, cs) = angle.sin_cos();
        let material_mesh = TriMesh {
            rest: rest
                .iter()
                .map(|p| [p[0] * cs - p[1] * sn, p[0] * sn + p[1] * cs])
                .collect(),
            triangles: mesh.triangles.clone(),
        };
        let shell = Shell::new(&material_mesh, material, ShellOptions::planar())?;
        let tol = 1e-9 * cfg.length;
        let n = rest.len();
        let mut fixed = vec![false; 2 * n];
        let mut right = Vec::new();
        let (mut mid_bottom, mut mid_top) = (None, None);
        let mut corner = None;
        for (v, p) in rest.iter().enumerate() {
            let at_left = p[0].abs() < tol;
            let at_right = (p[0] - cfg.length).abs() < tol;
            if at_left || at_right {
                fixed[2 * v] = true;
                if cfg.clamp == Clamp::Fixed {
                    fixed[2 * v + 1] = true;
                }
                if at_left && p[1].abs() < tol {
                    corner = Some(v);
                }
            }
            if at_right {
                right.push(v);
            }
            if (p[0] - 0.5 * cfg.length).abs() < tol {
                if p[1].abs() < tol {
                    mid_bottom = Some(v);
                } else if (p[1] - cfg.width).abs() < tol {
                    mid_top = Some(v);
                }
            }
        }
        if cfg.clamp == Clamp::Sliding {
            let c = corner.ok_or_else(|| ShellError::InvalidInput("no corner node".into()))?;
            fixed[2 * c + 1] = true;
        }
        let (Some(mid_bottom), Some(mid_top)) = (mid_bottom, mid_top) else {
            return Err(ShellError::InvalidInput("no mid-length edge nodes".into()));
        };
        let solver = NewtonSolver::new(&shell, &fixed)?;
        let x = shell.positions_from_rest(&rest);
        Ok(Self {
            cfg: cfg.clone(),
            material,
            shell,
            fixed,
            solver,
            rest,
            right,
            mid_bottom,
            mid_top,
            x,
            s: 0.0,
            angle,
        })
    }

    /// Number of nodes of the (subdivided) mesh.
    pub fn n_nodes(&self) -> usize {
        self.rest.len()
    }

    /// Current stretch (of the last equilibrium).
    pub fn stretch(&self) -> f64 {
        self.s
    }

    /// Current node positions (m, `(x, y)` per node, swatch frame).
    pub fn positions(&self) -> &[f64] {
        &self.x
    }

    /// The material.
    pub fn material(&self) -> Material {
        self.material
    }

    /// Changes the material, keeping the current positions as the warm start (the next
    /// [`solve_to`](Self::solve_to) re-equilibrates even at the same stretch).
    pub fn set_material(&mut self, material: Material) {
        self.material = material;
        self.shell.set_material(material);
    }

    /// Resets to the rest state (`s = 0`).
    pub fn reset(&mut self) {
        self.x = self.shell.positions_from_rest(&self.rest);
        self.s = 0.0;
    }

    /// Replaces the state by a stored one (positions from [`positions`](Self::positions) at
    /// stretch `s`).
    pub fn set_state(&mut self, s: f64, x: &[f64]) -> Result<(), ShellError> {
        if x.len() != self.x.len() {
            return Err(ShellError::InvalidInput(format!(
                "state has {} DOFs, the swatch {}",
                x.len(),
                self.x.len()
            )));
        }
        self.x.copy_from_slice(x);
        self.s = s;
        Ok(())
    }

    /// Moves the clamp to stretch `s` in load steps of at most `max_step`, halving a step whose
    /// Newton solve fails ([`solver::march`]); every step starts from the previous equilibrium
    /// stretched affinely. A step that fails with SPD-projected Hessians is retried once with
    /// the exact Hessian before it is halved.
    /// Errors (never NaN) if a step cannot be completed.
    pub fn solve_to(&mut self, s: f64) -> Result<StretchPoint, ShellError> {
        if !s.is_finite() || s <= -1.0 {
            return Err(ShellError::InvalidInput(format!(
                "stretch must be > −1, got {s}"
            )));
        }
        let mut iterations = 0;
        let settings = MarchSettings {
            max_step: self.cfg.max_step,
            max_halvings: self.cfg.max_halvings,
        };
        let from = self.s;
        march(from, s, &settings, |current, target, _| {
            let backup = self.x.clone();
            let ratio = (1.0 + target) / (1.0 + current);
            for v in 0..self.rest.len() {
                self.x[2 * v] *= ratio;
            }
            let stretched = self.x.clone();
            // The configured Newton first; if it fails with SPD-projected Hessians (linear
            // convergence far from equilibrium in strongly stiffening or near-inverted
            // states), once more from the same start with the exact Hessian before halving.
            let mut attempts = vec![self.cfg.newton.clone()];
            if self.cfg.newton.project_spd {
                attempts.push(NewtonSettings {
                    project_spd: false,
                    ..self.cfg.newton.clone()
                });
            }
            let mut detail = String::new();
            for settings in &attempts {
                self.x.copy_from_slice(&stretched);
                detail = match self.solver.minimize(&self.shell, &mut self.x, settings) {
                    Ok(report) if self.x.iter().all(|v| v.is_finite()) => {
                        iterations += report.iterations;
                        self.s = target;
                        return Ok(());
                    }
                    Err(e) => e.to_string(),
                    Ok(_) => "non-finite positions".into(),
                };
            }
            self.x = backup;
            Err(StepError::Halve(StepFailure(detail)))
        })
        .map_err(|e| match e {
            MarchError::Invalid(e) => ShellError::InvalidInput(e.to_string()),
            MarchError::Failed(e) => ShellError::NotConverged {
                s: e.failed,
                detail: format!(
                    "stretch test at {:.1}° failed after {} step halvings (from s = {:.4}): {}",
                    self.angle_deg(),
                    e.depth,
                    e.last_good,
                    e.source.0
                ),
            },
        })?;
        let point = self.measure(iterations);
        if !(point.force.is_finite() && point.compression.is_finite()) {
            return Err(ShellError::NotConverged {
                s,
                detail: "non-finite force or compression".into(),
            });
        }
        Ok(point)
    }

    fn angle_deg(&self) -> f64 {
        self.angle.to_degrees()
    }

    /// Force and compression of the current state.
    fn measure(&self, iterations: usize) -> StretchPoint {
        let g = full_gradient(&self.shell, &self.x);
        let force = self.right.iter().map(|&v| g[2 * v]).sum();
        let w = self.x[2 * self.mid_top + 1] - self.x[2 * self.mid_bottom + 1];
        StretchPoint {
            s: self.s,
            force,
            compression: 1.0 - w / self.cfg.width,
            iterations,
        }
    }

    /// Sensitivities `d f_s/dp` and `dc/dp` of the current equilibrium by the adjoint method:
    /// with `g_f(x, p) = 0` at equilibrium, `dq/dp = ∂q/∂p − λᵀ ∂g_f/∂p` where
    /// `H_ff λ = ∂q/∂x_f` (exact, unprojected Hessian; one sparse LU shared by both outputs).
    /// `∂g/∂p_k` is [`Shell::membrane_param_gradient`].
    pub fn sensitivities(&self) -> Result<Sensitivity, ShellError> {
        let n = self.x.len();
        let free = FreeDofs::new(&self.fixed[..n]);
        let (free_index, nf) = (&free.index, free.n);
        let mut is_right_x = vec![false; n];
        for &v in &self.right {
            is_right_x[2 * v] = true;
        }
        let mut dforce_dx = vec![0.0; nf];
        let triplets = free_hessian(&self.shell, &self.x, &free, |da, fb, h| {
            if is_right_x[da] {
                dforce_dx[fb] += h;
            }
        });
        let h = SparseColMat::<usize, f64>::try_new_from_triplets(nf, nf, &triplets)
            .map_err(|e| ShellError::Linear(format!("Hessian assembly: {e:?}")))?;
        let lu = h
            .sp_lu()
            .map_err(|e| ShellError::Linear(format!("sparse LU of the Hessian: {e:?}")))?;
        let mut rhs = faer::Mat::<f64>::zeros(nf, 2);
        for d in 0..nf {
            rhs[(d, 0)] = dforce_dx[d];
        }
        let w = self.cfg.width;
        rhs[(free_index[2 * self.mid_top + 1], 1)] -= 1.0 / w;
        if free_index[2 * self.mid_bottom + 1] != usize::MAX {
            rhs[(free_index[2 * self.mid_bottom + 1], 1)] += 1.0 / w;
        }
        lu.solve_in_place(rhs.as_mut());
        let mut out = Sensitivity {
            force: [0.0; InPlaneParams::LEN],
            compression: [0.0; InPlaneParams::LEN],
        };
        for k in 0..InPlaneParams::LEN {
            if !self.material.model.uses(k) {
                continue;
            }
            let gk = self.shell.membrane_param_gradient(&self.x, k);
            let (mut lf, mut lc) = (0.0, 0.0);
            for d in 0..n {
                let f = free_index[d];
                if f != usize::MAX {
                    lf += rhs[(f, 0)] * gk[d];
                    lc += rhs[(f, 1)] * gk[d];
                }
            }
            let direct: f64 = self.right.iter().map(|&v| gk[2 * v]).sum();
            out.force[k] = direct - lf;
            out.compression[k] = -lc;
        }
        Ok(out)
    }
}

/// Full gradient `∂E/∂x` (fixed DOFs included: their entries are the reaction forces, N).
pub fn full_gradient<P: Problem + ?Sized>(problem: &P, x: &[f64]) -> Vec<f64> {
    let mut g = vec![0.0; problem.n_dofs()];
    let mut local = Vec::new();
    for k in 0..problem.n_stencils() {
        let dofs = problem.stencil_dofs(k);
        local.clear();
        local.resize(dofs.len(), 0.0);
        problem.eval_stencil(k, x, &mut local, None);
        for (l, &d) in dofs.iter().enumerate() {
            g[d] += local[l];
        }
    }
    g
}
