//! The studies' protocol as data: which study ([`Study`]) and which of the protocol's choices a
//! run reverts ([`Revert`], README "The protocol", points 1-7). Every study's parameters name
//! them, so they sit below the studies (issue 50): the studies read this file, and the ablation
//! ([`super::ablation`]) and the runner ([`super::study`]) read the studies.

use serde::{Deserialize, Serialize};

/// Which of the paper's studies.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Study {
    /// Binary Critiquing on ball interception (Table 1, Figure 5).
    Bc,
    /// Advice-Operator Policy Improvement on spatial positioning (Figures 8, 9, 11).
    Aopi,
}

impl crate::choice::Choice for Study {
    fn all() -> &'static [Study] {
        &[Study::Bc, Study::Aopi]
    }

    fn name(self) -> &'static str {
        match self {
            Study::Bc => "bc",
            Study::Aopi => "aopi",
        }
    }

    fn help(self) -> &'static str {
        match self {
            Study::Bc => "Binary Critiquing on ball interception (Table 1, Figure 5)",
            Study::Aopi => {
                "Advice-Operator Policy Improvement on spatial positioning (Figures 8, 9, 11)"
            }
        }
    }
}

/// One choice of the protocol (README, "The protocol", points 1-7), to revert alone.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Revert {
    /// 1 (bc): the pre-protocol world, a ball up to 1.3 m/s against the teacher's 0.8 m/s cruise.
    Ball,
    /// 2 (bc, aopi): the stateless interception teacher; a teleoperator whose hand never varies.
    Teacher,
    /// 3 (bc): fixed 25-point chunks, at most the first two flagged.
    Chunks,
    /// 4 (bc): critique without the recorded support (the points nearest now).
    Support,
    /// 5 (aopi): the advisor on the goal point, rates from commanded speeds.
    Advisor,
    /// 6 (aopi): stopping and reporting on the test set (its best evaluation).
    Stopping,
    /// 7 (aopi): positioning demonstrations recorded at 30 Hz.
    Rate,
}

impl Revert {
    /// Every choice, in the protocol's order.
    pub const ALL: [Revert; 7] = [
        Revert::Ball,
        Revert::Teacher,
        Revert::Chunks,
        Revert::Support,
        Revert::Advisor,
        Revert::Stopping,
        Revert::Rate,
    ];

    /// The choice's number in the protocol's table.
    pub fn point(self) -> usize {
        Revert::ALL.iter().position(|&c| c == self).unwrap_or(0) + 1
    }

    /// The name `--revert` takes.
    pub fn name(self) -> &'static str {
        match self {
            Revert::Ball => "ball",
            Revert::Teacher => "teacher",
            Revert::Chunks => "chunks",
            Revert::Support => "support",
            Revert::Advisor => "advisor",
            Revert::Stopping => "stopping",
            Revert::Rate => "rate",
        }
    }

    /// Whether reverting this choice changes anything in `study`.
    pub fn affects(self, study: Study) -> bool {
        match self {
            Revert::Ball | Revert::Chunks | Revert::Support => study == Study::Bc,
            Revert::Advisor | Revert::Stopping | Revert::Rate => study == Study::Aopi,
            Revert::Teacher => true,
        }
    }
}

impl crate::choice::Choice for Revert {
    fn all() -> &'static [Revert] {
        &Revert::ALL
    }

    fn name(self) -> &'static str {
        Revert::name(self)
    }

    fn help(self) -> &'static str {
        match self {
            Revert::Ball => {
                "1 (bc): the pre-protocol world, a ball up to 1.3 m/s against the teacher's 0.8 m/s cruise"
            }
            Revert::Teacher => {
                "2 (bc, aopi): the stateless interception teacher; a teleoperator whose hand never varies"
            }
            Revert::Chunks => "3 (bc): fixed 25-point chunks, at most the first two flagged",
            Revert::Support => {
                "4 (bc): critique without the recorded support (the points nearest now)"
            }
            Revert::Advisor => {
                "5 (aopi): the advisor on the goal point, rates from commanded speeds"
            }
            Revert::Stopping => {
                "6 (aopi): stopping and reporting on the test set (its best evaluation)"
            }
            Revert::Rate => "7 (aopi): positioning demonstrations recorded at 30 Hz",
        }
    }
}

/// Whether `revert` is `choice` (what the studies' code paths ask).
pub fn reverts(revert: Option<Revert>, choice: Revert) -> bool {
    revert == Some(choice)
}
