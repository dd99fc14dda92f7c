//! Writes a synthetic town map (see `litesim_map::synth`).
//!
//! `cargo run --release -p litesim-map --example town -- OUT.xodr [BYTES]`:
//! without BYTES, the 1.8 MB, 234-road town of the load benchmark; with
//! BYTES (e.g. 200000000), a square town of about that size.

fn main() {
    let mut args = std::env::args().skip(1);
    let Some(out) = args.next() else {
        eprintln!("usage: town OUT.xodr [BYTES]");
        std::process::exit(2);
    };
    let spec = match args.next() {
        None => litesim_map::synth::TownSpec::city(),
        Some(b) => match b.parse::<usize>() {
            Ok(bytes) => litesim_map::synth::TownSpec::of_size(bytes),
            Err(e) => {
                eprintln!("BYTES = '{b}': {e}");
                std::process::exit(2);
            }
        },
    };
    let text = litesim_map::synth::town(&spec);
    if let Err(e) = std::fs::write(&out, &text) {
        eprintln!("{out}: {e}");
        std::process::exit(1);
    }
    println!(
        "{out}: {} bytes, {} roads, {} × {} junctions",
        text.len(),
        spec.road_count(),
        spec.nx,
        spec.ny
    );
}
