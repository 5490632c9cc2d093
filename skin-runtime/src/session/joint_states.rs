//! The robot's posture live, from its joint states (`sensor_msgs/JointState` as a ROS 2 stack
//! publishes it): joint angles, matched to the URDF chain's joints by name, become the poses of
//! the stitched links (skin-control's kinematics), and each frame is stitched at the posture
//! the robot had at its stamp.
//!
//! A [`PostureFeed`] is filled from any thread ([`PostureFeed::push`]: a Zenoh subscriber, a
//! ROS callback, a test) and read by the session at each frame. It keeps the last
//! [`FEED_CAPACITY`] postures; a frame takes the latest one stamped at or before it. A message
//! that cannot give a posture is not taken, the last good posture holds, and the session says
//! why in an [`Event::JointStates`](super::Event::JointStates) when the fault begins (a missing
//! joint, a NaN, a stamp older than the last, a message of another robot's joints), as it does
//! when the posture a frame gets is older than the feed's `max_age` (stale). One event a fault,
//! however many messages repeat it: a fault of a message is said again only after a second
//! without it (a robot whose gripper publishes its own joint states on the same topic gets
//! one event, not one a message); a stale posture again once a fresh one came.
//!
//! Replaying a file, the session may wait for the posture of each frame's time
//! ([`PostureFeed::new`]'s `wait`): a replay runs faster than the joint states arrive, and
//! stitching a frame at a posture of the past would place its contacts wrong. Live, it never
//! waits: the frame path reads the latest posture and goes on.

use super::{ConfigError, Event, Session, SessionError, Sink, send};
use nalgebra::Isometry3;
use skin_control::Chain;
use std::collections::VecDeque;
use std::sync::{Arc, Condvar, Mutex};
use std::time::Duration;

/// Postures a feed keeps (the newest; older ones than a frame's are dropped as frames go by).
pub const FEED_CAPACITY: usize = 16_384;

/// What is wrong with the joint states (an [`Event::JointStates`](super::Event::JointStates)).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum JointProblem {
    /// A joint of the chain is not in the message (which has some of the chain's).
    Missing,
    /// A joint of the chain is NaN or infinite.
    NotFinite,
    /// The posture a frame gets is older than the feed's `max_age`.
    Stale,
    /// A message stamped before the last one taken.
    OutOfOrder,
    /// A message with none of the chain's joints: another robot's, or another part's.
    OtherRobot,
    /// A message whose names and positions differ in number, or whose joint values the chain
    /// cannot take.
    Malformed,
    /// The chain cannot be stitched at the posture (the last one holds).
    Unstitchable,
}

const PROBLEMS: usize = 7;

impl JointProblem {
    fn index(self) -> usize {
        self as usize
    }
}

/// One fault, as the session reports it.
#[derive(Debug, Clone, PartialEq)]
pub struct JointFault {
    /// What is wrong.
    pub problem: JointProblem,
    /// The joints at fault (missing, not finite), or the first names of a message of another
    /// robot.
    pub joints: Vec<String>,
    /// In words: the stamps, the age, why.
    pub detail: String,
}

/// What a feed has taken: counts for a report.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct FeedCounts {
    /// Messages pushed.
    pub received: u64,
    /// Messages that gave a posture.
    pub taken: u64,
    /// Faults reported (one per fault, not per message).
    pub faults: u64,
}

#[derive(Debug)]
struct State {
    /// (stamp ns, link poses in chain order), stamps increasing.
    postures: VecDeque<(i128, Vec<Isometry3<f64>>)>,
    last_stamp: Option<i128>,
    /// Faults begun and not yet handed to the session (bounded).
    faults: Vec<JointFault>,
    /// Per kind: a fault of it is going on (reported once).
    active: [bool; PROBLEMS],
    /// Per kind: when a message last had a fault of it.
    last_fault: [Option<std::time::Instant>; PROBLEMS],
    counts: FeedCounts,
    /// The wait for a frame's posture ran out: no wait again until a message comes.
    starved: bool,
}

