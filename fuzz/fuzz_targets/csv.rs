//! The CSV readers on arbitrary text: shell-fem's measurement files (per direction and
//! stitch by stitch, bending targets), the fit's target curves ([`sim_periodic::fit::Targets`]) and the
//! figures' data tables ([`yarn_output::table::Table`]): data or an error naming the file and
//! line, never a panic or a hang.
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let _ = shell_fem::measurements::parse_direction_csv(text, "fuzz.csv");
    let _ = shell_fem::measurements::parse_stitch_csv(
        text,
        "fuzz.csv",
        yarn_pattern::direction::Direction::Weft,
        &shell_fem::measurements::BinOptions::default(),
    );
    let _ = shell_fem::bending_fit::parse_bending_csv(text, "fuzz.csv");
    let _ = sim_periodic::fit::Targets::parse(text, Path::new("fuzz.csv"));
    let _ = yarn_output::table::Table::parse_csv(text, "fuzz.csv");
});
