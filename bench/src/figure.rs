//! The figure registry: what a figure is, what it gets, what it returns.
//!
//! A figure is a plain function `fn(&FigureContext) -> anyhow::Result<FigureOutput>`
//! plus a static description ([`FigureSpec`]). The function computes its data,
//! draws its plot into [`FigureContext::out_dir`] (see [`crate::plot`]) and
//! returns the plotted data; the runner ([`crate::report`]) writes the CSV,
//! the manifest and the README index.

use std::any::Any;
use std::borrow::Cow;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};

use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressStyle};

use yarn_output::table::Table;

/// Static description of one figure and the function that produces it.
#[derive(Debug, Clone)]
pub struct FigureSpec {
    /// Kebab-case name, e.g. `"rod-cantilever"`; also the folder and file stem.
    pub name: &'static str,
    /// Human-readable title.
    pub title: &'static str,
    /// One line: what the figure shows.
    pub shows: &'static str,
    /// One line: how it compares with the paper or the closed form.
    pub paper: &'static str,
    /// Whether the figure's data is a reference curve guarded by CI
    /// (`reports/reference/<name>.csv`, checked by `workbench-tests`).
    pub guarded: bool,
    /// Computes the data, draws the plot into `ctx.out_dir`, returns the data.
    pub run: fn(&FigureContext) -> anyhow::Result<FigureOutput>,
}

/// What a figure function gets from the runner.
#[derive(Debug)]
pub struct FigureContext {
    /// The figure's name (use it as the file stem of the plot).
    pub name: &'static str,
    /// Quick mode: coarser sweeps so the whole set runs in seconds.
    /// Guarded reference curves are always computed in quick mode.
    pub quick: bool,
    /// Folder to draw the plot into (already exists).
    pub out_dir: PathBuf,
    /// Data shared by the figures of one run (e.g. generated databases), owned by the
    /// runner: one cache per [`crate::run_figures`] call, a fresh one per
    /// [`FigureContext::new`].
    pub cache: Arc<FigureCache>,
    multi: MultiProgress,
    bars: Mutex<Vec<ProgressBar>>,
}

impl FigureContext {
    /// A context with progress output hidden (for tests and library use).
    pub fn new(name: &'static str, quick: bool, out_dir: impl Into<PathBuf>) -> Self {
        let multi = MultiProgress::with_draw_target(ProgressDrawTarget::hidden());
        Self::with_progress(name, quick, out_dir.into(), multi, Arc::default())
    }

    pub(crate) fn with_progress(
        name: &'static str,
        quick: bool,
        out_dir: PathBuf,
        multi: MultiProgress,
        cache: Arc<FigureCache>,
    ) -> Self {
        Self {
            name,
            quick,
            out_dir,
            cache,
            multi,
            bars: Mutex::new(Vec::new()),
        }
    }

    /// A progress bar for `len` steps of this figure's work, shown under the
    /// figure-level bar (hidden when stderr is not a terminal). Call
    /// `inc(1)` per step; the runner clears it when the figure returns.
    pub fn progress(&self, len: u64, message: impl Into<Cow<'static, str>>) -> ProgressBar {
        let style = ProgressStyle::with_template("  {msg:24} [{bar:30}] {pos}/{len} {elapsed}")
            .expect("valid template")
            .progress_chars("=> ");
        let bar = self.multi.add(
            ProgressBar::new(len)
                .with_style(style)
                .with_message(message),
        );
        self.bars.lock().expect("progress lock").push(bar.clone());
        bar
    }

    /// Clears every bar created by [`FigureContext::progress`].
    pub(crate) fn clear_progress(&self) {
        for bar in self.bars.lock().expect("progress lock").drain(..) {
            bar.finish_and_clear();
            self.multi.remove(&bar);
        }
    }
}

/// Values shared between the figures of one run, one per type: a figure asks for its
/// cache type with [`FigureCache::get`] and memoizes inside it (e.g.
/// [`crate::studies::deform_databases::RealCache`]).
#[derive(Default)]
pub struct FigureCache {
    entries: Mutex<Vec<Arc<dyn Any + Send + Sync>>>,
}