#[derive(Debug)]
struct Shared {
    chain: Chain,
    /// The chain's joints, in its order.
    joints: Vec<String>,
    /// The stitched links, in the session's order.
    links: Vec<String>,
    max_age_ns: i128,
    wait: Option<Duration>,
    state: Mutex<State>,
    arrived: Condvar,
}

/// The robot's postures as its joint states give them, shared between whoever receives them and
/// the session (cheap to clone).
#[derive(Debug, Clone)]
pub struct PostureFeed(Arc<Shared>);

/// How long a message fault must be absent before it is said again.
const FAULT_QUIET: Duration = Duration::from_secs(1);

/// Faults a feed keeps for the session between frames.
const MAX_PENDING_FAULTS: usize = 64;

impl PostureFeed {
    /// A feed for the stitched `links` (the session's order) of `chain`; a frame's posture
    /// older than `max_age` is stale. With `wait` (replaying a file), a frame waits up to that
    /// long for a posture stamped at or after it.
    pub fn new(chain: Chain, links: Vec<String>, max_age: Duration, wait: Option<Duration>) -> PostureFeed {
        let joints = chain.joints().iter().map(|j| j.name.clone()).collect();
        PostureFeed(Arc::new(Shared {
            chain,
            joints,
            links,
            max_age_ns: max_age.as_nanos() as i128,
            wait,
            state: Mutex::new(State {
                postures: VecDeque::new(),
                last_stamp: None,
                faults: Vec::new(),
                active: [false; PROBLEMS],
                last_fault: [None; PROBLEMS],
                counts: FeedCounts::default(),
                starved: false,
            }),
            arrived: Condvar::new(),
        }))
    }

    /// The chain's joints, base to tip: the names a joint state must carry.
    pub fn joints(&self) -> &[String] {
        &self.0.joints
    }

    /// The stitched links it gives poses of.
    pub fn links(&self) -> &[String] {
        &self.0.links
    }

    /// What it has taken so far.
    pub fn counts(&self) -> FeedCounts {
        self.0.state.lock().map_or(FeedCounts::default(), |s| s.counts)
    }

