//! SIGINT (Ctrl-C) and SIGTERM. The handler only stores the signal in atomics; every phase polls
//! [`CANCEL`] in its inner loops and returns `Error::Interrupted`, so nothing is written. A watchdog
//! backs this up for the waits that cannot poll (an `open` blocked on a FIFO, a kd-tree build inside
//! FLANN): while it is armed — that is, before any output exists — it ends the process
//! [`GRACE`] after the signal.
//!
//! This is an FFI module (`sigaction`, `_exit`); its `unsafe` blocks are the only ones outside the
//! Embree, FLANN and OpenImageIO wrappers.

use std::sync::atomic::{AtomicBool, AtomicI32, Ordering};
use std::sync::Mutex;
use std::time::Duration;

/// Set by the first SIGINT or SIGTERM; the render's cancellation flag.
pub static CANCEL: AtomicBool = AtomicBool::new(false);
static SIGNAL: AtomicI32 = AtomicI32::new(0);
/// Whether the watchdog may end the process (no output file, not even a temporary one, exists).
static ARMED: Mutex<bool> = Mutex::new(false);

/// How long the watchdog lets cooperative cancellation work before it ends the process.
pub(crate) const GRACE: Duration = Duration::from_millis(800);

extern "C" fn on_signal(sig: libc::c_int) {
    // Only atomic stores: async-signal-safe.
    SIGNAL.store(sig, Ordering::SeqCst);
    CANCEL.store(true, Ordering::SeqCst);
}

/// Installs the handler for SIGINT and SIGTERM and starts the (disarmed) watchdog. A signal the parent
/// set to be ignored stays ignored (a shell's background job ignores SIGINT so that Ctrl-C spares it).
pub fn install() -> std::io::Result<()> {
    for sig in [libc::SIGINT, libc::SIGTERM] {
        // SAFETY: `sa` and `old` are fully initialised (zeroed, then the handler and an empty mask); the
        // handler only performs atomic stores, which are async-signal-safe.
        let rc = unsafe {
            let mut old: libc::sigaction = std::mem::zeroed();
            if libc::sigaction(sig, std::ptr::null(), &mut old) == 0
                && old.sa_sigaction == libc::SIG_IGN
            {
                continue;
            }
            let mut sa: libc::sigaction = std::mem::zeroed();
            sa.sa_sigaction = on_signal as extern "C" fn(libc::c_int) as libc::sighandler_t;
            sa.sa_flags = libc::SA_RESTART;
            libc::sigemptyset(&mut sa.sa_mask);
            libc::sigaction(sig, &sa, std::ptr::null_mut())
        };
        if rc != 0 {
            return Err(std::io::Error::last_os_error());
        }
    }
    std::thread::Builder::new()
        .name("pmrender-watchdog".into())
        .spawn(watchdog)?;
    Ok(())
}

/// Exit status for the signal received: 130 for SIGINT, 143 for SIGTERM (128 + signal number).
pub fn exit_code() -> i32 {
    match SIGNAL.load(Ordering::SeqCst) {
        0 => 130,
        s => 128 + s,
    }
}

/// Lets the watchdog end the process (`true`) or not. Disarming waits for a watchdog that is ending
/// the process, so once this returns `false`-armed, files may be created safely.
pub fn arm(armed: bool) {
    match ARMED.lock() {
        Ok(mut a) => *a = armed,
        Err(p) => *p.into_inner() = armed,
    }
}

fn watchdog() {
    while !CANCEL.load(Ordering::SeqCst) {
        std::thread::sleep(Duration::from_millis(20));
    }
    std::thread::sleep(GRACE);
    let guard = match ARMED.lock() {
        Ok(g) => g,
        Err(p) => p.into_inner(),
    };
    if *guard {
        eprintln!(
            "pmrender: interrupted (stopped by the watchdog {} ms after the signal)",
            GRACE.as_millis()
        );
        // SAFETY: `_exit` ends the process without running atexit handlers or destructors, which
        // other threads may still be using; no output file exists while the watchdog is armed.
        unsafe { libc::_exit(exit_code()) };
    }
}
