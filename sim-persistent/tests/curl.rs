//! Stitch wrapping (seed 000 Eq. 2) in simulations of free swatches, and the shapes it gives
//! them at rest (§3.1, §4.2, §5.2.2, Figs. 5 and 7): stockinette curls, garter stays flat.
//! Measures from [`sim_persistent::measure`] (curl > 0: the edge rolls towards the front, the
//! knit side of stockinette).
//!
//! Every swatch: Table 1 sweater yarn, loop width 3 mm, no gravity, no pins, mass damping
//! α = 10/s (Table 1), no stiffness damping, dt = 1 ms, the wrapping rest angles (and the
//! contact radii) ramped in over the first 0.1 s (default), 0.3 s simulated in all, Newton
//! stopped at a force residual of 1e-7 N. The model is the default one (the layout's wrapping
//! rest state with its bias, yarn self-contact) unless a test names the paper's fixed quarter
//! turn.

use rod::geometry::V3;
use sim_persistent::chart::Chart;
use sim_persistent::forces::ForceSet;
use sim_persistent::forces::wrapping::StitchWrap;
use sim_persistent::integrator::{Simulator, StepSettings};
use sim_persistent::layout::{Layout, LayoutParams};
use sim_persistent::measure::{EdgeCurl, course_width, edge_curl};
use sim_persistent::params::{DEFAULT_WRAP_BIAS, WrappingRest, YarnParams};
use sim_persistent::topology::{Construction, Side, Topology, knit_node};

/// What a settled swatch looks like.
struct Settled {
    curl: EdgeCurl,
    /// Side curl `(left, right)` (rad) along every row boundary `0..=H` (the measure of
    /// `edge_curl`, which uses the middle boundary only).
    side_curls: Vec<(f64, f64)>,
    /// Relaxed over laid-out side-to-side width.
    width_ratio: f64,
    /// Peak and final kinetic energy (J).
    peak_kinetic: f64,
    final_kinetic: f64,
    /// Mean of `ψ · sign(ψ₀)` over the wrapping pairs at the start and at the end (rad).
    wrap_start: f64,
    wrap_end: f64,
    /// Number of wrapping terms.
    n_wraps: usize,
    /// Fraction of wrapping pairs at the end whose degenerate-wing weight is below 1/2 (a
    /// wing within ≈ 6° of the contact axis, see `forces::wrapping`).
    collapsed: f64,
}

/// Mean of `ψ · sign(ψ₀)`, number of pairs, fraction of pairs with weight < 1/2.
fn wrap_stats(sim: &Simulator) -> (f64, usize, f64) {
    let q = &sim.state().q;
    let (mut sum, mut n, mut collapsed) = (0.0, 0, 0);
    let terms = sim.static_terms();
    for (k, w) in terms.iter_of::<StitchWrap, 12>() {
        let d = terms.dofs(k);
        let x: [f64; 12] = std::array::from_fn(|i| q[d[i]]);
        // The ramp keeps the sign of the rest angle (the layout angle is ≈ 0).
        sum += StitchWrap::angle(&x) * w.rest_angle.signum();
        n += 1;
        collapsed += usize::from(StitchWrap::weight(&x) < 0.5);
    }
    let n_f = n.max(1) as f64;
    (sum / n_f, n, collapsed as f64 / n_f)
}

/// Centroid of the four contact nodes of column `c` on boundary `b`.
fn cell(p: &[V3], w: usize, b: usize, c: usize) -> V3 {
    let mut s = V3::zeros();
    for side in [Side::Left, Side::Right] {
        for hi in [false, true] {
            s += p[knit_node(w, b, c, side, hi)];
        }
    }
    s / 4.0
}

/// Side curl `(left, right)` along row boundary `b` of a `w × h` knit, measured as
/// `measure::edge_curl` measures it on the middle boundary: accumulated turns of the
/// polyline of column centroids about the wale axis (from boundary `b − 1` to `b + 1`,
/// clamped), from the centre out to each side, positive towards the front.
fn side_curl(p: &[V3], w: usize, h: usize, b: usize) -> (f64, f64) {
    let pts: Vec<V3> = (0..w).map(|c| cell(p, w, b, c)).collect();
    let (up, down) = ((b + 1).min(h), b.saturating_sub(1));
    let mut theta = vec![0.0];
    for k in 0..w - 2 {
        let axis = -(cell(p, w, up, k + 1) - cell(p, w, down, k + 1)).normalize();
        let (t0, t1) = (pts[k + 1] - pts[k], pts[k + 2] - pts[k + 1]);
        theta.push(theta[k] + t0.cross(&t1).dot(&axis).atan2(t0.dot(&t1)));
    }
    let n = theta.len();
    let centre = 0.5 * (theta[(n - 1) / 2] + theta[n / 2]);
    (centre - theta[0], theta[n - 1] - centre)
}

