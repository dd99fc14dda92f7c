//! The code's shape that ARCHITECTURE.md promises (issue 49): no function
//! in non-test code is over 120 lines, so that the next engineer can read
//! each one on a screen or two. A function may only be longer when
//! ARCHITECTURE.md names it as an exception with its reason.

mod common;
use common::workspace;
use std::path::{Path, PathBuf};

/// The longest a function may be, signature to closing brace.
const MAX_LINES: usize = 120;

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    let mut entries: Vec<_> = entries.flatten().map(|e| e.path()).collect();
    entries.sort();
    for p in entries {
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|e| e == "rs") {
            out.push(p);
        }
    }
}

/// Whether a line starts a function item: `fn name`, with any of `pub`,
/// `pub(crate)`, `const`, `async`, `unsafe` before it.
fn fn_name(line: &str) -> Option<&str> {
    let mut rest = line.trim_start();
    for prefix in [
        "pub(crate) ",
        "pub(super) ",
        "pub ",
        "const ",
        "async ",
        "unsafe ",
    ] {
        rest = rest.strip_prefix(prefix).unwrap_or(rest);
    }
    let rest = rest.strip_prefix("fn ")?;
    let end = rest
        .find(|c: char| !(c.is_alphanumeric() || c == '_'))
        .unwrap_or(rest.len());
    (end > 0).then(|| &rest[..end])
}

/// A line with its string and character literals emptied and its comment
/// cut, so that only the code's own braces are counted.
fn code_of(line: &str) -> String {
    let mut out = String::with_capacity(line.len());
    let mut chars = line.chars().peekable();
    while let Some(c) = chars.next() {
        match c {
            '"' => {
                while let Some(d) = chars.next() {
                    match d {
                        '\\' => {
                            chars.next();
                        }
                        '"' => break,
                        _ => {}
                    }
                }
                out.push_str("\"\"");
            }
            // A char literal ('{', '\'', '\n'), not a lifetime ('a).
            '\'' => {
                let mut look = chars.clone();
                let lit = match (look.next(), look.next(), look.next()) {
                    (Some('\\'), Some(_), Some('\'')) => 3,
                    (Some(_), Some('\''), _) => 2,
                    _ => 0,
                };
                for _ in 0..lit {
                    chars.next();
                }
                out.push('\'');
            }
            '/' if chars.peek() == Some(&'/') => break,
            _ => out.push(c),
        }
    }
    out
}

/// (lines, file, first line, name) of each function over [`MAX_LINES`]
/// in `text`, before its `#[cfg(test)] mod`.
fn long_functions(text: &str) -> Vec<(usize, usize, String)> {
    let lines: Vec<&str> = text.lines().collect();
    let end = lines
        .windows(2)
        .position(|w| w[0].trim() == "#[cfg(test)]" && w[1].trim_start().starts_with("mod "))
        .unwrap_or(lines.len());
    let mut found = Vec::new();
    for (i, line) in lines[..end].iter().enumerate() {
        let Some(name) = fn_name(line) else { continue };
        let mut depth = 0i64;
        // Brackets and parentheses open in the signature: an array type's
        // `;` there (`-> [f64; 6]`) does not end a declaration.
        let mut nest = 0i64;
        let mut started = false;
        let mut last = None;
        'body: for (j, l) in lines[i..end].iter().enumerate() {
            for c in code_of(l).chars() {
                match c {
                    '{' => {
                        depth += 1;
                        started = true;
                    }
                    '}' => depth -= 1,
                    '(' | '[' => nest += 1,
                    ')' | ']' => nest -= 1,
                    // A declaration without a body (a trait's method).
                    ';' if !started && depth == 0 && nest == 0 => break 'body,
                    _ => {}
                }
                if started && depth == 0 {
                    last = Some(i + j);
                    break 'body;
                }
            }
        }
        if let Some(last) = last {
            let n = last - i + 1;
            if n > MAX_LINES {
                found.push((n, i + 1, name.to_string()));
            }
        }
    }
    found
}

#[test]
fn the_counter_sees_a_long_function_and_ignores_braces_in_literals() {
    let body = "    let x = 1;\n".repeat(MAX_LINES);
    let text = format!(
        "pub(crate) fn long() {{\n{body}}}\nfn short(c: char) -> bool {{\n    c == '{{' || \"}}\" == \"x\" // }}\n}}\n"
    );
    let found = long_functions(&text);
    assert_eq!(found, vec![(MAX_LINES + 2, 1, "long".to_string())]);
    // An array type in the signature (its `;` once read as the end of a
    // body-less declaration: a 175-line function went unseen).
    let text =
        format!("fn long(a: [u8; 2]) -> R<(u8, [f64; 6])> {{\n{body}}}\nfn decl(a: [u8; 2]);\n");
    assert_eq!(
        long_functions(&text),
        vec![(MAX_LINES + 2, 1, "long".to_string())]
    );
    let tests =
        format!("fn ok() {{}}\n#[cfg(test)]\nmod tests {{\n    fn long() {{\n{body}    }}\n}}\n");
    assert!(long_functions(&tests).is_empty());
}

