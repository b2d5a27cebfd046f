//! Knit and weave topologies and their initial layout: counts from seed 000 §3.2, the
//! cross-references between yarns and nodes, the pinning rules of stable edges, and a layout
//! that starts at zero stretch, below the bending-jamming angle, with knit/purl z signs.

use sim_persistent::chart::{Chart, Stitch};
use sim_persistent::forces::{ForceSet, Potential, TermKind, build_terms};
use sim_persistent::layout::{Layout, LayoutParams};
use sim_persistent::params::YarnParams;
use sim_persistent::state::{DofMap, State};
use sim_persistent::topology::{Side, Topology, TopologyError, knit_node};
use sim_persistent::weave::WeavePattern;

#[test]
fn knit_counts_follow_section_3_2_2() {
    let (w, h) = (6, 5);
    let topo = Topology::knit(&Chart::rib(w, h, 2, 2).unwrap());
    topo.validate().unwrap();
    // Two contact nodes per stitch contact, two contacts per leg pair, boundaries 0..=h.
    assert_eq!(topo.nodes.len(), 4 * w * (h + 1));
    assert_eq!(topo.yarns.len(), h);
    assert!(topo.yarns.iter().all(|y| y.passes.len() == 8 * w));
    // Interior stitch contacts: 2 per loop and row boundary, each with 2 two-yarn nodes.
    assert_eq!(topo.stitch_contacts.len(), 2 * w * (h - 1));
    let two_yarn = topo.nodes.iter().filter(|n| n.passes.len() == 2).count();
    assert_eq!(two_yarn, 4 * w * (h - 1));
    assert!(topo.nodes.iter().all(|n| (1..=2).contains(&n.passes.len())));
    // ≈ 4 nodes and ≈ 20 DoFs per loop away from the edges (exactly 20 per interior loop).
    let interior_dofs = two_yarn * 5;
    assert_eq!(interior_dofs, 20 * w * (h - 1));
    // Stitch kinds come from the chart.
    for sc in &topo.stitch_contacts {
        let expected = if sc.column % 4 < 2 {
            Stitch::Knit
        } else {
            Stitch::Purl
        };
        assert_eq!(sc.sign, expected.sign());
        assert_eq!(sc.upper.yarn, sc.row);
        assert_eq!(sc.lower.len(), 1);
        assert_eq!(sc.lower[0].yarn, sc.row - 1);
        assert!(sc.upper.forward && sc.lower[0].forward);
    }
}

#[test]
fn stable_edges_pin_sliding_of_single_yarn_nodes_and_yarn_ends() {
    let (w, h) = (3, 3);
    let topo = Topology::knit(&Chart::garter(w, h).unwrap());
    for (n, node) in topo.nodes.iter().enumerate() {
        for p in &node.passes {
            let end = p.index == 0 || p.index + 1 == topo.yarns[p.yarn].passes.len();
            assert_eq!(p.sliding_pinned, node.passes.len() == 1 || end, "node {n}");
        }
    }
    // Cast-on (boundary 0) and bind-off (boundary h) nodes carry one yarn.
    for c in 0..w {
        for side in [Side::Left, Side::Right] {
            for hi in [false, true] {
                assert_eq!(topo.nodes[knit_node(w, 0, c, side, hi)].passes.len(), 1);
                assert_eq!(topo.nodes[knit_node(w, h, c, side, hi)].passes.len(), 1);
                assert_eq!(topo.nodes[knit_node(w, 1, c, side, hi)].passes.len(), 2);
            }
        }
    }
}

