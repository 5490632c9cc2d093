//! The topics a skin publishes, under a prefix (`/skin` unless remapped):
//!
//! | topic | type | when |
//! |---|---|---|
//! | `PREFIX/<link>/pressure` | `sensor_msgs/msg/PointCloud2` | every frame after the baseline |
//! | `PREFIX/<link>/tactile_image` | `sensor_msgs/msg/Image` (`mono8`) | each decision on the link |
//! | `PREFIX/<link>/pressure_image` | `sensor_msgs/msg/Image` (`32FC1`) | each decision, when asked |
//! | `PREFIX/<link>/wrench` | `geometry_msgs/msg/WrenchStamped` | every frame after the baseline, on a link with a force calibration |
//! | `PREFIX/contacts` | `skin_msgs/msg/Contacts` | every frame with a contact |
//! | `PREFIX/events` | `skin_msgs/msg/TouchEvent` | every event (one per line of events.jsonl) |
//! | `PREFIX/markers` | `visualization_msgs/msg/MarkerArray` | every frame with a contact, and the frame after the last |
//! | `PREFIX/<link>/tactile_state` | `skin_msgs/msg/TactileState` | every frame after the baseline: readings in counts, or N on a link with a force calibration |
//! | `PREFIX/layout` | `skin_msgs/msg/TactileLayout` | once, at the first frame (transient local: a late subscriber gets it) |
//!
//! A link name is used as a topic token once mapped to ROS's rules ([`topic_token`]): letters,
//! digits and `_`, not starting with a digit, no `__`. The frame ids keep the name as it is
//! when tf2 can use it ([`is_frame_id`]); an empty or blank name, or one with a space, a
//! control character or a leading `/`, takes its topic token instead.

/// A topic: its full name and message type.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Topic {
    /// Full name, `/skin/forearm/pressure`.
    pub name: String,
    /// Message type, `sensor_msgs/msg/PointCloud2`.
    pub type_name: &'static str,
}

/// A link name as a ROS topic token: every character other than an ASCII letter, digit or `_`
/// becomes `_`, runs of `_` become one, `_` at either end goes, and a token that would start
/// with a digit (or be empty) gets `link_` in front. `upper arm.L` -> `upper_arm_L`,
/// `3rd-link` -> `link_3rd_link`.
pub fn topic_token(name: &str) -> String {
    let mut out = String::with_capacity(name.len());
    for c in name.chars() {
        let c = if c.is_ascii_alphanumeric() { c } else { '_' };
        if c == '_' && (out.is_empty() || out.ends_with('_')) {
            continue;
        }
        out.push(c);
    }
    while out.ends_with('_') {
        out.pop();
    }
    if out.is_empty() || out.starts_with(|c: char| c.is_ascii_digit()) {
        out.insert_str(0, if out.is_empty() { "link" } else { "link_" });
    }
    out
}

/// A link name tf2 can use as a frame id as it is: not empty, no leading `/` (tf2 refuses
/// both), and no white space or control character (a frame `" "` or `"upper arm"` cannot be
/// typed to `ros2 run tf2_ros tf2_echo` and looks like no frame at all).
pub fn is_frame_id(name: &str) -> bool {
    !name.is_empty() && !name.starts_with('/') && !name.chars().any(|c| c.is_whitespace() || c.is_control())
}

/// A topic prefix that is not a valid ROS name.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error(
    "topic prefix \"{prefix}\": {why} (a ROS name: '/' then tokens of letters, digits and '_' separated by '/', e.g. /skin or /robot1/skin)"
)]
pub struct PrefixError {
    /// The prefix given.
    pub prefix: String,
    /// What is wrong.
    pub why: &'static str,
}

