//! Who gets a connection, and what is given up when there are too many: the bookkeeping that
//! keeps idle sockets (a slowloris attack, or a browser's unused preconnection) from locking
//! browsers out of the page.
//!
//! A connection is *waiting* from the moment it is accepted until its request head has arrived.
//! A real client sends its head at once, so waiting is normally a matter of milliseconds; an
//! idle socket waits until [`HEAD_TIMEOUT`](crate::HEAD_TIMEOUT) closes it. Waiting connections are
//! the cheap ones to give up, so they are what is given up: a new connection never waits for an
//! idle one to time out, it takes the place of the oldest waiting connection of its own address
//! (past [`MAX_WAITING_PER_ADDRESS`]), or of the address holding the most waiting ones (past
//! [`MAX_WAITING`] or [`MAX_CONNECTIONS`]). An attacker's idle sockets therefore push out only
//! each other, even when they come from the real client's own address: the real client's head
//! arrives long before [`MAX_WAITING_PER_ADDRESS`] newer sockets could push it out.
//!
//! Streams (browsers watching) are limited in all ([`MAX_STREAMS`]) and per address
//! ([`MAX_STREAMS_PER_ADDRESS`]); the page itself is served whatever the streams, and says so
//! when it cannot have one. Addresses are counted as clients are: IPv4 by address (IPv4-mapped
//! IPv6 too), IPv6 by its /64 network (one host's share of addresses).
//!
//! Pure bookkeeping, no sockets: the server closes what this says to close.

use std::collections::{BTreeMap, HashMap};
use std::net::{IpAddr, Ipv6Addr};

/// Connections open at once, waiting, answered or streaming; past it a new one takes a waiting
/// one's place, or is refused (503) when every connection is past its head.
pub const MAX_CONNECTIONS: usize = 256;
/// Connections whose request head has not all arrived, over all addresses.
pub const MAX_WAITING: usize = 128;
/// Connections whose request head has not all arrived, from one address.
pub const MAX_WAITING_PER_ADDRESS: usize = 32;
/// Streams (browsers watching) at once, over all addresses.
pub const MAX_STREAMS: usize = 48;
/// Streams (browsers watching) at once from one address.
pub const MAX_STREAMS_PER_ADDRESS: usize = 16;

/// The address a client is counted under: IPv4 as it is (an IPv4-mapped IPv6 address as its
/// IPv4 one), IPv6 by its /64 network, which one host is typically given whole.
pub fn client_of(ip: IpAddr) -> IpAddr {
    match ip.to_canonical() {
        IpAddr::V6(v6) => {
            let s = v6.segments();
            IpAddr::V6(Ipv6Addr::new(s[0], s[1], s[2], s[3], 0, 0, 0, 0))
        }
        v4 => v4,
    }
}

/// What becomes of a connection just accepted.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Admit {
    /// It waits for its head under `ticket`; `evict` is the waiting connection to close to make
    /// room for it.
    Wait {
        /// This connection's number.
        ticket: u64,
        /// The waiting connection it replaces, if any.
        evict: Option<u64>,
    },
    /// [`MAX_CONNECTIONS`] are open and none is waiting: refused.
    Full,
}

/// Why a stream is refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StreamRefused {
    /// [`MAX_STREAMS`] browsers watch already.
    Full,
    /// [`MAX_STREAMS_PER_ADDRESS`] browsers watch from this address already.
    FromThisAddress,
}

/// The connections open, by phase and address.
#[derive(Debug, Default)]
pub struct Limits {
    /// Waiting connections, oldest first (tickets rise): ticket -> client.
    waiting: BTreeMap<u64, IpAddr>,
    waiting_by: HashMap<IpAddr, usize>,
    /// Connections past their head (answered or streaming): ticket -> client.
    served: HashMap<u64, IpAddr>,
    streams: usize,
    streams_by: HashMap<IpAddr, usize>,
    next: u64,
}

impl Limits {
    /// Connections open (waiting or past their head).
    pub fn connections(&self) -> usize {
        self.waiting.len() + self.served.len()
    }

    /// Connections still waiting for their head.
    #[cfg(test)]
    pub fn waiting(&self) -> usize {
        self.waiting.len()
    }

