//! Errors of the scenario engine: each says where (file:line:col when it
//! comes from the test) and what was expected.

use thiserror::Error;

/// What can go wrong between a test file and a run summary.
#[derive(Debug, Error)]
pub enum ScenarioError {
    /// The test could not be read or parsed; the text holds every diagnostic.
    #[error("{0}")]
    Load(String),
    /// The test uses something the engine cannot execute.
    #[error("elaboration: {0}")]
    Elaboration(String),
    /// The constraints have no solution on this map.
    #[error("constraints: {0}")]
    Unsatisfiable(String),
    /// The map is missing or named wrongly.
    #[error("map: {0}")]
    Map(String),
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
    /// Files.
    #[error("{0}")]
    Io(String),
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
    /// prints), for summaries and batch lines.
    pub fn chain(&self) -> String {
        let mut text = self.to_string();
        let mut cause = std::error::Error::source(self);
        while let Some(c) = cause {
            text.push_str(": ");
            text.push_str(&c.to_string());
            cause = c.source();
        }
        text
    }

    /// `top.main` has nothing to do.
    pub(crate) fn no_behaviour() -> Self {
        ScenarioError::Plan("top.main has no behaviour (add `extend top.main: do …`)".into())
    }
}