    /// One joint state: its stamp (ns, the clock the frames are stamped on), joint names and
    /// positions (rad or m), as `sensor_msgs/JointState` has them. Extra joints are ignored.
    pub fn push<'a>(&self, stamp_ns: i128, names: impl IntoIterator<Item = &'a str>, positions: &[f64]) {
        let names: Vec<&str> = names.into_iter().collect();
        let posture = self.posture_of(&names, positions);
        let Ok(mut s) = self.0.state.lock() else {
            return;
        };
        s.counts.received += 1;
        // Checked under the lock that inserts: two publishers' callbacks may run at once.
        let posture = posture.and_then(|poses| match s.last_stamp {
            Some(last) if stamp_ns < last => Err(JointFault {
                problem: JointProblem::OutOfOrder,
                joints: Vec::new(),
                detail: format!(
                    "stamped {:.6} s, before the last one taken ({:.6} s)",
                    stamp_ns as f64 * 1e-9,
                    last as f64 * 1e-9
                ),
            }),
            _ => Ok(poses),
        });
        match posture {
            Ok(poses) => {
                s.counts.taken += 1;
                s.last_stamp = Some(stamp_ns);
                s.starved = false;
                // A message fault is over once a second has gone without it.
                for p in [
                    JointProblem::Missing,
                    JointProblem::NotFinite,
                    JointProblem::OutOfOrder,
                    JointProblem::OtherRobot,
                    JointProblem::Malformed,
                ] {
                    let k = p.index();
                    if s.last_fault[k].is_none_or(|t| t.elapsed() >= FAULT_QUIET) {
                        s.active[k] = false;
                    }
                }
                if s.postures.len() >= FEED_CAPACITY {
                    s.postures.pop_front();
                }
                s.postures.push_back((stamp_ns, poses));
                self.0.arrived.notify_all();
            }
            Err(fault) => fault_begins(&mut s, fault),
        }
    }

    /// The posture of a message, or what is wrong with it.
    fn posture_of(&self, names: &[&str], positions: &[f64]) -> Result<Vec<Isometry3<f64>>, JointFault> {
        let fault = |problem, joints: Vec<String>, detail: String| JointFault {
            problem,
            joints,
            detail,
        };
        if names.len() != positions.len() {
            let why = format!("{} names and {} positions", names.len(), positions.len());
            return Err(fault(JointProblem::Malformed, Vec::new(), why));
        }
        let at: Vec<Option<usize>> = (self.0.joints.iter())
            .map(|j| names.iter().position(|n| n == j))
            .collect();
        if at.iter().all(Option::is_none) {
            let shown = names.iter().take(8).map(|n| n.to_string()).collect();
            let why = format!("none of the chain's joints ({})", self.0.joints.join(", "));
            return Err(fault(JointProblem::OtherRobot, shown, why));
        }
        // The chain's joints whose value `bad` says is wrong.
        let at_fault = |bad: &dyn Fn(usize) -> bool| -> Vec<String> {
            (self.0.joints.iter().enumerate())
                .filter(|(k, _)| bad(*k))
                .map(|(_, j)| j.clone())
                .collect()
        };
        let missing = at_fault(&|k| at[k].is_none());
        if !missing.is_empty() {
            return Err(fault(
                JointProblem::Missing,
                missing,
                "the last good posture holds".into(),
            ));
        }
        let q: Vec<f64> = at.iter().flatten().map(|&i| positions[i]).collect();
        let bad = at_fault(&|k| !q[k].is_finite());
        if !bad.is_empty() {
            return Err(fault(
                JointProblem::NotFinite,
                bad,
                "the last good posture holds".into(),
            ));
        }
        let posture = self
            .0
            .chain
            .posture(&q)
            .map_err(|e| fault(JointProblem::Malformed, Vec::new(), e.to_string()))?;
        (self.0.links.iter())
            .map(|l| posture.link_pose(l))
            .collect::<Result<Vec<_>, _>>()
            .map_err(|e| fault(JointProblem::Malformed, Vec::new(), e.to_string()))
    }

    /// The posture of a frame stamped `frame_ns`: the latest one stamped at or before it,
    /// copied into `out`, and whether it is fresh (within `max_age` of the frame: a stale one
    /// still holds for the stitching, but says nothing of where the robot is now); None when
    /// there is none yet. Replaying (a feed with `wait`), waits up
    /// to that long for one stamped at or after the frame. A posture older than `max_age`
    /// begins a stale fault.
    pub(super) fn posture_at(&self, frame_ns: i128, out: &mut Vec<Isometry3<f64>>) -> Option<bool> {
        let Ok(mut s) = self.0.state.lock() else {
            return None;
        };
        if let Some(wait) = self.0.wait
            && !s.starved
            && s.postures.back().is_none_or(|(t, _)| *t < frame_ns)
        {
            let (guard, timeout) = self
                .0
                .arrived
                .wait_timeout_while(s, wait, |s| s.postures.back().is_none_or(|(t, _)| *t < frame_ns))
                .unwrap_or_else(std::sync::PoisonError::into_inner);
            s = guard;
            s.starved = timeout.timed_out();
        }
        // The postures before the latest one at or before the frame serve no later frame.
        while s.postures.len() > 1 && s.postures.get(1).is_some_and(|(t, _)| *t <= frame_ns) {
            s.postures.pop_front();
        }
        let Some((stamp, poses)) = s.postures.front().filter(|(t, _)| *t <= frame_ns) else {
            // Every posture is stamped well after the frame: the two clocks differ.
            if let Some((first, _)) = s.postures.front()
                && first - frame_ns > self.0.max_age_ns
            {
                let detail = format!(
                    "every joint state is stamped after the frame (the first by {:.3} s): the joint states' clock is not the frames' (--ros-time rebase against a robot's clock?); no posture is taken",
                    (first - frame_ns) as f64 * 1e-9
                );
                fault_begins(
                    &mut s,
                    JointFault {
                        problem: JointProblem::Stale,
                        joints: Vec::new(),
                        detail,
                    },
                );
            }
            return None;
        };
        let age = frame_ns - stamp;
        out.clear();
        out.extend_from_slice(poses);
        let fresh = age <= self.0.max_age_ns;
        if !fresh {
            let detail = format!(
                "the last joint state is {:.3} s older than the frame (more than {:.3} s): its posture holds",
                age as f64 * 1e-9,
                self.0.max_age_ns as f64 * 1e-9
            );
            fault_begins(
                &mut s,
                JointFault {
                    problem: JointProblem::Stale,
                    joints: Vec::new(),
                    detail,
                },
            );
        } else if s.last_fault[JointProblem::Stale.index()].is_none_or(|t| t.elapsed() >= FAULT_QUIET) {
            // Fresh again, and for a second: a stale posture will be said again.
            s.active[JointProblem::Stale.index()] = false;
        }
        Some(fresh)
    }

    /// The chain was stitched at the posture a frame got: a later posture that cannot be is
    /// said again.
    pub(super) fn stitched(&self) {
        if let Ok(mut s) = self.0.state.lock() {
            s.active[JointProblem::Unstitchable.index()] = false;
        }
    }

    /// Reports that the chain cannot be stitched at the posture a frame got.
    pub(super) fn unstitchable(&self, why: String) {
        if let Ok(mut s) = self.0.state.lock() {
            fault_begins(
                &mut s,
                JointFault {
                    problem: JointProblem::Unstitchable,
                    joints: Vec::new(),
                    detail: why,
                },
            );
        }
    }

    /// The faults begun since the last call, oldest first.
    pub(super) fn take_faults(&self, out: &mut Vec<JointFault>) {
        if let Ok(mut s) = self.0.state.lock() {
            out.append(&mut s.faults);
        }
    }
}

