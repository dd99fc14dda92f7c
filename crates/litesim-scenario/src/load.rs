//! Loading a test, the pipeline's first stage ([`prepare`]): the OSC
//! program read and checked (litesim-osc), elaborated ([`crate::elab`]),
//! its map found and read once, and everything a run of it under any seed
//! shares (lane graph, conflict areas, calibrations read) kept in
//! [`Prepared`].

use crate::error::ScenarioError;
use crate::{RunOptions, calibrate, elab, runtime};
use litesim_map::RoadNetwork;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// How to load a test.
#[derive(Clone, Debug, Default)]
pub struct LoadOptions {
    /// Import search paths (`-I`).
    pub include: Vec<PathBuf>,
    /// Map file overriding the test's (`--map`).
    pub map: Option<PathBuf>,
    /// Environment lookups (`$FTX`); `None` reads the process environment.
    pub env: Option<BTreeMap<String, String>>,
    /// The OSC dialect (`--dialect`); `None` detects it.
    pub dialect: Option<litesim_osc::Dialect>,
    /// Where a CARLA scenario's `set_map("Town04")` finds `Town04.xodr`
    /// (`--map-dir`); `None`: the test's folder, then `maps/` in it and in
    /// each folder above it.
    pub map_dir: Option<PathBuf>,
    /// OpenSCENARIO XML global parameters set from outside (`--param
    /// NAME=VALUE`, a distribution's variation).
    pub params: Vec<(String, String)>,
    /// The OpenSCENARIO XML entity a SUT drives (`--ego NAME`); none: the
    /// one with an `ExternalController`.
    pub ego: Option<String>,
}

/// The OpenDRIVE file of a CARLA map name: `NAME.xodr` in `map_dir`, or
/// (without one) in the test's folder or the `maps/` of it or of a folder
/// above it. The error
/// says where it looked.
pub fn carla_map_file(
    test: &Path,
    name: &str,
    map_dir: Option<&Path>,
) -> Result<PathBuf, MapFileError> {
    let file = format!("{name}.xodr");
    let plain = !name.is_empty() && !name.contains(['/', '\\']) && name != "." && name != "..";
    if !plain {
        return Err(MapFileError::NotPlain {
            name: name.to_string(),
        });
    }
    let here = test.parent().unwrap_or(Path::new(".")).to_path_buf();
    let dirs: Vec<PathBuf> = match map_dir {
        Some(d) => vec![d.to_path_buf()],
        // The folder, then `maps/` in it and in each folder above it,
        // nearest first, written `../maps`, `../../maps` (a scenario in a
        // sub-folder of a project finds the project's maps; the names stay
        // as they were for the first levels, which runs record). As far up
        // as the folder has parents, at most 8 levels.
        None => {
            let depth = here
                .canonicalize()
                .map_or(1, |c| c.ancestors().count().saturating_sub(1))
                .min(8);
            let mut dirs = vec![here.clone(), here.join("maps")];
            let mut up = here.clone();
            for _ in 0..depth {
                up = up.join("..");
                dirs.push(up.join("maps"));
            }
            dirs
        }
    };
    dirs.iter()
        .map(|d| d.join(&file))
        .find(|p| p.is_file())
        .ok_or_else(|| MapFileError::NotFound {
            name: name.to_string(),
            looked: dirs.iter().map(|d| d.display().to_string()).collect(),
        })
}

/// Why a CARLA map name has no OpenDRIVE file ([`carla_map_file`]).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum MapFileError {
    /// A path, not a name (`../secret`, empty).
    #[error("map name '{name}' is not a plain name (CARLA names maps like \"Town04\")")]
    NotPlain {
        /// The name given.
        name: String,
    },
    /// No `NAME.xodr` in any folder looked in.
    #[error(
        "map '{name}': no {name}.xodr in {} — CARLA's maps are OpenDRIVE files: pass --map-dir with a folder that has {name}.xodr (CARLA ships them as CarlaUE4/Content/Carla/Maps/OpenDrive/*.xodr), or --map FILE",
        looked.join(", ")
    )]
    NotFound {
        /// The name given.
        name: String,
        /// The folders looked in, nearest first.
        looked: Vec<String>,
    },
}

/// A loaded, elaborated test with its map, ready to run under many seeds.
#[derive(Clone, Debug)]
pub struct Prepared {
    /// The test file.
    pub path: PathBuf,
    /// The elaborated test.
    pub test: elab::Test,
    /// The map, shared between runs.
    pub net: Option<Arc<RoadNetwork>>,
    /// The map's text (sent to the simulator for its traffic lights).
    pub map_text: Option<Arc<String>>,
    /// The map's file name (for messages).
    pub map_name: String,
    /// The map has dynamic signals (traffic lights) the simulator must know.
    pub has_lights: bool,
    /// SHA-256 of the test's source texts (the file and its imports, in
    /// loading order): what a batch manifest records of the test.
    pub source_hash: String,
    /// The map's lanes as drivers see them: built on first use (the first
    /// run with drivers), then shared by every run of a batch.
    pub lanes: Arc<std::sync::OnceLock<Arc<runtime::traffic::LaneGraph>>>,
    /// An OpenSCENARIO XML scenario (a `.xosc` file): its storyboard runs
    /// live on the runtime instead of a plan (`test` is then only the
    /// run's configuration).
    pub xosc: Option<Arc<crate::xosc::XoscTest>>,
    /// The driver gains runs read from files, per (calibration folder,
    /// look beside the test, profile): a file is found, read, parsed and
    /// hashed once per test, not once per seed.
    pub calibrations: Arc<std::sync::Mutex<Vec<(CalibrationKey, CalibrationRead)>>>,
}

