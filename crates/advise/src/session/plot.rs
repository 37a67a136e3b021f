//! Pictures of an execution: character plots for the terminal and SVG files (plotters).
//!
//! A teacher chooses the chunk to correct by looking, so every picture marks the current
//! selection and the chunks already critiqued or advised, and addresses points by index: the path
//! plot (equal scale on both axes, an index mark every [`INDEX_EVERY`] points, the goal or the
//! ball, the arena and the outcome), the actions plot (each action dimension against point index,
//! chunks shaded), and a comparison of two executions (before and after advice). No state and no
//! session knowledge: the session hands in a [`PlotView`]. SVGs are rendered to a string and
//! written at once, so a failed plot leaves no file.

use std::path::Path;

use plotters::prelude::*;

mod labels;
mod svg;
mod terminal;

use crate::domain::Domain;
use crate::program::task::{Drawn, ShapeKind};
use crate::trace::{Chunk, Pose, Trace};
use svg::{render_actions, render_paths};
pub use terminal::{ascii, strip};

/// Path plots mark and number every this many points.
pub const INDEX_EVERY: usize = 20;

/// The length of a heading arrow (the goal's, the robot's at the end), m.
pub const HEADING_ARROW_M: f64 = 0.3;

const SIZE: (u32, u32) = (900, 640);
const LEGEND_W: u32 = 230;
const PATH: RGBColor = RGBColor(40, 90, 200);
const AFTER: RGBColor = RGBColor(20, 150, 70);
const BALL: RGBColor = RGBColor(230, 140, 0);
const SELECTED: RGBColor = RGBColor(190, 60, 190);
const ADVISED: RGBColor = RGBColor(40, 170, 60);
const CRITIQUED: RGBColor = RGBColor(215, 40, 40);
/// The steps the teacher drove (a takeover).
const TEACHER: RGBColor = RGBColor(240, 150, 0);
const ARENA: RGBColor = RGBColor(120, 120, 120);
/// What a task draws besides its goal (the goal is black).
const DRAWN: RGBColor = RGBColor(110, 110, 110);

/// The interception arena: a square `[-half_m, half_m]^2` and the capture distance.
#[derive(Clone, Copy, Debug)]
pub struct Arena {
    pub half_m: f64,
    pub capture_m: f64,
}

/// What to draw of one execution.
pub struct PlotView<'a> {
    pub title: String,
    pub domain: &'a Domain,
    pub trace: &'a Trace,
    /// The robot's poses (true where known); empty when none were recorded.
    pub path: &'a [Pose],
    /// What the task draws for the run's goal (its `draw` clauses): the goal and anything else
    /// worth seeing.
    pub drawn: Vec<Drawn>,
    pub ball: Option<&'a [[f64; 2]]>,
    pub arena: Option<Arena>,
    /// One line: success or failure, why, how long.
    pub outcome: Option<String>,
    /// When the actions are changes of speed (interception): the clamps of the integrated speed
    /// command, `[trans, rot]`, so the plot can show the speeds that resulted.
    pub speed_limits: Option<[f64; 2]>,
    pub selection: Option<Chunk>,
    pub flagged: Vec<Chunk>,
    pub advised: Vec<Chunk>,
    /// The windows the teacher drove (a takeover).
    pub teacher: Vec<Chunk>,
}

/// One curve of the actions plot.
#[derive(Clone, Debug, PartialEq)]
pub struct ActionSeries {
    /// What is plotted, with its unit, as the axis says it.
    pub label: String,
    pub values: Vec<f64>,
}

