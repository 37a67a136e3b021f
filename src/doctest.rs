//! `advise test`: the examples of operators' doc comments, run.
