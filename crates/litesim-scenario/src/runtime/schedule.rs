//! What the plan makes at its times — light switches, changes of the
//! environment —: each made at the step its time falls on, in order, and
//! a simulator chunk cut where the next one is due.

/// The step at which something planned at `t` (s) happens.
pub(crate) fn tick_of(t: f64, step_ms: u64) -> u64 {
    (t * 1000.0 / step_ms as f64).round() as u64
}

/// Something the plan makes at a time.
pub(crate) trait Timed {
    /// When (s).
    fn time(&self) -> f64;
}

impl Timed for crate::plan::LightSwitch {
    fn time(&self) -> f64 {
        self.t
    }
}

impl Timed for crate::plan::EnvChange {
    fn time(&self) -> f64 {
        self.t
    }
}

/// How far a run is through one time-ordered list of the plan's.
#[derive(Debug, Default)]
pub(crate) struct Schedule {
    next: usize,
}

impl Schedule {
    /// The next item if it is due by step `k` (made once the caller calls
    /// [`Schedule::made`]).
    pub(crate) fn due<'p, T: Timed>(&self, items: &'p [T], k: u64, step_ms: u64) -> Option<&'p T> {
        items
            .get(self.next)
            .filter(|x| tick_of(x.time(), step_ms) <= k)
    }

    /// The item [`Schedule::due`] gave is made.
    pub(crate) fn made(&mut self) {
        self.next += 1;
    }

    /// The step of the next item not made yet.
    pub(crate) fn next_tick<T: Timed>(&self, items: &[T], step_ms: u64) -> Option<u64> {
        items.get(self.next).map(|x| tick_of(x.time(), step_ms))
    }

    /// The step of the first item after step `k` (the loop's head makes
    /// every item due by `k` first).
    pub(crate) fn next_after<T: Timed>(&self, items: &[T], k: u64, step_ms: u64) -> Option<u64> {
        items[self.next.min(items.len())..]
            .iter()
            .map(|x| tick_of(x.time(), step_ms))
            .find(|&at| at > k)
    }

    /// A new plan's items: those due before step `k` belong to the past.
    pub(crate) fn replanned<T: Timed>(&mut self, items: &[T], k: u64, step_ms: u64) {
        self.next = items
            .iter()
            .filter(|x| tick_of(x.time(), step_ms) < k)
            .count();
    }
}