impl PlotView<'_> {
    fn in_any(chunks: &[Chunk], i: usize) -> bool {
        chunks.iter().any(|c| c.range().contains(&i))
    }

    /// The curves of the actions plot: each action dimension by name and unit, and for actions
    /// that are changes of speed, the speed command they integrate to.
    pub fn action_series(&self) -> Vec<ActionSeries> {
        let n = self.trace.len();
        let mut out = Vec::new();
        for (d, dim) in self.domain.act.iter().enumerate() {
            if d >= self.trace.act_dim() {
                break;
            }
            let values: Vec<f64> = (0..n).map(|i| self.trace.a(i)[d]).collect();
            let unit = if dim.unit.is_empty() {
                String::new()
            } else {
                format!(" ({})", dim.unit)
            };
            let what = if self.speed_limits.is_some() {
                ""
            } else {
                " command"
            };
            out.push(ActionSeries {
                label: format!("{}{what}{unit}", dim.name),
                values: values.clone(),
            });
            if let Some(lim) = self.speed_limits.filter(|_| d < 2) {
                let mut speed = 0.0;
                let integrated = values
                    .iter()
                    .map(|v| {
                        speed = (speed + v).clamp(-lim[d], lim[d]);
                        speed
                    })
                    .collect();
                let base = dim.name.strip_suffix("_delta").unwrap_or(&dim.name);
                let unit = if dim.unit.is_empty() {
                    " (summed)".to_string()
                } else {
                    format!(" ({}, summed)", dim.unit)
                };
                out.push(ActionSeries {
                    label: format!("{base} speed{unit}"),
                    values: integrated,
                });
            }
        }
        out
    }
}

