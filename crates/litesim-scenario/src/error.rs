//! Errors of the scenario engine: each says where (file:line:col when it
//! comes from the test) and what was expected.

use thiserror::Error;

/// What can go wrong between a test file and a run summary.
#[derive(Debug, Error)]
pub enum ScenarioError {
    /// The test's entry file could not be read.
    #[error(transparent)]
    Load(#[from] litesim_osc::LoadError),
    /// An OpenSCENARIO XML file that cannot be read (file:line:col, the
    /// element path, what was expected).
    #[error(transparent)]
    Xosc(#[from] litesim_xosc::XoscError),
    /// The test has errors: each diagnostic rendered (where, what, what was
    /// expected).
    #[error("{}", diagnostics.join("\n"))]
    Invalid {
        /// The rendered diagnostics, in order.
        diagnostics: Vec<String>,
    },
    /// The test uses something the engine cannot execute.
    #[error("elaboration: {0}")]
    Elaboration(String),
    /// The constraints have no solution on this map.
    #[error("constraints: {0}")]
    Unsatisfiable(String),
    /// The map is missing or named wrongly.
    #[error("map: {0}")]
    Map(String),
    /// A CARLA scenario's map name has no OpenDRIVE file; `at` is the
    /// `set_map` call's file:line:col.
    #[error("map: {at}")]
    MapFile {
        /// Where the map is named.
        at: String,
        /// Which name, and where litesim looked.
        #[source]
        source: crate::load::MapFileError,
    },
    /// Ambient traffic cannot be placed; `at` is where the test asks for it.
    #[error("elaboration: {at}")]
    Traffic {
        /// Where the traffic is declared.
        at: String,
        /// Why.
        #[source]
        source: crate::runtime::traffic::spawn::TooManyVehicles,
    },
    /// The map file could not be read (missing, not a regular file, larger
    /// than the map reader takes) or is not valid OpenDRIVE.
    #[error("map {name}")]
    MapParse {
        /// The file.
        name: String,
        /// Where and what.
        #[source]
        source: litesim_map::MapError,
    },
    /// The behaviour cannot be planned (e.g. no lane to the left).
    #[error("plan: {0}")]
    Plan(String),
    /// The simulator refused a call.
    #[error("simulator")]
    Ssp(#[source] litesim_ssp::SspError),
    /// The simulator answered something the engine cannot use.
    #[error("simulator: {0}")]
    Simulator(String),
    /// An input file (a manifest, results, coverage, a calibration) could
    /// not be read.
    #[error(transparent)]
    Read(#[from] litesim_core::files::ReadError),
    /// A file or folder could not be written.
    #[error("{}", path.display())]
    Write {
        /// The file or folder.
        path: std::path::PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// A log-crate write (atomic files) failed.
    #[error(transparent)]
    Log(#[from] litesim_log::LogError),
    /// A file's content is not what it should hold (JSON, TOML).
    #[error("{what}")]
    Format {
        /// The file or the thing (`calibration`).
        what: String,
        /// The parser's error.
        #[source]
        source: Box<dyn std::error::Error + Send + Sync>,
    },
    /// A batch's spec or folders do not fit together (a shard, a seed
    /// range, a folder of another batch, conflicting results).
    #[error("{0}")]
    Batch(String),
    /// An error found once and shared by every run of a test (a
    /// calibration file that does not parse).
    #[error(transparent)]
    Shared(std::sync::Arc<ScenarioError>),
    /// A worker pool could not be made.
    #[error("cannot start the worker threads")]
    Threads(#[source] rayon::ThreadPoolBuildError),
    /// The system under test could not be started.
    #[error("cannot start the system under test {name}")]
    Sut {
        /// Its name (`grpc://…`).
        name: String,
        /// Why.
        #[source]
        source: crate::sut::SutError,
    },
}

impl ScenarioError {
    /// The error and its causes, `: `-joined (what `{:#}` of anyhow
    /// prints), for summaries and batch lines ([`chain_of`]).
    pub fn chain(&self) -> String {
        chain_of(self)
    }

    /// A file or folder could not be written.
    pub(crate) fn write(path: &std::path::Path, source: std::io::Error) -> Self {
        ScenarioError::Write {
            path: path.to_path_buf(),
            source,
        }
    }

    /// A file's content is not what it should hold.
    pub(crate) fn format(
        what: impl std::fmt::Display,
        source: impl std::error::Error + Send + Sync + 'static,
    ) -> Self {
        ScenarioError::Format {
            what: what.to_string(),
            source: Box::new(source),
        }
    }

    /// `top.main` has nothing to do.
    pub(crate) fn no_behaviour() -> Self {
        ScenarioError::Plan("top.main has no behaviour (add `extend top.main: do …`)".into())
    }
}

/// Any error and its causes, `: `-joined: what summaries, batch lines and
/// the Python package's exceptions say (a map error says where in the
/// file, an I/O error which file).
pub fn chain_of(e: &dyn std::error::Error) -> String {
    let mut text = e.to_string();
    let mut cause = e.source();
    while let Some(c) = cause {
        text.push_str(": ");
        text.push_str(&c.to_string());
        cause = c.source();
    }
    text
}
