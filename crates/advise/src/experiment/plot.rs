//! SVG figures of the experiments (plotters): success against critique rounds under each critique
//! rule that ran (Figure 5), and for A-OPI success, errors and dataset size per arm (Figures 8, 9,
//! 11). Each figure is drawn in memory and written with [`crate::files::write_bytes`]; no other IO.

use std::path::{Path, PathBuf};

use plotters::prelude::*;

use crate::experiment::ExperimentError;
use crate::experiment::aopi::{AopiResult, ArmFigures};
use crate::experiment::bc::BcResult;

fn err(path: &Path) -> impl Fn(&dyn std::fmt::Display) -> ExperimentError + '_ {
    move |e| ExperimentError::Plot {
        path: path.display().to_string(),
        message: e.to_string(),
    }
}

/// Figure 5: test-set success against critique rounds, the teacher as a dashed line. Returns the
/// files written.
pub fn bc(result: &BcResult, dir: &Path) -> Result<Vec<PathBuf>, ExperimentError> {
    let path = dir.join(format!("bc-seed{}-success.svg", result.seed));
    bc_success(result, &path)?;
    let mut written = vec![path];
    // The second arm (the human-like hand) in a file of its own.
    if let Some(h) = &result.hand {
        let path = dir.join(format!("bc-seed{}-hand-success.svg", h.seed));
        bc_success(h, &path)?;
        written.push(path);
    }
    Ok(written)
}

fn bc_success(result: &BcResult, path: &Path) -> Result<(), ExperimentError> {
    let e = err(path);
    // Drawn into memory and written at once: a failed figure leaves no file.
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (720, 480)).into_drawing_area();
        root.fill(&WHITE).map_err(|x| e(&x))?;
        let rounds = result.params.rounds.max(1) as f64;
        let mut chart = ChartBuilder::on(&root)
            .caption(
                format!(
                    "BC, {}: test-set success against critique rounds (seed {})",
                    result.teacher_kind.label(),
                    result.seed
                ),
                ("sans-serif", 18),
            )
            .margin(12)
            .x_label_area_size(36)
            .y_label_area_size(48)
            .build_cartesian_2d(0.0..rounds, 0.0..100.0)
            .map_err(|x| e(&x))?;
        chart
            .configure_mesh()
            .x_desc("critique rounds")
            .y_desc("test set success (%)")
            .draw()
            .map_err(|x| e(&x))?;
        // One curve per critique rule that ran, each named by its rule.
        let orange = RGBColor(230, 120, 20);
        let curves = std::iter::once((result.rule, &result.curve, BLUE)).chain(
            result
                .directional
                .as_ref()
                .map(|d| (d.rule, &d.curve, orange)),
        );
        for (rule, curve, colour) in curves {
            let pts: Vec<(f64, f64)> = curve
                .iter()
                .map(|c| (c.round as f64, 100.0 * c.success_rate))
                .collect();
            chart
                .draw_series(LineSeries::new(pts.clone(), colour.stroke_width(2)))
                .map_err(|x| e(&x))?
                .label(format!("learner, {}", rule.label()))
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], colour));
            chart
                .draw_series(pts.iter().map(|&p| Circle::new(p, 3, colour.filled())))
                .map_err(|x| e(&x))?;
        }
        let t = 100.0 * result.teacher.success_rate;
        chart
            .draw_series(DashedLineSeries::new(
                vec![(0.0, t), (rounds, t)],
                6,
                4,
                BLACK.stroke_width(1),
            ))
            .map_err(|x| e(&x))?
            .label("teacher")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], BLACK));
        // Critique's ceiling (the second protocol, S6): what re-weighting these demonstrations
        // could at best do.
        if let Some(o) = &result.oracles {
            let ceilings = [
                (
                    "ceiling: successful demonstrations",
                    &o.successful_demos,
                    RGBColor(44, 160, 44),
                ),
                (
                    "ceiling: perfect critique",
                    &o.perfect_critique,
                    RGBColor(148, 103, 189),
                ),
            ];
            for (name, oracle, colour) in ceilings {
                let Some(f) = &oracle.figures else { continue };
                let y = 100.0 * f.success_rate;
                chart
                    .draw_series(DashedLineSeries::new(
                        vec![(0.0, y), (rounds, y)],
                        3,
                        3,
                        colour.stroke_width(2),
                    ))
                    .map_err(|x| e(&x))?
                    .label(name)
                    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], colour));
            }
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .position(SeriesLabelPosition::LowerRight)
            .draw()
            .map_err(|x| e(&x))?;
        root.present().map_err(|x| e(&x))?;
    }
    crate::files::write_bytes(path, svg.as_bytes())?;
    Ok(())
}

