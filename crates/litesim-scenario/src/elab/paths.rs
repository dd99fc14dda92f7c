//! Paths and trajectories (`path`, `relative_path`, `trajectory`,
//! `relative_trajectory`): written as literals of their points
//! (`path(points: [position_3d(x: 0m, y: 0m), …])`) or read from a CSV
//! file of `x, y[, z, h, t]` (`path(file: "recorded.csv")`), resolved
//! against the OSC file that names it. Each becomes a [`PathDef`] of the
//! test; the action that follows it names it by index. A file that is
//! missing or empty, a value that is not a finite number, or times that do
//! not increase are errors at `file:line` (docs/osc-stdlib.md).

use super::*;
use std::path::Path;

/// Most points one path may have (a recorded drive at 100 Hz for an hour).
pub const MAX_PATH_POINTS: usize = 360_000;

/// One point of a path or trajectory.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct PathPoint {
    /// x (m): in the map's frame, or relative to the reference.
    pub x: f64,
    /// y (m).
    pub y: f64,
    /// z (m).
    pub z: f64,
    /// Heading (rad), if given.
    pub h: Option<f64>,
    /// Time stamp (s), for a trajectory.
    pub t: Option<f64>,
}

/// A path or trajectory of the test.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PathDef {
    /// Its points, at least two.
    pub points: Vec<PathPoint>,
    /// A trajectory: every point has a time stamp, increasing.
    pub timed: bool,
    /// Relative to a reference actor (`relative_path`,
    /// `relative_trajectory`).
    pub relative: bool,
    /// Where it comes from (`file.csv` or `file.osc:line:col`), for
    /// messages.
    pub source: String,
}

/// The path types and whether each is timed and relative.
const KINDS: [(&str, bool, bool); 4] = [
    ("path", false, false),
    ("relative_path", false, true),
    ("trajectory", true, false),
    ("relative_trajectory", true, true),
];

