//! # sim-persistent — yarn-level cloth with sliding persistent contacts
//!
//! Implements Cirio, Lopez-Moreno and Otaduy, *Yarn-Level Cloth Simulation with Sliding
//! Persistent Contacts* (IEEE TVCG 2017), "seed 000": yarns are segments between persistent
//! contact nodes `q = (x, u₁ … uₙ)` with one sliding (arc-length) coordinate per yarn, so no
//! contact detection is needed.
//!
//! | module | contents | source |
//! |---|---|---|
//! | [`chart`] | the text stitch-chart format (every stitch of §3.1: K, P, YO, SL, K2TOG, SSK, K3TOG, S2KP, purl counterparts, M1L/M1R, KFB/PFB), parser with located errors and stitch-count checks, garter / stockinette / rib / seed builders | seed 000 §3.1 |
//! | [`weave`] | plain, twill and satin weave patterns | seed 000 §3.1, §3.2.1 |
//! | [`topology`] | yarns as ordered node passes, n-yarn contact nodes, stitch contacts (two nodes each, stacked heads for decreases), the knit builder for any chart flat (one yarn per row or one continuous yarn) or in the round, weave crossings, stable edges | seed 000 §3.1–§3.2.3 |
//! | [`layout`] | initial positions and sliding coordinates from the chart (flat, or round a tube) | seed 000 §4.1 |
//! | [`params`] | yarn parameters, Table 1 presets | seed 000 Table 1 |
//! | [`state`] | generalized coordinates, DOF map, state-dependent segment mass matrix | seed 000 §3.2, physics notes |
//! | [`forces`] | gravity, stretch, bending with jamming (Eq. 1), stitch wrapping (Eq. 2, Eqs. 7–13), stitch-contact length (Eq. 6), compression estimation at contact nodes (Eqs. 3–4, closed form and exact NNLS), sliding friction with anchored springs and the Coulomb bound μλ (Eq. 5; pair springs on Δu for parallel stacked yarns) with an optional return mapping, contact between adjacent loops (off by default), yarn self-contact between segments not stitched together (seed 002's barrier, R-tree broad phase, opt-in), a floor on segments' material length (ours, on by default), weave crossing shear with jamming, sphere, plane and triangle-mesh obstacles (AABB tree, static or animated OBJ sequences), inertia and Rayleigh damping forms; the summed [`forces::Potential`] (a `solver::Terms` container with each term's kind) | seed 000 §4, ref. 6 |
//! | [`measure`] | edge curl and side-to-side width of knit swatches | seed 000 §3.1, §5.2.2, Figs. 5, 7 |
//! | [`fidelity`] | knit fidelity: gauge, turn per row and loop, kept size, roll radius, closest approach of unstitched yarns, wrapping-pair states, leg joints | seed 000 §4.1–§4.2, Figs. 5–7 |
//! | [`rest_shape`] | rest-shape bending compensation: repeat detection, relaxed characteristic rectangle, loop shapes applied to the whole chart | seed 000 §4.1, Fig. 6 |
//! | [`experiment`] | swatch experiments: settle, clamp sets (rows, sides, columns), rib stretch, load cycles, drops onto a sphere with sticking contacts, drape measures, yarn pull-out with contact breaking, garments knitted in the round dressed on body meshes | seed 000 §4.5, §5.2, §5.3 |
//! | [`scene`] | TOML scene files (knit or woven pattern, Table 1 preset + overrides, damping, force terms, crossing shear, obstacles (spheres, planes, OBJ meshes and sequences; optionally sticking), clamps with drivers, outputs); the `sim-persistent run` binary | issue 6 |
//! | [`output`] | smooth rendering curves (per-node plane normals fitted by SVD, ±R yarn offsets, centripetal Catmull-Rom); OBJ, PLY, `.bcc` and PNG frame writers | seed 000 §3.2 |
//! | [`integrator`] | backward Euler as one Newton minimization per step (step halving on failure, optional friction return mapping) or linearized (one damped Newton step), sparse Cholesky or preconditioned CG, Rayleigh damping, pinned and driven nodes, obstacles, static equilibrium for quasi-static loading, clamp forces, per-term energies | seed 000 §4, §5 |
//!
//! Typical use: [`chart::Chart`] → [`topology::Topology::knit`] → [`layout::Layout::new`] →
//! [`integrator::Simulator::new`] → [`integrator::Simulator::step`].
//!
//! Figures (`bench`): `rib-stretch` (Fig. 11, guarded reference curve), `curl` (Figs. 5, 7),
//! `plasticity` (Fig. 9), `patterns-on-sphere` (Fig. 12), `stitches` (Figs. 3–4: lace,
//! shaping, a tube in the round), `pullout` (Fig. 13) and `persistent-time-vs-error`.
//!
//! Contact breaking is implemented for a yarn's free end sliding through its stitch contacts
//! ([`experiment::pullout`], [`integrator::Simulator::break_passes`]); contacts do not break
//! elsewhere. The default construction is still one yarn per row
//! ([`topology::Construction::FlatPerRow`]); the continuous yarn is opt-in. Known limits,
//! measured: with the paper's explicit
//! anchor update (the default) friction acts as a viscous brake of coefficient ≈ `k_f dt`,
//! so forces depend on the time step; the friction return mapping
//! ([`integrator::StepSettings::friction_return_mapping`], with [`forces::segment_floor`])
//! removes that but is slower and opt-in ([`forces::friction`], `persistent-time-vs-error`,
//! the `friction_dt` example); garter knitted with one yarn per row is flat only in its
//! interior (below); the rest-shape compensation of [`rest_shape`] does not yet start
//! layouts closer to rest than the flat layout (measured there).
//!
//! **Curl of free swatches (measured, `tests/curl.rs`).** With the Table 1 sweater yarn the
//! model reproduces the senses of stockinette curl — side edges roll to the back, cast-on and
//! bind-off edges to the front — but a swatch rolls mainly along its longer direction (8 × 4:
//! sides −4.2 rad, ends +0.5/+1.3; 4 × 8: ends +4.8/+5.1, sides ≈ 0; 4 × 4: sides −2.8, ends
//! +1.5/+1.3), and the rolls are tight (radius of a few mm: wrapping, `k_w L ≈ 7.5e-6 J`
//! per rad², dominates bending until jamming). Rib 2 × 2 compresses to 0.56 of its laid-out
//! width. Garter is flat only in its interior: the side curl measured along each row
//! boundary of an 8 × 9 garter is S-shaped (+0.40, +0.18, +0.12, +0.06, 0.00, −0.09, −0.19,
//! −0.88, −1.67, +2.16 rad from cast-on to bind-off), so the side edges of 8 × 5 roll
//! ≈ +1.2–1.3 rad in all, about a third of stockinette's. The interior row boundaries let
//! 40–50 % of their wrapping pairs collapse a wing onto the contact axis (see
//! [`forces::wrapping`], "Degenerate wings"), the ones next to the edges only 15–20 %, so
//! the alternating wrapping moments do not cancel there. Contact between adjacent loops
//! ([`forces::loop_contact`]) reduces garter's edge roll (+0.45/+0.86) but also
//! stockinette's side curl (to −2.1/−0.7), so it is off by default. The roll comes from the
//! row ends tied to the fabric: knitted with one continuous yarn that turns at the row ends
//! ([`topology::Construction::Flat`], as garter is really knitted) the side edges of the
//! 8 × 5 garter stay at −0.28/+0.27 rad and no row boundary of a 6 × 9 garter curls by more
//! than 0.75 rad at its sides (tied rows: up to 2.75), measured; `tests/curl.rs` asserts
//! below 0.5 and 1.0 rad. The `curl` figure uses the continuous yarn (20 × 21 garter: sides
//! +0.08/−0.03 rad, ends +0.23/−0.28 rad).

pub mod chart;
pub mod experiment;
pub mod fidelity;
pub mod forces;
pub mod integrator;
pub mod layout;
pub mod measure;
pub mod output;
pub mod params;
pub mod rest_shape;
pub mod scene;
pub mod state;
pub mod topology;
pub mod weave;
