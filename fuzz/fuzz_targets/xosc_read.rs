//! The OpenSCENARIO XML reader must answer any input with a scenario or an
//! error, never a panic: the bytes are read as a scenario beside the corpus
//! (so its map and catalog paths resolve), and as a distribution file.
#![no_main]
use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    let here = Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/xosc/corpus/fuzz.xosc");
    if let Ok(sc) = litesim_xosc::read_str(&text, &here, &[]) {
        let _ = litesim_scenario::xosc::XoscTest::new(sc, None);
    }
    let _ = litesim_xosc::expr::eval(&text, &|_| Ok(1.0));
});
