//! The advising session (WIP): its parts.
pub mod journal;
pub mod plot;
pub mod script;
