//! SVG figures of the experiments (plotters): success against critique rounds (Figure 5), and
//! for A-OPI success, errors and dataset size per arm (Figures 8, 9, 11). Each figure is drawn in
//! memory and written with [`crate::files::write_bytes`]; no other IO.

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
    Ok(vec![path])
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
                    "BC: test-set success against critique rounds (seed {})",
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
        let pts: Vec<(f64, f64)> = result
            .curve
            .iter()
            .map(|c| (c.round as f64, 100.0 * c.success_rate))
            .collect();
        chart
            .draw_series(LineSeries::new(pts.clone(), BLUE.stroke_width(2)))
            .map_err(|x| e(&x))?
            .label("learner")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], BLUE));
        chart
            .draw_series(pts.iter().map(|&p| Circle::new(p, 3, BLUE.filled())))
            .map_err(|x| e(&x))?;
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

/// A bar chart's file stem, axis label and value per arm.
type Bar = (&'static str, &'static str, fn(&ArmFigures) -> f64);

/// Figures 8 and 9 (success, position and heading error per policy, as bars) and Figure 11
/// (dataset size against executions, per arm). Returns the files written.
pub fn aopi(result: &AopiResult, dir: &Path) -> Result<Vec<PathBuf>, ExperimentError> {
    let a = &result.arms;
    let arms = [
        ("Baseline", &a.baseline, RGBColor(120, 120, 120)),
        ("Advised", &a.advised, RGBColor(31, 119, 180)),
        ("Hybrid", &a.hybrid, RGBColor(44, 160, 44)),
        ("Teleop", &a.teleop, RGBColor(214, 39, 40)),
    ];
    let mut written = Vec::new();
    let bars: [Bar; 3] = [
        ("success", "test set success (%)", |f| {
            100.0 * f.success_rate
        }),
        ("position-error", "mean position error (m)", |f| {
            f.mean_position_error_m
        }),
        ("heading-error", "mean heading error (rad)", |f| {
            f.mean_heading_error_rad
        }),
    ];
    for (file, label, value) in bars {
        let path = dir.join(format!("aopi-seed{}-{file}.svg", result.seed));
        let values: Vec<(&str, f64, RGBColor)> =
            arms.iter().map(|(n, f, c)| (*n, value(f), *c)).collect();
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

fn bar_chart(
    path: &Path,
    title: &str,
    y_label: &str,
    values: &[(&str, f64, RGBColor)],
) -> Result<(), ExperimentError> {
    let e = err(path);
    // Drawn into memory and written at once: a failed figure leaves no file.
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (640, 420)).into_drawing_area();
        root.fill(&WHITE).map_err(|x| e(&x))?;
        let top = values.iter().map(|v| v.1).fold(0.0, f64::max).max(1e-9) * 1.15;
        let n = values.len();
        let names: Vec<String> = values.iter().map(|v| v.0.to_string()).collect();
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 18))
            .margin(12)
            .x_label_area_size(36)
            .y_label_area_size(52)
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
            .y_desc(y_label)
            .draw()
            .map_err(|x| e(&x))?;
        chart
            .draw_series(values.iter().enumerate().map(|(i, (_, v, c))| {
                Rectangle::new([(i as f64 + 0.2, 0.0), (i as f64 + 0.8, *v)], c.filled())
            }))
            .map_err(|x| e(&x))?;
        root.present().map_err(|x| e(&x))?;
    }
    crate::files::write_bytes(path, svg.as_bytes())?;
    Ok(())
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
            .x_desc("executions contributing to the dataset")
            .y_desc("data points")
            .draw()
            .map_err(|x| e(&x))?;
        for (name, f, color) in arms.iter().skip(1) {
            let color = *color;
            let pts: Vec<(f64, f64)> = f
                .curve
                .iter()
                .map(|c| (c.executions as f64, c.dataset_size as f64))
                .collect();
            chart
                .draw_series(LineSeries::new(pts.clone(), color.stroke_width(2)))
                .map_err(|x| e(&x))?
                .label(*name)
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], color));
            chart
                .draw_series(pts.iter().map(|&p| Circle::new(p, 3, color.filled())))
                .map_err(|x| e(&x))?;
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .position(SeriesLabelPosition::UpperLeft)
            .draw()
            .map_err(|x| e(&x))?;
        root.present().map_err(|x| e(&x))?;
    }
    crate::files::write_bytes(path, svg.as_bytes())?;
    Ok(())
}
