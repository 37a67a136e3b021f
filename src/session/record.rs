//! `record demo`: a person drives the ROS 2 base with their own teleoperation and the session
//! keeps it as a demonstration ([`crate::backend::ros2::record`] listens; the samples become a
//! positioning demonstration as a CSV log's do, [`crate::recording::episode`]). Journalled as
//! demonstrations, so a resume needs neither the base nor the person.

use std::f64::consts::PI;

use super::effect::{DemoEpisode, Effect};
use super::text::short_num;
use super::{BackendChoice, MAX_GOAL_M, Session, SessionError};
use crate::backend::ros2::record::{Ended, RecordOptions, record_teleop};
use crate::geometry::Pose;
use crate::task::TaskKind;

/// The longest recording `for` accepts, and the default, in seconds.
pub const MAX_RECORD_S: f64 = 3600.0;
pub const DEFAULT_RECORD_S: f64 = 600.0;
/// No command for this long with the base at rest ends a recording.
pub const RECORD_IDLE_S: f64 = 3.0;

impl Session {
    pub(super) fn record_demo(
        &mut self,
        topic: Option<&str>,
        goal: Option<[f64; 3]>,
        seconds: Option<f64>,
    ) -> Result<String, SessionError> {
        if self.task != TaskKind::Positioning {
            return Err(SessionError::RecordTask { task: self.task });
        }
        let BackendChoice::Ros2 { backend, .. } = &self.backend else {
            return Err(SessionError::RecordNeedsRos2 {
                backend: self.backend_name(),
            });
        };
        let max_s = seconds.unwrap_or(DEFAULT_RECORD_S);
        if !(max_s.is_finite() && max_s > 0.0 && max_s <= MAX_RECORD_S) {
            return Err(SessionError::RecordTime {
                seconds: short_num(max_s),
            });
        }
        let goal = match goal {
            Some([x, y, theta]) => {
                let within = |v: f64, limit: f64| v.is_finite() && v.abs() <= limit;
                if !(within(x, MAX_GOAL_M) && within(y, MAX_GOAL_M) && within(theta, 2.0 * PI)) {
                    return Err(SessionError::BadGoal {
                        goal: [x, y, theta].map(short_num).join(", "),
                    });
                }
                Some(Pose::new(x, y, theta))
            }
            None => None,
        };
        let spec = backend.spec().clone();
        let opts = RecordOptions {
            teleop_topic: topic.unwrap_or("cmd_vel").to_string(),
            period_s: self.sim_params().period_s(),
            max_s,
            idle_s: RECORD_IDLE_S,
        };
        self.stop.clear();
        let rec = record_teleop(&spec, &opts, &self.stop)
            .map_err(|error| SessionError::RecordFailed { error })?;
        self.stop.clear();
        if rec.samples.len() < 2 {
            return Err(SessionError::RecordEmpty {
                topic: rec.teleop_topic,
                heard: rec.commands_heard,
            });
        }
        let number = self.state.learner.dataset().demos().len();
        let episode = crate::recording::episode(format!("teleop {number}"), &rec.samples, goal);
        let points = episode.trace.len();
        let secs = rec.samples.last().map_or(0.0, |s| s.0);
        let ended = match rec.ended {
            Ended::Stopped => "ended by you",
            Ended::Idle => "the commands stopped and the base came to rest",
            Ended::TimeLimit => "the time limit",
            Ended::LinkLost => "odometry went stale; what came before is kept",
        };
        self.commit(Effect::Demos {
            source: format!("record demo from {}", rec.teleop_topic),
            episodes: vec![DemoEpisode {
                name: episode.name.clone(),
                trace: episode.trace.to_json(),
            }],
        })?;
        Ok(format!(
            "recorded demonstration `{}` from {} and {}: {points} points over {secs:.1} s ({ended}); the {} policy now has {} points",
            episode.name,
            rec.teleop_topic,
            rec.odom_topic,
            self.state.learner.kind_name(),
            self.state.learner.len(),
        ))
    }
}