/// Where a run looks for its calibration file.
pub type CalibrationKey = (Option<PathBuf>, bool, String);
/// What it found: the gains (none: built-in) and how the summary names
/// them, or why the file could not be used.
pub type CalibrationRead =
    Result<(Option<litesim_ssp::profile::Calibration>, String), Arc<ScenarioError>>;

impl Prepared {
    /// The calibration a run under `opts` and `profile` reads from a file
    /// (read once per test and key, then shared).
    pub(crate) fn calibration_read(&self, opts: &RunOptions, profile: &str) -> CalibrationRead {
        let key = (
            opts.calibration_dir.clone(),
            opts.calibration_near_test,
            profile.to_string(),
        );
        let mut cache = self
            .calibrations
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        if let Some((_, got)) = cache.iter().find(|(k, _)| *k == key) {
            return got.clone();
        }
        let got = match calibration_file(self, opts, profile) {
            Some(f) => {
                match litesim_core::files::read_text(&f, litesim_core::files::MAX_INPUT_BYTES) {
                    Ok(text) => calibrate::from_toml(&text)
                        .map(|c| {
                            (
                                Some(c),
                                format!("{} sha256:{}", f.display(), sha256_hex(text.as_bytes())),
                            )
                        })
                        .map_err(|e| Arc::new(ScenarioError::format(f.display(), e))),
                    Err(_) => Ok((None, "built-in".to_string())),
                }
            }
            None => Ok((None, "built-in".to_string())),
        };
        cache.push((key, got.clone()));
        got
    }

    /// The map's lanes as drivers see them (`None` without a map).
    pub fn lane_graph(&self) -> Option<Arc<runtime::traffic::LaneGraph>> {
        let net = self.net.as_deref()?;
        Some(
            self.lanes
                .get_or_init(|| Arc::new(runtime::traffic::LaneGraph::new(net)))
                .clone(),
        )
    }
}

/// The map's junction conflict areas (none without junctions: the lane
/// graph is then not built for them).
pub(crate) fn conflict_areas(prep: &Prepared) -> Arc<[runtime::traffic::ConflictArea]> {
    let junctions = prep
        .net
        .as_deref()
        .is_some_and(|n| n.roads().iter().any(|r| r.junction.is_some()));
    match prep.lane_graph() {
        Some(g) if junctions => g.areas.clone(),
        _ => Arc::default(),
    }
}

/// Whether `path` names an OpenSCENARIO XML file.
pub fn is_xosc(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("xosc"))
}

/// Reads an OpenSCENARIO XML scenario and its map (`RoadNetwork/LogicFile`,
/// relative to the file; `--map` overrides it).
fn prepare_xosc(path: &Path, opts: &LoadOptions) -> Result<Prepared, ScenarioError> {
    let text = litesim_core::files::read_text(path, litesim_xosc::MAX_FILE_BYTES)?;
    let sc = litesim_xosc::read_str(&text, path, &opts.params)?;
    let map_path = opts.map.clone().or_else(|| sc.map.clone()).ok_or_else(|| {
        ScenarioError::Map(format!(
            "{}: the scenario names no map (RoadNetwork/LogicFile): pass --map FILE.xodr",
            path.display()
        ))
    })?;
    let name = map_path.display().to_string();
    let map_text = RoadNetwork::read_text(&map_path).map_err(|source| ScenarioError::MapParse {
        name: name.clone(),
        source,
    })?;
    let net =
        RoadNetwork::from_xodr(&map_text, &name).map_err(|source| ScenarioError::MapParse {
            name: name.clone(),
            source,
        })?;
    let has_lights = net
        .roads()
        .iter()
        .any(|r| r.signals.iter().any(|s| s.dynamic));
    let mut test = elab::Test::default();
    test.config.map = Some(name.clone());
    Ok(Prepared {
        lanes: Default::default(),
        calibrations: Default::default(),
        has_lights,
        source_hash: sha256_hex(text.as_bytes()),
        path: path.to_path_buf(),
        test,
        net: Some(Arc::new(net)),
        map_text: Some(Arc::new(map_text)),
        map_name: name,
        xosc: Some(Arc::new(crate::xosc::XoscTest::new(
            sc,
            opts.ego.as_deref(),
        )?)),
    })
}