/// A bar chart's file stem, axis label, value per arm, and the paper's value per arm where the
/// paper gives one (Figure 8's success; Figure 9's errors are not in the text).
type Bar = (
    &'static str,
    &'static str,
    fn(&ArmFigures) -> f64,
    [Option<f64>; 5],
);

/// One bar: the arm, our value, the paper's value, the arm's colour.
type BarValue<'a> = (&'a str, f64, Option<f64>, RGBColor);

/// Figures 8 and 9 (success, position and heading error per policy, as bars) and Figure 11
/// (dataset size against executions, per arm). Returns the files written.
pub fn aopi(result: &AopiResult, dir: &Path) -> Result<Vec<PathBuf>, ExperimentError> {
    let a = &result.arms;
    let mut arms = vec![
        ("Baseline", &a.baseline, RGBColor(120, 120, 120)),
        ("Advised", &a.advised, RGBColor(31, 119, 180)),
        ("Hybrid", &a.hybrid, RGBColor(44, 160, 44)),
        ("Teleop", &a.teleop, RGBColor(214, 39, 40)),
    ];
    // The takeover arm (issue 53) is ours, not the paper's: no paper value beside it.
    if let Some(t) = &a.takeover {
        arms.push(("Takeover", t, RGBColor(148, 103, 189)));
    }
    let p = crate::experiment::aopi::PAPER;
    let paper_success = [
        Some(p.baseline_success),
        Some(p.advised_success),
        Some(p.hybrid_success),
        Some(p.teleop_success),
        None,
    ]
    .map(|v| v.map(|v| 100.0 * v));
    let mut written = Vec::new();
    let bars: [Bar; 3] = [
        (
            "success",
            "test set success (%)",
            |f| 100.0 * f.success_rate,
            paper_success,
        ),
        (
            "position-error",
            "mean position error (m)",
            |f| f.mean_position_error_m,
            [None; 5],
        ),
        (
            "heading-error",
            "mean heading error (rad)",
            |f| f.mean_heading_error_rad,
            [None; 5],
        ),
    ];
    for (file, label, value, paper) in bars {
        let path = dir.join(format!("aopi-seed{}-{file}.svg", result.seed));
        let values: Vec<BarValue<'_>> = arms
            .iter()
            .zip(paper)
            .map(|((n, f, c), p)| (*n, value(f), p, *c))
            .collect();
        bar_chart(
            &path,
            &format!("A-OPI: {label} (seed {})", result.seed),
            label,
            &values,
        )?;
        written.push(path);
    }
    let path = dir.join(format!("aopi-seed{}-dataset.svg", result.seed));
    dataset_chart(result, &arms, &path)?;
    written.push(path);
    Ok(written)
}

/// A value as a bar's label: percentages whole, errors to two decimals.
fn value_label(v: f64, percent: bool) -> String {
    if percent {
        format!("{v:.0}%")
    } else {
        format!("{v:.2}")
    }
}