#[test]
fn no_function_in_non_test_code_is_over_120_lines() {
    let root = workspace();
    let architecture = std::fs::read_to_string(root.join("ARCHITECTURE.md")).unwrap();
    let mut files = Vec::new();
    for dir in ["crates", "python/src"] {
        rust_files(&root.join(dir), &mut files);
    }
    assert!(files.len() > 100, "found only {} files", files.len());
    let mut over = Vec::new();
    for f in files {
        let rel = f.strip_prefix(&root).unwrap().display().to_string();
        // Only the code that ships: tests, benches and examples may be long.
        let ships = rel.contains("/src/") && !rel.contains("/tests/");
        if !ships {
            continue;
        }
        let text = std::fs::read_to_string(&f).unwrap();
        for (n, line, name) in long_functions(&text) {
            // An exception is named in ARCHITECTURE.md with its file.
            let named = architecture.contains(&format!("`{name}` ({rel}"));
            if !named {
                over.push(format!("{rel}:{line}: fn {name} is {n} lines"));
            }
        }
    }
    assert!(
        over.is_empty(),
        "functions over {MAX_LINES} lines (split them, or name each in ARCHITECTURE.md's \"Function length\" with its reason):\n{}",
        over.join("\n")
    );
}

/// The crates whose numbers reach a run's results (logs, summaries,
/// plans, maps read, parameters): their shipped code takes transcendental
/// functions from `litesim_core::math` (litesim's own `sin_cos`, the
/// pure-Rust `libm`), never from the platform's C library — glibc picks an
/// FMA or a plain variant of `sin`, `atan`, `pow`… by the CPU it runs on,
/// so the same binary would write other bytes on another machine.
const RESULT_CRATES: [&str; 7] = [
    "litesim-core",
    "litesim-ssp",
    "litesim-map",
    "litesim-plan",
    "litesim-scenario",
    "litesim-xosc",
    "litesim-osc",
];

/// `f64` methods that call the platform's libm.
const PLATFORM_MATH: [&str; 19] = [
    ".sin(",
    ".cos(",
    ".tan(",
    ".sin_cos(",
    ".asin(",
    ".acos(",
    ".atan(",
    ".atan2(",
    ".sinh(",
    ".cosh(",
    ".tanh(",
    ".exp(",
    ".exp_m1(",
    ".ln(",
    ".ln_1p(",
    ".log10(",
    ".log2(",
    ".powf(",
    ".hypot(",
];

/// Calls that look like the platform's but are litesim's own methods.
const OWN_METHODS: [(&str, &str); 1] = [
    // `RefPoint::sin_cos`: the sine and cosine a map reference point keeps.
    ("crates/litesim-map/src/", "r.sin_cos()"),
];

#[test]
fn results_use_litesims_own_transcendentals() {
    let root = workspace();
    let mut found = Vec::new();
    for c in RESULT_CRATES {
        let mut files = Vec::new();
        rust_files(&root.join("crates").join(c).join("src"), &mut files);
        assert!(!files.is_empty(), "{c} has no sources");
        for f in files {
            let rel = f.strip_prefix(&root).unwrap().display().to_string();
            let text = std::fs::read_to_string(&f).unwrap();
            for (i, line) in text.lines().enumerate() {
                // A file's unit tests come last: they may compute their
                // expectations any way they like.
                if line.trim_start().starts_with("#[cfg(test)]") {
                    break;
                }
                let code = code_of(line);
                let own = OWN_METHODS
                    .iter()
                    .any(|(dir, m)| rel.starts_with(dir) && code.contains(m));
                if let Some(m) = PLATFORM_MATH.iter().find(|m| code.contains(**m))
                    && !own
                {
                    found.push(format!("{rel}:{}: {m}…) — use litesim_core::math", i + 1));
                }
            }
        }
    }
    assert!(
        found.is_empty(),
        "the platform's libm in code whose results litesim promises bit for bit:\n{}",
        found.join("\n")
    );
}

#[test]
fn the_platform_math_check_sees_a_call_and_not_a_comment() {
    let hit = |l: &str| PLATFORM_MATH.iter().any(|m| code_of(l).contains(m));
    assert!(hit("    let y = x.sin() * 2.0;"));
    assert!(hit("let d = (a - b).hypot(c);"));
    assert!(!hit("let y = math::sin(x); // not x.sin()"));
    assert!(!hit(r#"let s = "x.cos()";"#));
}