impl Elab<'_> {
    /// The path or trajectory literal `e` (a `timed` one for the
    /// trajectory actions) as a new [`PathDef`]: its index.
    pub(super) fn path_def(
        &mut self,
        e: &Expr,
        timed: bool,
        at: &str,
    ) -> Result<usize, ScenarioError> {
        let err = |what: String| ScenarioError::Elaboration(format!("{at}: {what}"));
        let want = if timed { "trajectory" } else { "path" };
        let Expr::Call { callee, args, span } = e else {
            return Err(err(format!(
                "give the {want} as a literal: `{want}(file: \"drive.csv\")` or `{want}(points: [...])`"
            )));
        };
        let Expr::Ident { name, .. } = &**callee else {
            return Err(err(format!("expected a {want} literal")));
        };
        let Some(&(kind, is_timed, relative)) = KINDS.iter().find(|(k, ..)| k == name) else {
            return Err(err(format!(
                "expected a {want} literal, found a call of '{name}'"
            )));
        };
        if is_timed != timed {
            return Err(err(format!(
                "a {kind} is not a {want} (the {want} actions take {})",
                if timed {
                    "trajectory or relative_trajectory"
                } else {
                    "path or relative_path"
                }
            )));
        }
        let here = self.lib.at(*span);
        let named = |k: &str| {
            args.iter()
                .find(|a| a.name.as_ref().is_some_and(|n| n.text == k))
        };
        for a in args {
            let Some(n) = &a.name else {
                return Err(err(format!(
                    "{kind}(…): name its arguments (points, time_stamps, file, interpolation)"
                )));
            };
            if !["points", "time_stamps", "file", "interpolation"].contains(&n.text.as_str()) {
                return Err(err(format!(
                    "{kind} has no field '{}' (its fields: points, time_stamps, file, interpolation)",
                    n.text
                )));
            }
        }
        if let Some(a) = named("interpolation")
            && !matches!(&a.value, Expr::Ident { name, .. } if name == "straight_line")
        {
            return Err(err(format!(
                "{kind}(interpolation: smooth) is not supported by litesim (straight_line only)"
            )));
        }
        let (points, source) = match (named("file"), named("points")) {
            (Some(f), None) => {
                let Expr::Str { value, .. } = &f.value else {
                    return Err(err(format!("{kind}(file: …) takes a string")));
                };
                let base = self.lib.prog.sources.file(span.file).path.clone();
                let file = Path::new(&base)
                    .parent()
                    .unwrap_or(Path::new("."))
                    .join(value);
                (read_csv(&file, timed)?, file.display().to_string())
            }
            (None, Some(p)) => (
                self.literal_points(&p.value, named("time_stamps"), timed, &here)?,
                here.clone(),
            ),
            (Some(_), Some(_)) => {
                return Err(err(format!(
                    "{kind}: give its points or its file, not both"
                )));
            }
            (None, None) => return Err(err(format!("{kind} needs its points or its file"))),
        };
        self.test.paths.push(PathDef {
            points,
            timed,
            relative,
            source,
        });
        Ok(self.test.paths.len() - 1)
    }

    /// `points: [pose_3d(…) | position_3d(…), …]` with
    /// `time_stamps: [0s, …]` for a trajectory.
    fn literal_points(
        &self,
        e: &Expr,
        stamps: Option<&Arg>,
        timed: bool,
        at: &str,
    ) -> Result<Vec<PathPoint>, ScenarioError> {
        let err = |what: String| ScenarioError::Elaboration(format!("{at}: {what}"));
        let Expr::List { items, .. } = e else {
            return Err(err(
                "points: give a list `[position_3d(x: 0m, y: 0m), …]`".into()
            ));
        };
        let sc = Scope::default();
        let num = |x: &Expr| match self.cexpr(x, &sc) {
            CExpr::Const(Value::Num(v)) if v.is_finite() => Ok(v),
            _ => Err(err(format!("{}: expected a number", self.lib.at(x.span())))),
        };
        let mut out = Vec::with_capacity(items.len());
        for it in items {
            let Some((ty, fields)) = self.literal(it, &sc) else {
                return Err(err(format!(
                    "{}: a point is a pose_3d(…) or position_3d(…) literal",
                    self.lib.at(it.span())
                )));
            };
            let get = |k: &str| fields.iter().find(|(f, _)| f == k).map(|(_, v)| v.clone());
            let value = |k: &str| match get(k) {
                None => Ok(None),
                Some(CExpr::Const(Value::Num(v))) if v.is_finite() => Ok(Some(v)),
                Some(_) => Err(err(format!(
                    "{}: {ty}.{k} is not a number",
                    self.lib.at(it.span())
                ))),
            };
            let (px, py, pz, h) = match ty.as_str() {
                "position_3d" => (value("x")?, value("y")?, value("z")?, None),
                "pose_3d" => (
                    value("position.x")?,
                    value("position.y")?,
                    value("position.z")?,
                    value("orientation.yaw")?,
                ),
                _ => {
                    return Err(err(format!(
                        "{}: a point is a pose_3d or position_3d, not a {ty}",
                        self.lib.at(it.span())
                    )));
                }
            };
            out.push(PathPoint {
                x: px.unwrap_or(0.0),
                y: py.unwrap_or(0.0),
                z: pz.unwrap_or(0.0),
                h,
                t: None,
            });
        }
        if timed {
            let Some(Expr::List { items, .. }) = stamps.map(|a| &a.value) else {
                return Err(err("a trajectory needs its time_stamps: [0s, 1s, …]".into()));
            };
            if items.len() != out.len() {
                return Err(err(format!(
                    "{} time_stamps for {} points",
                    items.len(),
                    out.len()
                )));
            }
            for (p, x) in out.iter_mut().zip(items) {
                p.t = Some(num(x)?);
            }
        } else if stamps.is_some() {
            return Err(err("a path has no time_stamps (a trajectory has)".into()));
        }
        check_points(&out, timed).map_err(|(i, what)| err(format!("point {}: {what}", i + 1)))?;
        Ok(out)
    }
}