fn settle(chart: &Chart, steps: usize) -> Settled {
    settle_as(chart, steps, Construction::FlatPerRow)
}

/// [`settle`] for a chart knitted as `construction`.
fn settle_as(chart: &Chart, steps: usize, construction: Construction) -> Settled {
    settle_with(chart, steps, construction, WrappingRest::default(), true)
}

/// [`settle_as`] with the wrapping rest state `wrapping` and yarn self-contact on or off.
fn settle_with(
    chart: &Chart,
    steps: usize,
    construction: Construction,
    wrapping: WrappingRest,
    yarn_contact: bool,
) -> Settled {
    let topo = Topology::knit_with(chart, construction).unwrap();
    let mut params = YarnParams::sweater();
    params.gravity *= 0.0;
    params.wrapping_rest = wrapping;
    let layout = Layout::new(&topo, &LayoutParams::new(3e-3, params.radius)).unwrap();
    let mut settings = StepSettings {
        rayleigh_alpha: 10.0,
        ..StepSettings::default()
    };
    // Forces are ~1 mN; 1e-7 N stops Newton where rounding and the kinks of the jamming and
    // degenerate-wing transitions keep the default 1e-10 N from being reached.
    settings.newton.gradient_abs_tol = 1e-7;
    let forces = ForceSet {
        gravity: false,
        yarn_contact,
        ..ForceSet::default()
    };
    let mut sim = Simulator::new(topo.clone(), &layout, params, forces, settings).unwrap();
    let (wrap_start, n_wraps, _) = wrap_stats(&sim);
    let mut peak_kinetic: f64 = 0.0;
    for k in 0..steps {
        sim.step()
            .unwrap_or_else(|e| panic!("{chart:?} step {k}: {e}"));
        peak_kinetic = peak_kinetic.max(sim.kinetic_energy());
    }
    let s = sim.state();
    assert!(s.q.iter().chain(&s.v).all(|v| v.is_finite()));
    let positions: Vec<_> = (0..topo.nodes.len())
        .map(|n| sim.dofs().position(&s.q, n))
        .collect();
    let (wrap_end, _, collapsed) = wrap_stats(&sim);
    let (w, h) = (chart.width(), chart.height());
    Settled {
        curl: edge_curl(&topo, &positions).unwrap(),
        side_curls: (0..=h).map(|b| side_curl(&positions, w, h, b)).collect(),
        width_ratio: course_width(&topo, &positions).unwrap()
            / course_width(&topo, &layout.positions).unwrap(),
        peak_kinetic,
        final_kinetic: sim.kinetic_energy(),
        wrap_start,
        wrap_end,
        n_wraps,
        collapsed,
    }
}

fn report(name: &str, s: &Settled) {
    let c = &s.curl;
    eprintln!(
        "{name}: curl left {:+.3} right {:+.3} bottom {:+.3} top {:+.3} rad; width ratio {:.3}; \
         kinetic peak {:.2e} J, final {:.2e} J; mean ψ·sign(ψ₀) {:.3} → {:.3} rad over {} pairs, \
         {:.0} % collapsed",
        c.left,
        c.right,
        c.bottom,
        c.top,
        s.width_ratio,
        s.peak_kinetic,
        s.final_kinetic,
        s.wrap_start,
        s.wrap_end,
        s.n_wraps,
        100.0 * s.collapsed
    );
    let per: Vec<String> = s
        .side_curls
        .iter()
        .map(|(l, r)| format!("{l:+.2}/{r:+.2}"))
        .collect();
    eprintln!("  side curl per boundary 0..=H: {}", per.join(" "));
}

