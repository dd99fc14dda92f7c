//! The scenario engine must answer any test text with diagnostics or an
//! error, never a panic or a hang: the bytes follow an import of litesim's
//! domain library and a map setting, then load, solve, plan and run.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let dir = std::env::temp_dir().join(format!("litesim-fuzz-{}", std::process::id()));
    let _ = std::fs::create_dir_all(&dir);
    let file = dir.join("t.osc");
    let text = format!(
        "import \"{}\"\nextend test_config:\n    set map = \"{}\"\n{}",
        root.join("osc/domain/config.osc").display(),
        root.join("examples/maps/straight.xodr").display(),
        String::from_utf8_lossy(data)
    );
    if std::fs::write(&file, text).is_err() {
        return;
    }
    if let Ok(prep) = litesim_scenario::prepare(&file, &Default::default()) {
        let _ = litesim_scenario::run(
            &prep,
            &mut litesim_scenario::in_process(),
            &Default::default(),
        );
    }
});
