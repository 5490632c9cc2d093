//! Message stamps from the input's clock, checked: a `builtin_interfaces/msg/Time` holds its
//! seconds in an `int32`, so ROS 2 time ends on 2038-01-19 at 03:14:07 UTC, and an MCAP
//! `log_time` is a `u64` of nanoseconds. A stamp is either exact or an error, never clamped or
//! wrapped.
//!
//! [`RosTime::Input`] keeps the input's clock (a candump log's time since the epoch; a raw
//! recording's time since its first frame) and refuses a time past the end of ROS 2 time.
//! [`RosTime::Rebase`] counts from 0 at the session's first frame: the same input always gives
//! the same stamps (an MCAP file made twice is the same file), as a raw recording's already
//! are; the wall clock would make a replayed log pass for live data.

use crate::messages::Stamp;

/// Nanoseconds a second.
const NS: u128 = 1_000_000_000;

/// The last nanosecond ROS 2 time can hold: `i32::MAX` seconds and 999,999,999 ns.
pub const ROS_TIME_END_NS: u64 = (i32::MAX as u64 + 1) * 1_000_000_000 - 1;

/// What the stamps of a session count from.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum RosTime {
    /// The input's clock as it is; a time past the end of ROS 2 time (2038-01-19) is refused.
    #[default]
    Input,
    /// From 0 at the session's first frame.
    Rebase,
}

/// A time that cannot be a ROS 2 stamp.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum StampError {
    /// The input's clock reads past the end of ROS 2 time.
    #[error(
        "ROS stamps: the input's clock reads {} ({} s since 1970) at {what}, past the end of ROS 2 time, {} (builtin_interfaces/Time holds seconds in an int32): stamp from 0 at the first frame instead (skin: --ros-time rebase)",
        date(*ns), seconds(*ns), date(u128::from(ROS_TIME_END_NS))
    )]
    PastEnd {
        /// Which time: "the first frame", "a frame", "an event".
        what: &'static str,
        /// The time, ns since 1970 (it may be past `u64`).
        ns: u128,
    },
    /// Counted from the first frame, the session is longer than ROS 2 time (68 years).
    #[error(
        "ROS stamps: {what} comes {} s after the first frame, past what ROS 2 time can hold ({} s)",
        seconds(*ns), seconds(u128::from(ROS_TIME_END_NS))
    )]
    TooLong {
        /// Which time: "a frame", "an event".
        what: &'static str,
        /// ns from the first frame.
        ns: u128,
    },
    /// A frame earlier than the first one, stamped from the first frame.
    #[error(
        "ROS stamps: a frame at {} s on the input's clock comes before the first frame ({} s): the clock went backwards, and stamps counted from the first frame cannot be negative (keep the input's clock: --ros-time input)",
        seconds(u128::from(*time_us) * 1000), seconds(u128::from(*origin_us) * 1000)
    )]
    BeforeFirst {
        /// The frame, µs on the input's clock.
        time_us: u64,
        /// The first frame, µs on the input's clock.
        origin_us: u64,
    },
    /// An event time that is not a time after the first frame.
    #[error("ROS stamps: an event at {0} s after the first frame cannot be stamped")]
    EventTime(f64),
}

/// The stamps of one session (see the [module](self)).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Clock {
    mode: RosTime,
    /// The input's clock at the first frame, µs (once known).
    origin_us: Option<u64>,
}

impl Clock {
    /// A clock stamping in `mode`, before the first frame.
    pub fn new(mode: RosTime) -> Clock {
        Clock {
            mode,
            origin_us: None,
        }
    }

    /// The session's first frame is at `origin_us` on the input's clock: checked now, so that
    /// an input past the end of ROS 2 time is refused before its first message.
    pub fn set_origin(&mut self, origin_us: u64) -> Result<(), StampError> {
        self.origin_us = Some(origin_us);
        let ns = match self.mode {
            RosTime::Input => u128::from(origin_us) * 1000,
            RosTime::Rebase => 0,
        };
        self.stamp(ns, "the first frame").map(|_| ())
    }

    /// A frame at `time_us` on the input's clock: its stamp, ns (an MCAP log time), and as a
    /// `builtin_interfaces/Time`.
    pub fn frame(&self, time_us: u64) -> Result<(u64, Stamp), StampError> {
        let ns = u128::from(time_us) * 1000;
        match (self.mode, self.origin_us) {
            (RosTime::Rebase, Some(origin_us)) => {
                let Some(since) = time_us.checked_sub(origin_us) else {
                    return Err(StampError::BeforeFirst { time_us, origin_us });
                };
                self.stamp(u128::from(since) * 1000, "a frame")
            }
            _ => self.stamp(ns, "a frame"),
        }
    }

