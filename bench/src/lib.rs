//! Figure generators, run-time-vs-error studies and benchmarks for the
//! yarn-level cloth workbench.
//!
//! The figure pipeline:
//! - [`figure`]: the registry ([`FigureSpec`], [`all_figures`]) and what a
//!   figure function gets ([`FigureContext`]) and returns ([`FigureOutput`]).
//! - [`plot`]: line charts written as PNG + SVG.
//! - [`Table`] (from `yarn-output`): the numeric table with CSV read/write.
//! - [`report`]: the runner behind `cargo xtask reproduce-figures`.
//! - [`reference`](mod@reference): comparison against guarded reference curves.
//! - [`studies`]: the computations behind the figures (callable from tests).
//!
//! Writing a figure:
//!
//! ```
//! use bench::plot::{LineChart, Series};
//! use bench::{FigureContext, FigureOutput, FigureSpec, Table};
//!
//! fn run(ctx: &FigureContext) -> anyhow::Result<FigureOutput> {
//!     let sizes: &[f64] = if ctx.quick { &[4.0, 8.0] } else { &[4.0, 8.0, 16.0, 32.0] };
//!     let progress = ctx.progress(sizes.len() as u64, "refining");
//!     let mut data = Table::new(&["segments", "relative error"]);
//!     for &n in sizes {
//!         data.push_row([n, 1.0 / (n * n)]); // the real computation goes here
//!         progress.inc(1);
//!     }
//!     let points = data.rows.iter().map(|r| (r[0], r[1]));
//!     LineChart::new("Convergence")
//!         .x_label("segments")
//!         .y_label("relative error")
//!         .log_x()
//!         .log_y()
//!         .series(Series::line_markers("discrete rod", points))
//!         .save(&ctx.out_dir, ctx.name)?;
//!     let last = data.rows.last().unwrap()[1];
//!     Ok(FigureOutput {
//!         summary: vec![("finest error".into(), format!("{:.2} %", 100.0 * last))],
//!         config: serde_json::json!({ "segments": sizes }),
//!         data,
//!     })
//! }
//!
//! pub fn spec() -> FigureSpec {
//!     FigureSpec {
//!         name: "rod-convergence",
//!         title: "Rod convergence",
//!         shows: "relative tip error against segment count",
//!         paper: "second order, as in the paper",
//!         guarded: true,
//!         run,
//!     }
//! }
//! # let dir = std::env::temp_dir().join(format!("bench-doc-{}", std::process::id()));
//! # std::fs::create_dir_all(&dir).unwrap();
//! # let out = (spec().run)(&FigureContext::new("rod-convergence", true, &dir)).unwrap();
//! # assert_eq!(out.data.rows.len(), 2);
//! # std::fs::remove_dir_all(&dir).unwrap();
//! ```

pub mod figure;
pub mod figures;
pub mod plot;
pub mod reference;
pub mod report;
pub mod studies;

pub use figure::{FigureContext, FigureOutput, FigureSpec, all_figures, percent};
pub use reference::{Tolerance, Tolerances, compare_tables, compare_with_file};
pub use report::{FigureRun, RunOptions, run_figures};
pub use yarn_output::table::Table;
