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
