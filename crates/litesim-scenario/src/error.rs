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
    /// The map could not be loaded.
    #[error("map: {0}")]
    Map(String),
    /// The behaviour cannot be planned (e.g. no lane to the left).
    #[error("plan: {0}")]
    Plan(String),
    /// The plan breaks the profile's post-plan limits.
    #[error("post-plan checks failed:\n  {}", .0.join("\n  "))]
    PostPlan(Vec<String>),
    /// The simulator refused a call.
    #[error("simulator: {0}")]
    Ssp(String),
    /// Files.
    #[error("{0}")]
    Io(String),
    /// The system under test could not be started.
    #[error("system under test: {0}")]
    Sut(String),
}

impl ScenarioError {
    /// `top.main` has nothing to do.
    pub(crate) fn no_behaviour() -> Self {
        ScenarioError::Plan("top.main has no behaviour (add `extend top.main: do …`)".into())
    }
}
