//! What an interrupt (Ctrl-C, SIGTERM) does at each phase of a render job.
//! The first, while rendering, stops after the pass under way and writes
//! what exists; a second, while still rendering, exits at once without
//! writing. Once writing has begun the files are finished first, whatever
//! comes: they replace the earlier files as one set, so stopping halfway
//! would gain a moment and lose the render. (SIGKILL still stops at once;
//! the next render to that name removes the temporary files it leaves.)

use std::sync::atomic::{AtomicBool, AtomicU8, Ordering};
use std::sync::Arc;

const RENDERING: u8 = 0;
const STOPPING: u8 = 1;
const WRITING: u8 = 2;
const ABANDONED: u8 = 3;

/// What the signal handler is to do with an interrupt.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reaction {
    /// Finish the pass under way, then write.
    Stop,
    /// Exit now: nothing has been written.
    Exit,
    /// The files are being written: let them finish.
    Wait,
}

/// The phase of a render job, shared with the signal handler.
#[derive(Debug, Default)]
pub struct Interrupts {
    /// Read by the render loop between passes.
    stop: Arc<AtomicBool>,
    phase: AtomicU8,
}

impl Interrupts {
    pub fn new() -> Arc<Self> {
        Arc::new(Self::default())
    }

    /// The flag the render loop watches.
    pub fn stop_flag(&self) -> Arc<AtomicBool> {
        self.stop.clone()
    }

    /// Called for each interrupt (from the signal handler's thread).
    pub fn on_signal(&self) -> Reaction {
        let moved = |from, to| {
            self.phase
                .compare_exchange(from, to, Ordering::SeqCst, Ordering::SeqCst)
                .is_ok()
        };
        if moved(RENDERING, STOPPING) {
            self.stop.store(true, Ordering::SeqCst);
            Reaction::Stop
        } else if moved(STOPPING, ABANDONED) || self.phase.load(Ordering::SeqCst) == ABANDONED {
            Reaction::Exit
        } else {
            Reaction::Wait
        }
    }

    /// Called before the first file is written: from here on interrupts
    /// wait. False if the job was abandoned (the process is exiting).
    pub fn begin_writing(&self) -> bool {
        for from in [RENDERING, STOPPING] {
            if self
                .phase
                .compare_exchange(from, WRITING, Ordering::SeqCst, Ordering::SeqCst)
                .is_ok()
            {
                return true;
            }
        }
        self.phase.load(Ordering::SeqCst) == WRITING
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interrupts_stop_then_exit_while_rendering_and_wait_while_writing() {
        let i = Interrupts::new();
        assert_eq!(i.on_signal(), Reaction::Stop);
        assert!(i.stop_flag().load(Ordering::SeqCst));
        assert_eq!(i.on_signal(), Reaction::Exit);
        assert!(!i.begin_writing(), "an abandoned job writes nothing");

        let i = Interrupts::new();
        assert_eq!(i.on_signal(), Reaction::Stop);
        assert!(i.begin_writing());
        assert_eq!(i.on_signal(), Reaction::Wait);
        assert_eq!(i.on_signal(), Reaction::Wait);

        let i = Interrupts::new();
        assert!(i.begin_writing());
        assert_eq!(i.on_signal(), Reaction::Wait);
    }
}
