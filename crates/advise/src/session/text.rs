//! How replies word things: what changed between two evaluations, an execution's outcome, the
//! stretch of a path worth a look, short numbers and excerpts.

use std::fmt::Write as _;

use crate::backend::sim::wrap_angle;
use crate::eval::Report;
use crate::task::Execution;
use crate::trace::{Chunk, Pose};

/// What changed between two evaluations of the same test set; with `detail`, the goals whose
/// outcome changed.
pub(super) fn eval_change(since: &str, before: &Report, now: &Report, detail: bool) -> String {
    let mut out = format!(
        "  {since}: success {:.1}% -> {:.1}% ({:+.1} points), mean position error {:.3} -> {:.3} m ({:+.3}), mean length {:.3} -> {:.3} m ({:+.3})\n",
        100.0 * before.success_rate,
        100.0 * now.success_rate,
        100.0 * (now.success_rate - before.success_rate),
        before.mean_position_error_m,
        now.mean_position_error_m,
        now.mean_position_error_m - before.mean_position_error_m,
        before.mean_length_m,
        now.mean_length_m,
        now.mean_length_m - before.mean_length_m,
    );
    let changed: Vec<String> = before
        .outcomes
        .iter()
        .zip(&now.outcomes)
        .enumerate()
        .filter(|(_, (b, n))| b.success != n.success)
        .map(|(i, (b, n))| {
            format!(
                "    test {i}: {} -> {} (position error {:.2} -> {:.2} m)",
                if b.success { "success" } else { "failure" },
                if n.success { "success" } else { "failure" },
                b.position_error_m,
                n.position_error_m
            )
        })
        .collect();
    if detail {
        if changed.is_empty() {
            out.push_str("  no test changed outcome\n");
        } else {
            let _ = writeln!(out, "  {} changed outcome:", tests(changed.len()));
            for c in changed {
                let _ = writeln!(out, "{c}");
            }
        }
    } else if !changed.is_empty() {
        let _ = writeln!(
            out,
            "  {} changed outcome (`eval --detail` lists them)",
            tests(changed.len())
        );
    }
    out
}

/// `1 test`, `2 tests`.
fn tests(n: usize) -> String {
    if n == 1 {
        "1 test".into()
    } else {
        format!("{n} tests")
    }
}

/// A duration for a person: microseconds below a millisecond (`40 µs`, never `0.0 ms`), a
/// decimal below 10 ms (`3.2 ms`), whole milliseconds above.
pub(super) fn fmt_ms(ms: f64) -> String {
    if !ms.is_finite() || ms < 0.0 {
        "an unknown time".into()
    } else if ms < 1.0 {
        format!("{} µs", (ms * 1000.0).round().max(1.0))
    } else if ms < 10.0 {
        format!("{ms:.1} ms")
    } else {
        format!("{ms:.0} ms")
    }
}

pub(super) fn outcome_line(e: &Execution) -> String {
    let o = &e.outcome;
    let mut s = format!(
        "{} ({:?}{}) after {:.1} s, {:.2} m driven, position error {:.2} m",
        if o.success { "success" } else { "failure" },
        o.ending,
        o.end_rule
            .as_ref()
            .map_or(String::new(), |rule| format!(": `{rule}`")),
        o.duration_s,
        o.length_m,
        o.position_error_m
    );
    if let Some(h) = o.heading_error_rad {
        let _ = write!(s, ", heading error {h:.2} rad");
    }
    if let Some(n) = &o.non_finite {
        let _ = write!(s, "; stopped: {n}");
    }
    s
}

/// Values with their dimensions' names: `[range=0.6579, bearing=1.5555]`.
pub(super) fn fmt_named(dims: &[crate::domain::Dim], v: &[f64]) -> String {
    let parts: Vec<String> = dims
        .iter()
        .zip(v)
        .map(|(d, x)| format!("{}={x:.4}", d.name))
        .collect();
    format!("[{}]", parts.join(", "))
}

/// The stretch of `w` points of a path where the robot turned or slowed the most (what a teacher
/// most likely wants to look at), and which of the two it did; `None` if it never moved.
pub(super) fn worth_a_look(path: &[Pose], t: &[f64], w: usize) -> Option<(Chunk, &'static str)> {
    let n = path.len().min(t.len());
    if n < 3 {
        return None;
    }
    let w = w.clamp(2, n);
    let speed: Vec<f64> = (0..n - 1)
        .map(|i| {
            let (a, b) = (path[i], path[i + 1]);
            let dt = (t[i + 1] - t[i]).max(1e-6);
            (b.x_m - a.x_m).hypot(b.y_m - a.y_m) / dt
        })
        .collect();
    // Per step: how much it turned (rad) and how much it slowed (m/s), both at least 0.
    let turn: Vec<f64> = (0..n - 1)
        .map(|i| wrap_angle(path[i + 1].theta_rad - path[i].theta_rad).abs())
        .collect();
    let slow: Vec<f64> = (0..n - 1)
        .map(|i| (speed[i.saturating_sub(1)] - speed[i]).max(0.0))
        .collect();
    let mut best: Option<(f64, usize, &'static str)> = None;
    for start in 0..=(n - w) {
        let steps = start..(start + w - 1);
        let moving = steps.clone().map(|i| speed[i]).sum::<f64>() / (w - 1) as f64;
        if moving < 0.02 {
            continue;
        }
        let turned: f64 = steps.clone().map(|i| turn[i]).sum();
        let slowed: f64 = steps.map(|i| slow[i]).sum();
        // A radian of turning and a metre per second of slowing weigh alike.
        let score = turned + slowed;
        if best.is_none_or(|(b, _, _)| score > b) {
            let what = if turned >= slowed { "turned" } else { "slowed" };
            best = Some((score, start, what));
        }
    }
    let (_, start, what) = best?;
    Some((Chunk::new(start, start + w, n).ok()?, what))
}

/// A number as a teacher typed it, unless it is huge or tiny: then in exponent form, so a
/// diagnostic never prints hundreds of digits.
pub(super) fn short_num(v: f64) -> String {
    if v != 0.0 && v.is_finite() && !(1e-4..1e6).contains(&v.abs()) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

pub(super) fn first_chars(s: &str, n: usize) -> String {
    match s.char_indices().nth(n) {
        Some((i, _)) => format!("{}...", &s[..i]),
        None => s.to_string(),
    }
}

/// Check warnings as a reply shows them, after a blank line; empty when there are none.
pub(super) fn warnings_text(
    sources: &crate::diag::SourceMap,
    warnings: &[crate::check::CheckWarning],
) -> String {
    warnings
        .iter()
        .map(|w| format!("\n\n{}", crate::diag::render(sources, w, false).trim_end()))
        .collect()
}
