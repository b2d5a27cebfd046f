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
//! | [`measure`] | edge curl and side-to-side width of knit swatches | seed 000 §3.1, §5.2.2, Figs. 5, 7 |
//! | [`scene`] | TOML scene files (pattern, Table 1 preset + overrides, damping, force terms, clamps with drivers) and OBJ yarn-curve output; the `sim-persistent run` binary | issue 6 |
//! | [`integrator`] | backward Euler as one Newton minimization per step (step halving on failure), Rayleigh damping, pinned and driven nodes, static equilibrium for quasi-static loading, clamp forces, per-term energies | seed 000 §4, §5 |
//!
//! Typical use: [`chart::Chart`] → [`topology::Topology::knit`] → [`layout::Layout::new`] →
//! [`integrator::Simulator::new`] → [`integrator::Simulator::step`].
//!
//! Status: first slice of the `sim-persistent` issue, with stitch wrapping (Eq. 2) assembled
//! for knits (rest angles ramped in from the flat layout, [`integrator::StepSettings`]). Not
//! yet implemented: compression estimation at simulated nodes (so friction uses a constant
//! slip force instead of μλ), stacked stitches and the reserved chart stitches, row-end
//! turns of a continuous yarn, rest-shape bending compensation, contact between adjacent
//! loops, weave crossing shear/jamming, obstacles, weaves and obstacles in scene files,
//! smooth rendering curves, PLY/`.bcc`/PNG output and the figures.
//!
//! **Curl of free swatches (measured, `tests/curl.rs`).** With the Table 1 sweater yarn the
//! model reproduces the senses of stockinette curl — side edges roll to the back, cast-on and
//! bind-off edges to the front — but a swatch rolls mainly along its longer direction (8 × 4:
//! sides −4.2 rad, ends +0.5/+1.3; 4 × 8: ends +4.8/+5.1, sides ≈ 0; 4 × 4: sides −2.8, ends
//! +1.5/+1.3), and the rolls are tight (radius of a few mm: wrapping, `k_w L ≈ 7.5e-6 J`
//! per rad², dominates bending until jamming). Rib 2 × 2 compresses to 0.56 of its laid-out
//! width. Garter is not flat: its side edges roll ≈ 1.2–1.3 rad to the front (8 × 5), about
//! a third of stockinette's side curl. In the settled swatches 20–35 % of the wrapping pairs
//! have a wing within ≈ 6° of the contact axis (see [`forces::wrapping`], "Degenerate
//! wings"): the frustrated contacts escape their wrapping energy that way, which the
//! missing contact between adjacent loops would probably prevent.

pub mod chart;
pub mod forces;
pub mod integrator;
pub mod layout;
pub mod measure;
pub mod params;
pub mod scene;
pub mod state;
pub mod topology;
pub mod weave;