    /// An event `time_s` seconds after the first frame (the session's event time), rounded to
    /// the microsecond (the input's resolution).
    pub fn event(&self, time_s: f64) -> Result<(u64, Stamp), StampError> {
        let us = time_s * 1e6;
        // Past u64 µs is past ROS time whatever the origin; NaN is in no range.
        if !(0.0..18_446_744_073_709_551_616.0).contains(&us) {
            return Err(StampError::EventTime(time_s));
        }
        let since_ns = u128::from(us.round() as u64) * 1000;
        let base_ns = match self.mode {
            RosTime::Input => u128::from(self.origin_us.unwrap_or(0)) * 1000,
            RosTime::Rebase => 0,
        };
        self.stamp(base_ns + since_ns, "an event")
    }

    /// `ns` (on the stamps' scale) as a stamp, or the error of `what`.
    fn stamp(&self, ns: u128, what: &'static str) -> Result<(u64, Stamp), StampError> {
        if ns > u128::from(ROS_TIME_END_NS) {
            return Err(match self.mode {
                RosTime::Input => StampError::PastEnd { what, ns },
                RosTime::Rebase => StampError::TooLong { what, ns },
            });
        }
        let past = || StampError::PastEnd { what, ns };
        let ns = u64::try_from(ns).map_err(|_| past())?;
        Ok((ns, Stamp::from_ns(ns).ok_or_else(past)?))
    }
}

/// `ns` as seconds with microseconds, `1700000000.123456`.
fn seconds(ns: u128) -> String {
    format!("{}.{:06}", ns / NS, ns % NS / 1000)
}

