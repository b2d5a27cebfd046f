//! Sphere, plane and triangle-mesh obstacles: one-sided, frictionless penalty contact of the
//! contact nodes, and on meshes also of the yarn segments' midpoints (seed 000 §5.2.1, Fig. 12:
//! "the samples are dropped onto a sphere and are simulated until coming to a rest"; the
//! paper does not describe its obstacle contact).
//!
//! A yarn point at `x` is a yarn of radius `R`, so it touches an obstacle when its signed gap
//!
//! ```text
//! sphere (centre c, radius ρ):   g(x) = |x − c| − ρ − R
//! plane (point p, unit normal n): g(x) = n·(x − p) − R          (the half-space n·(x − p) < 0 is solid)
//! mesh:                           g(x) = φ(x) − R               (φ the signed distance of [`mesh`])
//! ```
//!
//! becomes negative. With the penetration `d = −g` the energy is
//!
//! ```text
//! V = 0                                d ≤ 0
//! V = k d³/(6δ)                        0 < d < δ
//! V = k (d²/2 − δ d/2 + δ²/6)          d ≥ δ
//! ```
//!
//! a quadratic penalty of stiffness `k` (N/m) whose onset is smoothed over the depth `δ`
//! (m): `V`, `V' = k d²/(2δ) | k (d − δ/2)` and `V'' = k d/δ | k` are continuous, so the
//! energy is **C²** (only `V'''` jumps, at `d = 0` and `d = δ`) and Newton sees a continuous
//! Hessian across the contact boundary. Under a steady normal load F a node rests at
//! `d = √(2δF/k)` if `F < kδ/2`, else at `d = F/k + δ/2`. Defaults ([`Obstacle::stiffness`], [`ONSET_FRACTION`]): `k = k_s/R` (the
//! axial stiffness of a yarn piece one radius long, as the friction stiffness of Eq. 5) and
//! `δ = R/20`.
//!
//! **Documented choices.** On spheres and planes only node positions touch obstacles (the
//! straight segments between nodes may cut a sphere by their sagitta `w²/(8ρ)`). On meshes
//! the midpoint of every segment touches too ([`Obstacle::midpoints`], a 6-DoF stencil on the
//! segment's end positions: a mesh's edges and corners are sharper than the node spacing, and
//! a segment may otherwise lie across a body edge with both nodes outside); the contact is
//! frictionless
//! (no tangential force: a swatch can slide off a sphere); it is not Rayleigh-β damped (a
//! Hessian frozen at the start of a step would damp contacts that are no longer there). The
//! gradient of `|x − c|` is undefined at the sphere's centre; there the stencil pushes along
//! +z (a node cannot get there from outside without passing through the stiff shell).
//! Terms exist only when a simulation has obstacles ([`crate::integrator::Simulator::add_obstacles`]),
//! one per node and obstacle (and per segment and mesh obstacle). An animated mesh moves to
//! the end of each (sub)step before it is solved ([`mesh::MeshAnimation`]).

pub mod mesh;

use crate::params::YarnParams;
use crate::state::DofMap;
use crate::topology::Topology;
use nalgebra::{SMatrix, SVector};
use rod::geometry::V3;
use rod::{Evaluation, Stencil};
use std::sync::Arc;

pub use mesh::{MeshAnimation, MeshShape, TriangleMesh};

/// The smoothing depth `δ` of the contact onset, as a fraction of the yarn radius.
pub const ONSET_FRACTION: f64 = 0.05;

/// The shape of an obstacle (SI units).
#[derive(Clone, Debug)]
pub enum Shape {
    /// A solid sphere.
    Sphere {
        /// Centre c (m).
        center: V3,
        /// Radius ρ (m), > 0.
        radius: f64,
    },
    /// A solid half-space `n·(x − p) < 0`.
    Plane {
        /// A point p on the plane (m).
        point: V3,
        /// The outward normal n (unit length; [`Obstacle::new`] normalizes it).
        normal: V3,
    },
    /// A triangle mesh, static or animated ([`mesh`]); shared by all its contact terms.
    Mesh(Arc<MeshShape>),
}

impl PartialEq for Shape {
    /// Spheres and planes by value, meshes by identity (the same shared geometry).
    fn eq(&self, other: &Self) -> bool {
        match (self, other) {
            (Shape::Mesh(a), Shape::Mesh(b)) => Arc::ptr_eq(a, b),
            (
                Shape::Sphere { center, radius },
                Shape::Sphere {
                    center: c2,
                    radius: r2,
                },
            ) => center == c2 && radius == r2,
            (
                Shape::Plane { point, normal },
                Shape::Plane {
                    point: p2,
                    normal: n2,
                },
            ) => point == p2 && normal == n2,
            _ => false,
        }
    }
}

impl Shape {
    /// A static mesh obstacle.
    pub fn mesh(mesh: TriangleMesh) -> Self {
        Shape::Mesh(Arc::new(MeshShape {
            mesh,
            animation: None,
            time: 0.0,
        }))
    }

