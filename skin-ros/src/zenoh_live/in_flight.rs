//! Where the bytes written to the network stand at the end, read from the system's socket
//! tables (Linux): what [`ZenohOutlet::close`](super::ZenohOutlet::close) waits on.

/// Where the bytes written to the network stand (as
/// [`ZenohOutlet::close`](super::ZenohOutlet::close) found them).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct InFlight {
    /// Bytes written and not yet taken: on a connection to a process of this machine, not yet
    /// read by that process; on one to another machine, not yet acknowledged by it.
    pub bytes: u64,
    /// Connections to a process of this machine (a router or node on localhost).
    pub local: usize,
    /// Connections to other machines.
    pub remote: usize,
}

/// Where the bytes this process wrote to its TCP connections stand, read from Linux's socket
/// tables (`/proc/self/net/tcp{,6}`): for each established connection of this process, the
/// bytes the other end has not acknowledged (`tx_queue`) and, where the other end is a process
/// of this machine (its row is in the same table), the bytes that process has not read yet
/// (its `rx_queue`). `None` where the system does not say.
pub(super) fn in_flight() -> Option<InFlight> {
    #[cfg(target_os = "linux")]
    {
        let mut sockets = std::collections::HashSet::new();
        for entry in std::fs::read_dir("/proc/self/fd").ok()?.flatten() {
            let Ok(target) = std::fs::read_link(entry.path()) else {
                continue;
            };
            if let Some(inode) = target
                .to_string_lossy()
                .strip_prefix("socket:[")
                .and_then(|t| t.strip_suffix(']'))
                .and_then(|t| t.parse::<u64>().ok())
            {
                sockets.insert(inode);
            }
        }
        let mut found = InFlight::default();
        let mut read_any = false;
        for table in ["/proc/self/net/tcp", "/proc/self/net/tcp6"] {
            let Ok(text) = std::fs::read_to_string(table) else {
                continue;
            };
            read_any = true;
            // sl local rem st tx_queue:rx_queue tr:when retrnsmt uid timeout inode ...
            let rows: Vec<Vec<&str>> = text
                .lines()
                .skip(1)
                .map(|l| l.split_whitespace().take(10).collect::<Vec<&str>>())
                .filter(|f| f.len() == 10 && f[3] == "01")
                .collect();
            let queue = |f: &[&str], k: usize| {
                f[4].split(':')
                    .nth(k)
                    .and_then(|q| u64::from_str_radix(q, 16).ok())
                    .unwrap_or(0)
            };
            for ours in rows
                .iter()
                .filter(|f| f[9].parse::<u64>().is_ok_and(|i| sockets.contains(&i)))
            {
                found.bytes += queue(ours, 0);
                match rows.iter().find(|f| f[1] == ours[2] && f[2] == ours[1]) {
                    Some(theirs) => {
                        found.local += 1;
                        found.bytes += queue(theirs, 1);
                    }
                    None => found.remote += 1,
                }
            }
        }
        read_any.then_some(found)
    }
    #[cfg(not(target_os = "linux"))]
    None
}