/// The points of a CSV file: `x, y[, z, h, t]` in metres, radians and
/// seconds, one point a line; a first line of names (`x,y,t`) gives the
/// columns in another order. Blank lines and lines from `#` are skipped.
pub fn read_csv(path: &Path, timed: bool) -> Result<Vec<PathPoint>, ScenarioError> {
    let shown = path.display();
    let text = std::fs::read_to_string(path).map_err(|e| {
        ScenarioError::Elaboration(format!("{shown}: cannot read the path file: {e}"))
    })?;
    let err =
        |line: usize, what: String| ScenarioError::Elaboration(format!("{shown}:{line}: {what}"));
    let mut columns: Vec<String> = ["x", "y", "z", "h", "t"].map(String::from).to_vec();
    let mut out = Vec::new();
    let mut first = true;
    for (i, raw) in text.lines().enumerate() {
        let line = raw.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let cells: Vec<&str> = line.split(',').map(str::trim).collect();
        // A first line of names (letters only) names the columns.
        let names = cells
            .iter()
            .all(|c| !c.is_empty() && c.chars().all(|ch| ch.is_ascii_alphabetic() || ch == '_'));
        if std::mem::take(&mut first) && names {
            columns = cells.iter().map(|c| c.to_ascii_lowercase()).collect();
            for c in &columns {
                if !["x", "y", "z", "h", "t"].contains(&c.as_str()) {
                    return Err(err(
                        i + 1,
                        format!("unknown column '{c}' (columns: x, y, z, h, t)"),
                    ));
                }
            }
            if !columns.iter().any(|c| c == "x") || !columns.iter().any(|c| c == "y") {
                return Err(err(i + 1, "the columns must include x and y".into()));
            }
            continue;
        }
        if cells.len() < 2 || cells.len() > columns.len() {
            return Err(err(
                i + 1,
                format!(
                    "{} values; expected x, y[, z, h, t] ({} columns)",
                    cells.len(),
                    columns.len()
                ),
            ));
        }
        let mut p = PathPoint {
            x: f64::NAN,
            y: f64::NAN,
            z: 0.0,
            h: None,
            t: None,
        };
        for (c, cell) in columns.iter().zip(&cells) {
            let v: f64 = cell
                .parse()
                .map_err(|_| err(i + 1, format!("{c} = '{cell}' is not a number")))?;
            if !v.is_finite() {
                return Err(err(i + 1, format!("{c} = {cell} is not a finite number")));
            }
            match c.as_str() {
                "x" => p.x = v,
                "y" => p.y = v,
                "z" => p.z = v,
                "h" => p.h = Some(v),
                _ => p.t = Some(v),
            }
        }
        if p.x.is_nan() || p.y.is_nan() {
            return Err(err(i + 1, "x and y are needed".into()));
        }
        if timed && p.t.is_none() {
            return Err(err(i + 1, "a trajectory's point needs its time t".into()));
        }
        if out.len() == MAX_PATH_POINTS {
            return Err(err(i + 1, format!("more than {MAX_PATH_POINTS} points")));
        }
        out.push((i + 1, p));
    }
    if out.is_empty() {
        return Err(ScenarioError::Elaboration(format!(
            "{shown}: the path file has no points"
        )));
    }
    let lines: Vec<usize> = out.iter().map(|(l, _)| *l).collect();
    let points: Vec<PathPoint> = out.into_iter().map(|(_, p)| p).collect();
    check_points(&points, timed).map_err(|(k, what)| err(lines[k], what))?;
    Ok(points)
}

/// At least two points; times, where given, increasing. The index of the
/// point at fault and what is wrong.
fn check_points(points: &[PathPoint], timed: bool) -> Result<(), (usize, String)> {
    if points.len() < 2 {
        return Err((
            0,
            format!("a path needs at least two points ({} given)", points.len()),
        ));
    }
    if timed || points.iter().any(|p| p.t.is_some()) {
        for (k, w) in points.windows(2).enumerate() {
            match (w[0].t, w[1].t) {
                (Some(a), Some(b)) if b > a => {}
                (Some(a), Some(b)) => {
                    return Err((
                        k + 1,
                        format!("t = {b} s does not increase (the point before is at {a} s)"),
                    ));
                }
                _ => return Err((k + 1, "every point needs its time t, or none".into())),
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn csv(text: &str, timed: bool) -> Result<Vec<PathPoint>, String> {
        let f = tempfile::NamedTempFile::new().unwrap();
        std::fs::write(f.path(), text).unwrap();
        read_csv(f.path(), timed)
            .map_err(|e| e.to_string().replace(&f.path().display().to_string(), "F"))
    }

    #[test]
    fn csv_files_read_with_or_without_names_and_fail_at_their_line() {
        let p = csv("0,0\n10,0\n10,5\n", false).unwrap();
        assert_eq!(p.len(), 3);
        let p = csv("# recorded\nt,x,y\n0,0,0\n1,10,0\n", true).unwrap();
        assert_eq!((p[1].t, p[1].x), (Some(1.0), 10.0));
        assert_eq!(
            csv("", false).unwrap_err(),
            "elaboration: F: the path file has no points"
        );
        assert_eq!(
            csv("0,0\n1,NaN\n", false).unwrap_err(),
            "elaboration: F:2: y = NaN is not a finite number"
        );
        assert_eq!(
            csv("x,y,t\n0,0,0\n1,0,2\n2,0,2\n", true).unwrap_err(),
            "elaboration: F:4: t = 2 s does not increase (the point before is at 2 s)"
        );
        assert_eq!(
            csv("0,0\n1,a\n", false).unwrap_err(),
            "elaboration: F:2: y = 'a' is not a number"
        );
        assert_eq!(
            csv("0,0\n", false).unwrap_err(),
            "elaboration: F:1: a path needs at least two points (1 given)"
        );
        assert!(
            csv("x,q\n", false)
                .unwrap_err()
                .contains("F:1: unknown column 'q'")
        );
        assert!(
            csv("0,0\n1,1\n", true)
                .unwrap_err()
                .contains("F:1: a trajectory's point needs its time t")
        );
        let missing = read_csv(Path::new("/nonexistent/drive.csv"), false)
            .unwrap_err()
            .to_string();
        assert!(
            missing.contains("/nonexistent/drive.csv: cannot read the path file"),
            "{missing}"
        );
    }
}
