//! The software rasteriser's share of the cores. Without a GPU, Mesa's
//! lavapipe draws the window on the CPU with one thread per core
//! (`llvmpipe-N`), and a window frame of the editor costs ~100 ms of CPU: at
//! normal priority drawing took a third of the simulation's time. Its
//! threads are put in the idle class, so they draw on what the simulation
//! leaves free (it keeps ~0.5 of 2 cores idle in its serial parts). Should a
//! scene keep every core busy, a frame that takes too long gives them their
//! normal share back: the window never freezes.

use std::time::Duration;

/// A window frame slower than this, wall time, gives the rasteriser its
/// normal priority back.
pub const STARVED_FRAME: Duration = Duration::from_millis(500);

/// Whether the rasteriser's threads yield to the simulation.
#[derive(Debug, Default)]
pub struct RasteriserPriority {
    yielding: bool,
}

impl RasteriserPriority {
    /// Puts the rasteriser's threads (they exist once the device does) in
    /// the idle scheduling class.
    pub fn yield_to_the_simulation(&mut self) {
        self.yielding = set_policy(Policy::Idle) > 0;
    }

    /// Called with each window frame's wall time: a starved frame gives the
    /// rasteriser its normal share back, for the rest of the session.
    pub fn frame_took(&mut self, wall: Duration) {
        if self.yielding && wall > STARVED_FRAME {
            set_policy(Policy::Normal);
            self.yielding = false;
        }
    }
}

/// A Linux scheduling class for a thread.
#[derive(Clone, Copy)]
enum Policy {
    /// Runs only on otherwise idle cores (SCHED_IDLE).
    Idle,
    /// The default time-sharing class (SCHED_OTHER).
    Normal,
}

/// Sets `policy` on this process's rasteriser threads; how many it set.
#[cfg(target_os = "linux")]
fn set_policy(policy: Policy) -> usize {
    let class = match policy {
        Policy::Idle => libc::SCHED_IDLE,
        Policy::Normal => libc::SCHED_OTHER,
    };
    let tasks = std::fs::read_dir("/proc/self/task").into_iter().flatten().flatten();
    let rasteriser = tasks.filter(|task| {
        std::fs::read_to_string(task.path().join("comm")).is_ok_and(|name| name.starts_with("llvmpipe"))
    });
    let ids = rasteriser.filter_map(|task| task.file_name().to_str()?.parse::<libc::pid_t>().ok());
    let param = libc::sched_param { sched_priority: 0 };
    // SAFETY: sched_setscheduler only reads `param`; on Linux a thread id
    // names that thread. A failure leaves its class as it was, harmless.
    ids.filter(|&id| unsafe { libc::sched_setscheduler(id, class, &param) } == 0).count()
}

/// Elsewhere the threads keep the process's priority.
#[cfg(not(target_os = "linux"))]
fn set_policy(_: Policy) -> usize {
    0
}
