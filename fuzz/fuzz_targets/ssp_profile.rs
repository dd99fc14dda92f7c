//! Profile files are user data: any text must load or be refused, never panic.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = litesim_ssp::Profile::from_toml(&String::from_utf8_lossy(data));
});