/// Checks a topic prefix (`/skin`, `/robot1/skin`): absolute, tokens of ASCII letters, digits
/// and `_` not starting with a digit, no `__`, no trailing `/`. Returns it without a trailing
/// `/`.
pub fn check_prefix(prefix: &str) -> Result<String, PrefixError> {
    let err = |why| PrefixError {
        prefix: prefix.to_owned(),
        why,
    };
    let trimmed = prefix.strip_suffix('/').unwrap_or(prefix);
    let Some(rest) = trimmed.strip_prefix('/') else {
        return Err(err("it must start with '/'"));
    };
    if rest.is_empty() {
        return Err(err("it needs at least one token after '/'"));
    }
    for token in rest.split('/') {
        if token.is_empty() {
            return Err(err("it has an empty token ('//')"));
        }
        if !token.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
            return Err(err("a token has a character other than a letter, digit or '_'"));
        }
        if token.starts_with(|c: char| c.is_ascii_digit()) {
            return Err(err("a token starts with a digit"));
        }
        if token.contains("__") {
            return Err(err("a token has '__'"));
        }
    }
    Ok(trimmed.to_owned())
}

/// The topics of a skin with these links, in a fixed order, with the index of each kind.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Topics {
    /// The prefix, checked, without a trailing `/`: `/skin`. The services are under it too.
    pub prefix: String,
    /// Every topic; publishers and channels are made in this order.
    pub list: Vec<Topic>,
    /// Per link: its pressure cloud, decision image and (when asked) pressure image topics.
    pub links: Vec<LinkTopics>,
    /// `PREFIX/contacts`.
    pub contacts: usize,
    /// `PREFIX/events`.
    pub events: usize,
    /// `PREFIX/markers`.
    pub markers: usize,
    /// `PREFIX/layout`: the skin described, once (transient local).
    pub layout: usize,
    /// Per link: the frame id of its messages, the link name itself when [`is_frame_id`],
    /// else [`topic_token`] of it (with `_2`, `_3` ... where that is another link's name or
    /// frame id).
    pub frame_ids: Vec<String>,
}

/// The topics of one link (indices into [`Topics::list`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LinkTopics {
    /// `PREFIX/<link>/pressure`.
    pub pressure: usize,
    /// `PREFIX/<link>/tactile_image`.
    pub tactile_image: usize,
    /// `PREFIX/<link>/pressure_image`, when asked.
    pub pressure_image: Option<usize>,
    /// `PREFIX/<link>/wrench`, on a link with a force calibration ([`Topics::with_wrenches`]).
    pub wrench: Option<usize>,
    /// `PREFIX/<link>/tactile_state`.
    pub state: usize,
}

/// `sensor_msgs/msg/PointCloud2`.
pub const POINT_CLOUD2: &str = "sensor_msgs/msg/PointCloud2";
/// `sensor_msgs/msg/Image`.
pub const IMAGE: &str = "sensor_msgs/msg/Image";
/// `visualization_msgs/msg/MarkerArray`.
pub const MARKER_ARRAY: &str = "visualization_msgs/msg/MarkerArray";
/// `skin_msgs/msg/Contacts`.
pub const CONTACTS: &str = "skin_msgs/msg/Contacts";
/// `skin_msgs/msg/TouchEvent`.
pub const TOUCH_EVENT: &str = "skin_msgs/msg/TouchEvent";
/// `geometry_msgs/msg/WrenchStamped`.
pub const WRENCH_STAMPED: &str = "geometry_msgs/msg/WrenchStamped";
/// `skin_msgs/msg/TactileState`.
pub const TACTILE_STATE: &str = "skin_msgs/msg/TactileState";
/// `skin_msgs/msg/TactileLayout`.
pub const TACTILE_LAYOUT: &str = "skin_msgs/msg/TactileLayout";