impl FigureCache {
    /// The run's value of type `T`, created with `T::default()` on first use.
    pub fn get<T: Default + Send + Sync + 'static>(&self) -> Arc<T> {
        let mut entries = self.entries.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(t) = entries.iter().find_map(|e| e.clone().downcast::<T>().ok()) {
            return t;
        }
        let t = Arc::new(T::default());
        entries.push(t.clone());
        t
    }
}

impl std::fmt::Debug for FigureCache {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let n = self.entries.lock().map_or(0, |e| e.len());
        write!(f, "FigureCache({n} entries)")
    }
}

/// What a figure function returns.
#[derive(Debug, Clone, Default)]
pub struct FigureOutput {
    /// The plotted data; written to `reports/<name>/<name>.csv` and, for
    /// guarded figures, compared against `reports/reference/<name>.csv`.
    pub data: Table,
    /// Key numbers for the README and the summary, e.g.
    /// `("error at 64 segments", "0.31 %")`.
    pub summary: Vec<(String, String)>,
    /// The parameters used (material, sweep, quick-mode choices); stored in
    /// the manifest.
    pub config: serde_json::Value,
}

/// Every registered figure, in README order.
///
/// Add a figure by writing a module in `bench/src/figures/` with a
/// `pub fn spec() -> FigureSpec` and listing it here.
pub fn all_figures() -> Vec<FigureSpec> {
    use crate::figures::*;
    vec![
        rod_cantilever::spec(),
        rod_convergence::spec(),
        shell_nh_vs_stvk::spec(),
        shell_fit::spec(),
        shell_fit_all::spec(),
        shell_bending_fit::spec(),
        shell_time_vs_error::spec(),
        deform_throughput::spec(),
        deform_compression_clamping::spec(),
        deform_sampling_density::spec(),
        deform_naive_vs_mechanics::spec(),
        deform_bending_models::spec(),
        deform_time_vs_error::spec(),
        periodic_curves::spec(),
        periodic_tiles::spec(),
        periodic_bending::spec(),
        periodic_time_vs_error::spec(),
        periodic_vs_reference::spec(),
        periodic_databases::spec(),
        persistent_rib_stretch::spec(),
        persistent_curl::spec(),
        persistent_knit_fidelity::spec(),
        persistent_rest_shape::spec(),
        persistent_plasticity::spec(),
        persistent_patterns_on_sphere::spec(),
        persistent_stitches::spec(),
        persistent_garment::spec(),
        persistent_pullout::spec(),
        persistent_time_vs_error::spec(),
        yarn_fit::spec(),
        yarn_fit_ablations::spec(),
        yarn_fit_seeds::spec(),
        cross_method::spec(),
        closed_loop::spec(),
    ]
}

/// Formats a relative error as a percentage with three significant digits
/// (`0.0123` → `"1.23 %"`, `4.2e-6` → `"4.20e-4 %"`), for figure key numbers.
pub fn percent(relative: f64) -> String {
    let p = 100.0 * relative;
    if p == 0.0 || p.abs() >= 0.01 {
        format!("{p:.3} %")
    } else {
        format!("{p:.2e} %")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One value per type and cache: the same `Arc` on every `get`, separate per type, and a
    /// fresh cache (a new run) starts empty.
    #[test]
    fn figure_cache_keeps_one_value_per_type() {
        let cache = FigureCache::default();
        let a = cache.get::<Mutex<Vec<usize>>>();
        a.lock().unwrap().push(7);
        assert!(Arc::ptr_eq(&a, &cache.get::<Mutex<Vec<usize>>>()));
        assert_eq!(*cache.get::<Mutex<Vec<usize>>>().lock().unwrap(), vec![7]);
        assert!(cache.get::<Mutex<Option<f64>>>().lock().unwrap().is_none());
        let other = FigureCache::default();
        assert!(other.get::<Mutex<Vec<usize>>>().lock().unwrap().is_empty());
        assert_eq!(format!("{cache:?}"), "FigureCache(2 entries)");
    }
}