/// `ns` since 1970 as a UTC date and time, `2038-01-19 03:14:07 UTC` (proleptic Gregorian).
fn date(ns: u128) -> String {
    let secs = ns / NS;
    let days = secs / 86_400;
    let day_secs = secs % 86_400;
    // Days since 1970-01-01 to a civil date (H. Hinnant's algorithm, for days >= 0).
    let z = days + 719_468;
    let era = z / 146_097;
    let doe = z % 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + u128::from(month <= 2);
    format!(
        "{year}-{month:02}-{day:02} {:02}:{:02}:{:02} UTC",
        day_secs / 3600,
        day_secs % 3600 / 60,
        day_secs % 60
    )
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)] // a failed case should stop the test
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn dates_and_the_end_of_ros_time() {
        assert_eq!(date(0), "1970-01-01 00:00:00 UTC");
        assert_eq!(date(u128::from(ROS_TIME_END_NS)), "2038-01-19 03:14:07 UTC");
        assert_eq!(date(951_782_400 * NS), "2000-02-29 00:00:00 UTC");
        assert_eq!(date(2_208_988_800 * NS), "2040-01-01 00:00:00 UTC");
        assert_eq!(seconds(1_500_000), "0.001500");
    }

    #[test]
    fn an_input_past_2038_is_refused_at_its_first_frame() {
        // 2040-01-01, a candump log's clock.
        let origin_us = 2_208_988_800_000_000;
        let mut input = Clock::new(RosTime::Input);
        let err = input.set_origin(origin_us).unwrap_err().to_string();
        assert!(
            err.contains("2040-01-01 00:00:00 UTC") && err.contains("--ros-time rebase"),
            "{err}"
        );
        let mut rebased = Clock::new(RosTime::Rebase);
        assert_eq!(rebased.set_origin(origin_us), Ok(()));
        assert_eq!(
            rebased.frame(origin_us + 1_500_000),
            Ok((
                1_500_000_000,
                Stamp {
                    sec: 1,
                    nanosec: 500_000_000
                }
            ))
        );
        assert_eq!(
            rebased.event(2.25),
            Ok((
                2_250_000_000,
                Stamp {
                    sec: 2,
                    nanosec: 250_000_000
                }
            ))
        );
        assert!(matches!(
            rebased.frame(origin_us - 1),
            Err(StampError::BeforeFirst { .. })
        ));
    }

    #[test]
    fn the_last_second_of_ros_time_is_kept_and_the_next_refused() {
        let mut clock = Clock::new(RosTime::Input);
        let last_us = ROS_TIME_END_NS / 1000;
        assert_eq!(clock.set_origin(last_us), Ok(()));
        let (ns, stamp) = clock.frame(last_us).unwrap();
        assert_eq!((stamp.sec, stamp.nanosec), (i32::MAX, 999_999_000));
        assert_eq!(ns, last_us * 1000);
        assert!(matches!(
            clock.frame(last_us + 1),
            Err(StampError::PastEnd { what: "a frame", .. })
        ));
        assert!(matches!(clock.event(1e-6), Err(StampError::PastEnd { .. })));
        // Near 1.8e10 s the nanoseconds pass u64: still an error, never a wrap.
        assert!(clock.frame(u64::MAX).is_err());
        for bad in [f64::NAN, -1.0, f64::INFINITY, 1e300] {
            assert!(clock.event(bad).is_err(), "{bad}");
        }
    }

    /// The exact stamp of an event, by arithmetic that cannot overflow: ns, or None.
    fn expected(mode: RosTime, origin_us: u64, time_s: f64) -> Option<u128> {
        let us = time_s * 1e6;
        if !(0.0..18_446_744_073_709_551_616.0).contains(&us) {
            return None;
        }
        let base = match mode {
            RosTime::Input => u128::from(origin_us) * 1000,
            RosTime::Rebase => 0,
        };
        let ns = base + u128::from(us.round() as u64) * 1000;
        (ns <= u128::from(ROS_TIME_END_NS)).then_some(ns)
    }

    fn time_s() -> impl Strategy<Value = f64> {
        prop_oneof![
            0.0..1e5f64,
            any::<f64>(),
            Just(f64::NAN),
            Just(f64::INFINITY),
            Just(-0.0),
            0.0..3e9f64,
        ]
    }

    fn origin_us() -> impl Strategy<Value = u64> {
        prop_oneof![
            any::<u64>(),
            1_600_000_000_000_000..2_200_000_000_000_000u64,
            Just(ROS_TIME_END_NS / 1000),
            0..1_000_000u64,
        ]
    }

    proptest! {
        /// Any origin and event time: the stamp is exact (its seconds and nanoseconds give back
        /// the very nanosecond) or an error, never a clamped or wrapped value.
        #[test]
        fn event_stamps_are_exact_or_refused(origin in origin_us(), t in time_s(), rebase in any::<bool>()) {
            let mode = if rebase { RosTime::Rebase } else { RosTime::Input };
            let mut clock = Clock::new(mode);
            let origin_ok = clock.set_origin(origin).is_ok();
            prop_assert_eq!(origin_ok, rebase || u128::from(origin) * 1000 <= u128::from(ROS_TIME_END_NS));
            match (clock.event(t), expected(mode, origin, t)) {
                (Ok((ns, stamp)), Some(want)) => {
                    prop_assert_eq!(u128::from(ns), want);
                    prop_assert!(stamp.sec >= 0 && stamp.nanosec < 1_000_000_000);
                    prop_assert_eq!(u128::try_from(stamp.sec).unwrap() * NS + u128::from(stamp.nanosec), want);
                }
                (Err(_), None) => {}
                (got, want) => prop_assert!(false, "{:?} for {:?}", got, want),
            }
        }

        /// Frames likewise, on the input's clock or from the first frame.
        #[test]
        fn frame_stamps_are_exact_or_refused(origin in origin_us(), time in origin_us(), rebase in any::<bool>()) {
            let mode = if rebase { RosTime::Rebase } else { RosTime::Input };
            let mut clock = Clock::new(mode);
            let _ = clock.set_origin(origin);
            let want = match mode {
                RosTime::Input => Some(u128::from(time) * 1000),
                RosTime::Rebase => time.checked_sub(origin).map(|d| u128::from(d) * 1000),
            }
            .filter(|ns| *ns <= u128::from(ROS_TIME_END_NS));
            match (clock.frame(time), want) {
                (Ok((ns, stamp)), Some(want)) => {
                    prop_assert_eq!(u128::from(ns), want);
                    prop_assert_eq!(u128::try_from(stamp.sec).unwrap() * NS + u128::from(stamp.nanosec), want);
                }
                (Err(_), None) => {}
                (got, want) => prop_assert!(false, "{:?} for {:?}", got, want),
            }
        }
    }
}
