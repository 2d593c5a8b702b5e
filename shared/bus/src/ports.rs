//! Loopback ports for clusters started by tests and benchmarks.

use std::net::TcpListener;
use std::sync::atomic::{AtomicU32, Ordering};

const FIRST: u32 = 20_000;
const SPAN: u32 = 12_000;

/// A loopback TCP port that is free now, for a cluster to listen on.
///
/// It lies below the kernel's ephemeral range (32768 and up), so no outgoing
/// connection (another cluster's Zenoh session, say) can take it between this
/// check and the cluster's own bind, which is how a port from `bind(":0")` is
/// lost; the process id and a counter spread processes that ask at once.
pub fn free_loopback_port() -> std::io::Result<u16> {
    static NEXT: AtomicU32 = AtomicU32::new(0);
    let start = std::process::id().wrapping_mul(97);
    for _ in 0..SPAN {
        let k = NEXT.fetch_add(1, Ordering::Relaxed);
        let port = (FIRST + start.wrapping_add(k.wrapping_mul(13)) % SPAN) as u16;
        if TcpListener::bind(("127.0.0.1", port)).is_ok() {
            return Ok(port);
        }
    }
    Err(std::io::Error::new(
        std::io::ErrorKind::AddrInUse,
        format!("no free loopback port in {FIRST}..{}", FIRST + SPAN),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ports_are_below_the_ephemeral_range_and_bindable() {
        let a = free_loopback_port().expect("a free port");
        let b = free_loopback_port().expect("a free port");
        assert_ne!(a, b, "two calls in one process give two ports");
        for p in [a, b] {
            // The kernel's ephemeral range starts at 32768.
            assert!(
                (FIRST..FIRST + SPAN).contains(&u32::from(p)) && p < 32_768,
                "{p}"
            );
            TcpListener::bind(("127.0.0.1", p)).expect("still free");
        }
    }
}
