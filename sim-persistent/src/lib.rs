//! # sim-persistent — yarn-level cloth with sliding persistent contacts
//!
//! Implements Cirio, Lopez-Moreno and Otaduy, *Yarn-Level Cloth Simulation with Sliding
//! Persistent Contacts* (IEEE TVCG 2017), "seed 000": yarns are segments between persistent
//! contact nodes `q = (x, u₁ … uₙ)` with one sliding (arc-length) coordinate per yarn, so no
//! contact detection is needed.
//!
//! | module | contents | source |
//! |---|---|---|
//! | [`chart`] | the text stitch-chart format (K, P; YO, K2TOG, SSK, M1 reserved), parser with located errors, garter / stockinette / rib / seed builders | seed 000 §3.1 |
//! | [`weave`] | plain, twill and satin weave patterns | seed 000 §3.1, §3.2.1 |
//! | [`topology`] | yarns as ordered node passes, n-yarn contact nodes, stitch contacts (two nodes each), weave crossings, stable edges | seed 000 §3.2 |
//! | [`layout`] | initial positions and sliding coordinates from the chart | seed 000 §4.1 |
//! | [`params`] | yarn parameters, Table 1 presets | seed 000 Table 1 |
//! | [`state`] | generalized coordinates, DOF map, state-dependent segment mass matrix | seed 000 §3.2, physics notes |
//! | [`forces`] | gravity, stretch, bending with jamming (Eq. 1), stitch-contact length (Eq. 6), sliding friction (Eq. 5, constant slip force), inertia and damping forms; the summed [`forces::Potential`]; stitch-wrapping stencil (Eq. 2, not assembled yet); compression solvers (Eqs. 3–4, closed form and exact NNLS) | seed 000 §4 |
//! | [`integrator`] | backward Euler as one Newton minimization per step (step halving on failure), Rayleigh damping, pinned and driven nodes, static equilibrium for quasi-static loading, clamp forces, per-term energies | seed 000 §4, §5 |
//!
//! Typical use: [`chart::Chart`] → [`topology::Topology::knit`] → [`layout::Layout::new`] →
//! [`integrator::Simulator::new`] → [`integrator::Simulator::step`].
//!
//! Status: first slice of the `sim-persistent` issue. Not yet implemented: assembling stitch
//! wrapping (Eq. 2) into simulations, compression estimation at simulated nodes (so friction
//! uses a constant slip force instead of μλ), stacked stitches and the reserved chart
//! stitches, row-end turns of a continuous yarn, rest-shape bending compensation, contact
//! between adjacent loops, weave crossing shear/jamming, obstacles, scene files, output and
//! the figures.

pub mod chart;
pub mod forces;
pub mod integrator;
pub mod layout;
pub mod params;
pub mod state;
pub mod topology;
pub mod weave;