    /// An animated mesh obstacle, at time 0.
    pub fn animated_mesh(animation: MeshAnimation) -> Self {
        Shape::Mesh(Arc::new(MeshShape {
            mesh: animation.at(0.0),
            animation: Some(Arc::new(animation)),
            time: 0.0,
        }))
    }

    /// Signed distance (m) of `x` from the obstacle's surface (positive outside) with its
    /// gradient (unit) and Hessian (1/m). A mesh reports points beyond its reach as infinitely
    /// far outside ([`mesh`]).
    pub fn distance(&self, x: &V3) -> (f64, V3, SMatrix<f64, 3, 3>) {
        match self {
            Shape::Mesh(m) => {
                m.mesh
                    .signed_distance(x)
                    .unwrap_or((f64::INFINITY, V3::z(), SMatrix::zeros()))
            }
            _ => self.analytic_distance(x),
        }
    }

    fn analytic_distance(&self, x: &V3) -> (f64, V3, SMatrix<f64, 3, 3>) {
        match *self {
            Shape::Sphere { center, radius } => {
                let r = x - center;
                let len = r.norm();
                if len == 0.0 {
                    // The centre: no defined direction (module documentation).
                    return (-radius, V3::z(), SMatrix::zeros());
                }
                let n = r / len;
                let hess = (SMatrix::<f64, 3, 3>::identity() - n * n.transpose()) / len;
                (len - radius, n, hess)
            }
            Shape::Plane { point, normal } => ((x - point).dot(&normal), normal, SMatrix::zeros()),
            Shape::Mesh(_) => unreachable!("meshes are handled by Shape::distance"),
        }
    }

    /// This shape at time `t` (s): an animated mesh moved there, anything else unchanged.
    pub fn at_time(&self, t: f64) -> Shape {
        match self {
            Shape::Mesh(m) => match &m.animation {
                Some(a) if m.time != t => Shape::Mesh(Arc::new(MeshShape {
                    mesh: a.at(t),
                    animation: Some(a.clone()),
                    time: t,
                })),
                _ => self.clone(),
            },
            _ => self.clone(),
        }
    }

    /// Whether the shape moves in time.
    pub fn is_animated(&self) -> bool {
        matches!(self, Shape::Mesh(m) if m.animation.is_some())
    }
}

/// An obstacle: a shape, an optional penalty stiffness and whether segment midpoints touch it.
#[derive(Clone, Debug, PartialEq)]
pub struct Obstacle {
    /// The shape.
    pub shape: Shape,
    /// Penalty stiffness `k` (N/m); `None`: the default `k_s/R` of the yarn.
    pub stiffness: Option<f64>,
    /// Whether the midpoint of every yarn segment touches the obstacle too (module
    /// documentation); [`Obstacle::new`] sets it for meshes.
    pub midpoints: bool,
}

impl Obstacle {
    /// A validated obstacle (finite values, sphere radius > 0, non-zero plane normal,
    /// stiffness > 0); the plane normal is normalized. Segment midpoints touch meshes only.
    pub fn new(shape: Shape, stiffness: Option<f64>) -> Result<Self, String> {
        let finite = |v: &V3| v.iter().all(|c| c.is_finite());
        let show = |v: &V3| format!("[{}, {}, {}]", v.x, v.y, v.z);
        let shape = match shape {
            Shape::Sphere { center, radius } => {
                if !finite(&center) {
                    return Err(format!(
                        "sphere centre must be finite, got {}",
                        show(&center)
                    ));
                }
                if !(radius.is_finite() && radius > 0.0) {
                    return Err(format!(
                        "sphere radius must be finite and > 0 m, got {radius}"
                    ));
                }
                shape
            }
            Shape::Plane { point, normal } => {
                if !finite(&point) {
                    return Err(format!("plane point must be finite, got {}", show(&point)));
                }
                let len = normal.norm();
                if !(len.is_finite() && len > 0.0) {
                    return Err(format!(
                        "plane normal must be finite and non-zero, got {}",
                        show(&normal)
                    ));
                }
                Shape::Plane {
                    point,
                    normal: normal / len,
                }
            }
            Shape::Mesh(_) => shape,
        };
        let midpoints = matches!(shape, Shape::Mesh(_));
        if let Some(k) = stiffness
            && !(k.is_finite() && k > 0.0)
        {
            return Err(format!(
                "obstacle stiffness must be finite and > 0 N/m, got {k}"
            ));
        }
        Ok(Self {
            shape,
            stiffness,
            midpoints,
        })
    }

    /// The penalty stiffness (N/m) for yarns of `params`: the given one, or `k_s/R`.
    pub fn stiffness(&self, params: &YarnParams) -> f64 {
        self.stiffness
            .unwrap_or(params.stretch_stiffness() / params.radius)
    }
}

/// The penalty contact of one node with one obstacle (module documentation). DOFs: the
/// node position `x` (3).
#[derive(Clone, Debug, PartialEq)]
pub struct ObstacleContact {
    /// The obstacle's shape.
    pub shape: Shape,
    /// Contact offset (m): the yarn radius R.
    pub offset: f64,
    /// Penalty stiffness `k` (N/m).
    pub stiffness: f64,
    /// Onset smoothing depth `δ` (m), > 0.
    pub onset: f64,
}