impl Topics {
    /// The topics of `links` (layout order) under `prefix` (checked with [`check_prefix`]).
    /// Two links whose tokens coincide get `_2`, `_3` ... in layout order.
    pub fn new(prefix: &str, links: &[&str], pressure_images: bool) -> Result<Topics, PrefixError> {
        let prefix = check_prefix(prefix)?;
        let mut list = Vec::new();
        let mut tokens: Vec<String> = Vec::new();
        let mut per_link = Vec::new();
        let mut add = |name: String, type_name| {
            list.push(Topic { name, type_name });
            list.len() - 1
        };
        for link in links {
            let base = topic_token(link);
            let mut token = base.clone();
            let mut k = 2;
            while tokens.contains(&token) {
                token = format!("{base}_{k}");
                k += 1;
            }
            let pressure = add(format!("{prefix}/{token}/pressure"), POINT_CLOUD2);
            let tactile_image = add(format!("{prefix}/{token}/tactile_image"), IMAGE);
            let pressure_image =
                pressure_images.then(|| add(format!("{prefix}/{token}/pressure_image"), IMAGE));
            tokens.push(token);
            per_link.push(LinkTopics {
                pressure,
                tactile_image,
                pressure_image,
                wrench: None,
                state: usize::MAX,
            });
        }
        let mut frame_ids: Vec<String> = Vec::with_capacity(links.len());
        for link in links {
            let mut id = link.to_string();
            let mut k = 2;
            if !is_frame_id(link) {
                let token = topic_token(link);
                id.clone_from(&token);
                while links.contains(&id.as_str()) || frame_ids.contains(&id) {
                    id = format!("{token}_{k}");
                    k += 1;
                }
            }
            frame_ids.push(id);
        }
        let contacts = add(format!("{prefix}/contacts"), CONTACTS);
        let events = add(format!("{prefix}/events"), TOUCH_EVENT);
        let markers = add(format!("{prefix}/markers"), MARKER_ARRAY);
        // After the topics a skin published before it described itself, so those keep their
        // places.
        let layout = add(format!("{prefix}/layout"), TACTILE_LAYOUT);
        for (l, token) in tokens.iter().enumerate() {
            per_link[l].state = add(format!("{prefix}/{token}/tactile_state"), TACTILE_STATE);
        }
        Ok(Topics {
            prefix,
            list,
            links: per_link,
            contacts,
            events,
            markers,
            layout,
            frame_ids,
        })
    }
}

impl Topics {
    /// With `PREFIX/<link>/wrench` for each link `weighed` says (layout order; a link past its
    /// end has none): the links with a force calibration. Added after the other topics, so
    /// that a skin without one publishes the same list as before.
    pub fn with_wrenches(mut self, weighed: &[bool]) -> Topics {
        for (l, _) in weighed.iter().enumerate().filter(|(_, w)| **w) {
            let Some(pressure) = self.links.get(l).map(|t| t.pressure) else {
                continue;
            };
            let name = &self.list[pressure].name;
            let base = name.strip_suffix("/pressure").unwrap_or(name).to_owned();
            self.list.push(Topic {
                name: format!("{base}/wrench"),
                type_name: WRENCH_STAMPED,
            });
            self.links[l].wrench = Some(self.list.len() - 1);
        }
        self
    }
}

/// The depth of the frame topics' history: reliable (RViz's image display subscribes reliable),
/// volatile, keep last 10. The events topic keeps all (see [`offered_qos_yaml`]).
pub const QOS_DEPTH: u32 = 10;

/// The QoS a topic is offered with (every topic is reliable).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Qos {
    /// Volatile, keep last [`QOS_DEPTH`]: the frame topics.
    Frames,
    /// Volatile, keep all: the events, never dropped.
    Events,
    /// Transient local, keep last 1: the layout, which a subscriber that joins late still gets.
    Latched,
}

impl Topics {
    /// The QoS topic `k` is offered with.
    pub fn qos(&self, k: usize) -> Qos {
        if k == self.events {
            Qos::Events
        } else if k == self.layout {
            Qos::Latched
        } else {
            Qos::Frames
        }
    }
}