    /// A connection from `client` was accepted.
    pub fn accept(&mut self, client: IpAddr) -> Admit {
        let mine = self.waiting_by.get(&client).copied().unwrap_or(0);
        let evict = if mine >= MAX_WAITING_PER_ADDRESS {
            self.oldest_of(client)
        } else if self.waiting.len() >= MAX_WAITING || self.connections() >= MAX_CONNECTIONS {
            self.busiest().and_then(|c| self.oldest_of(c))
        } else {
            None
        };
        if let Some(t) = evict {
            self.forget(t);
        } else if self.connections() >= MAX_CONNECTIONS {
            return Admit::Full;
        }
        let ticket = self.next;
        self.next += 1;
        self.waiting.insert(ticket, client);
        *self.waiting_by.entry(client).or_default() += 1;
        Admit::Wait { ticket, evict }
    }

    /// The head of `ticket` arrived: it is served from now on. False if it was given up
    /// meanwhile (its connection is being closed).
    pub fn head_arrived(&mut self, ticket: u64) -> bool {
        let Some(client) = self.waiting.remove(&ticket) else {
            return false;
        };
        self.uncount_waiting(client);
        self.served.insert(ticket, client);
        true
    }

    /// The connection of `ticket` is closed (nothing happens if it was given up already).
    pub fn closed(&mut self, ticket: u64) {
        self.forget(ticket);
    }

    /// A stream for a browser at `client`, if the limits allow one; give it back with
    /// [`Limits::stream_closed`].
    pub fn open_stream(&mut self, client: IpAddr) -> Result<(), StreamRefused> {
        let mine = self.streams_by.get(&client).copied().unwrap_or(0);
        if self.streams >= MAX_STREAMS {
            return Err(StreamRefused::Full);
        }
        if mine >= MAX_STREAMS_PER_ADDRESS {
            return Err(StreamRefused::FromThisAddress);
        }
        self.streams += 1;
        *self.streams_by.entry(client).or_default() += 1;
        Ok(())
    }

    /// A stream [`Limits::open_stream`] allowed has ended.
    pub fn stream_closed(&mut self, client: IpAddr) {
        self.streams = self.streams.saturating_sub(1);
        if let Some(n) = self.streams_by.get_mut(&client) {
            *n = n.saturating_sub(1);
            if *n == 0 {
                self.streams_by.remove(&client);
            }
        }
    }

    fn forget(&mut self, ticket: u64) {
        if let Some(client) = self.waiting.remove(&ticket) {
            self.uncount_waiting(client);
        } else {
            self.served.remove(&ticket);
        }
    }

    fn uncount_waiting(&mut self, client: IpAddr) {
        if let Some(n) = self.waiting_by.get_mut(&client) {
            *n = n.saturating_sub(1);
            if *n == 0 {
                self.waiting_by.remove(&client);
            }
        }
    }

    /// The oldest waiting connection of `client`.
    fn oldest_of(&self, client: IpAddr) -> Option<u64> {
        self.waiting.iter().find(|(_, c)| **c == client).map(|(t, _)| *t)
    }

