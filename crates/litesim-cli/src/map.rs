//! `litesim map info | export`.

use anyhow::{Context, Result, bail};
use clap::Subcommand;
use litesim_map::RoadNetwork;
use std::collections::BTreeMap;
use std::path::PathBuf;

/// Map subcommands.
#[derive(Subcommand)]
pub enum MapCommand {
    /// Roads, lanes by type, junctions, total length, signals and warnings.
    Info {
        /// The .xodr file.
        file: PathBuf,
        /// Also list every road.
        #[arg(long)]
        roads: bool,
    },
    /// Lane polylines (centre and borders) as GeoJSON or CSV.
    Export {
        /// The .xodr file.
        file: PathBuf,
        /// Write GeoJSON here.
        #[arg(long, value_name = "OUT")]
        geojson: Option<PathBuf>,
        /// Write CSV here.
        #[arg(long, value_name = "OUT")]
        csv: Option<PathBuf>,
        /// Largest distance between the polylines and the true curves (m).
        #[arg(long, default_value_t = 0.05)]
        tolerance: f64,
    },
}

fn load(file: &std::path::Path) -> Result<RoadNetwork> {
    RoadNetwork::load(file).map_err(|e| anyhow::anyhow!("{e}"))
}

/// Runs a map subcommand.
pub fn run(cmd: MapCommand) -> Result<()> {
    match cmd {
        MapCommand::Info { file, roads } => {
            let m = load(&file)?;
            let h = &m.od.header;
            println!(
                "{}: OpenDRIVE {}.{} \"{}\"",
                file.display(),
                h.rev_major,
                h.rev_minor,
                h.name
            );
            let in_junction = m.roads().iter().filter(|r| r.junction.is_some()).count();
            println!(
                "roads: {} ({} in junctions), total length {:.1} m",
                m.roads().len(),
                in_junction,
                m.total_length()
            );
            let mut lanes: BTreeMap<&str, usize> = BTreeMap::new();
            for r in m.roads() {
                for s in &r.sections {
                    for l in s.left.iter().chain(s.right.iter()) {
                        *lanes.entry(l.kind.as_str()).or_default() += 1;
                    }
                }
            }
            let list: Vec<String> = lanes.iter().map(|(k, n)| format!("{k} {n}")).collect();
            println!("lanes by type: {}", list.join(", "));
            let conns: usize = m.od.junctions.iter().map(|j| j.connections.len()).sum();
            println!(
                "junctions: {} ({} connections)",
                m.od.junctions.len(),
                conns
            );
            let signals: Vec<_> = m.roads().iter().flat_map(|r| r.signals.iter()).collect();
            let lights = signals.iter().filter(|s| s.dynamic).count();
            println!(
                "signals: {} ({} dynamic: traffic lights), controllers: {}",
                signals.len(),
                lights,
                m.od.controllers.len()
            );
            let sums = m.road_summaries();
            let one_way = sums.iter().filter(|s| s.one_way).count();
            println!(
                "one-way roads: {one_way}, two-way roads: {}",
                sums.iter()
                    .filter(|s| !s.one_way && s.max_driving_lanes > 0)
                    .count()
            );
            if let Some(g) = &h.geo_reference {
                println!("geoReference: {g}");
            }
            if roads {
                println!(
                    "\n{:<8} {:>9} {:<9} {:>4} {:>4} {:>8}",
                    "road", "length", "junction", "fwd", "bwd", "one-way"
                );
                for s in &sums {
                    println!(
                        "{:<8} {:>9.2} {:<9} {:>4} {:>4} {:>8}",
                        s.id,
                        s.length,
                        s.junction.as_deref().unwrap_or("-"),
                        s.min_forward_lanes,
                        s.min_backward_lanes,
                        s.one_way
                    );
                }
            }
            println!("warnings: {}", m.warnings.len());
            for w in &m.warnings {
                println!(
                    "  warning: {}:{}: {}: {}",
                    file.display(),
                    w.line,
                    w.path,
                    w.message
                );
            }
            Ok(())
        }
        MapCommand::Export {
            file,
            geojson,
            csv,
            tolerance,
        } => {
            if geojson.is_none() && csv.is_none() {
                bail!("say where to write: --geojson OUT and/or --csv OUT");
            }
            if !(tolerance.is_finite() && tolerance > 0.0) {
                bail!("--tolerance must be a positive number of metres, got {tolerance}");
            }
            let m = load(&file)?;
            let lanes = m.lane_polylines(tolerance);
            if let Some(p) = geojson {
                std::fs::write(&p, litesim_map::export::geojson(&lanes))
                    .with_context(|| format!("cannot write {}", p.display()))?;
                println!("wrote {} ({} lanes)", p.display(), lanes.len());
            }
            if let Some(p) = csv {
                std::fs::write(&p, litesim_map::export::csv(&lanes))
                    .with_context(|| format!("cannot write {}", p.display()))?;
                println!("wrote {} ({} lanes)", p.display(), lanes.len());
            }
            Ok(())
        }
    }
}