impl Session {
    /// Gives this stitched session the robot's joint states: the returned feed is filled by
    /// whoever receives them ([`PostureFeed::push`]), and from the first posture it gives on,
    /// each frame is stitched at the robot's posture at its stamp (the poses file's postures,
    /// if any, only before). Needs `[stitch] urdf` (or [`Session::with_kinematics`]). Stamps
    /// are compared on the input's clock (ns since the epoch for a candump log or a live bus),
    /// or from 0 at the first frame when `rebased`. `wait`: replaying a file, how long a frame
    /// may wait for its posture; none live.
    pub fn joint_state_feed(
        &mut self,
        wait: Option<Duration>,
        rebased: bool,
    ) -> Result<PostureFeed, SessionError> {
        let Some((chain, max_age)) = self.setup.kinematics.clone() else {
            return Err(ConfigError::NoKinematics.into());
        };
        let links = self.setup.links.iter().map(|l| l.name.clone()).collect();
        let feed = PostureFeed::new(chain, links, max_age, wait);
        self.setup.feed = Some((feed.clone(), rebased));
        Ok(feed)
    }

    /// The kinematics of the stitched chain (its links the layout's, base to tip), and how
    /// old a posture may be before it is stale: what `[stitch] urdf` and `max_age_s` give.
    pub fn with_kinematics(mut self, chain: Chain, max_age: Duration) -> Result<Session, SessionError> {
        for l in &self.setup.links {
            chain
                .posture(&vec![0.0; chain.dof()])
                .and_then(|p| p.link_pose(&l.name))
                .map_err(|e| ConfigError::Kinematics { why: e.to_string() })?;
        }
        self.setup.kinematics = Some((chain, max_age));
        Ok(self)
    }

