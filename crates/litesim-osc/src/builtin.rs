//! litesim's own OSC libraries, compiled into the binary: the domain
//! library (`osc/domain`) and the CARLA dialect's `basic.osc`
//! (`osc/carla`). A CARLA scenario that says `import basic.osc` runs from
//! any folder — and from the Python wheel — without a checkout of litesim.
//!
//! Built-in files have virtual paths under [`ROOT`]; their relative
//! imports resolve among themselves.

use std::path::{Component, Path, PathBuf};

/// The virtual folder of the built-in files (shown in diagnostics).
pub const ROOT: &str = "<litesim>/osc";

/// The CARLA dialect's library, relative to [`ROOT`].
pub const CARLA_BASIC: &str = "carla/basic.osc";

/// Every built-in file: path relative to [`ROOT`], text.
pub const FILES: &[(&str, &str)] = &[
    (CARLA_BASIC, include_str!("../../../osc/carla/basic.osc")),
    (
        "domain/actors.osc",
        include_str!("../../../osc/domain/actors.osc"),
    ),
    (
        "domain/behavior.osc",
        include_str!("../../../osc/domain/behavior.osc"),
    ),
    (
        "domain/config.osc",
        include_str!("../../../osc/domain/config.osc"),
    ),
    (
        "domain/environment.osc",
        include_str!("../../../osc/domain/environment.osc"),
    ),
    (
        "domain/map.osc",
        include_str!("../../../osc/domain/map.osc"),
    ),
    (
        "domain/units.osc",
        include_str!("../../../osc/domain/units.osc"),
    ),
];

/// The virtual path of built-in file `rel`.
pub fn path_of(rel: &str) -> PathBuf {
    Path::new(ROOT).join(rel)
}

/// Whether `p` is inside the built-in folder.
pub fn is_builtin(p: &Path) -> bool {
    p.starts_with(ROOT)
}

/// The text of the built-in file at virtual path `p` (`..` and `.`
/// resolved lexically).
pub fn text_of(p: &Path) -> Option<&'static str> {
    let rel = p.strip_prefix(ROOT).ok()?;
    let mut parts: Vec<&str> = Vec::new();
    for c in rel.components() {
        match c {
            Component::Normal(s) => parts.push(s.to_str()?),
            Component::ParentDir => {
                parts.pop()?;
            }
            Component::CurDir => {}
            _ => return None,
        }
    }
    let key = parts.join("/");
    FILES.iter().find(|(k, _)| *k == key).map(|(_, t)| *t)
}

/// `p` with `..` and `.` resolved lexically (built-in paths only).
pub fn normalise(p: &Path) -> PathBuf {
    let mut out = PathBuf::new();
    for c in p.components() {
        match c {
            Component::ParentDir => {
                out.pop();
            }
            Component::CurDir => {}
            other => out.push(other.as_os_str()),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_carla_library_and_its_imports_are_found() {
        let basic = path_of(CARLA_BASIC);
        assert!(text_of(&basic).unwrap().contains("actor Path"));
        let config = basic.parent().unwrap().join("../domain/config.osc");
        assert!(text_of(&config).unwrap().contains("struct test_config"));
        assert!(text_of(&path_of("../etc/passwd")).is_none());
        assert!(text_of(Path::new("/etc/passwd")).is_none());
    }
}
