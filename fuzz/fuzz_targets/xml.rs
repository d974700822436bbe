//! Any text as a Mitsuba XML scene, loaded into a scene: a scene or an error, never a panic.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let path = std::path::Path::new("fuzz.xml");
    if let Ok(props) = nlos_rs::xml::parse(text, path, &Default::default()) {
        let _ = nlos_rs::Scene::from_props(&props, std::path::Path::new("/nonexistent-fuzz-dir"));
    }
});
