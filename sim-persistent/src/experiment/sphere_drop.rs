//! Swatches dropped onto a sphere (seed 000 §5.2.1, Fig. 12), the `patterns-on-sphere`
//! experiment.
//!
//! Every swatch uses the Table 1 sweater yarn (R = 0.75 mm; the paper uses R = 1 mm for
//! Fig. 12 with otherwise unstated parameters) with a loop width / yarn spacing of 3 mm,
//! Table 1 mass damping α = 10 /s and every default force term. Each swatch is
//!
//! 1. **settled** free and weightless from its flat layout (as in the `curl` figure: the stitch
//!    wrapping rest angles ramp in over 0.1 s; rib pulls in, garter edges roll a little; the
//!    weave layout is already at rest);
//! 2. **re-laid at rest** (zero velocity, the settled positions and sliding coordinates as a new
//!    layout, wrapping rest angles of the flat layout, friction anchors at the settled coordinates)
//!    with its node centroid over the centre of a sphere of radius ρ, face up or face down (a half
//!    turn about x), whichever puts its centre (the pole nodes below) lowest relative to the rest —
//!    a settled knit is not flat, and one that lands on its edges slides off the frictionless
//!    sphere — and lifted so that its lowest yarn surface is 1 mm above the sphere;
//! 3. **dropped** under gravity (−z) onto the sphere ([`crate::forces::obstacle`]:
//!    frictionless penalty contact of the contact nodes), until it is **nearly at rest**:
//!    the rms node speed `v_rms = √(2 E_kin / M)` (M the yarn mass) has stayed below
//!    `REST_SPEED` over the last `REST_WINDOW`, at least `MIN_DROP_TIME` after the release
//!    (the kinetic energy oscillates as the swatch rocks, so one low value is not enough), or
//!    the time limit is reached (reported).
//!
//! **A sticking sphere (a deviation).** The obstacle contact is frictionless, and a cloth
//! draped over a frictionless sphere is an unstable equilibrium (like a rope over a
//! frictionless peg: the side hanging lower pulls the rest after it); the first runs of this
//! figure slid the knits off the sphere (0.3 m below it after 0.5 s). Holding only the nodes
//! near the pole failed for a saddle-shaped settled knit (garter 12 × 11), which lands on its
//! rolled edges, and holding only the first contact left the knits swinging from one node.
//! As a stand-in for the sphere's friction (the limit μ → ∞), every node is held (pinned)
//! where it is at the end of the first step in which it touches the sphere: contacts stick,
//! the parts not yet in contact drape freely.
//!
//! Drape measures: [`super::drape`].

use std::time::Instant;

use anyhow::Context;
use rod::geometry::V3;

use super::drape::{DrapeSample, corners, projected_area, yarn_length};
use super::swatch::{LOOP_WIDTH, SwatchSettings, positions, run_steps};
use crate::forces::obstacle::{Obstacle, Shape};
use crate::forces::{ForceSet, TermKind};
use crate::integrator::{SimError, Simulator};
use crate::layout::{Layout, LayoutParams};
use crate::topology::Topology;

/// The swatch is at rest when its rms node speed is below this (m/s).
pub const REST_SPEED: f64 = 2e-3;

/// The rms speed must stay below [`REST_SPEED`] for this long (s).
pub const REST_WINDOW: f64 = 0.02;

/// The rest criterion is checked only after this much dropped time (s): the swatch has
/// landed (a 1 mm fall under damped gravity takes ≈ 15 ms).
pub const MIN_DROP_TIME: f64 = 0.1;

/// Gap between the lowest yarn surface and the sphere at the release (m).
pub const DROP_GAP: f64 = 1e-3;

/// Nodes within this horizontal distance (m) of the pole axis at the release (at least the
/// nearest node) are the swatch's centre, used to lay it face up or face down.
pub const POLE_RADIUS: f64 = 1.8e-3;

/// Samples of the drop history are taken every this many steps.
pub const SAMPLE_EVERY: usize = 10;

/// Sizes and times of a drop.
#[derive(Clone, Debug)]
pub struct DropSetup {
    /// Sphere radius ρ (m).
    pub sphere_radius: f64,
    /// Free settling time before the drop (s).
    pub settle_time: f64,
    /// Longest dropped time (s).
    pub max_drop_time: f64,
}

/// The result of a drop.
pub struct Dropped {
    /// The pattern's name.
    pub name: String,
    /// Samples every [`SAMPLE_EVERY`] steps from the release, and the last.
    pub samples: Vec<DrapeSample>,
    /// Deepest penetration over every step of the drop (R).
    pub deepest: f64,
    /// When the first node touched the sphere (s after the release), if one did.
    pub held_at: Option<f64>,
    /// Nodes held (touching the sphere) at the end, and how many of them are centre nodes.
    pub held: (usize, usize),
    /// Whether the rest criterion was met (else the time limit ended the drop).
    pub at_rest: bool,
    /// Degrees of freedom.
    pub dofs: usize,
    /// Obstacle terms of the simulator.
    pub obstacle_terms: usize,
    /// Drop steps.
    pub steps: usize,
    /// Newton iterations of the settle and the drop.
    pub newton_iterations: usize,
    /// Wall time of settle and drop (s).
    pub seconds: f64,
    /// The dropped swatch at the end.
    pub drop: SphereDrop,
}

