//! `litesim check FILE.osc [-I DIR] [--json | --format json] [--dump-ast] [--dialect D]`.

use anyhow::{Result, anyhow};
use std::path::{Path, PathBuf};

/// Loads and checks a program; prints every diagnostic; errors exit 1.
pub fn run(
    file: &Path,
    include: &[PathBuf],
    json: bool,
    rustc_json: bool,
    dump_ast: bool,
    dialect: Option<litesim_osc::Dialect>,
) -> Result<()> {
    if litesim_scenario::load::is_xosc(file) {
        return check_xosc(file, json || rustc_json);
    }
    let env = |name: &str| std::env::var(name).ok();
    let prog = litesim_osc::load_with(file, include, &env, dialect).map_err(|e| anyhow!(e))?;
    if dump_ast && let Some((_, ast)) = prog.files.iter().find(|(id, _)| *id == 0) {
        println!("{}", serde_json::to_string_pretty(ast)?);
    }
    for d in &prog.diagnostics {
        if rustc_json {
            println!("{}", d.to_rustc_json(&prog.sources));
        } else if json {
            println!("{}", d.to_json(&prog.sources));
        } else {
            eprint!("{}", d.render(&prog.sources));
        }
    }
    let errors = prog
        .diagnostics
        .iter()
        .filter(|d| d.severity == litesim_osc::Severity::Error)
        .count();
    let warnings = prog.diagnostics.len() - errors;
    if !json && !rustc_json {
        let dialect = match prog.dialect {
            litesim_osc::Dialect::Litesim => "",
            litesim_osc::Dialect::Carla => " (CARLA dialect)",
        };
        eprintln!(
            "{}: {} file(s), {errors} error(s), {warnings} warning(s){dialect}",
            file.display(),
            prog.sources.files.len()
        );
    }
    if errors > 0 {
        // The diagnostics are the message; exit 1 without repeating them.
        std::process::exit(1);
    }
    // The process ends here: freeing the tree node by node would cost a
    // tenth of a large file's check for memory the OS takes back anyway
    // (compilers skip it for the same reason).
    std::mem::forget(prog);
    Ok(())
}

/// `litesim check FILE.xosc`: an OpenSCENARIO XML scenario (or parameter
/// distribution) read and checked; its error (file:line:col, the element
/// path, what was expected) on stderr, or JSON, and exit 1.
fn check_xosc(file: &Path, json: bool) -> Result<()> {
    let read = if litesim_xosc::is_distribution(file) {
        litesim_xosc::read_distribution(file).map(|d| {
            format!(
                "a parameter distribution of {}: {} variation(s)",
                d.scenario.display(),
                d.variations.len()
            )
        })
    } else {
        litesim_xosc::read(file, &[]).map(|s| {
            format!(
                "OpenSCENARIO {}.{}: {} entities, {} Init action(s), {} stor{}",
                s.version.0,
                s.version.1,
                s.entities.len(),
                s.init.len(),
                s.stories.len(),
                if s.stories.len() == 1 { "y" } else { "ies" }
            )
        })
    };
    match read {
        Ok(what) => {
            if json {
                println!(
                    "{}",
                    serde_json::json!({"file": file.display().to_string(), "ok": true, "what": what})
                );
            } else {
                eprintln!("{}: {what}, no errors", file.display());
            }
            Ok(())
        }
        Err(e) => {
            if json {
                println!(
                    "{}",
                    serde_json::json!({
                        "file": e.file, "line": e.line, "col": e.col,
                        "path": e.path, "severity": "error", "message": e.message,
                    })
                );
            } else {
                eprintln!("error: {e}");
            }
            std::process::exit(1);
        }
    }
}