/// Loads, checks and elaborates a test; loads its map. An OpenSCENARIO
/// XML file (`.xosc`) is read and checked; its storyboard runs live.
pub fn prepare(path: &Path, opts: &LoadOptions) -> Result<Prepared, ScenarioError> {
    if is_xosc(path) {
        return prepare_xosc(path, opts);
    }
    let env = |k: &str| match &opts.env {
        Some(m) => m.get(k).cloned(),
        None => std::env::var(k).ok(),
    };
    let prog = litesim_osc::load_with(path, &opts.include, &env, opts.dialect)?;
    let source_hash = {
        let mut all = Vec::new();
        for f in &prog.sources.files {
            all.extend_from_slice(f.text.as_bytes());
            all.push(0);
        }
        sha256_hex(&all)
    };
    if prog.has_errors() {
        let diagnostics: Vec<String> = prog
            .diagnostics
            .iter()
            .filter(|d| d.severity == litesim_osc::Severity::Error)
            .map(|d| d.render(&prog.sources))
            .collect();
        return Err(ScenarioError::Invalid { diagnostics });
    }
    let test = elab::elaborate(&prog)?;
    let carla_map = prog.carla.as_ref().and_then(|c| c.map.as_ref());
    let map_path = match (&opts.map, &test.config.map) {
        (Some(p), _) => Some(p.clone()),
        (None, _) if let Some((name, span)) = carla_map => Some(
            carla_map_file(path, name, opts.map_dir.as_deref()).map_err(|source| {
                let f = prog.sources.file(span.file);
                let (line, col) = f.line_col(span.start as usize);
                ScenarioError::MapFile {
                    at: format!("{}:{line}:{col}", f.path),
                    source,
                }
            })?,
        ),
        (None, Some(m)) if !m.is_empty() => {
            let expanded = litesim_osc::loader::expand_env(m, &env).map_err(
                |litesim_osc::loader::UnsetVar(v)| {
                    ScenarioError::Map(format!("test_config.map '{m}' uses ${v}, which is not set"))
                },
            )?;
            // A path written in the test is relative to the test's folder
            // only: a map found through the current directory would make
            // results depend on where the command ran. One that starts
            // from an environment variable (`$FTX/…`, the seed's layout)
            // is where that variable says, as a shell would read it;
            // `--map` names a map relative to where you are.
            let p = PathBuf::from(&expanded);
            let from_env = m.trim_start().starts_with('$');
            Some(if p.is_relative() && !from_env {
                path.parent().unwrap_or(Path::new(".")).join(&p)
            } else {
                p
            })
        }
        _ => None,
    };
    let (net, map_text, map_name) = match map_path {
        Some(p) => {
            let name = p.display().to_string();
            // The guarded read (a regular file, at most MAX_MAP_BYTES).
            let text = RoadNetwork::read_text(&p).map_err(|source| ScenarioError::MapParse {
                name: name.clone(),
                source,
            })?;
            let net =
                RoadNetwork::from_xodr(&text, &name).map_err(|source| ScenarioError::MapParse {
                    name: name.clone(),
                    source,
                })?;
            (Some(Arc::new(net)), Some(Arc::new(text)), name)
        }
        None => (None, None, String::new()),
    };
    let has_lights = net.as_ref().is_some_and(|n| {
        n.roads()
            .iter()
            .any(|r| r.signals.iter().any(|s| s.dynamic))
    });
    Ok(Prepared {
        lanes: Default::default(),
        calibrations: Default::default(),
        has_lights,
        source_hash,
        path: path.to_path_buf(),
        test,
        net,
        map_text,
        map_name,
        xosc: None,
    })
}

/// `calibration/PROFILE.toml` in the test's folder or the nearest
/// ancestor that has one.
/// The path is returned relative to the test's folder (`../../calibration/
/// dummy.toml`) joined to it as given, so that what a summary names does
/// not depend on where the checkout lives or where the command ran.
pub fn calibration_near(test: &Path, profile: &str) -> Option<PathBuf> {
    let given = test.parent().unwrap_or(Path::new(""));
    // Ancestors of the real folder (a relative path's own ancestors would
    // end at the current directory, which is not where the test lives).
    let real = std::fs::canonicalize(if given.as_os_str().is_empty() {
        Path::new(".")
    } else {
        given
    })
    .ok()?;
    let file = PathBuf::from("calibration").join(format!("{profile}.toml"));
    real.ancestors().enumerate().find_map(|(up, d)| {
        d.join(&file).is_file().then(|| {
            let mut rel = given.to_path_buf();
            for _ in 0..up {
                rel.push("..");
            }
            rel.join(&file)
        })
    })
}

/// Lower-case hex SHA-256 of `bytes` (content hashes in manifests and
/// summaries).
pub fn sha256_hex(bytes: &[u8]) -> String {
    use sha2::Digest;
    sha2::Sha256::digest(bytes)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

/// The calibration file a run under `profile` reads when `opts` gives no
/// gains: in `calibration_dir`, else (when asked) beside the test.
pub(crate) fn calibration_file(
    prep: &Prepared,
    opts: &RunOptions,
    profile: &str,
) -> Option<PathBuf> {
    match &opts.calibration_dir {
        Some(dir) => Some(dir.join(format!("{profile}.toml"))),
        None if opts.calibration_near_test => calibration_near(&prep.path, profile),
        None => None,
    }
}