/// Data bounds of the path plot: the path, the goal, what the task draws, the ball and the arena;
/// with `arrows` (the SVG draws them, the terminal does not) the goal's heading arrow and the
/// robot's at the end too.
fn bounds(views: &[&PlotView<'_>], arrows: bool) -> (f64, f64, f64, f64) {
    let mut xs = Vec::new();
    let mut ys = Vec::new();
    for v in views {
        for p in v.path {
            xs.push(p.x_m);
            ys.push(p.y_m);
        }
        if let Some(p) = v.path.last().filter(|_| arrows) {
            xs.push(p.x_m + HEADING_ARROW_M * p.theta_rad.cos());
            ys.push(p.y_m + HEADING_ARROW_M * p.theta_rad.sin());
        }
        for d in v.drawn.iter().filter(|d| d.is_finite()) {
            let (x, y) = d.at();
            let r = d.radius();
            xs.extend([x - r, x + r]);
            ys.extend([y - r, y + r]);
            if let Some(h) = d.heading().filter(|h| arrows && h.is_finite()) {
                xs.push(x + HEADING_ARROW_M * h.cos());
                ys.push(y + HEADING_ARROW_M * h.sin());
            }
        }
        for b in v.ball.unwrap_or(&[]) {
            xs.push(b[0]);
            ys.push(b[1]);
        }
        if let Some(a) = v.arena {
            xs.extend([-a.half_m, a.half_m]);
            ys.extend([-a.half_m, a.half_m]);
        }
    }
    let finite = |v: &f64| v.is_finite();
    let lo = |v: &[f64]| {
        v.iter()
            .copied()
            .filter(finite)
            .fold(f64::INFINITY, f64::min)
    };
    let hi = |v: &[f64]| {
        v.iter()
            .copied()
            .filter(finite)
            .fold(f64::NEG_INFINITY, f64::max)
    };
    let (mut x0, mut x1, mut y0, mut y1) = (lo(&xs), hi(&xs), lo(&ys), hi(&ys));
    if !(x0.is_finite() && y0.is_finite()) {
        (x0, x1, y0, y1) = (-1.0, 1.0, -1.0, 1.0);
    }
    // A margin and a minimum extent so a short path is not blown up to fill the frame.
    let pad_x = ((x1 - x0) * 0.06).max(0.25);
    let pad_y = ((y1 - y0) * 0.06).max(0.25);
    (x0 - pad_x, x1 + pad_x, y0 - pad_y, y1 + pad_y)
}

/// Widen the narrower extent so a metre is as many pixels across as up.
fn equal_scale(b: (f64, f64, f64, f64), px_w: u32, px_h: u32) -> (f64, f64, f64, f64) {
    let (x0, x1, y0, y1) = b;
    let (w, h) = (f64::from(px_w.max(1)), f64::from(px_h.max(1)));
    let per_px = ((x1 - x0) / w).max((y1 - y0) / h);
    let (cx, cy) = ((x0 + x1) / 2.0, (y0 + y1) / 2.0);
    let (hx, hy) = (per_px * w / 2.0, per_px * h / 2.0);
    (cx - hx, cx + hx, cy - hy, cy + hy)
}

/// A tick label with as many decimals as the axis needs, and never `-0.0`.
/// `-0.00` reads `0.00`.
fn no_minus_zero(s: String) -> String {
    if s.starts_with('-') && s[1..].chars().all(|c| c == '0' || c == '.') {
        s[1..].to_string()
    } else {
        s
    }
}

/// An axis tick of a panel whose values may span far less than one unit (an actions panel): below
/// a span of 2, a decimal more per tenfold narrower span than [`tick`] (a command spanning 0.03
/// read `0.01, 0.01, 0.00` with two).
fn fine_tick(v: f64, span: f64) -> String {
    if !(span > 0.0 && span < 0.2) {
        return tick(v, span);
    }
    let decimals = (2.0 - (span / 2.0).log10()).floor().clamp(3.0, 6.0) as usize;
    no_minus_zero(format!("{v:.decimals$}"))
}

fn tick(v: f64, span: f64) -> String {
    let decimals = if span < 2.0 {
        2
    } else if span < 40.0 {
        1
    } else {
        0
    };
    no_minus_zero(format!("{v:.decimals$}"))
}

/// Why a plot could not be drawn or written.
#[derive(Debug, thiserror::Error, miette::Diagnostic)]
pub enum PlotError {
    #[error("cannot draw the plot `{path}`: {message}")]
    #[diagnostic(code(advise::plot::draw))]
    Draw { path: String, message: String },
    #[error(transparent)]
    #[diagnostic(transparent)]
    File(#[from] crate::files::FileError),
}

fn write(path: &Path, svg: Result<String, String>) -> Result<(), PlotError> {
    let svg = svg.map_err(|message| PlotError::Draw {
        path: path.display().to_string(),
        message,
    })?;
    crate::files::write_bytes(path, svg.as_bytes())?;
    Ok(())
}

/// Write the execution's path as an SVG file.
pub fn svg(view: &PlotView<'_>, path: &Path) -> Result<(), PlotError> {
    write(
        path,
        render_paths(&[view], &["path".to_string()], &view.title),
    )
}

/// Write the execution's actions against point index as an SVG file.
pub fn svg_actions(view: &PlotView<'_>, path: &Path) -> Result<(), PlotError> {
    write(path, render_actions(view))
}

/// Write two executions' paths overlaid (before and after advice) as an SVG file.
pub fn svg_compare(
    before: &PlotView<'_>,
    after: &PlotView<'_>,
    path: &Path,
) -> Result<(), PlotError> {
    // The legend names each by its number (`execution 0`); the title carries the labels.
    let short = |v: &PlotView<'_>| v.title.split(':').next().unwrap_or_default().to_string();
    let names = [
        format!("before: {}", short(before)),
        format!("after: {}", short(after)),
    ];
    let title = format!("before: {}; after: {}", before.title, after.title);
    let title = title.as_str();
    write(path, render_paths(&[before, after], &names, title))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn line(n: usize) -> Vec<Pose> {
        (0..n)
            .map(|i| Pose::new(i as f64 * 0.1, 0.0, 0.0))
            .collect()
    }

    fn trace(n: usize) -> Trace {
        let d = Domain::positioning();
        let mut t = Trace::new(&d);
        for i in 0..n {
            let x = i as f64 / n as f64;
            t.push(i as f64 * 0.1, &vec![0.0; d.obs_dim()], &[x, -x], None);
        }
        t
    }

    fn view<'a>(d: &'a Domain, t: &'a Trace, path: &'a [Pose]) -> PlotView<'a> {
        PlotView {
            title: "run".into(),
            domain: d,
            trace: t,
            path,
            drawn: vec![Drawn {
                name: "goal".into(),
                shape: ShapeKind::Pose,
                values: vec![3.5, 1.0, 0.5],
            }],
            ball: None,
            arena: None,
            outcome: Some("success (Rested) after 3.0 s".into()),
            speed_limits: None,
            selection: Some(Chunk { start: 2, end: 9 }),
            flagged: vec![Chunk { start: 12, end: 15 }],
            advised: vec![Chunk { start: 20, end: 25 }],
            teacher: vec![],
        }
    }

    /// The numbers in an attribute `name="..."` of every element that starts with `prefix`.
    fn elements<'s>(svg: &'s str, prefix: &str) -> Vec<&'s str> {
        svg.match_indices(prefix)
            .map(|(i, _)| {
                let rest = &svg[i..];
                &rest[..rest.find('>').unwrap_or(rest.len())]
            })
            .collect()
    }

    fn attr(el: &str, name: &str) -> Option<f64> {
        let key = format!(" {name}=\"");
        let i = el.find(&key)? + key.len();
        el[i..].split('"').next()?.parse().ok()
    }

    fn texts(svg: &str) -> Vec<(f64, String)> {
        svg.match_indices("<text")
            .map(|(i, _)| {
                let rest = &svg[i..];
                let open = rest.find('>').unwrap();
                let close = rest.find("</text>").unwrap();
                (
                    attr(&rest[..open], "x").unwrap_or(0.0),
                    rest[open + 1..close].trim().to_string(),
                )
            })
            .collect()
    }

    #[test]
    fn ascii_marks_selection_start_end_and_goal() {
        let (d, t) = (Domain::positioning(), trace(30));
        let path = line(30);
        let mut v = view(&d, &t, &path);
        v.selection = Some(Chunk { start: 10, end: 20 });
        let s = ascii(&v, 40, 8);
        for c in ['S', 'E', 'G', '#', '.'] {
            assert!(s.contains(c), "{c} missing in\n{s}");
        }
    }

    #[test]
    fn strip_has_a_row_per_action_and_marks_chunks_in_place() {
        let (d, t) = (Domain::positioning(), trace(128));
        let path = line(128);
        let mut v = view(&d, &t, &path);
        v.selection = Some(Chunk { start: 64, end: 80 });
        v.flagged = vec![Chunk { start: 0, end: 8 }];
        v.advised = vec![];
        let s = strip(&v, 64);
        let rows: Vec<&str> = s.lines().collect();
        assert_eq!(rows.len(), 4, "{s}");
        assert!(rows[0].contains("trans command (m/s) 0.00..0.99"), "{s}");
        // Rising trans: the lowest level first, the highest last.
        let cells: Vec<char> = rows[0].chars().skip(1).take(64).collect();
        assert_eq!((cells[0], cells[63]), ('▁', '█'));
        let marks: Vec<char> = rows[2].chars().skip(1).take(64).collect();
        assert_eq!(marks[..4], ['x'; 4]);
        assert_eq!(marks[32..40], ['#'; 8]);
        assert_eq!(marks[10], ' ');
        assert!(rows[3].starts_with(" 0") && rows[3].contains("32"), "{s}");
    }

    #[test]
    fn interception_series_integrate_speed_changes() {
        let d = Domain::interception();
        let mut t = Trace::new(&d);
        for i in 0..5 {
            t.push(i as f64, &[0.0; 6], &[0.1, -0.2], None);
        }
        let mut v = view(&d, &t, &[]);
        v.speed_limits = Some([0.25, 1.0]);
        let s = v.action_series();
        let labels: Vec<&str> = s.iter().map(|s| s.label.as_str()).collect();
        assert_eq!(
            labels,
            [
                "trans_delta (m/s)",
                "trans speed (m/s, summed)",
                "rot_delta (rad/s)",
                "rot speed (rad/s, summed)"
            ]
        );
        let speed: Vec<String> = s[1].values.iter().map(|v| format!("{v:.2}")).collect();
        assert_eq!(speed, ["0.10", "0.20", "0.25", "0.25", "0.25"]);
    }

    #[test]
    fn ticks_of_a_narrow_span_are_distinct() {
        // Ticks 0.005 apart over a span of 0.03 (a command that barely moves).
        let shown: Vec<String> = [-0.01, -0.005, 0.0, 0.005, 0.01]
            .iter()
            .map(|v| fine_tick(*v, 0.03))
            .collect();
        assert_eq!(shown, ["-0.010", "-0.005", "0.000", "0.005", "0.010"]);
        assert_eq!(fine_tick(0.5, 1.0), "0.50");
        assert_eq!(fine_tick(-0.0001, 0.03), "0.000");
    }

    #[test]
    fn ticks_never_read_minus_zero() {
        assert_eq!(tick(-0.0001, 1.0), "0.00");
        assert_eq!(tick(-0.04, 10.0), "0.0");
        assert_eq!(tick(-0.4, 10.0), "-0.4");
        assert_eq!(tick(-0.0, 100.0), "0");
    }

    #[test]
    fn path_svg_has_equal_scale_index_marks_and_legend_outside() {
        let (d, t) = (Domain::positioning(), trace(60));
        // A long thin L: 3 m along x, then 1 m up; distortion would show as unequal scales.
        let path: Vec<Pose> = (0..60)
            .map(|i| {
                if i < 30 {
                    Pose::new(i as f64 * 0.1, 0.0, 0.0)
                } else {
                    Pose::new(3.0, (i - 30) as f64 / 30.0, 1.5)
                }
            })
            .collect();
        let v = view(&d, &t, &path);
        let svg = render_paths(&[&v], &["path".into()], "t").unwrap();
        // The path's polyline: its pixels per metre across and up.
        let poly = elements(&svg, "<polyline")
            .into_iter()
            .find(|e| e.contains("stroke=\"#285AC8\"") && e.contains("stroke-width=\"2\""))
            .expect("the path polyline");
        let pts: Vec<(f64, f64)> = poly
            .split("points=\"")
            .nth(1)
            .unwrap()
            .split_whitespace()
            .filter_map(|p| {
                let (x, y) = p.trim_end_matches('"').split_once(',')?;
                Some((x.parse().ok()?, y.parse().ok()?))
            })
            .collect();
        assert_eq!(pts.len(), 60);
        let per_m_x = (pts[29].0 - pts[0].0) / 2.9;
        let per_m_y = (pts[30].1 - pts[59].1) / (29.0 / 30.0);
        assert!(
            (per_m_x / per_m_y - 1.0).abs() < 0.03,
            "{per_m_x} px/m across, {per_m_y} px/m up"
        );
        let texts = texts(&svg);
        for i in ["0", "20", "40"] {
            assert!(texts.iter().any(|(_, s)| s == i), "index {i} missing");
        }
        assert!(
            !texts
                .iter()
                .any(|(_, s)| s.starts_with("-0.0") || s == "-0")
        );
        // Legend entries lie right of the plot area.
        let plot_right = f64::from(SIZE.0 - LEGEND_W);
        for label in [
            "selected 2..9",
            "critiqued 12..15",
            "advised 20..25",
            "path",
        ] {
            let (x, _) = texts
                .iter()
                .find(|(_, s)| s == label)
                .unwrap_or_else(|| panic!("{label} missing"));
            assert!(*x > plot_right, "{label} at x = {x}");
        }
        assert!(texts.iter().any(|(_, s)| s.contains("success")));
    }

    #[test]
    fn critiqued_is_drawn_after_advised_and_selection() {
        let (d, t) = (Domain::positioning(), trace(30));
        let path = line(30);
        let v = view(&d, &t, &path);
        let svg = render_paths(&[&v], &["path".into()], "t").unwrap();
        let at = |color: &str| svg.find(&format!("stroke=\"{color}\"")).unwrap();
        assert!(at("#D72828") > at("#28AA3C"));
        assert!(at("#D72828") > at("#BE3CBE"));
    }

    #[test]
    fn actions_svg_shades_chunks_in_each_panel() {
        let (d, t) = (Domain::positioning(), trace(40));
        let v = view(&d, &t, &[]);
        let svg = render_actions(&v).unwrap();
        let fills = |c: &str| {
            elements(&svg, "<rect")
                .iter()
                .filter(|e| e.contains(&format!("fill=\"{c}\"")))
                .count()
        };
        // Two panels (trans, rot), each with one band per chunk (and one legend swatch).
        assert_eq!(fills("#BE3CBE"), 3);
        assert_eq!(fills("#28AA3C"), 3);
        assert_eq!(fills("#D72828"), 3);
        let texts = texts(&svg);
        assert!(texts.iter().any(|(_, s)| s == "trans command (m/s)"));
        assert!(texts.iter().any(|(_, s)| s == "rot command (rad/s)"));
        assert!(texts.iter().any(|(_, s)| s.contains("(1.0 s)")));
        assert!(!texts.iter().any(|(_, s)| s.starts_with("-0.0")));
    }

    #[test]
    fn svg_is_written_and_a_failure_leaves_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("p.svg");
        let (d, t) = (Domain::positioning(), trace(30));
        let path = line(30);
        let v = view(&d, &t, &path);
        svg(&v, &p).unwrap();
        let text = std::fs::read_to_string(&p).unwrap();
        assert!(text.starts_with("<svg") && text.contains("selected 2..9"));
        assert!(svg(&v, &dir.path().join("no/such/dir/p.svg")).is_err());
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
        let fifo = dir.path().join("fifo.svg");
        assert!(
            std::process::Command::new("mkfifo")
                .arg(&fifo)
                .status()
                .unwrap()
                .success()
        );
        assert!(matches!(
            svg_actions(&v, &fifo),
            Err(PlotError::File(crate::files::FileError::NotRegular { .. }))
        ));
    }

    /// Issue 49: the goal's heading arrow and the robot's final one are inside the plot's bounds
    /// (a goal at the path's edge pointing away used to fall out), and the SVG draws the final
    /// heading and names the rule that ended the run.
    #[test]
    fn the_headings_are_inside_and_the_ending_names_its_rule() {
        let (d, t) = (Domain::positioning(), trace(30));
        // Ends at (2.9, 0) facing up; the goal at (3.5, 1) faces +x.
        let mut path = line(30);
        path.last_mut().unwrap().theta_rad = std::f64::consts::FRAC_PI_2;
        let mut v = view(&d, &t, &path);
        v.outcome = Some("failure (Rule: `end when post < 0.25`) after 3.0 s".into());
        let (x0, x1, y0, y1) = bounds(&[&v], true);
        assert!(x1 >= 3.5 + HEADING_ARROW_M && x0 < 0.0, "{x0}..{x1}");
        assert!(y1 >= 1.0 && y0 < 0.0, "{y0}..{y1}");
        // The terminal draws no arrows: its bounds are the marks'.
        let (_, tx1, _, _) = bounds(&[&v], false);
        assert!(tx1 < x1);
        let svg = render_paths(&[&v], &["path".to_string()], "run").unwrap();
        // The legend's entries and the outcome's note, wrapped in the legend's panel.
        let text: String = texts(&svg).into_iter().map(|(_, t)| t + " ").collect();
        assert!(text.contains("end, and the heading there"), "{text}");
        assert!(
            text.contains("(Rule: `end when post &lt; 0.25`)")
                || text.contains("(Rule: `end when post < 0.25`)"),
            "{text}"
        );
    }
}