    /// The address holding the most waiting connections (of equals, the one whose oldest
    /// waits longest).
    fn busiest(&self) -> Option<IpAddr> {
        let most = self.waiting_by.values().copied().max()?;
        self.waiting
            .values()
            .find(|c| self.waiting_by.get(c) == Some(&most))
            .copied()
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::panic)] // a failed set-up should stop the test
    use super::*;
    use std::net::Ipv4Addr;

    fn ip(last: u8) -> IpAddr {
        IpAddr::V4(Ipv4Addr::new(10, 0, 0, last))
    }

    fn wait(l: &mut Limits, client: IpAddr) -> (u64, Option<u64>) {
        match l.accept(client) {
            Admit::Wait { ticket, evict } => (ticket, evict),
            Admit::Full => panic!("refused"),
        }
    }

    #[test]
    fn idle_sockets_from_one_address_push_out_only_each_other() {
        let mut l = Limits::default();
        let idle: Vec<u64> = (0..MAX_WAITING_PER_ADDRESS)
            .map(|_| wait(&mut l, ip(1)).0)
            .collect();
        // The next from the same address takes the oldest's place, and so on, whatever comes.
        for k in 0..200 {
            let (_, evict) = wait(&mut l, ip(1));
            assert!(evict.is_some(), "connection {k} was let in beside a full address");
            assert_eq!(l.waiting(), MAX_WAITING_PER_ADDRESS);
        }
        assert!(!l.head_arrived(idle[0]), "an evicted connection was served");
        // A real client from that address connects and its head comes at once: served.
        let (real, _) = wait(&mut l, ip(1));
        assert!(l.head_arrived(real));
        // Another address is not touched by the first one's idle sockets.
        let (other, evict) = wait(&mut l, ip(2));
        assert_eq!(evict, None);
        assert!(l.head_arrived(other));
    }

    #[test]
    fn past_the_total_the_busiest_address_gives_way() {
        let mut l = Limits::default();
        let per = MAX_WAITING_PER_ADDRESS;
        // Four addresses fill the waiting list, the first with the most.
        let mut first = Vec::new();
        for (k, client) in (1..=5u8).map(ip).enumerate() {
            let n = if k == 0 { per } else { (MAX_WAITING - per) / 4 };
            for _ in 0..n {
                let t = wait(&mut l, client).0;
                if k == 0 {
                    first.push(t);
                }
            }
        }
        assert_eq!(l.waiting(), MAX_WAITING);
        let (_, evict) = wait(&mut l, ip(9));
        assert_eq!(evict, Some(first[0]), "the busiest address's oldest goes first");
        assert_eq!(l.waiting(), MAX_WAITING);
    }

    #[test]
    fn a_full_server_refuses_only_when_nothing_waits() {
        let mut l = Limits::default();
        for k in 0..MAX_CONNECTIONS {
            let (t, _) = wait(&mut l, ip(u8::try_from(k % 200).unwrap()));
            assert!(l.head_arrived(t));
        }
        assert_eq!(l.accept(ip(1)), Admit::Full);
        l.closed(0);
        let (t, evict) = wait(&mut l, ip(1));
        assert_eq!(evict, None);
        // Full again, but this one waits: the next takes its place.
        let (_, evict) = wait(&mut l, ip(2));
        assert_eq!(evict, Some(t));
        assert_eq!(l.connections(), MAX_CONNECTIONS);
    }

    #[test]
    fn streams_are_limited_in_all_and_per_address() {
        let mut l = Limits::default();
        for _ in 0..MAX_STREAMS_PER_ADDRESS {
            l.open_stream(ip(1)).unwrap();
        }
        assert_eq!(l.open_stream(ip(1)), Err(StreamRefused::FromThisAddress));
        let mut k = 2;
        while l.open_stream(ip(k)).is_ok() {
            k += 1;
        }
        assert_eq!(l.open_stream(ip(k)), Err(StreamRefused::Full));
        assert_eq!(l.streams, MAX_STREAMS);
        l.stream_closed(ip(1));
        l.open_stream(ip(1)).unwrap();
    }

    #[test]
    fn any_sequence_of_connections_keeps_every_limit() {
        // Connections accepted, served and closed in a fixed pseudo-random order (xorshift, the
        // same every run) from a few addresses: the counts never pass a limit and always add up.
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut next = |n: u64| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state % n
        };
        let mut l = Limits::default();
        let mut open: Vec<u64> = Vec::new();
        for _ in 0..20_000 {
            match next(4) {
                0 | 1 => {
                    let client = ip(u8::try_from(next(6)).unwrap());
                    if let Admit::Wait { ticket, evict } = l.accept(client) {
                        open.retain(|t| Some(*t) != evict);
                        open.push(ticket);
                    }
                }
                2 if !open.is_empty() => {
                    let t = open[usize::try_from(next(open.len() as u64)).unwrap()];
                    let _ = l.head_arrived(t);
                }
                _ if !open.is_empty() => {
                    let t = open.swap_remove(usize::try_from(next(open.len() as u64)).unwrap());
                    l.closed(t);
                }
                _ => {}
            }
            assert!(l.connections() <= MAX_CONNECTIONS);
            assert!(l.waiting() <= MAX_WAITING);
            assert!(
                l.waiting_by
                    .values()
                    .all(|&n| n > 0 && n <= MAX_WAITING_PER_ADDRESS)
            );
            assert_eq!(l.waiting_by.values().sum::<usize>(), l.waiting());
            assert_eq!(l.connections(), open.len());
        }
    }

    #[test]
    fn ipv6_clients_are_counted_by_their_network() {
        let a: IpAddr = "2001:db8:1:2:aaaa::1".parse().unwrap();
        let b: IpAddr = "2001:db8:1:2:bbbb::7".parse().unwrap();
        let other: IpAddr = "2001:db8:1:3::1".parse().unwrap();
        assert_eq!(client_of(a), client_of(b));
        assert_ne!(client_of(a), client_of(other));
        let mapped: IpAddr = "::ffff:10.0.0.1".parse().unwrap();
        assert_eq!(client_of(mapped), ip(1));
    }
}
