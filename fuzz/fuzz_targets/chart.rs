//! The stitch-chart reader ([`sim_persistent::chart::Chart::parse`]) on arbitrary text, and the
//! knit topology of every chart it accepts: an error or a value, never a panic or a hang.
#![no_main]

use libfuzzer_sys::fuzz_target;
use sim_persistent::chart::Chart;
use sim_persistent::topology::{Construction, Topology};

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        if let Ok(chart) = Chart::parse(text) {
            if chart.width() * chart.height() <= 400 {
                let _ = Topology::knit_with(&chart, Construction::default());
            }
        }
    }
});