/// A free 4 × 4 stockinette settles without blow-up: every step converges, the state stays
/// finite, the kinetic energy decays to under 5 % of its peak, and the contacts wrap in their
/// sense by the bias of the rest state: the mean of `ψ · sign(ψ₀)` goes from ≈ 0 at the flat
/// layout up by at least half the bias β and by less than twice it (the layout's angles are
/// the rest state; a fabric that rolled up would wrap by far more), with fewer than 5 % of
/// the pairs' wings collapsed onto their axis. The square also curls with the real
/// stockinette's senses on both edge pairs: side edges to the back, ends to the front.
/// Measured: 0.013 → 0.114 rad, no collapsed wing, curls −0.15/−0.15 and +0.11/+0.17 rad.
#[test]
fn free_swatch_wraps_up_and_settles() {
    let s = settle(&Chart::stockinette(4, 4).unwrap(), 300);
    report("stockinette 4×4", &s);
    let c = s.curl;
    assert!(c.left < 0.0 && c.right < 0.0, "{c:?}");
    assert!(c.bottom > 0.0 && c.top > 0.0, "{c:?}");
    assert!(s.n_wraps > 0);
    assert!(s.wrap_start.abs() < 0.1, "layout wrap {}", s.wrap_start);
    let wrapped = s.wrap_end - s.wrap_start;
    assert!(
        wrapped > 0.5 * DEFAULT_WRAP_BIAS && wrapped < 2.0 * DEFAULT_WRAP_BIAS,
        "contacts wrapped by {wrapped} rad (bias {DEFAULT_WRAP_BIAS})"
    );
    assert!(s.collapsed < 0.05, "collapsed wings {}", s.collapsed);
    assert!(s.peak_kinetic > 0.0);
    assert!(
        s.final_kinetic < 0.05 * s.peak_kinetic,
        "kinetic energy {:e} J vs peak {:e} J",
        s.final_kinetic,
        s.peak_kinetic
    );
}

/// The headline of issue 6. Real stockinette rolls its side edges towards the back (purl
/// side) and its cast-on and bind-off edges towards the front (knit side): rows and columns
/// curl in opposite senses (§3.1, Fig. 5 left). Each sense is measured on a strip long in
/// that direction (a sheet cannot roll both ways at once without stretching):
///
/// - stockinette 8 × 4 (wide): both side edges curl visibly to the back (< −0.2 rad on the
///   middle boundary), and no boundary's side curls to the front;
/// - stockinette 4 × 8 (tall): both end edges curl visibly to the front (> +0.2 rad);
/// - garter 8 × 5 (alternating rows, an odd row count so that the contact boundaries hold as
///   many knit as purl stitches): every edge curl below half the smaller side curl of the
///   stockinette strip of the same width (alternate rows unwrap in opposite senses, §4.2).
///
/// Measured: wide sides −0.49/−0.49 rad (−0.02 to −1.07 from cast-on to bind-off), tall
/// ends +0.28/+0.33 rad, garter ≤ 0.15 rad. The rolls are loose: with the default bias a
/// stockinette edge turns by about a radian over a few loops, not into a rod (the paper's
/// fixed quarter turn rolls these strips by 1–5 rad, through themselves without contact).
#[test]
fn stockinette_rows_and_columns_curl_in_opposite_senses_garter_less() {
    let (wide, tall, garter) = std::thread::scope(|scope| {
        let wide = scope.spawn(|| settle(&Chart::stockinette(8, 4).unwrap(), 300));
        let tall = scope.spawn(|| settle(&Chart::stockinette(4, 8).unwrap(), 300));
        let garter = settle(&Chart::garter(8, 5).unwrap(), 300);
        (wide.join().unwrap(), tall.join().unwrap(), garter)
    });
    report("stockinette 8×4", &wide);
    report("stockinette 4×8", &tall);
    report("garter 8×5", &garter);
    assert!(
        wide.curl.left < -0.2 && wide.curl.right < -0.2,
        "stockinette side edges must roll to the back: {:?}",
        wide.curl
    );
    assert!(
        wide.side_curls.iter().all(|&(l, r)| l < 0.0 && r < 0.0),
        "stockinette side edges roll to the back along every boundary: {:?}",
        wide.side_curls
    );
    assert!(
        tall.curl.bottom > 0.2 && tall.curl.top > 0.2,
        "stockinette end edges must roll to the front: {:?}",
        tall.curl
    );
    let sides = wide.curl.left.abs().min(wide.curl.right.abs());
    assert!(
        garter.curl.max_abs() < 0.5 * sides,
        "garter {:?} vs stockinette {:?}",
        garter.curl,
        wide.curl
    );
}

