//! The TOML readers of `sim-periodic` on arbitrary text: the run config
//! ([`sim_periodic::config::Config`]), the fit config ([`sim_periodic::config::FitConfig`])
//! and the campaign file ([`sim_periodic::campaign::Campaign`]), each parsed and then
//! validated the way the command line does it (model, solver and fit settings): a value or an
//! error naming the file, never a panic or a hang.
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let path = Path::new("fuzz.toml");
    if let Ok(config) = sim_periodic::config::Config::parse(text, path) {
        let _ = config.model(1e-3, path);
        let _ = config.equilibrium();
    }
    if let Ok(config) = sim_periodic::config::FitConfig::parse(text, path) {
        let _ = config.model(1e-3, path);
        let _ = config.settings(path);
    }
    if let Ok(campaign) = sim_periodic::campaign::Campaign::parse(text, path) {
        let _ = campaign.tasks();
    }
});
