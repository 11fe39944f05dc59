//! Cancellation of long CPU loops. A job hands its work a keep-going predicate
//! ([`crate::methods::Env::keep_going`], a bake's progress callback): false once the job is
//! canceled, timed out or the server shuts down. Loops over pixels, photons, triangles or
//! samples ask it every 10–100 ms of work (per row, per chunk of a parallel loop, per sun or
//! sample) through a [`Stop`], and end with [`Canceled`]: never a partial result presented as
//! a whole one.

use std::sync::atomic::{AtomicBool, Ordering::Relaxed};

/// The predicate work is handed: false once it should stop.
pub type KeepGoing<'a> = &'a (dyn Fn() -> bool + Sync);

/// Work stopped because its keep-going predicate said so.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[error("canceled")]
pub struct Canceled;

impl From<Canceled> for crate::methods::MethodError {
    fn from(_: Canceled) -> Self {
        crate::methods::MethodError::Canceled
    }
}

impl From<Canceled> for crate::bake::BakeError {
    fn from(_: Canceled) -> Self {
        crate::bake::BakeError::Canceled
    }
}

/// A keep-going predicate shared by the workers of a (parallel) loop: once it has said stop,
/// a flag remembers it, so that every worker stops at its next test without asking again.
pub struct Stop<'a> {
    ask: KeepGoing<'a>,
    stopped: AtomicBool,
}

impl<'a> Stop<'a> {
    pub fn new(ask: KeepGoing<'a>) -> Stop<'a> {
        Stop {
            ask,
            stopped: AtomicBool::new(false),
        }
    }

    /// Asks the predicate (not once it has said stop): whether to go on.
    pub fn go(&self) -> bool {
        if self.stopped.load(Relaxed) {
            return false;
        }
        if (self.ask)() {
            true
        } else {
            self.stopped.store(true, Relaxed);
            false
        }
    }

    /// Whether the predicate has said stop, without asking it.
    pub fn stopped(&self) -> bool {
        self.stopped.load(Relaxed)
    }

    /// The per-item test of a loop: asks the predicate at every `every`-th item `k`
    /// (`k % every == 0`), only reads the flag otherwise.
    #[inline]
    pub fn go_at(&self, k: usize, every: usize) -> bool {
        if k.is_multiple_of(every.max(1)) {
            self.go()
        } else {
            !self.stopped()
        }
    }

    /// Err(Canceled) once the predicate says stop (asking it now).
    pub fn check(&self) -> Result<(), Canceled> {
        if self.go() { Ok(()) } else { Err(Canceled) }
    }

    /// Err(Canceled) when the predicate has said stop (without asking): the test after a
    /// loop whose workers asked.
    pub fn checked(&self) -> Result<(), Canceled> {
        if self.stopped() {
            Err(Canceled)
        } else {
            Ok(())
        }
    }
}

/// A predicate for tests: true for the first `n` calls, false after; it counts the calls.
#[cfg(test)]
pub(crate) struct CountDown {
    pub n: usize,
    pub calls: std::sync::atomic::AtomicUsize,
}

#[cfg(test)]
impl CountDown {
    pub fn new(n: usize) -> CountDown {
        CountDown {
            n,
            calls: std::sync::atomic::AtomicUsize::new(0),
        }
    }

    /// The predicate.
    pub fn ask(&self) -> bool {
        self.calls.fetch_add(1, Relaxed) < self.n
    }

    pub fn calls(&self) -> usize {
        self.calls.load(Relaxed)
    }
}

/// Runs `run` with a predicate that always says go, counting its questions (at least `min`:
/// it is asked inside the loops, not only between them), then with predicates that say stop
/// after the first question, a quarter, half and all but the last of them: each run must end
/// canceled (`canceled`), having asked more than that many. The number of questions.
#[cfg(test)]
pub(crate) fn assert_cancels<T, E: std::fmt::Debug>(
    min: usize,
    run: impl Fn(KeepGoing) -> Result<T, E>,
    canceled: impl Fn(&E) -> bool,
) -> usize {
    let all = CountDown::new(usize::MAX);
    if let Err(e) = run(&|| all.ask()) {
        panic!("failed when never asked to stop: {e:?}");
    }
    let total = all.calls();
    assert!(total >= min, "asked {total} times, fewer than {min}");
    let mut at = vec![1, total / 4, total / 2, total - 1];
    at.dedup();
    for n in at.into_iter().filter(|&n| n < total) {
        let c = CountDown::new(n);
        match run(&|| c.ask()) {
            Ok(_) => panic!("not canceled when told to stop after {n} of {total} questions"),
            Err(e) => assert!(canceled(&e), "stopped after {n} of {total} with {e:?}"),
        }
        assert!(
            c.calls() > n,
            "{} questions, told to stop after {n}",
            c.calls()
        );
    }
    total
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_stop_asks_until_told_then_only_remembers() {
        let c = CountDown::new(2);
        let ask = || c.ask();
        let s = Stop::new(&ask);
        assert!(s.go() && s.go());
        assert!(!s.go());
        assert!(s.stopped() && !s.go() && !s.go_at(0, 4));
        assert_eq!(s.check(), Err(Canceled));
        assert_eq!(c.calls(), 3);
        let ask = || true;
        let s = Stop::new(&ask);
        assert!(s.go_at(3, 4) && s.check().is_ok() && s.checked().is_ok());
    }
}
