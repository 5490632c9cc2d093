//! Joining the Zenoh network: the options, the endpoints checked before anything opens, and
//! the session's configuration (a peer as rmw_zenoh's nodes are).

use crate::RosError;
use std::time::Duration;

/// How long a blocking message (an event) may wait for room on a link before Zenoh closes
/// that link: far above what a slow subscriber needs, while a peer that stops answering is
/// dropped by the lease (10 s) whatever this says.
pub const BLOCK_BEFORE_CLOSE: Duration = Duration::from_secs(60);

/// The kernel's send buffer of each connection: bytes of frame messages that can sit in it
/// ahead of an event (a slow subscriber reads them first).
const SEND_BUFFER: u32 = 256 * 1024;

/// How to join the Zenoh network, and as what node.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ZenohOptions {
    /// Endpoints to connect to, `tcp/HOST:PORT`.
    pub connect: Vec<String>,
    /// Endpoints to listen on, `tcp/HOST:PORT`.
    pub listen: Vec<String>,
    /// ROS domain id (`ROS_DOMAIN_ID`), 0 to 232.
    pub domain: u32,
    /// Node name.
    pub node: String,
    /// Node namespace, `/` or `/robot1` ...
    pub namespace: String,
    /// Frame messages (all but events) that may wait for the network before new ones are
    /// dropped.
    pub queue: usize,
}

impl Default for ZenohOptions {
    fn default() -> Self {
        ZenohOptions {
            connect: Vec::new(),
            listen: Vec::new(),
            domain: 0,
            node: "skin".into(),
            namespace: "/".into(),
            queue: 256,
        }
    }
}

/// Checks an endpoint: `tcp/HOST:PORT` (TCP is the only transport built in).
pub fn check_endpoint(endpoint: &str) -> Result<(), RosError> {
    let bad = |why: &str| RosError::Endpoint {
        endpoint: endpoint.to_owned(),
        why: why.to_owned(),
    };
    let Some(address) = endpoint.strip_prefix("tcp/") else {
        return Err(bad(
            "only tcp/HOST:PORT endpoints are supported (e.g. tcp/127.0.0.1:7447)",
        ));
    };
    let Some((host, port)) = address.rsplit_once(':') else {
        return Err(bad("it needs a port (tcp/HOST:PORT)"));
    };
    if host.is_empty() {
        return Err(bad("it needs a host (tcp/HOST:PORT)"));
    }
    if port.parse::<u16>().is_err() {
        return Err(bad("the port is not a number from 0 to 65535"));
    }
    Ok(())
}

/// Checks a set of endpoints: each valid ([`check_endpoint`]), none given twice, none both
/// connected to and listened on (the session would connect to itself).
pub fn check_endpoints(connect: &[String], listen: &[String]) -> Result<(), RosError> {
    for e in connect.iter().chain(listen) {
        check_endpoint(e)?;
    }
    let twice = |list: &[String], what: &str| {
        for (k, e) in list.iter().enumerate() {
            if list[..k].contains(e) {
                return Err(RosError::Endpoint {
                    endpoint: e.clone(),
                    why: format!("given twice to {what}: give each endpoint once"),
                });
            }
        }
        Ok(())
    };
    twice(connect, "connect to")?;
    twice(listen, "listen on")?;
    if let Some(e) = connect.iter().find(|e| listen.contains(e)) {
        return Err(RosError::Endpoint {
            endpoint: e.clone(),
            why: "both connected to and listened on: the session would connect to itself".into(),
        });
    }
    Ok(())
}

/// The largest ROS domain id (`ROS_DOMAIN_ID`).
pub const MAX_DOMAIN: u32 = 232;

/// A Zenoh error as one line: without the source file and line Zenoh appends (a path inside
/// the build machine's crate registry means nothing to a user).
pub(super) fn zenoh_error(e: impl std::fmt::Display) -> RosError {
    RosError::Zenoh(without_source(&e.to_string()))
}

/// `text` without its ` at /path/file.rs:123.` parts, on one line.
pub(super) fn without_source(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let mut rest = text;
    while let Some(k) = rest.find(" at ") {
        let after = &rest[k + 4..];
        let token_end = after.find(char::is_whitespace).unwrap_or(after.len());
        let token = &after[..token_end];
        out.push_str(&rest[..k]);
        if token.contains(".rs:") {
            rest = &after[token_end..];
        } else {
            out.push_str(" at ");
            rest = after;
        }
    }
    out.push_str(rest);
    out.split_whitespace().collect::<Vec<_>>().join(" ")
}