fn bar_chart(
    path: &Path,
    title: &str,
    y_label: &str,
    values: &[BarValue<'_>],
) -> Result<(), ExperimentError> {
    let e = err(path);
    let percent = y_label.contains('%');
    let with_paper = values.iter().any(|v| v.2.is_some());
    // Drawn into memory and written at once: a failed figure leaves no file.
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (680, 440)).into_drawing_area();
        root.fill(&WHITE).map_err(|x| e(&x))?;
        // Room above the tallest bar for its label.
        let top = values
            .iter()
            .flat_map(|v| [v.1, v.2.unwrap_or(0.0)])
            .filter(|v| v.is_finite())
            .fold(0.0, f64::max)
            .max(1e-9)
            * 1.2;
        let n = values.len();
        let names: Vec<String> = values.iter().map(|v| v.0.to_string()).collect();
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 18))
            .margin(16)
            .x_label_area_size(40)
            .y_label_area_size(64)
            .build_cartesian_2d(0.0..n as f64, 0.0..top)
            .map_err(|x| e(&x))?;
        chart
            .configure_mesh()
            .disable_x_mesh()
            .x_labels(n * 2 + 1)
            .x_label_formatter(&|x| {
                let i = x.floor() as usize;
                if (x - i as f64 - 0.5).abs() < 0.26 && i < names.len() {
                    names[i].clone()
                } else {
                    String::new()
                }
            })
            .y_label_formatter(&|v| value_label(*v, percent))
            .label_style(("sans-serif", 13))
            .y_desc(y_label)
            .draw()
            .map_err(|x| e(&x))?;
        // Ours solid; the paper's beside it, pale with the arm's outline.
        let (ours_x, paper_x) = if with_paper {
            ((0.12, 0.5), (0.5, 0.88))
        } else {
            ((0.2, 0.8), (0.0, 0.0))
        };
        let font = ("sans-serif", 13).into_font();
        for (i, (_, v, paper, c)) in values.iter().enumerate() {
            let x = i as f64;
            chart
                .draw_series(std::iter::once(Rectangle::new(
                    [(x + ours_x.0, 0.0), (x + ours_x.1, *v)],
                    c.filled(),
                )))
                .map_err(|x| e(&x))?;
            let label = (x + (ours_x.0 + ours_x.1) / 2.0, *v);
            chart
                .draw_series(std::iter::once(label_above(
                    label,
                    value_label(*v, percent),
                    &font,
                )))
                .map_err(|x| e(&x))?;
            if let Some(p) = paper {
                chart
                    .draw_series([
                        Rectangle::new(
                            [(x + paper_x.0, 0.0), (x + paper_x.1, *p)],
                            c.mix(0.25).filled(),
                        ),
                        Rectangle::new(
                            [(x + paper_x.0, 0.0), (x + paper_x.1, *p)],
                            c.stroke_width(1),
                        ),
                    ])
                    .map_err(|x| e(&x))?;
                chart
                    .draw_series(std::iter::once(label_above(
                        (x + (paper_x.0 + paper_x.1) / 2.0, *p),
                        format!("paper {}", value_label(*p, percent)),
                        &font,
                    )))
                    .map_err(|x| e(&x))?;
            }
        }
        if with_paper {
            let note = "solid: this run; pale: the paper's Figure 8";
            root.draw(&Text::new(note, (90, 412), font.clone()))
                .map_err(|x| e(&x))?;
        }
        root.present().map_err(|x| e(&x))?;
    }
    crate::files::write_bytes(path, svg.as_bytes())?;
    Ok(())
}

/// A text centred just above a data point.
fn label_above<'a>(
    at: (f64, f64),
    text: String,
    font: &FontDesc<'a>,
) -> Text<'a, (f64, f64), String> {
    use plotters::style::text_anchor::{HPos, Pos, VPos};
    Text::new(
        text,
        at,
        TextStyle::from(font.clone()).pos(Pos::new(HPos::Center, VPos::Bottom)),
    )
}

