//! The whole OSC front end on any bytes: load (imports resolved from a
//! scratch folder and litesim's built-in libraries), check and — for
//! CARLA-dialect programs — lowering, in each dialect. Never a panic or a
//! hang; every diagnostic renders.
#![no_main]
use libfuzzer_sys::fuzz_target;
use litesim_osc::Dialect;

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    let dir = std::env::temp_dir().join(format!("litesim-fuzz-osc-{}", std::process::id()));
    let _ = std::fs::create_dir_all(&dir);
    let path = dir.join("t.osc");
    if std::fs::write(&path, text.as_bytes()).is_err() {
        return;
    }
    for dialect in [None, Some(Dialect::Litesim), Some(Dialect::Carla)] {
        if let Ok(prog) = litesim_osc::load_with(&path, &[], &|_| None, dialect) {
            for d in &prog.diagnostics {
                let _ = d.render(&prog.sources);
            }
        }
    }
});