/// Garter 6 × 9 (§3.1, §4.2: "in the garter pattern, adjacent rows of loops unwrap in
/// opposite directions"): its interior stays flat. Along every row boundary at least three
/// boundaries away from the cast-on and the bind-off (boundaries 3 to 6) both side curls
/// are below 0.25 rad, and the middle boundary's side curls (the `edge_curl` measure) are
/// below 0.15 rad.
#[test]
fn garter_interior_stays_flat() {
    let garter = settle(&Chart::garter(6, 9).unwrap(), 300);
    report("garter 6×9", &garter);
    let h = garter.side_curls.len() - 1;
    for (b, &(l, r)) in garter.side_curls.iter().enumerate().take(h - 2).skip(3) {
        assert!(
            l.abs().max(r.abs()) < 0.25,
            "garter 6×9 boundary {b}: side curls {l:+.3}/{r:+.3} rad"
        );
    }
    let c = garter.curl;
    assert!(c.left.abs() < 0.15 && c.right.abs() < 0.15, "{c:?}");
}

/// Garter's edges stay flat whether its rows are tied off (one yarn per row, the default
/// construction) or knitted with one continuous yarn that turns at the row ends
/// (`Construction::Flat`, as garter is really knitted): the middle boundary's side curls and
/// the end curls of an 8 × 5 garter are within 0.3 rad either way (measured: tied
/// +0.15/+0.15, continuous +0.07/+0.13, ends ≤ 0.04), and no row boundary of a continuous
/// 6 × 9 garter curls by more than 1 rad at its sides. Near the cast-on and the bind-off
/// the side curl does grow (8 × 5: +0.65 at the cast-on to −0.69 at the bind-off, a twist
/// rather than a roll). Under the paper's fixed quarter turn without contact the tied rows
/// rolled by more than 1 rad (the escape of collapsed wings, which the guard of
/// `forces::wrapping` has removed).
#[test]
fn garter_edges_stay_flat_with_a_continuous_yarn() {
    let chart = Chart::garter(8, 5).unwrap();
    let tied = settle(&chart, 300);
    let turning = settle_as(&chart, 300, Construction::Flat);
    report("garter 8×5, one yarn per row", &tied);
    report("garter 8×5, continuous yarn", &turning);
    for c in [tied.curl, turning.curl] {
        assert!(c.left.abs().max(c.right.abs()) < 0.3, "{c:?}");
        assert!(c.bottom.abs().max(c.top.abs()) < 0.3, "{c:?}");
    }
    let tall = settle_as(&Chart::garter(6, 9).unwrap(), 300, Construction::Flat);
    report("garter 6×9, continuous yarn", &tall);
    for (b, &(l, r)) in tall.side_curls.iter().enumerate() {
        assert!(
            l.abs().max(r.abs()) < 1.0,
            "boundary {b}: side curls {l:+.3}/{r:+.3} rad"
        );
    }
}

/// A 2 × 2 rib (8 stitches wide, 6 rows) under the paper's fixed quarter turn (without yarn
/// contact, as the paper) compresses in width: each pair of knit columns and each pair of
/// purl columns curl in opposite senses (§3.1, Fig. 5 right), so the swatch folds into
/// ridges and its side-to-side width drops below 0.95 of the laid-out width. The default
/// rest state does not fold it: with the bias of 0.1 rad the ribs turn by ±0.1 rad and the
/// width ratio is 1.31, the stockinette's (yarn contact opens the crowded Table 1 layout by
/// a third; the `knit-fidelity` figure reports both ribs).
#[test]
fn rib_compresses_in_width() {
    let chart = Chart::rib(8, 6, 2, 2).unwrap();
    let s = settle_with(
        &chart,
        300,
        Construction::FlatPerRow,
        WrappingRest::paper(),
        false,
    );
    report("rib 2×2, 8×6, paper's quarter turn", &s);
    assert!(s.width_ratio < 0.95, "width ratio {}", s.width_ratio);
}