#[test]
fn weaves_share_one_crossing_node_per_warp_and_weft() {
    let topo = Topology::weave(WeavePattern::Plain, 4, 3).unwrap();
    topo.validate().unwrap();
    assert_eq!(topo.nodes.len(), 12);
    assert_eq!(topo.yarns.len(), 7);
    assert!(topo.nodes.iter().all(|n| n.passes.len() == 2));
    assert_eq!(topo.n_dofs(), 12 * 5);
    // Plain: no floats, alternating in both directions.
    for c in &topo.crossings {
        assert_eq!(c.warp_over, (c.warp + c.weft) % 2 == 0);
    }
    // 2/1 twill: each weft row has the warp on top at 2 of every 3 crossings, shifted by one
    // per row.
    let twill = Topology::weave(WeavePattern::Twill { over: 2, under: 1 }, 6, 3).unwrap();
    let over = |j: usize| -> Vec<bool> {
        twill
            .crossings
            .iter()
            .filter(|c| c.weft == j)
            .map(|c| c.warp_over)
            .collect()
    };
    assert_eq!(over(0), vec![true, true, false, true, true, false]);
    assert_eq!(over(1), vec![true, false, true, true, false, true]);
    // 5-harness satin: exactly one warp float per weft and per warp in each repeat, and no
    // two warp-up crossings side by side.
    let satin = WeavePattern::Satin {
        harness: 5,
        step: 2,
    };
    let topo = Topology::weave(satin, 5, 5).unwrap();
    for j in 0..5 {
        assert_eq!(
            topo.crossings
                .iter()
                .filter(|c| c.weft == j && c.warp_over)
                .count(),
            1
        );
        assert_eq!(
            topo.crossings
                .iter()
                .filter(|c| c.warp == j && c.warp_over)
                .count(),
            1
        );
    }
    for c in topo.crossings.iter().filter(|c| c.warp_over) {
        assert!(!satin.warp_over(c.warp + 1, c.weft) && !satin.warp_over(c.warp, c.weft + 1));
    }
    // Invalid parameters are errors, not panics.
    assert!(matches!(
        Topology::weave(
            WeavePattern::Satin {
                harness: 6,
                step: 2
            },
            6,
            6
        ),
        Err(TopologyError::Invalid(_))
    ));
    assert!(Topology::weave(WeavePattern::Twill { over: 0, under: 1 }, 3, 3).is_err());
    assert!(Topology::weave(WeavePattern::Plain, 1, 3).is_err());
}

#[test]
fn layout_starts_unstretched_below_jamming_with_knit_purl_signs() {
    let params = YarnParams::sweater();
    let lp = LayoutParams::new(3e-3, params.radius);
    let chart = Chart::garter(4, 4).unwrap();
    let topo = Topology::knit(&chart);
    let layout = Layout::new(&topo, &lp).unwrap();
    let dofs = DofMap::new(&topo);
    let state = State::from_layout(&topo, &dofs, &layout);
    let pot = build_terms(&topo, &dofs, &params, &ForceSet::default(), &state.q);
    for (kind, e) in pot.energy_by_kind(&state.q) {
        match kind {
            TermKind::Stretch | TermKind::StitchLength | TermKind::Friction => {
                assert!(e.abs() < 1e-20, "{kind:?} energy {e:e} at the layout");
            }
            TermKind::Bending => assert!(e > 0.0, "loops are bent"),
            _ => {}
        }
    }
    // Every turn is below the π/2 jamming onset (the default layout keeps it under 70°).
    let mut max_angle: f64 = 0.0;
    for (y, i) in topo.bends() {
        let p = &topo.yarns[y].passes;
        let x = |k: usize| layout.positions[p[k].node];
        max_angle = max_angle.max(rod::geometry::turning_angle(
            &(x(i) - x(i - 1)),
            &(x(i + 1) - x(i)),
        ));
    }
    assert!(
        max_angle.to_degrees() < 70.0,
        "max turn {}°",
        max_angle.to_degrees()
    );
    // Knit row 2 (boundary 2): lo node behind, hi node in front; purl row 1: the opposite.
    let z = |b, hi| layout.positions[knit_node(4, b, 1, Side::Left, hi)].z;
    assert!(z(2, false) < 0.0 && z(2, true) > 0.0);
    assert!(z(1, false) > 0.0 && z(1, true) < 0.0);
    assert!(
        z(4, false) == 0.0 && z(4, true) == 0.0,
        "bind-off nodes lie in the plane"
    );
    // Sliding coordinates increase along every yarn.
    for yarn in &topo.yarns {
        let u: Vec<f64> = yarn
            .passes
            .iter()
            .map(|p| layout.sliding[p.node][p.slot])
            .collect();
        assert!(u.windows(2).all(|w| w[1] > w[0]));
    }
    // A contact that does not fit in the loop is rejected.
    let mut bad = lp;
    bad.contact_length = 3e-3;
    assert!(Layout::new(&topo, &bad).is_err());
}

