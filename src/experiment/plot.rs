//! SVG figures of the experiments (plotters): success against critique rounds (Figure 5), and
//! for A-OPI success, errors and dataset size per arm (Figures 8, 9, 11). No other IO.

use std::path::{Path, PathBuf};

use plotters::prelude::*;

use crate::experiment::ExperimentError;
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
    let root = SVGBackend::new(path, (720, 480)).into_drawing_area();
    root.fill(&WHITE).map_err(|x| e(&x))?;
    let rounds = result.params.rounds.max(1) as f64;
    let mut chart = ChartBuilder::on(&root)
        .caption(
            format!("BC: test-set success against critique rounds (seed {})", result.seed),
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
    root.present().map_err(|x| e(&x))
}
