//! A strand's state of the error-controlled step (`[simulation] tolerance`): the step
//! size it tries next, what its accepted steps did (the smallest and largest step, the
//! largest estimated error, over the run and since the last frame) and its part of a
//! checkpoint. The step itself is the kernels' (`superhelix_kernels::fixed::
//! step_to_tolerance_views`, module page `fixed::error_control`: variable-step BDF2 with
//! its predictor's estimate, the energy balance, contacts), which both engines take
//! ([`super::one_step`], the embedded engine); its scheme and error norm are described
//! in docs/time-stepping.md.
//!
//! Measured: `runtime/tests/error_control.rs` (the swing against references of other
//! schemes) and `superhelix study`'s `tolerance` problem (docs/time-stepping.md).

/// One strand's state of the error-controlled step.
#[derive(Debug, Clone, Default)]
pub struct ErrorControl {
    /// The step size to try next, s (0: none yet).
    pub next_h: f64,
    /// The smallest step accepted so far, s (0: none).
    pub smallest_h: f64,
    /// The largest step accepted so far, s.
    pub largest_h: f64,
    /// The largest estimated error of an accepted step so far, relative to the length.
    pub largest_error: f64,
    /// What the accepted steps since the last [`ErrorControl::take_window`] did.
    window: StepWindow,
}

/// What the error-controlled step carries from one step to the next (a checkpoint's
/// part): the step size to try, what the accepted steps did so far and since the last
/// frame.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ErrorControlState {
    next_h: f64,
    smallest_h: f64,
    largest_h: f64,
    largest_error: f64,
    window: StepWindow,
}

impl ErrorControl {
    /// What the next step needs (see [`ErrorControlState`]).
    pub fn state(&self) -> ErrorControlState {
        ErrorControlState {
            next_h: self.next_h,
            smallest_h: self.smallest_h,
            largest_h: self.largest_h,
            largest_error: self.largest_error,
            window: self.window,
        }
    }

    /// Continue from `state`.
    pub fn restore(&mut self, state: ErrorControlState) {
        self.next_h = state.next_h;
        self.smallest_h = state.smallest_h;
        self.largest_h = state.largest_h;
        self.largest_error = state.largest_error;
        self.window = state.window;
    }
}

/// What one strand's accepted error-controlled steps did over a stretch of time (a frame).
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct StepWindow {
    /// The largest estimated error of a step, relative to the strand's length.
    pub largest_error: f64,
    /// The smallest step, s (0: no step).
    pub smallest_h: f64,
    /// The largest step, s.
    pub largest_h: f64,
}

impl StepWindow {
    fn add(&mut self, error: f64, h: f64) {
        self.largest_error = self.largest_error.max(error);
        self.smallest_h = if self.smallest_h > 0.0 {
            self.smallest_h.min(h)
        } else {
            h
        };
        self.largest_h = self.largest_h.max(h);
    }

    /// Both windows as one.
    pub fn merge(&self, other: &StepWindow) -> StepWindow {
        let mut m = *self;
        if other.smallest_h > 0.0 {
            m.add(other.largest_error, other.smallest_h);
            m.largest_h = m.largest_h.max(other.largest_h);
        }
        m
    }
}

impl ErrorControl {
    /// Add what the one step's error-controlled steps did over one call (`report`, of
    /// that call alone) to the sizes and errors so far and to the window.
    pub(super) fn record(&mut self, report: &superhelix_kernels::fixed::ToleranceReport) {
        if report.steps == 0 {
            return;
        }
        let window = StepWindow {
            largest_error: report.largest_error,
            smallest_h: report.smallest_step,
            largest_h: report.largest_step,
        };
        self.window = self.window.merge(&window);
        self.largest_error = self.largest_error.max(report.largest_error);
        self.largest_h = self.largest_h.max(report.largest_step);
        self.smallest_h = if self.smallest_h > 0.0 {
            self.smallest_h.min(report.smallest_step)
        } else {
            report.smallest_step
        };
    }

    /// What the accepted steps did since the last call (or the start), and start anew.
    pub fn take_window(&mut self) -> StepWindow {
        std::mem::take(&mut self.window)
    }
}
