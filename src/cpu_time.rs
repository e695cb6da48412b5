//! CPU time of the calling thread: what `simserpent bench` compares besides wall time.
//!
//! Wall time on a shared machine measures the neighbours as much as the program; the CPU time a
//! thread was actually given (`CLOCK_THREAD_CPUTIME_ID`: time on a core, not time waiting for
//! one or blocked) does not depend on how many other processes want the cores. It still
//! depends on what shares the caches and memory with the thread (another thread of the same
//! process, another process on the sibling core). On Windows the same time comes from
//! `GetThreadTimes`.

/// Nanoseconds of CPU time the calling thread has used since it started (0 if the clock cannot
/// be read, which POSIX systems do not do for this clock).
#[cfg(unix)]
pub fn thread_cpu_ns() -> u64 {
    let mut t = libc::timespec { tv_sec: 0, tv_nsec: 0 };
    // SAFETY: `clock_gettime` writes one `timespec` through a valid pointer to a local.
    #[allow(unsafe_code)]
    let rc = unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut t) };
    if rc != 0 {
        return 0;
    }
    u64::try_from(t.tv_sec).unwrap_or(0) * 1_000_000_000 + u64::try_from(t.tv_nsec).unwrap_or(0)
}

/// Nanoseconds of CPU time (kernel and user) the calling thread has used since it started,
/// from `GetThreadTimes` (0 if it fails). Windows counts it in scheduler ticks (about 15.6 ms).
#[cfg(windows)]
pub fn thread_cpu_ns() -> u64 {
    windows::thread_cpu_ns()
}

#[cfg(windows)]
#[allow(unsafe_code)]
mod windows {
    use std::ffi::c_void;

    /// A time in units of 100 ns, as two 32-bit halves.
    #[repr(C)]
    #[derive(Default)]
    struct FileTime {
        low: u32,
        high: u32,
    }

    #[link(name = "kernel32")]
    unsafe extern "system" {
        fn GetCurrentThread() -> *mut c_void;
        fn GetThreadTimes(
            thread: *mut c_void,
            creation: *mut FileTime,
            exit: *mut FileTime,
            kernel: *mut FileTime,
            user: *mut FileTime,
        ) -> i32;
    }

    pub fn thread_cpu_ns() -> u64 {
        let (mut creation, mut exit, mut kernel, mut user) =
            (FileTime::default(), FileTime::default(), FileTime::default(), FileTime::default());
        // SAFETY: `GetCurrentThread` returns a pseudo-handle that needs no closing; `GetThreadTimes`
        // writes four `FILETIME`s through valid pointers to locals.
        let ok = unsafe { GetThreadTimes(GetCurrentThread(), &mut creation, &mut exit, &mut kernel, &mut user) };
        if ok == 0 {
            return 0;
        }
        let ticks = |t: &FileTime| (u64::from(t.high) << 32) | u64::from(t.low);
        (ticks(&kernel) + ticks(&user)) * 100
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_busy_thread_uses_cpu_time_and_a_sleeping_one_does_not() {
        let start = thread_cpu_ns();
        let mut x = 1u64;
        // Busy until 5 ms of CPU time (however long a loaded machine makes that in wall time);
        // a clock that does not advance with work runs into the 10 s bound and fails.
        let busy = std::time::Instant::now();
        while thread_cpu_ns() - start < 5_000_000 && busy.elapsed() < std::time::Duration::from_secs(10) {
            for _ in 0..1000 {
                x = std::hint::black_box(x.wrapping_mul(6364136223846793005).wrapping_add(1));
            }
        }
        let after_busy = thread_cpu_ns();
        assert!(after_busy - start >= 5_000_000, "busy {:?} wall, {} ns CPU", busy.elapsed(), after_busy - start);
        std::thread::sleep(std::time::Duration::from_millis(50));
        let after_sleep = thread_cpu_ns();
        assert!(after_sleep - after_busy < 10_000_000, "slept 50 ms, {} ns CPU", after_sleep - after_busy);
    }
}
