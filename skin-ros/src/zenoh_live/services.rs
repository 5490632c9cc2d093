//! The services a live node serves, as rmw_zenoh serves them: `PREFIX/tare` and
//! `PREFIX/tare_forced` (`std_srvs/srv/Trigger`: the baseline learned again, see
//! [`TareHandle`]) and `PREFIX/describe` (`skin_msgs/srv/Describe`: the skin's
//! `TactileLayout`).
//!
//! A service is a queryable (complete) on `<domain>/<service>/<DDS type>/<service hash>`, the
//! DDS type being the service's name with `_` (`std_srvs::srv::dds_::Trigger_`), announced by
//! an `SS` liveliness token. A client's query carries the 33-byte attachment (its sequence
//! number, its time, 16, its GID) and a CDR request; the reply carries the CDR response and
//! the attachment with the same sequence number and GID and the server's time, as rmw_zenoh's
//! `ServiceData::send_response` writes it (rclcpp matches a reply to its request by them).
//!
//! Replies are made on Zenoh's thread at once: a tare is answered by what [`TareHandle::tare`]
//! decides, and carried out at the next frame. A query without the attachment or without a
//! CDR request is counted and answered with an error reply, never served.

use super::config::zenoh_error;
use super::names::{Place, attachment as attachment_of, dds_type, sender_of};
use crate::RosError;
use crate::cdr::{CDR_LE, CdrWriter};
use crate::interfaces::Interfaces;
use crate::messages::{Stamp, tactile_layout};
use crate::topics::Topics;
use skin_runtime::session::{Description, TareHandle};
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use zenoh::Wait;

/// What a live node serves besides its topics ([`crate::ZenohOutlet::serve`]).
#[derive(Debug, Clone, Default)]
pub struct Services {
    /// `PREFIX/tare` and `PREFIX/tare_forced`, asking this session's tare.
    pub tare: Option<TareHandle>,
    /// `PREFIX/describe`, answering with this description.
    pub description: Option<Description>,
}

/// What one service did with its calls.
#[derive(Debug, Default)]
pub struct ServiceCounts {
    /// The service, `/skin/tare`.
    pub name: String,
    /// Calls answered with a response.
    pub served: AtomicU64,
    /// Of those, requests the service refused (a tare during a touch), with the reason.
    pub refused: AtomicU64,
    /// Queries that were not rmw_zenoh requests (no attachment, no CDR): answered with an
    /// error reply.
    pub malformed: AtomicU64,
}

/// The queryables and tokens of the services being served.
pub(super) struct Served {
    pub counts: Vec<Arc<ServiceCounts>>,
    _queryables: Vec<zenoh::query::Queryable<()>>,
    _tokens: Vec<zenoh::liveliness::LivelinessToken>,
}

/// Which service a queryable answers.
#[derive(Clone)]
enum Answer {
    Tare { handle: TareHandle, force: bool },
    Describe(Arc<Vec<u8>>),
}

/// Declares the services `services` asks for, under `topics.prefix`.
pub(super) fn serve(
    session: &zenoh::Session,
    topics: &Topics,
    services: Services,
    place: &Place<'_>,
    first_id: usize,
) -> Result<Served, RosError> {
    let interfaces = Interfaces::skin()?;
    let mut wanted: Vec<(String, &'static str, Answer)> = Vec::new();
    if let Some(handle) = services.tare {
        for (name, force) in [("tare", false), ("tare_forced", true)] {
            let answer = Answer::Tare {
                handle: handle.clone(),
                force,
            };
            wanted.push((
                format!("{}/{name}", topics.prefix),
                "std_srvs/srv/Trigger",
                answer,
            ));
        }
    }
    if let Some(d) = services.description {
        let mut w = CdrWriter::new();
        // Describe_Response holds one TactileLayout: its CDR is the layout's.
        tactile_layout(&mut w, Stamp::default(), &d, &topics.frame_ids);
        let answer = Answer::Describe(Arc::new(w.bytes().to_vec()));
        wanted.push((
            format!("{}/describe", topics.prefix),
            "skin_msgs/srv/Describe",
            answer,
        ));
    }
    let mut served = Served {
        counts: Vec::new(),
        _queryables: Vec::new(),
        _tokens: Vec::new(),
    };
    for (k, (name, type_name, answer)) in wanted.into_iter().enumerate() {
        let hash = interfaces
            .type_hash(type_name)
            .ok_or(RosError::UnknownType(type_name))?;
        let dds = dds_type(type_name);
        let key = format!("{}/{}/{dds}/{hash}", place.domain, name.trim_start_matches('/'));
        let counts = Arc::new(ServiceCounts {
            name: name.clone(),
            ..ServiceCounts::default()
        });
        let c = counts.clone();
        let reply_key = key.clone();
        let queryable = session
            .declare_queryable(key.clone())
            .complete(true)
            .callback(move |query| answer_query(&query, &reply_key, &answer, &c))
            .wait()
            .map_err(zenoh_error)?;
        // Default service QoS, as rmw_zenoh writes it.
        let token = place.token(first_id + k, "SS", &name, &dds, &hash, "::,10:,:,:,,");
        served._tokens.push(
            session
                .liveliness()
                .declare_token(token)
                .wait()
                .map_err(zenoh_error)?,
        );
        served._queryables.push(queryable);
        served.counts.push(counts);
    }
    Ok(served)
}

/// Answers one query.
fn answer_query(query: &zenoh::query::Query, key: &str, answer: &Answer, counts: &ServiceCounts) {
    let attachment = query.attachment().map(|a| a.to_bytes().into_owned());
    let client = attachment.as_deref().and_then(sender_of);
    let request_ok = query
        .payload()
        .is_some_and(|p| p.to_bytes().get(..4) == Some(&CDR_LE[..]));
    let Some((seq, gid)) = client.filter(|_| request_ok) else {
        counts.malformed.fetch_add(1, Ordering::Relaxed);
        let _ = query
            .reply_err(
                "not an rmw_zenoh service request: a CDR request and the 33-byte attachment are needed",
            )
            .wait();
        return;
    };
    let payload = match answer {
        Answer::Tare { handle, force } => {
            let (success, message) = match handle.tare(*force) {
                Ok(started) => (true, started.to_string()),
                Err(refused) => {
                    counts.refused.fetch_add(1, Ordering::Relaxed);
                    (false, refused.to_string())
                }
            };
            let mut w = CdrWriter::new();
            w.start();
            w.bool(success).string(&message);
            w.bytes().to_vec()
        }
        Answer::Describe(bytes) => bytes.to_vec(),
    };
    // The client's sequence number and GID, the server's time.
    let reply = attachment_of(seq, &gid);
    if query
        .reply(key, payload)
        .attachment(reply.as_slice())
        .wait()
        .is_ok()
    {
        counts.served.fetch_add(1, Ordering::Relaxed);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn attachments_give_the_client_or_nothing() {
        let mut a = [0u8; 33];
        a[..8].copy_from_slice(&7i64.to_le_bytes());
        a[16] = 16;
        a[17..].copy_from_slice(&[9u8; 16]);
        assert_eq!(sender_of(&a), Some((7, [9u8; 16])));
        assert_eq!(sender_of(&a[..32]), None);
        a[16] = 15;
        assert_eq!(sender_of(&a), None);
        let made = attachment_of(7, &[9u8; 16]);
        assert_eq!(sender_of(&made), Some((7, [9u8; 16])));
    }
}