fn dataset_chart(
    result: &AopiResult,
    arms: &[(&str, &ArmFigures, RGBColor)],
    path: &Path,
) -> Result<(), ExperimentError> {
    let e = err(path);
    // Drawn into memory and written at once: a failed figure leaves no file.
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (720, 480)).into_drawing_area();
        root.fill(&WHITE).map_err(|x| e(&x))?;
        let all = arms.iter().flat_map(|(_, f, _)| f.curve.iter());
        let (max_x, max_y) = all.fold((1.0f64, 1.0f64), |(x, y), c| {
            (x.max(c.executions as f64), y.max(c.dataset_size as f64))
        });
        let mut chart = ChartBuilder::on(&root)
            .caption(
                format!(
                    "A-OPI: dataset size against executions (seed {})",
                    result.seed
                ),
                ("sans-serif", 18),
            )
            .margin(12)
            .x_label_area_size(36)
            .y_label_area_size(60)
            .build_cartesian_2d(0.0..max_x * 1.05, 0.0..max_y * 1.1)
            .map_err(|x| e(&x))?;
        chart
            .configure_mesh()
            .x_desc("executions contributing to the dataset (ring: the kept policy; dashed: run after it)")
            .y_desc("data points")
            .x_label_formatter(&|v| format!("{v:.0}"))
            .y_label_formatter(&|v| format!("{v:.0}"))
            .light_line_style(WHITE.mix(0.0))
            .draw()
            .map_err(|x| e(&x))?;
        let p = crate::experiment::aopi::PAPER;
        let paper = [
            Some(p.advised_executions),
            Some(p.hybrid_executions),
            Some(p.teleop_executions),
            None,
        ];
        for ((name, f, color), paper) in arms.iter().skip(1).zip(paper) {
            let color = *color;
            let pts: Vec<(f64, f64)> = f
                .curve
                .iter()
                .map(|c| (c.executions as f64, c.dataset_size as f64))
                .collect();
            // The kept policy is the arm's result; what the arm ran after it (until patience ran
            // out) is drawn dashed and pale so the curve does not seem to end elsewhere.
            let kept = kept_index(f);
            let (upto, after) = pts.split_at((kept + 1).min(pts.len()));
            chart
                .draw_series(LineSeries::new(upto.to_vec(), color.stroke_width(2)))
                .map_err(|x| e(&x))?
                .label(match paper {
                    Some(paper) => format!(
                        "{name}: kept at {} executions (paper {paper})",
                        f.executions
                    ),
                    None => format!("{name}: kept at {} executions (ours)", f.executions),
                })
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], color));
            chart
                .draw_series(upto.iter().map(|&p| Circle::new(p, 3, color.filled())))
                .map_err(|x| e(&x))?;
            if let Some(&last) = upto.last().filter(|_| !after.is_empty()) {
                let mut rest = vec![last];
                rest.extend_from_slice(after);
                chart
                    .draw_series(DashedLineSeries::new(
                        rest,
                        5,
                        4,
                        color.mix(0.45).stroke_width(1),
                    ))
                    .map_err(|x| e(&x))?;
            }
            if let Some(&k) = upto.last() {
                chart
                    .draw_series([Circle::new(k, 8, color.stroke_width(2))])
                    .map_err(|x| e(&x))?;
                let font = ("sans-serif", 12).into_font().color(&color);
                let at = chart.backend_coord(&k);
                root.draw(&Text::new("kept", (at.0 - 12, at.1 - 24), font))
                    .map_err(|x| e(&x))?;
            }
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .position(SeriesLabelPosition::UpperLeft)
            .label_font(("sans-serif", 13))
            .draw()
            .map_err(|x| e(&x))?;
        root.present().map_err(|x| e(&x))?;
    }
    crate::files::write_bytes(path, svg.as_bytes())?;
    Ok(())
}

/// Which curve point is the kept (final) policy: the evaluation at the practice count the arm
/// kept; the last point when none matches (an arm that never improved keeps its first).
fn kept_index(f: &ArmFigures) -> usize {
    f.curve
        .iter()
        .position(|c| c.practice == f.practice_final && c.dataset_size == f.dataset_size)
        .or_else(|| f.curve.iter().position(|c| c.practice == f.practice_final))
        .unwrap_or(f.curve.len().saturating_sub(1))
}