/// rosbag2's `offered_qos_profiles` channel metadata (YAML, as rosbag2 of Jazzy writes it; zero
/// durations are the defaults): reliable for every topic; keep-all history for the events (as
/// the live publisher offers them: an event is never dropped), keep last [`QOS_DEPTH`] for the
/// frame topics, and transient local, keep last 1 for the layout. `ros2 bag play` offers the
/// same QoS again.
pub fn offered_qos_yaml(qos: Qos) -> String {
    let (history, depth, durability) = match qos {
        Qos::Events => ("keep_all", 0, "volatile"),
        Qos::Frames => ("keep_last", QOS_DEPTH, "volatile"),
        Qos::Latched => ("keep_last", 1, "transient_local"),
    };
    format!(
        "- history: {history}\n  depth: {depth}\n  reliability: reliable\n  durability: {durability}\n  deadline:\n    sec: 0\n    nsec: 0\n  lifespan:\n    sec: 0\n    nsec: 0\n  liveliness: automatic\n  liveliness_lease_duration:\n    sec: 0\n    nsec: 0\n  avoid_ros_namespace_conventions: false\n"
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn link_names_become_valid_tokens() {
        assert_eq!(topic_token("forearm"), "forearm");
        assert_eq!(topic_token("upper arm.L"), "upper_arm_L");
        assert_eq!(topic_token("3rd-link"), "link_3rd_link");
        assert_eq!(topic_token("__a__b__"), "a_b");
        assert_eq!(topic_token("ёж"), "link");
        assert_eq!(topic_token(""), "link");
    }

    #[test]
    fn events_are_offered_keep_all_and_frames_keep_last() {
        let events = offered_qos_yaml(Qos::Events);
        assert!(events.starts_with("- history: keep_all\n  depth: 0\n  reliability: reliable\n"));
        let frames = offered_qos_yaml(Qos::Frames);
        assert!(frames.starts_with("- history: keep_last\n  depth: 10\n  reliability: reliable\n"));
    }

    #[test]
    fn blank_link_names_get_frame_ids_tf2_accepts() -> Result<(), PrefixError> {
        let t = Topics::new(
            "/skin",
            &["", " ", "forearm", "upper arm.L", "/abs", "link"],
            false,
        )?;
        assert_eq!(
            t.frame_ids,
            ["link_2", "link_3", "forearm", "upper_arm_L", "abs", "link"]
        );
        for id in &t.frame_ids {
            assert!(is_frame_id(id), "{id:?}");
        }
        Ok(())
    }

    #[test]
    fn prefixes_are_checked() {
        assert_eq!(check_prefix("/skin/").as_deref(), Ok("/skin"));
        assert_eq!(check_prefix("/robot1/skin").as_deref(), Ok("/robot1/skin"));
        for bad in ["skin", "/", "/a//b", "/a b", "/1skin", "/a__b"] {
            assert!(check_prefix(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn colliding_tokens_are_numbered() -> Result<(), PrefixError> {
        let t = Topics::new("/skin", &["upper arm", "upper-arm", "hand"], true)?;
        let names: Vec<&str> = t.list.iter().map(|t| t.name.as_str()).collect();
        assert_eq!(names[0], "/skin/upper_arm/pressure");
        assert_eq!(names[3], "/skin/upper_arm_2/pressure");
        assert_eq!(
            t.links[2].pressure_image.map(|i| names[i]),
            Some("/skin/hand/pressure_image")
        );
        assert_eq!(names[t.events], "/skin/events");
        let t = t.with_wrenches(&[true, false]);
        let wrenches: Vec<&str> = t
            .links
            .iter()
            .filter_map(|l| l.wrench)
            .map(|i| t.list[i].name.as_str())
            .collect();
        assert_eq!(wrenches, ["/skin/upper_arm/wrench"]);
        assert_eq!(t.list.last().map(|t| t.type_name), Some(WRENCH_STAMPED));
        Ok(())
    }

    proptest! {
        #[test]
        fn any_name_gives_a_valid_topic(name in "\\PC{0,24}") {
            let t = Topics::new("/skin", &[name.as_str()], false);
            prop_assert!(t.is_ok());
            if let Ok(t) = t {
                for topic in &t.list {
                    prop_assert!(check_prefix(&topic.name).is_ok(), "{}", topic.name);
                }
                prop_assert!(is_frame_id(&t.frame_ids[0]), "{:?}", t.frame_ids[0]);
            }
        }
    }
}
