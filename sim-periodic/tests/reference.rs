//! Our table of MADYPG's published stockinette against the published one, and the per-term
//! forces of our model on the file geometry.

use sim_periodic::database::{DatabaseSettings, relax_reference};
use sim_periodic::periodic::{EquilibriumSettings, YarnModel};
use sim_periodic::reference::{compare_with_published, rest_state_forces};
use yarn_pattern::madypg::Database;
use yarn_pattern::pyp::read_pyp;

const PUBLISHED: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../tests/data/madypg/model_stock_5"
);
/// The table's tile (MADYPG's `pyp`, byte-identical).
const TILE: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../tests/data/patterns/stockinette.pyp"
);

#[test]
fn term_forces_cancel_at_our_equilibrium_but_not_on_the_file_geometry() {
    let tile = read_pyp(TILE).unwrap().tile;
    let model = YarnModel::default_for_radius(tile.radius);
    let file = rest_state_forces(&tile, &model, 1.5).unwrap();
    let largest = [file.stretch, file.bending, file.twist, file.contact]
        .map(|f| f.position)
        .into_iter()
        .fold(0.0, f64::max);
    // On the file geometry our model's forces do not cancel...
    assert!(file.total.position > 0.1 * largest, "{file:?}");
    // ...on our own zero-strain equilibrium they do, while each term stays large.
    let (relaxed, _) = relax_reference(&tile, &model, &EquilibriumSettings::default()).unwrap();
    let ours = rest_state_forces(&relaxed, &model, 1.5).unwrap();
    let largest = [ours.stretch, ours.bending, ours.twist, ours.contact]
        .map(|f| f.position)
        .into_iter()
        .fold(0.0, f64::max);
    assert!(ours.total.position < 1e-6 * largest, "{ours:?}");
}

#[test]
fn our_table_on_published_axes_is_relative_to_the_file_geometry() {
    let tile = read_pyp(TILE).unwrap().tile;
    let full = Database::read(PUBLISHED).unwrap();
    // The zero-strain sample and one weft stretch of the published 5³ table.
    let (isx, isa, isy) = ([1usize, 2], 2usize, 1usize);
    let mut published = Database {
        axes: [isx.map(|i| full.axes[0][i]).to_vec(), vec![0.0], vec![0.0]],
        n_vertices: full.n_vertices,
        data: Vec::new(),
    };
    for v in 0..full.n_vertices {
        for i in isx {
            published.data.push(full.get(v, i, isa, isy).unwrap());
        }
    }
    assert_eq!(published.axes[0], [0.0, 0.33]);
    let model = YarnModel::default_for_radius(tile.radius);
    let c =
        compare_with_published(&tile, &published, &model, &DatabaseSettings::default()).unwrap();
    assert_eq!(c.unsolved, 0);
    // At zero strain our table is our relaxation's shift from the file geometry (the shift
    // has no mean: the relaxation keeps the mean fluctuation at zero).
    let zero = &c.agreement.samples[0];
    assert!(c.relaxation_shift > 0.01 * tile.radius);
    assert!(
        (zero.rms_ours - c.relaxation_shift).abs() < 1e-3 * c.relaxation_shift,
        "{zero:?} vs shift {}",
        c.relaxation_shift
    );
    let stretched = &c.agreement.samples[1];
    assert!(stretched.rms_reference > 0.1 * tile.radius, "{stretched:?}");
    // Under weft stretch the two fields point the same way overall.
    assert!(stretched.correlation > 0.0, "{stretched:?}");
}