    /// At a frame stamped `time_us`, `time` s into the session: where its links are. With joint
    /// states, the robot's posture then (the stitching follows it, and holds the last one when
    /// they stop); the poses file's posture then until the first one comes, or without them.
    /// The touch pipeline gets each link's pose in the chain's base frame only while it is the
    /// robot's: not from a joint state older than `max_age_s` (stale), nor from a chain stitched
    /// at the middle of its joints' limits for want of a posture. A contact's base-frame
    /// centroid is never a guess.
    pub(super) fn place_links(&mut self, time_us: u64, time: f64) {
        let mut fresh = None;
        if let Some((feed, rebased)) = &self.setup.feed {
            let t0 = if *rebased { self.t0_us.unwrap_or(0) } else { 0 };
            let frame_ns = i128::from(time_us.saturating_sub(t0)) * 1000;
            fresh = feed.posture_at(frame_ns, &mut self.live_poses);
            if fresh.is_some()
                && let Some(st) = &mut self.setup.stitching
            {
                match st.set_live_posture(&self.live_poses) {
                    Ok(true) => feed.stitched(),
                    Ok(false) => {}
                    Err(e) => feed.unstitchable(format!(
                        "the chain cannot be stitched at the posture of the joint states: {e}"
                    )),
                }
            }
        }
        let poses: &[nalgebra::Isometry3<f64>] = match (fresh, &self.setup.stitching) {
            (Some(true), _) => &self.live_poses,
            // A stale posture, or none yet while one was: not where the robot is now.
            (Some(false), _) => &[],
            (None, _) if self.live_placed => &[],
            (None, Some(st)) if self.setup.posed_by_file => st.poses_at(time),
            (None, _) => &[],
        };
        self.live_placed |= fresh.is_some();
        if poses.is_empty() && !self.placed {
            return;
        }
        for l in 0..self.setup.links.len() {
            self.pipeline.set_pose(l, poses.get(l).copied());
        }
        self.placed = !poses.is_empty();
    }

    /// An event for each joint-state fault begun since the last frame (at `time`, s).
    pub(super) fn report_joint_faults<S: Sink + ?Sized>(
        &mut self,
        time: f64,
        sink: &mut S,
    ) -> Result<(), SessionError> {
        let Some((feed, _)) = &self.setup.feed else {
            return Ok(());
        };
        feed.take_faults(&mut self.joint_faults);
        for f in std::mem::take(&mut self.joint_faults) {
            let event = Event::JointStates {
                time,
                problem: f.problem,
                joints: f.joints,
                detail: f.detail,
            };
            send(&mut self.stopped, sink, |s| s.event(&event))?;
        }
        Ok(())
    }
}

