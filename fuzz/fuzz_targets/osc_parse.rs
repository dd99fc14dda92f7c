//! The OSC front end must answer any bytes with a tree and diagnostics, never a panic or a hang.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    let (sources, _ast, diags) = litesim_osc::parse_str("fuzz.osc", &text);
    for d in &diags {
        let _ = d.render(&sources);
    }
});