/// Only the terms a scene needs are built: no gravity terms without gravity, no friction
/// springs when friction is off, no wrapping when it is off, no stitch-length or wrapping
/// terms for a weave (no stitch contacts).
#[test]
fn only_needed_terms_are_built() {
    let count = |terms: &Potential, kind: TermKind| terms.count(kind);
    let chart = Chart::garter(3, 3).unwrap();
    let topo = Topology::knit(&chart);
    let dofs = DofMap::new(&topo);
    let layout = Layout::new(&topo, &LayoutParams::new(3e-3, 0.75e-3)).unwrap();
    let q = State::from_layout(&topo, &dofs, &layout).q;
    let mut params = YarnParams::sweater();
    let all = build_terms(&topo, &dofs, &params, &ForceSet::default(), &q);
    let n_segments = topo.segments().count();
    assert_eq!(count(&all, TermKind::Gravity), n_segments);
    assert_eq!(count(&all, TermKind::Stretch), n_segments);
    assert_eq!(count(&all, TermKind::Bending), topo.bends().count());
    assert_eq!(
        count(&all, TermKind::StitchLength),
        2 * topo.stitch_contacts.len()
    );
    let free_sliding = topo
        .nodes
        .iter()
        .filter(|n| n.passes.len() >= 2)
        .flat_map(|n| n.passes.iter())
        .filter(|p| !p.sliding_pinned)
        .count();
    assert_eq!(count(&all, TermKind::Friction), free_sliding);
    // Stitch wrapping: two pairs per stitch contact, less one pair at each contact where a
    // row's yarn starts or ends (column 0 left legs, last column right legs).
    let edge_contacts = 2 * (chart.height() - 1);
    assert_eq!(
        count(&all, TermKind::Wrapping),
        2 * topo.stitch_contacts.len() - edge_contacts
    );
    let unwrapped = ForceSet {
        wrapping: false,
        ..ForceSet::default()
    };
    let no_wrap = build_terms(&topo, &dofs, &params, &unwrapped, &q);
    assert_eq!(count(&no_wrap, TermKind::Wrapping), 0);
    assert_eq!(no_wrap.len(), all.len() - count(&all, TermKind::Wrapping));
    params.gravity *= 0.0;
    let forces = ForceSet {
        friction: false,
        ..ForceSet::default()
    };
    let fewer = build_terms(&topo, &dofs, &params, &forces, &q);
    assert_eq!(count(&fewer, TermKind::Gravity), 0);
    assert_eq!(count(&fewer, TermKind::Friction), 0);
    assert_eq!(fewer.len(), all.len() - n_segments - free_sliding);
    let weave = Topology::weave(WeavePattern::Twill { over: 2, under: 2 }, 4, 4).unwrap();
    let wd = DofMap::new(&weave);
    let wl = Layout::new(&weave, &LayoutParams::new(3e-3, 0.75e-3)).unwrap();
    let wq = State::from_layout(&weave, &wd, &wl).q;
    let terms = build_terms(
        &weave,
        &wd,
        &YarnParams::sweater(),
        &ForceSet::default(),
        &wq,
    );
    assert_eq!(count(&terms, TermKind::StitchLength), 0);
    // Never wrapping for a weave, even with the term switched on.
    assert_eq!(count(&terms, TermKind::Wrapping), 0);
}

/// The clamp node sets: a row boundary has 4 nodes per column, a column 4 per boundary, all
/// distinct, and the boundaries `0..=h` together hold every node exactly once.
#[test]
fn boundary_and_column_node_sets() {
    use sim_persistent::topology::{knit_boundary_nodes, knit_column_nodes};
    let (w, h) = (4, 3);
    let topo = Topology::knit(&Chart::stockinette(w, h).unwrap());
    assert_eq!(knit_column_nodes(w, h, 0).len(), 4 * (h + 1));
    let mut all: Vec<usize> = (0..=h).flat_map(|b| knit_boundary_nodes(w, b)).collect();
    assert!((0..=h).all(|b| knit_boundary_nodes(w, b).len() == 4 * w));
    all.sort_unstable();
    all.dedup();
    assert_eq!(all, (0..topo.nodes.len()).collect::<Vec<_>>());
    let mut column = knit_column_nodes(w, h, w - 1);
    column.sort_unstable();
    column.dedup();
    assert_eq!(column.len(), 4 * (h + 1));
}
