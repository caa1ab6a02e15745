//! On-CPU time (`clock_gettime`): unlike wall time, it does not count the time other
//! processes of a busy machine take, so timings stay comparable on a shared box.

/// On-CPU time of the calling thread, seconds, where the platform has it.
pub fn thread_seconds() -> Option<f64> {
    clock(CLOCK_THREAD)
}

/// On-CPU time of the whole process (all threads), seconds, where the platform has it.
pub fn process_seconds() -> Option<f64> {
    clock(CLOCK_PROCESS)
}

#[cfg(unix)]
const CLOCK_THREAD: i32 = libc::CLOCK_THREAD_CPUTIME_ID;
#[cfg(unix)]
const CLOCK_PROCESS: i32 = libc::CLOCK_PROCESS_CPUTIME_ID;
#[cfg(not(unix))]
const CLOCK_THREAD: i32 = 0;
#[cfg(not(unix))]
const CLOCK_PROCESS: i32 = 0;

#[cfg(unix)]
fn clock(id: i32) -> Option<f64> {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `ts` is a valid, writable timespec for the duration of the call.
    let rc = unsafe { libc::clock_gettime(id as libc::clockid_t, &mut ts) };
    (rc == 0).then_some(ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9)
}

#[cfg(not(unix))]
fn clock(_id: i32) -> Option<f64> {
    None
}
