//! probe
use rod::stretch::StretchLaw;
use sim_periodic::patterns::{Pattern, RelaxSettings, relax};
use sim_periodic::periodic::YarnModel;
fn main() {
    let p = Pattern::from_name(&std::env::var("PAT").unwrap_or("stockinette".into())).unwrap();
    let mut m = YarnModel::default_for_radius(1e-3);
    m.stretch = StretchLaw::TwoPhase {
        k1: 24.76,
        k2: 200.0,
        onset: 0.0211,
    };
    m.bending = 1.01e-7;
    m.twist = 8.1e-8;
    m.contact[0].stiffness = 141.2;
    m.contact[0].radius = 1.18e-3;
    m.contact[1].radius = 0.2456e-3;
    let g = p.generate(&p.default_params(1e-3)).unwrap();
    println!("period {:?}", g.period);
    for rounds in [0, 1, 2, 4, 8, 16] {
        let t = std::time::Instant::now();
        match relax(
            &g,
            &m,
            &RelaxSettings {
                rounds,
                ..Default::default()
            },
        ) {
            Ok((tile, r)) => println!(
                "rounds {rounds}: stress {:.3} {:.3} {:.3} N/m, Ψ {:.3}, max rest change {:.3}, {:.2} s",
                r.stress[(0, 0)],
                r.stress[(1, 1)],
                r.stress[(0, 1)],
                r.density,
                tile.rest_lengths
                    .iter()
                    .zip(&g.rest_lengths)
                    .map(|(a, b)| (a / b - 1.0).abs())
                    .fold(0.0, f64::max),
                t.elapsed().as_secs_f64()
            ),
            Err(e) => println!("rounds {rounds}: {e}"),
        }
    }
}
