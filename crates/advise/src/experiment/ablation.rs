//! The ablation of the studies' protocol (issue 33; README, "The protocol"; `docs/ablation.md`):
//! each of the protocol's choices 1-7, reverted **alone** to what it replaced, so a re-run of the
//! study it affects says which choice moved which figure. It is a record: no choice of the
//! protocol is changed because of it.
//!
//! `advise experiment bc|aopi --revert CHOICE` runs the study with everything as the protocol has
//! it but that one choice, and the parameters in `--json` name it (`params.revert`). What each
//! choice reverts to is the behaviour of the commit before the protocol (`8c9cd11^`), kept here or
//! beside the code it replaced:
//!
//! | choice | study | reverted to |
//! |---|---|---|
//! | `ball` (1) | bc | the world the pre-protocol calibration chose with no interceptability constraint: the ball 1-2 m away at up to 1.3 m/s, a 9 m arena, a 0.4 m capture ([`InterceptionRules::pre_protocol`]) |
//! | `teacher` (2) | bc, aopi | bc: the stateless interception teacher, a function of the observation ([`StatelessInterceptionTeacher`]); aopi: the teleoperator's hand fixed at a 0.25 s lag and 0.03 tremor, never hesitating |
//! | `chunks` (3) | bc | consecutive 25-point chunks, the first two poor ones flagged ([`crate::experiment::critic::critique_fixed`]) |
//! | `support` (4) | bc | critique without the recorded support: each chunk penalises the points nearest now |
//! | `advisor` (5) | aopi | arcs judged against the goal point with commanded curvature, rates from medians of commanded ratios, speed and heading advice at the operators' default gains |
//! | `stopping` (6) | aopi | each arm stops when its test-set evaluation no longer improves and reports its best test-set evaluation |
//! | `rate` (7) | aopi | positioning demonstrations recorded at the 30 Hz control rate |
//!
//! Everything a choice did not touch stays as the protocol has it: the shipped calibration, the
//! seeds, the other choices. A choice reverted in a study it does not affect is refused by the
//! command line ([`Revert::affects`]).

pub use super::protocol::{Revert, reverts};
use crate::experiment::aopi::AopiParams;
use crate::experiment::bc::BcParams;
use crate::experiment::protocol::Study;
use crate::task::InterceptionRules;
use crate::task::human::HandRanges;
use crate::task::positioning::TeacherStyle;

pub use crate::task::interception::StatelessInterceptionTeacher;

impl Revert {
    /// The BC study's parameters with this choice reverted (unchanged for a choice that does
    /// not affect it). The code paths that are not data (the stateless teacher, the fixed chunks,
    /// critique without support) read `params.revert`.
    pub fn bc(self, params: BcParams) -> BcParams {
        if !self.affects(Study::Bc) {
            return params;
        }
        let world = match self {
            Revert::Ball => InterceptionRules::pre_protocol(),
            _ => params.world.clone(),
        };
        BcParams {
            world,
            revert: Some(self),
            ..params
        }
    }

    /// The A-OPI study's parameters with this choice reverted (unchanged for a choice that does
    /// not affect it). The stopping rule and the recording rate read `params.revert`.
    pub fn aopi(self, params: AopiParams) -> AopiParams {
        if !self.affects(Study::Aopi) {
            return params;
        }
        let mut teacher = params.teacher.clone();
        if self == Revert::Teacher {
            // The teleoperator before the protocol: its lag and tremor fixed at the hand-written
            // teacher's, never hesitating.
            teacher.hand = HandRanges::fixed(TeacherStyle::default().hand());
        }
        let mut advisor = params.advisor.clone();
        advisor.pre_protocol = self == Revert::Advisor;
        AopiParams {
            teacher,
            advisor,
            revert: Some(self),
            // The ablation reverts choices of the paper's arms; the takeover arm came after it.
            takeover_arm: false,
            ..params
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_choice_has_its_number_and_name_once() {
        let names: Vec<&str> = Revert::ALL.iter().map(|c| c.name()).collect();
        assert_eq!(
            names,
            [
                "ball", "teacher", "chunks", "support", "advisor", "stopping", "rate"
            ]
        );
        for (i, c) in Revert::ALL.iter().enumerate() {
            assert_eq!(c.point(), i + 1);
            // The name a front end takes is the same.
            assert_eq!(<Revert as crate::choice::Choice>::parse(c.name()), Some(*c));
        }
    }

    /// The BC parameters differ from the protocol's only in the reverted piece.
    #[test]
    fn a_bc_revert_changes_only_its_piece() {
        let base = BcParams::default();
        for c in Revert::ALL {
            let p = c.bc(base.clone());
            if !c.affects(Study::Bc) {
                assert_eq!(p, base, "{c:?}");
                continue;
            }
            assert_eq!(p.revert, Some(c));
            let same_but_world = BcParams {
                world: base.world.clone(),
                revert: None,
                ..p.clone()
            };
            assert_eq!(same_but_world, base, "{c:?}");
            if c == Revert::Ball {
                // The pre-protocol ball: up to 1.3 m/s, faster than the teacher's 0.8 m/s.
                assert_eq!(p.world.ball_speed_mps, (0.0, 1.3));
                assert_eq!(p.world.ball_dist_m, (1.0, 2.0));
                assert_eq!((p.world.arena_half_m, p.world.capture_m), (4.5, 0.4));
                assert!(p.world.ball_speed_mps.1 > p.teacher.cruise_mps);
                assert!(base.world.ball_speed_mps.1 <= base.teacher.cruise_mps);
            } else {
                assert_eq!(p.world, base.world, "{c:?}");
            }
        }
    }

    /// The A-OPI parameters differ from the protocol's only in the reverted piece.
    #[test]
    fn an_aopi_revert_changes_only_its_piece() {
        let base = AopiParams::default();
        for c in Revert::ALL {
            let p = c.aopi(base.clone());
            if !c.affects(Study::Aopi) {
                assert_eq!(p, base, "{c:?}");
                continue;
            }
            assert_eq!(p.revert, Some(c));
            let mut same = p.clone();
            same.revert = None;
            // Every revert leaves the takeover arm out (it is not one of the paper's arms).
            assert!(!p.takeover_arm && base.takeover_arm);
            same.takeover_arm = true;
            if c == Revert::Teacher {
                // Only the hand: fixed at 0.25 s and 0.03, no hesitation.
                assert_eq!(p.teacher.hand.reaction_s, [0.25, 0.25]);
                assert_eq!(p.teacher.hand.tremor, [0.03, 0.03]);
                assert_eq!(p.teacher.hand.hesitate_per_s, [0.0, 0.0]);
                assert_ne!(base.teacher.hand, p.teacher.hand);
                same.teacher.hand = base.teacher.hand;
            }
            if c == Revert::Advisor {
                assert!(p.advisor.pre_protocol && !base.advisor.pre_protocol);
                same.advisor.pre_protocol = false;
            }
            assert_eq!(p.record_every(), if c == Revert::Rate { 1 } else { 2 });
            assert_eq!(p.stops_on_test(), c == Revert::Stopping);
            assert_eq!(same, base, "{c:?}");
        }
    }
}