/// The drop scene of one pattern (module documentation).
pub struct SphereDrop {
    /// The simulator (gravity along −z, the sphere obstacle).
    pub sim: Simulator,
    /// Sphere centre (m).
    pub center: V3,
    /// Sphere radius ρ (m).
    pub radius: f64,
    /// Projected area of the settled flat swatch (m²).
    pub flat_area: f64,
    /// The four layout corners ([`corners`]).
    pub corners: [usize; 4],
    /// The nodes within [`POLE_RADIUS`] of the pole axis at the release.
    pub pole_nodes: Vec<usize>,
    /// Whether the swatch was laid face down (turned about x).
    pub flipped: bool,
    /// Yarn mass M (kg).
    pub mass: f64,
    /// Yarn radius R (m).
    pub yarn_radius: f64,
}

impl SphereDrop {
    /// The nodes touching the sphere (gap ≤ 0).
    pub fn touching(&self) -> Vec<usize> {
        let p = positions(&self.sim);
        (0..p.len())
            .filter(|&n| (p[n] - self.center).norm() <= self.radius + self.yarn_radius)
            .collect()
    }

    /// The drape measures now, with `time` zero.
    pub fn sample(&self) -> DrapeSample {
        let p = positions(&self.sim);
        let kinetic = self.sim.kinetic_energy();
        let pole = self.center.z + self.radius + self.yarn_radius;
        let corner_drop = self.corners.iter().map(|&c| pole - p[c].z).sum::<f64>() / 4.0;
        let penetration = p
            .iter()
            .map(|x| self.radius + self.yarn_radius - (x - self.center).norm())
            .fold(f64::NEG_INFINITY, f64::max)
            / self.yarn_radius;
        DrapeSample {
            time: 0.0,
            kinetic,
            rms_speed: (2.0 * kinetic / self.mass).sqrt(),
            drape_ratio: projected_area(&p) / self.flat_area,
            corner_drop,
            penetration,
        }
    }
}

/// Settles `topo` free and weightless, re-lays it above the sphere and builds the drop;
/// also returns the Newton iterations of the settling.
pub fn prepare(topo: Topology, setup: &DropSetup) -> anyhow::Result<(SphereDrop, usize)> {
    let free = SwatchSettings {
        settle_time: setup.settle_time,
        ..SwatchSettings::default()
    };
    let flat = Layout::new(&topo, &LayoutParams::new(LOOP_WIDTH, free.params.radius))?;
    let corners = corners(&flat.positions);
    let mut sim = Simulator::new(
        topo.clone(),
        &flat,
        free.params,
        free.forces,
        free.step_settings(),
    )?;
    let newton = run_steps(&mut sim, free.steps(free.settle_time)).context("settling")?;
    let mut p = positions(&sim);
    anyhow::ensure!(
        p.iter().all(|v| v.iter().all(|c| c.is_finite())),
        "non-finite positions after settling"
    );
    // Centre the swatch over the origin, then put the sphere under it.
    let centroid = p.iter().sum::<V3>() / p.len() as f64;
    for v in &mut p {
        v.x -= centroid.x;
        v.y -= centroid.y;
    }
    let axis_distance = |v: &V3| v.x.hypot(v.y);
    let nearest = p.iter().map(axis_distance).fold(f64::INFINITY, f64::min);
    let pole_nodes: Vec<usize> = (0..p.len())
        .filter(|&n| axis_distance(&p[n]) <= POLE_RADIUS.max(nearest))
        .collect();
    // Face up or face down (a half turn about x), whichever puts the pole nodes lowest
    // relative to the rest of the swatch, so that it lands on its centre.
    let lowest = |p: &[V3], sign: f64| {
        let pole = pole_nodes
            .iter()
            .map(|&n| sign * p[n].z)
            .fold(f64::INFINITY, f64::min);
        pole - p.iter().map(|v| sign * v.z).fold(f64::INFINITY, f64::min)
    };
    let flipped = lowest(&p, -1.0) < lowest(&p, 1.0);
    if flipped {
        for v in &mut p {
            v.y = -v.y;
            v.z = -v.z;
        }
    }
    let r = free.params.radius;
    let rho = setup.sphere_radius;
    let reach = rho + r + DROP_GAP;
    let center_z = p
        .iter()
        .filter_map(|v| {
            let h2 = reach * reach - v.x * v.x - v.y * v.y;
            (h2 > 0.0).then(|| v.z - h2.sqrt())
        })
        .fold(f64::INFINITY, f64::min);
    anyhow::ensure!(center_z.is_finite(), "no node lies over the sphere");
    let center = V3::new(0.0, 0.0, center_z);
    let q = &sim.state().q;
    let sliding = topo
        .nodes
        .iter()
        .enumerate()
        .map(|(n, node)| {
            (0..node.passes.len())
                .map(|s| q[sim.dofs().u(n, s)])
                .collect()
        })
        .collect();
    let flat_area = projected_area(&p);
    let relaid = Layout {
        positions: p,
        sliding,
    };
    let mut params = free.params;
    params.gravity = V3::new(0.0, 0.0, -9.81);
    let mut settings = free.step_settings();
    // Already wrapped and pushed apart: no settling ramps, and the wrapping rest angles stay
    // those of the flat layout the swatch settled against (a half turn about x does not
    // change a signed wrapping angle), not the settled angles plus the bias again.
    settings.wrapping_ramp_time = 0.0;
    let mut drop = Simulator::new(topo, &relaid, params, ForceSet::default(), settings)?;
    drop.set_wrapping_reference(&flat)?;
    drop.add_obstacles(&[Obstacle::new(
        Shape::Sphere {
            center,
            radius: rho,
        },
        None,
    )
    .map_err(anyhow::Error::msg)?])?;
    let mass = params.linear_density * yarn_length(&drop);
    Ok((
        SphereDrop {
            sim: drop,
            center,
            radius: rho,
            flat_area,
            corners,
            pole_nodes,
            flipped,
            mass,
            yarn_radius: r,
        },
        newton,
    ))
}