impl ObstacleContact {
    /// Signed gap `g` (m) between the yarn surface at `x` and the obstacle (negative when
    /// penetrating).
    pub fn gap(&self, x: &V3) -> f64 {
        self.shape.distance(x).0 - self.offset
    }

    /// `(V, V', V'')` of the penetration depth `d` (m).
    pub fn profile(&self, d: f64) -> (f64, f64, f64) {
        let (k, delta) = (self.stiffness, self.onset);
        if d <= 0.0 {
            (0.0, 0.0, 0.0)
        } else if d < delta {
            (
                k * d * d * d / (6.0 * delta),
                k * d * d / (2.0 * delta),
                k * d / delta,
            )
        } else {
            (
                k * (0.5 * d * d - 0.5 * delta * d + delta * delta / 6.0),
                k * (d - 0.5 * delta),
                k,
            )
        }
    }
}

impl Stencil<3> for ObstacleContact {
    fn energy(&self, q: &SVector<f64, 3>) -> f64 {
        self.profile(-self.gap(&V3::from(*q))).0
    }

    fn eval(&self, q: &SVector<f64, 3>) -> Evaluation<3> {
        let (dist, n, hess) = self.shape.distance(&V3::from(*q));
        let d = self.offset - dist;
        if d <= 0.0 {
            return Evaluation::zero();
        }
        let (v, v1, v2) = self.profile(d);
        // ∇d = −n, ∇²d = −∇²(distance).
        Evaluation {
            energy: v,
            gradient: -v1 * n,
            hessian: v2 * n * n.transpose() - v1 * hess,
        }
    }
}

/// The penalty contact of a segment's midpoint `(x_a + x_b)/2` with one obstacle (module
/// documentation). DOFs: the end positions `x_a`, `x_b` (6).
#[derive(Clone, Debug, PartialEq)]
pub struct MidpointContact(pub ObstacleContact);

impl MidpointContact {
    fn midpoint(q: &SVector<f64, 6>) -> SVector<f64, 3> {
        0.5 * (q.fixed_rows::<3>(0) + q.fixed_rows::<3>(3))
    }
}

impl Stencil<6> for MidpointContact {
    fn energy(&self, q: &SVector<f64, 6>) -> f64 {
        self.0.energy(&Self::midpoint(q))
    }

    fn eval(&self, q: &SVector<f64, 6>) -> Evaluation<6> {
        let e = self.0.eval(&Self::midpoint(q));
        let mut out = Evaluation::<6>::zero();
        out.energy = e.energy;
        // ∂m/∂x_a = ∂m/∂x_b = I/2.
        for a in 0..2 {
            out.gradient
                .fixed_rows_mut::<3>(3 * a)
                .copy_from(&(0.5 * e.gradient));
            for b in 0..2 {
                out.hessian
                    .fixed_view_mut::<3, 3>(3 * a, 3 * b)
                    .copy_from(&(0.25 * e.hessian));
            }
        }
        out
    }
}

/// The points of a yarn that touch obstacles, from the node positions `nodes` (m) of
/// `topology`: every node, then the midpoint of every segment (in [`Topology::segments`]
/// order), the points of the node and midpoint stencils of [`stencils`].
pub fn contact_points(topology: &Topology, nodes: &[V3]) -> Vec<V3> {
    let midpoints = topology.segments().map(|(y, i)| {
        let p = &topology.yarns[y].passes;
        0.5 * (nodes[p[i].node] + nodes[p[i + 1].node])
    });
    nodes.iter().copied().chain(midpoints).collect()
}

/// The contact stencils of `obstacles`: one per node and obstacle with the node's position
/// DOFs, and one per segment and obstacle with [`Obstacle::midpoints`] with the segment's end
/// positions. Errors if an obstacle is invalid (see [`Obstacle::new`]).
#[allow(clippy::type_complexity)]
pub fn stencils(
    topology: &Topology,
    dofs: &DofMap,
    params: &YarnParams,
    obstacles: &[Obstacle],
) -> Result<
    (
        Vec<(ObstacleContact, [usize; 3])>,
        Vec<(MidpointContact, [usize; 6])>,
    ),
    String,
> {
    let mut nodes = Vec::with_capacity(obstacles.len() * topology.nodes.len());
    let mut midpoints = Vec::new();
    for o in obstacles {
        let checked = Obstacle::new(o.shape.clone(), o.stiffness)?;
        let contact = ObstacleContact {
            shape: checked.shape.clone(),
            offset: params.radius,
            stiffness: checked.stiffness(params),
            onset: ONSET_FRACTION * params.radius,
        };
        for n in 0..topology.nodes.len() {
            let x = dofs.x(n);
            nodes.push((contact.clone(), [x, x + 1, x + 2]));
        }
        if o.midpoints {
            for (y, i) in topology.segments() {
                let p = &topology.yarns[y].passes;
                let d = dofs.segment_dofs(p[i], p[i + 1]);
                midpoints.push((
                    MidpointContact(contact.clone()),
                    [d[0], d[1], d[2], d[4], d[5], d[6]],
                ));
            }
        }
    }
    Ok((nodes, midpoints))
}
