//! The scene reader ([`sim_persistent::scene::Scene::parse`]) on arbitrary text: a scene or an
//! error naming its line, never a panic or a hang.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        let _ = sim_persistent::scene::Scene::parse(text, std::path::Path::new("fuzz.toml"));
    }
});
