//! Garments knitted in the round and dressed on body meshes (`experiment::garment`): the hat
//! and sweater charts, the closed, outward-wound surfaces of revolution (edge manifoldness,
//! enclosed volume against the ellipsoid's), placement with clearance, a small hat dressed on
//! a head that stays on it without passing through, and the errors for garments that cannot
//! be dressed.

use rod::geometry::V3;
use sim_persistent::chart::Chart;
use sim_persistent::experiment::garment::{
    CLEARANCE, Dressing, Profile, hat_chart, head, head_for_hat, mannequin, revolved, sweater_chart,
};
use sim_persistent::experiment::positions;
use sim_persistent::forces::obstacle::mesh::TriangleMesh;
use sim_persistent::integrator::StepSettings;
use std::collections::HashMap;

/// The hat narrows from `sectors × width` loops to `sectors` with every round knitting what
/// the round below made; the sweater's yoke ends at `sectors × neck`; bad sizes are errors.
#[test]
fn hat_and_sweater_charts() {
    let hat = hat_chart(8, 8, 6, 12).unwrap();
    let made: Vec<usize> = (0..hat.height()).map(|r| hat.loops_made(r)).collect();
    assert_eq!(made[0], 64);
    assert_eq!(*made.last().unwrap(), 8);
    assert!(made.windows(2).all(|w| w[1] <= w[0]));
    assert_eq!(made.iter().filter(|&&m| m == 64).count(), 1 + 6 + 12);
    let sweater = sweater_chart(8, 10, 2, 5, 6).unwrap();
    let made: Vec<usize> = (0..sweater.height())
        .map(|r| sweater.loops_made(r))
        .collect();
    assert_eq!((made[0], *made.last().unwrap()), (80, 48));
    // The yoke decreases every round: 10 → 6 loops per sector in 4 rounds.
    assert_eq!(sweater.height(), 1 + 2 + 5 + 4);
    for bad in [
        hat_chart(2, 8, 1, 1),
        hat_chart(8, 1, 1, 1),
        hat_chart(3, 5, 1, 1),
    ] {
        assert!(bad.is_err());
    }
    assert!(sweater_chart(8, 6, 1, 1, 6).is_err());
}

/// Every edge of the revolved head and mannequin is shared by exactly two triangles with
/// opposite directions (closed, consistently wound), the enclosed volume is positive
/// (outward winding) and a revolved ellipsoid's volume is within 1 % of 4/3 π a b c.
#[test]
fn revolved_bodies_are_closed_and_wound_outwards() {
    let volume = |m: &TriangleMesh| {
        m.triangles()
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| m.vertices()[i as usize]);
                a.dot(&b.cross(&c)) / 6.0
            })
            .sum::<f64>()
    };
    for (name, profile) in [
        ("head", head(0.02, 0.024, 0.022)),
        ("mannequin", mannequin(0.75)),
        ("ellipsoid", Profile::ellipsoid(0.02, 0.03, 0.025, 48)),
    ] {
        // A reach beyond the bodies' sizes: every query below finds the surface.
        let mesh = revolved(&profile, 96, 1.0).unwrap();
        let mut edges: HashMap<(u32, u32), i32> = HashMap::new();
        for t in mesh.triangles() {
            for k in 0..3 {
                let (i, j) = (t[k], t[(k + 1) % 3]);
                assert_ne!(i, j, "{name}: degenerate triangle");
                *edges.entry((i, j)).or_default() += 1;
            }
        }
        for (&(i, j), &n) in &edges {
            assert_eq!(n, 1, "{name}: edge {i}→{j} used {n} times the same way");
            assert_eq!(
                edges.get(&(j, i)),
                Some(&1),
                "{name}: edge {i}–{j} is a border"
            );
        }
        let v = volume(&mesh);
        assert!(v > 0.0, "{name}: volume {v}");
        if name == "ellipsoid" {
            let exact = 4.0 / 3.0 * std::f64::consts::PI * 0.02 * 0.03 * 0.025;
            assert!((v / exact - 1.0).abs() < 0.01, "{v} vs {exact}");
        }
        // A point on the axis at mid-height is inside, one beside the body outside.
        let (y0, y1) = (profile.rings[0].0, profile.rings[profile.rings.len() - 1].0);
        let mid = 0.5 * (y0 + y1);
        let (d, _, _) = mesh.signed_distance(&V3::new(0.0, mid, 0.0)).unwrap();
        assert!(d < 0.0, "{name}: axis point at {d} m");
        let (d, _, _) = mesh.signed_distance(&V3::new(0.0, mid, y1 - y0)).unwrap();
        assert!(d > 0.0, "{name}: outside point at {d} m");
    }
    assert!(
        revolved(
            &Profile {
                rings: vec![(0.0, 1.0, 1.0)]
            },
            8,
            1e-3
        )
        .is_err()
    );
}

fn settings() -> StepSettings {
    StepSettings {
        rayleigh_alpha: 10.0,
        rayleigh_beta: 0.01,
        ..StepSettings::default()
    }
}

/// A small hat (16 loops around) is laid out around a head with every node at least the
/// clearance away, then dressed for 80 ms: no yarn point goes more than 5 % R into the head,
/// the hat's crown stays above the head's top (it rests on it rather than passing through),
/// and the head stays inside the hat's brim (the brim is lower than the head's top).
#[test]
fn a_small_hat_dressed_on_a_head_stays_on_it() {
    let chart = hat_chart(4, 4, 1, 2).unwrap();
    let profile = head_for_hat(16);
    let mut d = Dressing::new(&chart, &profile, 48, settings()).unwrap();
    let r = d.params.radius;
    let start = d.lowest_gap();
    assert!(
        start >= CLEARANCE * 0.999,
        "laid out {start} m from the head"
    );
    let head_top = d.body_offset + profile.rings[profile.rings.len() - 1].0;
    let mut lowest = f64::INFINITY;
    for _ in 0..8 {
        d.run(10).unwrap();
        lowest = lowest.min(d.lowest_gap());
    }
    let p = positions(&d.sim);
    let top = p.iter().map(|x| x.y).fold(f64::NEG_INFINITY, f64::max);
    let bottom = p.iter().map(|x| x.y).fold(f64::INFINITY, f64::min);
    eprintln!(
        "small hat: lowest gap {:.4} R, top {:.2} mm over the head's top, bottom {:.2} mm below it",
        lowest / r,
        1e3 * (top - head_top),
        1e3 * (head_top - bottom)
    );
    assert!(lowest > -0.05 * r, "went {} R into the head", -lowest / r);
    assert!(top > head_top, "the hat fell through the head");
    assert!(bottom < head_top - 0.5 * (head_top - d.body_offset) / 3.0);
}

/// A plain tube has nothing to rest on and a tube narrower than the head cannot be put on:
/// both are errors that say so.
#[test]
fn garments_that_cannot_be_dressed_are_errors() {
    let tube = Chart::parse(&["K24"; 6].join("\n")).unwrap();
    let profile = head(0.008, 0.009, 0.0085);
    let err = Dressing::new(&tube, &profile, 32, settings())
        .err()
        .unwrap()
        .to_string();
    assert!(err.contains("passes through"), "{err}");
    let narrow = hat_chart(4, 4, 1, 2).unwrap();
    let big = head(0.02, 0.02, 0.02);
    let err = Dressing::new(&narrow, &big, 32, settings())
        .err()
        .unwrap()
        .to_string();
    assert!(err.contains("too narrow"), "{err}");
}
