//! Yarn pull-out (seed 000 §5.2.4, Fig. 13): contact breaking at a yarn end without a restart.

use sim_persistent::chart::Chart;
use sim_persistent::experiment::PullOut;
use sim_persistent::topology::Topology;

/// Breaking passes: only yarn ends, only where another yarn stays; stitch contacts lose the
/// strand, a node left alone pins its remaining yarn, a free end stays free.
#[test]
fn passes_leave_their_nodes_at_yarn_ends_only() {
    let topo = Topology::knit(&Chart::garter(3, 3).unwrap());
    let y = 1;
    let n = topo.yarns[y].passes.len();
    let first = topo.yarns[y].passes[0];
    assert_eq!(topo.nodes[first.node].passes.len(), 2);
    let (after, slots) = topo.without_passes(&[(y, 0)]).unwrap();
    after.validate().unwrap();
    assert_eq!(after.yarns[y].passes.len(), n - 1);
    assert_eq!(after.nodes[first.node].passes.len(), 1);
    assert!(after.nodes[first.node].passes[0].sliding_pinned);
    assert_eq!(slots[first.node][first.slot], None);
    // The contact whose upper leg started at that node is gone, the others remain.
    assert_eq!(after.stitch_contacts.len(), topo.stitch_contacts.len() - 1);
    // Interior passes, one-yarn nodes and unknown yarns are refused with the reason.
    let e = topo.without_passes(&[(y, 3)]).unwrap_err().to_string();
    assert!(e.contains("not an end"), "{e}");
    let e = topo.without_passes(&[(0, 0)]).unwrap_err().to_string();
    assert!(e.contains("no other yarn"), "{e}");
    assert!(topo.without_passes(&[(9, 0)]).is_err());
}

/// A 5 × 5 garter: its middle row pulled 6 mm at 5 cm/s. The free end slides through its
/// contacts and they break one after another (two passes each) while the simulation runs on;
/// the pull force is finite and positive at its peak, and every contact the end leaves
/// removes one stitch contact.
#[test]
fn a_pulled_row_unravels() {
    let mut test = PullOut::garter(5, 5, 0.006).unwrap();
    test.snapshots = vec![0.0, 0.006];
    let run = test.run().unwrap();
    println!(
        "broken {} + {} while settling, failure {:?}, last {:?}, {} Newton iterations",
        run.broken,
        run.broken_settling,
        run.failure,
        run.samples.last(),
        run.newton_iterations
    );
    assert!(run.failure.is_none(), "{:?}", run.failure);
    let first = run.samples[0];
    let last = *run.samples.last().unwrap();
    let yarn_passes = 5 * 8;
    // The first sample comes after the breaks while settling; the pull itself breaks more.
    assert_eq!(yarn_passes - first.passes, run.broken_settling);
    assert_eq!(first.passes - last.passes, run.broken);
    assert!(
        run.broken >= 4,
        "{} passes broke during the pull",
        run.broken
    );
    assert_eq!(run.broken % 2, 0);
    assert_eq!(first.contacts - last.contacts, run.broken / 2);
    let peak = run.samples.iter().map(|s| s.force).fold(0.0, f64::max);
    assert!(peak > 0.0 && peak.is_finite(), "peak {peak}");
    assert!(run.samples.iter().all(|s| s.force.is_finite()));
    // Passes only ever leave.
    assert!(run.samples.windows(2).all(|w| w[1].passes <= w[0].passes));
    assert_eq!(run.snapshots.len(), 2);
}