/// Sticking contacts, the stand-in for the sphere's friction (μ → ∞, module documentation):
/// a node is pinned where it is at the end of the first step in which it touches.
#[derive(Clone, Debug)]
pub struct StickyContacts {
    /// Per node: held.
    pub held: Vec<bool>,
    /// Time of the first hold (s), if any.
    pub first: Option<f64>,
}

impl StickyContacts {
    /// No node held yet, of `nodes`.
    pub fn new(nodes: usize) -> Self {
        Self {
            held: vec![false; nodes],
            first: None,
        }
    }

    /// Pins the nodes of `touching` not held yet where they are now, at `time` (s).
    pub fn hold(
        &mut self,
        sim: &mut Simulator,
        touching: &[usize],
        time: f64,
    ) -> Result<(), SimError> {
        let new: Vec<usize> = touching
            .iter()
            .copied()
            .filter(|&n| !self.held[n])
            .collect();
        if !new.is_empty() {
            sim.pin_nodes(&new)?;
            for &n in &new {
                self.held[n] = true;
            }
            self.first.get_or_insert(time);
        }
        Ok(())
    }
}

/// Runs the drop of one pattern until nearly at rest (module documentation).
pub fn drop_pattern(name: &str, topo: Topology, setup: &DropSetup) -> anyhow::Result<Dropped> {
    let start = Instant::now();
    let (mut drop, mut newton_iterations) =
        prepare(topo, setup).with_context(|| format!("{name}: settling"))?;
    let dt = drop.sim.settings().dt;
    let max_steps = (setup.max_drop_time / dt).round() as usize;
    let min_steps = (MIN_DROP_TIME / dt).round() as usize;
    let window = ((REST_WINDOW / dt).round() as usize).max(1);
    // Consecutive steps with v_rms below REST_SPEED.
    let mut quiet = 0;
    let mut samples = vec![drop.sample()];
    let mut at_rest = false;
    let mut deepest = samples[0].penetration;
    let mut sticky = StickyContacts::new(drop.sim.topology().nodes.len());
    let mut steps = 0;
    while steps < max_steps {
        let report = drop.sim.step().with_context(|| {
            format!("{name}: drop step {steps} at t = {:.4} s", drop.sim.time())
        })?;
        newton_iterations += report.newton_iterations;
        steps += 1;
        let mut s = drop.sample();
        s.time = steps as f64 * dt;
        deepest = deepest.max(s.penetration);
        let touching = drop.touching();
        sticky.hold(&mut drop.sim, &touching, s.time)?;
        if steps % SAMPLE_EVERY == 0 {
            samples.push(s);
        }
        quiet = if s.rms_speed < REST_SPEED {
            quiet + 1
        } else {
            0
        };
        if steps >= min_steps && quiet >= window {
            at_rest = true;
            if steps % SAMPLE_EVERY != 0 {
                samples.push(s);
            }
            break;
        }
    }
    let p = positions(&drop.sim);
    anyhow::ensure!(
        p.iter().all(|v| v.iter().all(|c| c.is_finite())),
        "{name}: non-finite positions after the drop"
    );
    let obstacle_terms = drop.sim.static_terms().count(TermKind::Obstacle);
    Ok(Dropped {
        name: name.to_string(),
        samples,
        deepest,
        held_at: sticky.first,
        held: (
            sticky.held.iter().filter(|&&h| h).count(),
            drop.pole_nodes.iter().filter(|&&n| sticky.held[n]).count(),
        ),
        at_rest,
        dofs: drop.sim.dofs().n_dofs(),
        obstacle_terms,
        steps,
        newton_iterations,
        seconds: start.elapsed().as_secs_f64(),
        drop,
    })
}
