//! Events: the times where a function of the state crosses zero, found between the ends of
//! each accepted step and located on the step's continuous extension (the dense output of
//! DOPRI5, DOP853 and Vern9, the Taylor method's own series), as `solve_ivp`'s `events`,
//! DifferentialEquations.jl's `ContinuousCallback` and heyoka's events do. A terminal event
//! ends the integration there.
//!
//! A crossing is seen when the condition's sign differs at the two ends of a step (so two
//! crossings inside one step cancel and go unseen, as in `solve_ivp`); the root is then
//! bracketed and refined by the Anderson–Björck variant of regula falsi on the continuous
//! extension until the bracket is a few units in the last place of t wide. Its accuracy is the
//! continuous extension's: to the tolerance the integration was asked for.

use serde::{Deserialize, Serialize};

/// Which sign changes of an event's condition count.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Crossing {
    /// From negative to positive.
    Rising,
    /// From positive to negative.
    Falling,
    /// Either way.
    #[default]
    Either,
}

impl Crossing {
    /// Whether going from `before` to `after` is a crossing of this kind (a zero at the start of
    /// a step is not one: it was counted, or was the initial state).
    fn between(self, before: f64, after: f64) -> bool {
        let rising = before < 0.0 && after >= 0.0;
        let falling = before > 0.0 && after <= 0.0;
        match self {
            Crossing::Rising => rising,
            Crossing::Falling => falling,
            Crossing::Either => rising || falling,
        }
    }
}

/// The condition of an event: g(t, y), whose zeros are the event.
pub type Condition<'a> = dyn Fn(f64, &[f64]) -> f64 + Sync + 'a;

/// A zero of `condition` to find while integrating.
pub struct Event<'a> {
    /// The condition g(t, y).
    pub condition: Box<Condition<'a>>,
    /// Which crossings count.
    pub crossing: Crossing,
    /// Whether the integration ends at the first crossing.
    pub terminal: bool,
}

impl std::fmt::Debug for Event<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Event")
            .field("crossing", &self.crossing)
            .field("terminal", &self.terminal)
            .finish_non_exhaustive()
    }
}

/// An event found: which one, when, and the state there.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct EventHit {
    /// Index of the event in the list given to [`crate::integrate_with_events`].
    pub event: usize,
    /// The time of the crossing.
    pub t: f64,
    /// The state at `t` (projected like an output, for a system that projects).
    pub y: Vec<f64>,
    /// Whether it ended the integration.
    pub terminal: bool,
}

/// The events' conditions at the start of the current step, and the crossings found in the
/// last one (buffers kept, so that watching allocates nothing per step).
pub(crate) struct Watch<'e, 'a> {
    events: &'e [Event<'a>],
    /// The conditions see the state's first `dim` components (not the forces' work).
    dim: usize,
    before: Vec<f64>,
    /// The crossings in the last step, in step order, up to the first terminal one.
    pub found: Vec<Found>,
    /// Room for a state, for locating.
    scratch: Vec<f64>,
    /// Room for a state, lent to the driver.
    pub lent: Vec<f64>,
}

/// A crossing inside a step: which event, and where in the step (θ in (0, 1]).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Found {
    pub event: usize,
    pub theta: f64,
}

impl<'e, 'a> Watch<'e, 'a> {
    /// The conditions at the initial point.
    pub fn new(events: &'e [Event<'a>], t0: f64, y0: &[f64], dim: usize) -> Self {
        let before = events
            .iter()
            .map(|e| (e.condition)(t0, &y0[..dim]))
            .collect();
        Watch {
            events,
            dim,
            before,
            found: Vec::new(),
            scratch: vec![0.0; y0.len()],
            lent: vec![0.0; y0.len()],
        }
    }

    /// Whether there is anything to watch.
    pub fn is_empty(&self) -> bool {
        self.events.is_empty()
    }

    /// How many components of the state the events see.
    pub fn dim(&self) -> usize {
        self.dim
    }

    /// Finds the crossings over the step from `t` to `t + h` ending at `y_new`, located on
    /// `state(θ, out)` (the continuous extension at `t + θh`), into `found`; returns their
    /// number. The conditions at the step's end are kept for the next step.
    pub fn step(
        &mut self,
        t: f64,
        h: f64,
        y_new: &[f64],
        state: &mut dyn FnMut(f64, &mut [f64]),
    ) -> usize {
        self.found.clear();
        let (dim, y) = (self.dim, &mut self.scratch);
        for (i, e) in self.events.iter().enumerate() {
            let after = (e.condition)(t + h, &y_new[..dim]);
            if e.crossing.between(self.before[i], after) {
                let mut g = |theta: f64| {
                    state(theta, y);
                    (e.condition)(t + theta * h, &y[..dim])
                };
                let theta = locate(&mut g, self.before[i], after, h, t);
                self.found.push(Found { event: i, theta });
            }
            self.before[i] = after;
        }
        self.found.sort_by(|a, b| a.theta.total_cmp(&b.theta));
        if let Some(k) = self
            .found
            .iter()
            .position(|f| self.events[f.event].terminal)
        {
            self.found.truncate(k + 1);
        }
        self.found.len()
    }

    /// Whether event `i` ends the integration.
    pub fn terminal(&self, i: usize) -> bool {
        self.events[i].terminal
    }
}

/// The zero of `g` in (0, 1] given g(0) = `g0` and g(1) = `g1` of opposite signs (or g1 = 0):
/// Anderson–Björck regula falsi, to a bracket no wider than a few ulps of `t` (in units of the
/// step `h`), or 100 iterations. The end of the bracket where g has the sign of `g1` is
/// returned, so that at the time reported the crossing has happened.
fn locate(g: &mut dyn FnMut(f64) -> f64, g0: f64, g1: f64, h: f64, t: f64) -> f64 {
    if g1 == 0.0 {
        return 1.0;
    }
    // (a, ga) the end kept longest, (b, gb) the latest point; the zero lies between them.
    let (mut a, mut b, mut ga, mut gb) = (0.0_f64, 1.0_f64, g0, g1);
    let width = 4.0 * f64::EPSILON * (t.abs() + h.abs()) / h.abs();
    for _ in 0..100 {
        if (b - a).abs() <= width {
            break;
        }
        let c = b - gb * (b - a) / (gb - ga);
        let (lo, hi) = (a.min(b), a.max(b));
        let c = if c > lo && c < hi { c } else { 0.5 * (a + b) };
        let gc = g(c);
        if gc == 0.0 {
            return c;
        }
        if gc.signum() != gb.signum() {
            (a, ga) = (b, gb);
        } else {
            // a stays an end: Anderson–Björck's scaling of its value
            let m = 1.0 - gc / gb;
            ga *= if m > 0.0 { m } else { 0.5 };
        }
        (b, gb) = (c, gc);
    }
    if gb.signum() == g1.signum() { b } else { a }
}