/// The endpoints (at least one), and the domain.
pub(super) fn check_options(options: &ZenohOptions) -> Result<(), RosError> {
    check_endpoints(&options.connect, &options.listen)?;
    if options.connect.is_empty() && options.listen.is_empty() {
        return Err(RosError::Endpoint {
            endpoint: String::new(),
            why: "give an endpoint to connect to or to listen on".into(),
        });
    }
    if options.domain > MAX_DOMAIN {
        return Err(RosError::Domain(options.domain));
    }
    Ok(())
}

/// Every endpoint to listen on can be had.
///
/// A listener that cannot be had (an address not of this machine, a port in use, two endpoints
/// on one port) is said plainly here; Zenoh's own error names its source files. All are held at
/// once, so that two endpoints on one port are found, and let go before Zenoh takes them.
pub(super) fn check_listeners(listen: &[String]) -> Result<(), RosError> {
    let mut held: Vec<(std::net::TcpListener, &String)> = Vec::new();
    for e in listen {
        let address = e.strip_prefix("tcp/").unwrap_or(e);
        match std::net::TcpListener::bind(address) {
            Ok(l) => held.push((l, e)),
            Err(err) => {
                let port = address.rsplit_once(':').map(|(_, p)| p.parse::<u16>().ok());
                let same = held.iter().find(|(l, _)| {
                    port.flatten()
                        .is_some_and(|p| l.local_addr().is_ok_and(|a| a.port() == p))
                });
                return Err(RosError::Endpoint {
                    endpoint: e.clone(),
                    why: match same {
                        Some((_, other)) => format!(
                            "cannot listen there: {other} already listens on that port (give it once)"
                        ),
                        None => format!("cannot listen there: {err}"),
                    },
                });
            }
        }
    }
    drop(held);
    Ok(())
}

/// The Zenoh configuration of a peer as rmw_zenoh's nodes are: no multicast scouting, the
/// endpoints given, blocking publishers' wait bounded, the socket's send buffer set.
pub(super) fn session_config(options: &ZenohOptions) -> Result<zenoh::Config, RosError> {
    let mut config = zenoh::Config::default();
    let json = |v: &[String]| serde_json::to_string(v).unwrap_or_else(|_| "[]".into());
    for (key, value) in [
        ("mode", "\"peer\"".to_owned()),
        ("scouting/multicast/enabled", "false".to_owned()),
        ("connect/endpoints", json(&options.connect)),
        ("listen/endpoints", json(&options.listen)),
        // Keep trying an endpoint that does not answer, without failing the open.
        ("connect/exit_on_failure", "false".to_owned()),
        ("connect/timeout_ms", "0".to_owned()),
        ("listen/exit_on_failure", "true".to_owned()),
        (
            "transport/link/tx/queue/congestion_control/block/wait_before_close",
            BLOCK_BEFORE_CLOSE.as_micros().to_string(),
        ),
        ("transport/link/tcp/so_sndbuf", SEND_BUFFER.to_string()),
        // The layout's cache (a transient-local publisher) stamps what it keeps, as rmw_zenoh's
        // sessions do.
        ("timestamping/enabled", "true".to_owned()),
    ] {
        config.insert_json5(key, &value).map_err(zenoh_error)?;
    }
    Ok(config)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn endpoints_are_checked_and_zenoh_errors_lose_their_source_files() {
        assert!(check_endpoint("tcp/127.0.0.1:7447").is_ok());
        assert!(check_endpoint("tcp/[::1]:7447").is_ok());
        let zenoh_said = "Can not create a new TCP listener bound to tcp/127.0.0.1:7448: [127.0.0.1:7448: Address already in use (os error 98) at /root/.cargo/registry/src/index.crates.io-1949cf8c6b5b557f/zenoh-link-commons-1.10.2/src/tcp.rs:61.] at /root/.cargo/registry/src/x/zenoh-1.10.2/src/net/runtime/orchestrator.rs:412.";
        assert_eq!(
            without_source(zenoh_said),
            "Can not create a new TCP listener bound to tcp/127.0.0.1:7448: [127.0.0.1:7448: Address already in use (os error 98)"
        );
        assert_eq!(without_source("look at this"), "look at this");
        let twice = vec!["tcp/127.0.0.1:7448".to_owned(); 2];
        assert!(check_endpoints(&[], &twice).is_err());
        assert!(check_endpoints(&twice[..1], &twice[..1]).is_err());
        assert!(check_endpoints(&twice[..1], &[]).is_ok());
        for bad in [
            "127.0.0.1:7447",
            "udp/1.2.3.4:7447",
            "tcp/host",
            "tcp/:7447",
            "tcp/h:99999",
        ] {
            assert!(check_endpoint(bad).is_err(), "{bad}");
        }
    }
}
