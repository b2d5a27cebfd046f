//! Swatch experiments of the persistent-contact simulator (seed 000 §4.5, §5.2): the
//! computations behind the `rib-stretch`, `curl`, `plasticity`, `patterns-on-sphere`,
//! `pullout` and `persistent-time-vs-error` figures, usable from library code, tests and (clamp sets)
//! scene files.
//!
//! | module | contents | source |
//! |---|---|---|
//! | [`swatch`](mod@swatch) | swatch settings (Table 1 sweater yarn, loop width 3 mm, α = 10 /s), builder, free settling, stepping, positions and energies | seed 000 §5.2 |
//! | [`clamps`] | clamp sets (cast-on, bind-off, left / right side, any column) of knits and weaves; side clamps pinned where the nodes are | seed 000 §4.5, §5.2.3 |
//! | [`pull`] | the rib stretch: a settled 2 × 2 rib pulled between side clamps | seed 000 §5.2.3, Fig. 11 |
//! | [`cycles`] | loading–unloading cycles between side clamps, residual deformation | seed 000 §4.5, Fig. 9 |
//! | [`free_swatch`] | a free swatch from its layout at a gauge, measured for knit fidelity at the layout and at the end | seed 000 §4.1–§4.2 |
//! | [`drape`] | drape measures: projected-area ratio, corner drop, penetration | seed 000 §5.2.1 |
//! | [`sphere_drop`] | swatches dropped onto a sphere with sticking contacts until at rest | seed 000 §5.2.1, Fig. 12 |
//! | [`pullout`] | yarn pull-out: one row's yarn pulled out of a garter with its edges pinned, contacts breaking as the free end slides through them | seed 000 §5.2.4, Fig. 13 |
//! | [`garment`] | garments knitted in the round from charts (a hat, a sweater body with a yoke) dressed on a body mesh (a surface of revolution: a head, a mannequin) | seed 000 §5.3, Fig. 1 |
//! | [`uniaxial`] | the virtual swatch test: quasi-static clamped uniaxial stretch, force and orthogonal compression | seed 002 §4.3 |

pub mod clamps;
pub mod cycles;
pub mod drape;
pub mod free_swatch;
pub mod garment;
pub mod pull;
pub mod pullout;
pub mod sphere_drop;
pub mod swatch;
pub mod uniaxial;

pub use clamps::{ClampSet, Grid, SideClamps};
pub use cycles::{CycleSample, Cycles, CyclesRun};
pub use free_swatch::{FreeSwatch, FreeSwatchRun, Measures};
pub use pull::{RibStretch, RibStretchRun, SettledRib, StretchSample};
pub use pullout::{PullOut, PullOutRun, PullOutSample};
pub use swatch::{
    ALPHA, LOOP_WIDTH, SwatchSettings, centroid, elastic_energies, kind_name, positions, run_steps,
    settled, swatch,
};
pub use uniaxial::{Pull, UniaxialRun, UniaxialSample, UniaxialTest};
