//! Real-time facilities of Linux: absolute-deadline sleeping, SCHED_FIFO, locked memory.

use std::io;

/// Nanoseconds on CLOCK_MONOTONIC, the clock `clock_nanosleep` sleeps on.
pub fn monotonic_ns() -> u64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: ts is a valid, writable timespec; CLOCK_MONOTONIC always exists on Linux.
    unsafe { libc::clock_gettime(libc::CLOCK_MONOTONIC, &mut ts) };
    ts.tv_sec as u64 * 1_000_000_000 + ts.tv_nsec as u64
}

/// Sleep until an absolute CLOCK_MONOTONIC time. Absolute deadlines do not accumulate the drift
/// that relative sleeps (`sleep(period - elapsed)`) add every cycle.
pub fn sleep_until_ns(deadline_ns: u64) {
    let ts = libc::timespec {
        tv_sec: (deadline_ns / 1_000_000_000) as libc::time_t,
        tv_nsec: (deadline_ns % 1_000_000_000) as libc::c_long,
    };
    loop {
        // SAFETY: ts is a valid timespec; the remainder pointer may be null with TIMER_ABSTIME.
        let rc = unsafe {
            libc::clock_nanosleep(
                libc::CLOCK_MONOTONIC,
                libc::TIMER_ABSTIME,
                &ts,
                std::ptr::null_mut(),
            )
        };
        // Interrupted by a signal: sleep again to the same absolute deadline.
        if rc != libc::EINTR {
            return;
        }
    }
}

/// Ask for SCHED_FIFO at `priority` for the calling thread.
pub fn set_fifo_priority(priority: i32) -> io::Result<()> {
    let param = libc::sched_param {
        sched_priority: priority,
    };
    // SAFETY: param is valid; 0 means the calling thread.
    let rc = unsafe { libc::sched_setscheduler(0, libc::SCHED_FIFO, &param) };
    if rc == 0 {
        Ok(())
    } else {
        Err(io::Error::last_os_error())
    }
}

/// Lock current and future pages in RAM.
pub fn lock_memory() -> io::Result<()> {
    // SAFETY: plain system call with flag arguments.
    let rc = unsafe { libc::mlockall(libc::MCL_CURRENT | libc::MCL_FUTURE) };
    if rc == 0 {
        Ok(())
    } else {
        Err(io::Error::last_os_error())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sleeping_to_an_absolute_deadline_never_wakes_early() {
        let start = monotonic_ns();
        for k in 1..=5 {
            let deadline = start + k * 1_000_000;
            sleep_until_ns(deadline);
            assert!(monotonic_ns() >= deadline);
        }
    }
}
