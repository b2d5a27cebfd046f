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
    let row: String = rib.row(1).iter().map(|s| s.name()).collect();
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
    let ChartError::UnexpectedToken {
        line,
        column,
        token,
        expected,
    } = &err
    else {
        panic!("{err:?}");
    };
    assert_eq!((*line, *column, token.as_str()), (2, 4, "X2"));
    assert!(
        expected.contains("K2TOG") && expected.contains("KFB"),
        "{expected}"
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
    // A name that only starts like a stitch: `K2TOGX` is K2TOG followed by garbage.
    assert!(matches!(
        Chart::parse("K4\nK2TOGX K2\n").unwrap_err(),
        ChartError::UnexpectedToken {
            line: 2,
            column: 1,
            ..
        }
    ));
}

#[test]
fn every_stitch_has_its_documented_counts_and_names() {
    let table = [
        ("K", 1, 1, 1.0),
        ("P", 1, 1, -1.0),
        ("YO", 0, 1, 0.0),
        ("SL", 1, 1, 0.0),
        ("K2TOG", 2, 1, 1.0),
        ("SSK", 2, 1, 1.0),
        ("K3TOG", 3, 1, 1.0),
        ("S2KP", 3, 1, 1.0),
        ("P2TOG", 2, 1, -1.0),
        ("SSP", 2, 1, -1.0),
        ("P3TOG", 3, 1, -1.0),
        ("S2PP", 3, 1, -1.0),
        ("M1L", 0, 1, 1.0),
        ("M1R", 0, 1, 1.0),
        ("M1LP", 0, 1, -1.0),
        ("M1RP", 0, 1, -1.0),
        ("KFB", 1, 2, 1.0),
        ("PFB", 1, 2, -1.0),
        ("SSSK", 3, 1, 1.0),
        ("SSSP", 3, 1, -1.0),
        ("SK2P", 3, 1, 1.0),
        ("SP2P", 3, 1, -1.0),
    ];
    assert_eq!(table.len(), Stitch::ALL.len());
    for (&s, (name, consumes, produces, sign)) in Stitch::ALL.iter().zip(table) {
        assert_eq!(s.name(), name);
        assert_eq!(
            (s.consumes(), s.produces(), s.sign()),
            (consumes, produces, sign),
            "{name}"
        );
        assert_eq!(s.flipped().flipped(), s);
        assert_eq!(s.flipped().sign(), -s.sign(), "{name}");
        let mut order = s.stack_order().to_vec();
        order.sort_unstable();
        assert_eq!(order, (0..consumes.max(1)).collect::<Vec<_>>(), "{name}");
    }
}

/// Knitters' other names read as the stitch with the same stack; names that start like
/// another (SSK / SSSK, M1 / M1L, S2KP / SK2P) are told apart by the longest match.
#[test]
fn aliases_and_similar_names() {
    let chart = Chart::parse("K12\nSKP CDD M1 K SSSK SK2P\n").unwrap();
    assert_eq!(
        chart.row(1),
        &[
            Stitch::Ssk,
            Stitch::S2kp,
            Stitch::M1l,
            Stitch::Knit,
            Stitch::Sssk,
            Stitch::Sk2p
        ]
    );
    assert_eq!(chart.to_text(), "K12\nSSK S2KP M1L K SSSK SK2P\n");
    assert_eq!(
        Chart::parse("K4\nK M12 K3\n").unwrap().row(1)[1..3],
        [Stitch::M1l; 2]
    );
    // SK2P stacks the slipped right loop on top of the left two knitted together.
    assert_eq!(Stitch::Sk2p.stack_order(), &[2, 0, 1]);
    assert_eq!(Stitch::S2kp.stack_order(), &[1, 2, 0]);
}

#[test]
fn shaped_and_lace_charts_parse_with_changing_widths() {
    let text = "K6\nK K2TOG YO K YO SSK\nK2 M1L K2 M1R K2\nKFB K6 PFB\n. . K3TOG S2KP S2PP K . .\n";
    let chart = Chart::parse(text).unwrap();
    assert_eq!(chart.height(), 5);
    let made: Vec<usize> = (0..5).map(|r| chart.loops_made(r)).collect();
    assert_eq!(made, vec![6, 6, 8, 10, 4]);
    assert_eq!(chart.row_width(4), 4); // the `.` placeholders are ignored
    assert!(!chart.is_rectangular());
    assert!(Chart::rib(4, 3, 1, 1).unwrap().is_rectangular());
    // Round trip through the text format, lower case and run-length encoded.
    assert_eq!(Chart::parse(&chart.to_text()).unwrap(), chart);
    assert_eq!(Chart::parse(&text.to_lowercase()).unwrap(), chart);
    assert_eq!(
        Chart::parse("K4\nK2TOG2\n").unwrap().row(1),
        &[Stitch::K2tog, Stitch::K2tog]
    );
}

#[test]
fn stitch_counts_that_do_not_match_name_line_and_column() {
    let cases: [(&str, usize, usize, &str); 7] = [
        // Too few loops worked: the column after the row's last token.
        ("K3\nK2\n", 2, 3, "works 2 of the 3 loops"),
        // A stitch that needs more loops than are left.
        ("K3\nK2TOG K2\n", 2, 7, "only 0 of the 3 loops"),
        ("K4\nK2 K3TOG\n", 2, 4, "`K3TOG` works 3 loop(s)"),
        // Increases through the bar need loops on both sides.
        ("K3\nM1L K3\n", 2, 1, "lifts the bar"),
        ("K3\nK3 M1R\n", 2, 4, "lifts the bar"),
        // The first row sits on the cast-on.
        ("K2 YO K\n", 1, 4, "first row"),
        // A row of placeholders only.
        ("K2\n. .\n", 2, 4, "no stitches"),
    ];
    for (text, line, column, what) in cases {
        let err = Chart::parse(text).unwrap_err();
        match &err {
            ChartError::StitchCount {
                line: l,
                column: c,
                message,
            } => {
                assert_eq!((*l, *c), (line, column), "{text:?}: {err}");
                assert!(message.contains(what), "{text:?}: {message}");
            }
            other => panic!("{text:?}: {other:?}"),
        }
        assert!(
            err.to_string()
                .starts_with(&format!("line {line}, column {column}:"))
        );
    }
    // Charts built in code are checked too, naming row and stitch.
    let err = Chart::from_rows(vec![vec![Stitch::Knit; 3], vec![Stitch::K2tog]]).unwrap_err();
    assert!(err.to_string().contains("row 1"), "{err}");
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
    assert!(matches!(
        Chart::parse("# rows\nK3\n\n  P2\n").unwrap_err(),
        ChartError::StitchCount {
            line: 4,
            column: 5,
            ..
        }
    ));
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

/// The lace builder: 6 rows per repeat and a closing knit row, every row keeping 9 loops per
/// repeat across (yarn-overs balance the decreases), and zero repeats are an error.
#[test]
fn lace_repeats_keep_their_loop_count() {
    let chart = Chart::lace(2, 3).unwrap();
    assert_eq!(chart.height(), 19);
    for r in 0..chart.height() {
        assert_eq!(chart.loops_made(r), 18, "row {r}");
    }
    assert!(!chart.is_rectangular());
    assert!(Chart::lace(0, 1).is_err() && Chart::lace(1, 0).is_err());
}