/// A fault: reported unless one of its kind is going on already.
fn fault_begins(s: &mut State, fault: JointFault) {
    let k = fault.problem.index();
    s.last_fault[k] = Some(std::time::Instant::now());
    if s.active[k] {
        return;
    }
    s.active[k] = true;
    s.counts.faults += 1;
    if s.faults.len() < MAX_PENDING_FAULTS {
        s.faults.push(fault);
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    const URDF: &str = r#"<robot name="r"><link name="a"/><link name="b"/><link name="c"/>
        <joint name="j1" type="revolute"><parent link="a"/><child link="b"/><origin xyz="0 0.3 0"/>
        <axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
        <joint name="j2" type="revolute"><parent link="b"/><child link="c"/><origin xyz="0 0.2 0"/>
        <axis xyz="1 0 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>"#;

    fn feed(wait: Option<Duration>) -> PostureFeed {
        let chain = Chain::from_urdf_str(URDF, "a", "c").unwrap();
        PostureFeed::new(
            chain,
            vec!["a".into(), "b".into(), "c".into()],
            Duration::from_millis(100),
            wait,
        )
    }

    fn faults(f: &PostureFeed) -> Vec<JointProblem> {
        let mut out = Vec::new();
        f.take_faults(&mut out);
        out.iter().map(|f| f.problem).collect()
    }

    #[test]
    fn postures_follow_the_stamps_and_bad_messages_keep_the_last_good_one() {
        let f = feed(None);
        let mut poses = Vec::new();
        assert!(f.posture_at(0, &mut poses).is_none());
        // Joints in any order, with others: matched by name.
        f.push(1_000, ["gripper", "j2", "j1"], &[0.3, 0.0, 0.5]);
        assert!(f.posture_at(1_000, &mut poses).is_some());
        let turned = poses[1].rotation.angle();
        assert!((turned - 0.5).abs() < 1e-12, "{turned}");
        assert_eq!(poses[0], Isometry3::identity());
        // Missing, NaN, out of order, another robot's: one fault each, repeats silent.
        f.push(2_000, ["j1"], &[0.1]);
        f.push(2_100, ["j1"], &[0.1]);
        f.push(3_000, ["j1", "j2"], &[f64::NAN, 0.0]);
        f.push(500, ["j1", "j2"], &[0.2, 0.0]);
        f.push(4_000, ["hand_1", "hand_2"], &[0.0, 0.0]);
        f.push(4_000, ["j1", "j2"], &[0.0]);
        assert_eq!(
            faults(&f),
            [
                JointProblem::Missing,
                JointProblem::NotFinite,
                JointProblem::OutOfOrder,
                JointProblem::OtherRobot,
                JointProblem::Malformed
            ]
        );
        assert!(f.posture_at(5_000, &mut poses).is_some());
        assert!((poses[1].rotation.angle() - 0.5).abs() < 1e-12);
        // A good message right after does not end them: a missing joint within the second is
        // not said again (a gripper's own joint states between the arm's).
        f.push(6_000, ["j1", "j2"], &[-0.25, 0.0]);
        f.push(6_100, ["j2"], &[0.0]);
        assert_eq!(faults(&f), []);
        assert_eq!(
            f.counts(),
            FeedCounts {
                received: 9,
                taken: 2,
                faults: 5
            }
        );
        // A second later, it is.
        f.0.state.lock().unwrap().last_fault = [None; PROBLEMS];
        f.push(7_000, ["j1", "j2"], &[-0.25, 0.0]);
        f.push(7_100, ["j2"], &[0.0]);
        assert_eq!(faults(&f), [JointProblem::Missing]);
    }

    #[test]
    fn a_posture_too_old_is_stale_once_until_a_fresh_one() {
        let f = feed(None);
        let mut poses = Vec::new();
        f.push(0, ["j1", "j2"], &[0.0, 0.0]);
        for t in [50_000_000, 150_000_000, 200_000_000] {
            assert!(f.posture_at(t, &mut poses).is_some());
        }
        assert_eq!(faults(&f), [JointProblem::Stale]);
        // Fresh again within the second: a stale posture right after is not said again (a
        // publisher slower than max_age gives one event, not one a message)...
        f.push(250_000_000, ["j1", "j2"], &[0.0, 0.0]);
        assert!(f.posture_at(260_000_000, &mut poses).is_some());
        assert!(f.posture_at(400_000_000, &mut poses).is_some());
        assert_eq!(faults(&f), []);
        // ...but after a second fresh, it is.
        f.push(450_000_000, ["j1", "j2"], &[0.0, 0.0]);
        f.0.state.lock().unwrap().last_fault = [None; PROBLEMS];
        assert!(f.posture_at(460_000_000, &mut poses).is_some());
        assert!(f.posture_at(600_000_000, &mut poses).is_some());
        assert_eq!(faults(&f), [JointProblem::Stale]);
        // Joint states on another clock than the frames' are said.
        let other = feed(None);
        other.push(50_000_000_000, ["j1", "j2"], &[0.0, 0.0]);
        assert!(other.posture_at(1_000_000, &mut poses).is_none());
        assert_eq!(faults(&other), [JointProblem::Stale]);
    }

    #[test]
    fn a_replay_waits_for_the_posture_of_its_frame_but_not_twice_for_nothing() {
        let f = feed(Some(Duration::from_secs(5)));
        let writer = f.clone();
        let t = std::thread::spawn(move || {
            std::thread::sleep(Duration::from_millis(50));
            writer.push(1_000, ["j1", "j2"], &[0.0, 0.0]);
            writer.push(2_000, ["j1", "j2"], &[0.5, 0.0]);
        });
        let mut poses = Vec::new();
        assert!(f.posture_at(2_000, &mut poses).is_some());
        t.join().unwrap();
        assert!((poses[1].rotation.angle() - 0.5).abs() < 1e-12);
        // The joint states stop: one wait runs out, and the frames after it do not wait again
        // until a message comes.
        let quick = feed(Some(Duration::from_millis(20)));
        quick.push(0, ["j1", "j2"], &[0.0, 0.0]);
        assert!(quick.posture_at(10_000_000, &mut poses).is_some());
        assert!(quick.0.state.lock().unwrap().starved);
        quick.push(20_000_000, ["j1", "j2"], &[0.0, 0.0]);
        assert!(!quick.0.state.lock().unwrap().starved);
    }
}
