//! The stitch-chart format: builders, round trip through text, and parse errors that name the
//! line and column of the offending token.

use sim_persistent::chart::{Chart, ChartError, Stitch};

#[test]
fn builders_have_the_documented_patterns() {
    let g = Chart::garter(5, 4).unwrap();
    assert_eq!((g.width(), g.height()), (5, 4));
    assert!(g.row(0).iter().all(|&s| s == Stitch::Knit));
    assert!(g.row(1).iter().all(|&s| s == Stitch::Purl));
    assert!(g.row(2).iter().all(|&s| s == Stitch::Knit));

    let s = Chart::stockinette(3, 2).unwrap();
    assert!((0..2).all(|r| s.row(r).iter().all(|&x| x == Stitch::Knit)));

    let rib = Chart::rib(7, 2, 2, 1).unwrap();
    let row: String = rib.row(1).iter().map(|s| s.letter()).collect();
    assert_eq!(row, "KKPKKPK");

    let seed = Chart::seed(3, 2).unwrap();
    assert_eq!(seed.to_text(), "K P K\nP K P\n");

    assert!(matches!(
        Chart::rib(4, 4, 0, 2),
        Err(ChartError::InvalidSize(_))
    ));
    assert!(matches!(
        Chart::garter(0, 4),
        Err(ChartError::InvalidSize(_))
    ));
}

#[test]
fn text_round_trip_and_run_length() {
    for chart in [
        Chart::garter(6, 3).unwrap(),
        Chart::rib(10, 4, 2, 2).unwrap(),
        Chart::rib(9, 2, 3, 1).unwrap(),
        Chart::seed(5, 5).unwrap(),
    ] {
        let text = chart.to_text();
        assert_eq!(Chart::parse(&text).unwrap(), chart, "{text}");
    }
    assert_eq!(Chart::rib(6, 1, 2, 2).unwrap().to_text(), "K2 P2 K2\n");
    let parsed: Chart = "# a comment\n\n k2,p2 # trailing\nK P K P\n"
        .parse()
        .unwrap();
    assert_eq!(
        parsed,
        Chart::from_rows(vec![
            vec![Stitch::Knit, Stitch::Knit, Stitch::Purl, Stitch::Purl],
            vec![Stitch::Knit, Stitch::Purl, Stitch::Knit, Stitch::Purl],
        ])
        .unwrap()
    );
}

#[test]
fn unknown_token_names_line_and_column() {
    let err = Chart::parse("K4\nK2 X2\n").unwrap_err();
    assert_eq!(
        err,
        ChartError::UnexpectedToken {
            line: 2,
            column: 4,
            token: "X2".into(),
            expected: "a stitch `K` or `P` with an optional repeat count (e.g. `K3`)",
        }
    );
    let msg = err.to_string();
    assert!(
        msg.contains("line 2, column 4") && msg.contains("expected"),
        "{msg}"
    );
    // Garbage after the count is also a token error, at the token's column.
    assert!(matches!(
        Chart::parse("  K3x").unwrap_err(),
        ChartError::UnexpectedToken {
            line: 1,
            column: 3,
            ..
        }
    ));
}

#[test]
fn reserved_stitches_are_rejected_as_unsupported() {
    for (text, token, column) in [
        ("K2 YO K\n", "YO", 4),
        ("K3\nK k2tog\n", "k2tog", 3),
        ("P SSK P\n", "SSK", 3),
        ("M1 K2\n", "M1", 1),
    ] {
        let err = Chart::parse(text).unwrap_err();
        let line = text.lines().count();
        assert_eq!(
            err,
            ChartError::Unsupported {
                line,
                column,
                token: token.into()
            },
            "{text:?}"
        );
        assert!(err.to_string().contains("not supported yet"));
    }
}

#[test]
fn counts_rows_and_empty_charts_are_checked() {
    assert_eq!(
        Chart::parse("K0\n").unwrap_err(),
        ChartError::BadCount {
            line: 1,
            column: 2,
            count: "0".into(),
            max: sim_persistent::chart::MAX_RUN
        }
    );
    assert!(matches!(
        Chart::parse("K99999999999999999999999\n").unwrap_err(),
        ChartError::BadCount {
            line: 1,
            column: 2,
            ..
        }
    ));
    assert_eq!(
        Chart::parse("# rows\nK3\n\n  P2\n").unwrap_err(),
        ChartError::RaggedRow {
            line: 4,
            column: 3,
            found: 2,
            expected: 3,
            first_line: 2
        }
    );
    assert_eq!(
        Chart::parse("# nothing\n\n").unwrap_err(),
        ChartError::Empty { line: 3 }
    );
    assert_eq!(Chart::parse("").unwrap_err(), ChartError::Empty { line: 1 });
}

mod round_trip {
    use proptest::prelude::*;
    use proptest::test_runner::{Config, RngSeed};
    use sim_persistent::chart::{Chart, Stitch};

    fn config() -> Config {
        Config {
            cases: 128,
            rng_seed: RngSeed::Fixed(0x000c_1212),
            failure_persistence: None,
            ..Config::default()
        }
    }

    proptest! {
        #![proptest_config(config())]

        /// Any chart survives `to_text` → `parse`, also with lower-case letters and extra
        /// separators and comments.
        #[test]
        fn any_chart_round_trips(width in 1usize..12, height in 1usize..8, seed in any::<u64>()) {
            let chart = Chart::from_fn(width, height, |r, c| {
                if (seed >> ((r * width + c) % 64)) & 1 == 1 { Stitch::Knit } else { Stitch::Purl }
            }).unwrap();
            let text = chart.to_text();
            prop_assert_eq!(Chart::parse(&text).unwrap(), chart.clone());
            let noisy: String = text
                .lines()
                .map(|l| format!("  {} ,\t# row\n", l.to_lowercase().replace(' ', " , ")))
                .collect();
            prop_assert_eq!(Chart::parse(&noisy).unwrap(), chart);
        }
    }
}
