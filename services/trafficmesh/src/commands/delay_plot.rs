//! `bench intersection`'s figure: mean delay against demand, one line per
//! controller, as a PNG (drawn without system libraries: the bitmap backend
//! and the DejaVu Sans bytes of the `dejavu` crate). Written whole or not at
//! all.

use std::path::Path;
use std::sync::Once;

use anyhow::{Context, Result, anyhow};
use plotters::prelude::*;
use plotters::style::{FontStyle, register_font};

/// One controller's line: (demand, mean delay, p95 delay), by demand.
pub struct Line<'a> {
    pub controller: &'a str,
    pub points: Vec<(f64, f64, f64)>,
}

const COLORS: [RGBColor; 4] = [
    RGBColor(214, 39, 40),
    RGBColor(31, 119, 180),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
];

/// Draws mean delay (solid, dots) and p95 delay (thin) against demand.
pub fn write(path: &Path, lines: &[Line]) -> Result<()> {
    static FONT: Once = Once::new();
    FONT.call_once(|| {
        // Refused only for bytes that are no font: these are one.
        let _ = register_font("sans-serif", FontStyle::Normal, dejavu::sans::regular());
    });
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    // The encoder picks the format by extension: keep `.png` on the temporary file.
    let tmp = path.with_extension("partial.png");
    draw(&tmp, lines).map_err(|e| anyhow!("drawing {}: {e}", tmp.display()))?;
    std::fs::rename(&tmp, path).with_context(|| format!("writing {}", path.display()))?;
    Ok(())
}

fn draw(path: &Path, lines: &[Line]) -> Result<(), Box<dyn std::error::Error>> {
    let all = || lines.iter().flat_map(|l| l.points.iter());
    let max_demand = all().map(|p| p.0).fold(0.0, f64::max);
    let max_delay = all().map(|p| p.2.max(p.1)).fold(1.0, f64::max);
    let root = BitMapBackend::new(path, (900, 560)).into_drawing_area();
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(&root)
        .caption(
            "Delay through the intersection against demand",
            ("sans-serif", 22),
        )
        .margin(14)
        .x_label_area_size(44)
        .y_label_area_size(60)
        .build_cartesian_2d(0.0..max_demand * 1.08, 0.0..max_delay * 1.08)?;
    chart
        .configure_mesh()
        .x_desc("demand, vehicles per hour per lane")
        .y_desc("delay, s")
        .light_line_style(WHITE.mix(0.0))
        .draw()?;
    for (k, line) in lines.iter().enumerate() {
        let color = COLORS[k % COLORS.len()];
        chart
            .draw_series(LineSeries::new(
                line.points.iter().map(|p| (p.0, p.1)),
                color.stroke_width(3),
            ))?
            .label(format!("{} mean", line.controller))
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 24, y)], color.stroke_width(3)));
        chart.draw_series(
            line.points
                .iter()
                .map(|p| Circle::new((p.0, p.1), 4, color.filled())),
        )?;
        chart
            .draw_series(LineSeries::new(
                line.points.iter().map(|p| (p.0, p.2)),
                color.mix(0.6).stroke_width(1),
            ))?
            .label(format!("{} p95", line.controller))
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 24, y)], color.mix(0.6)));
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperLeft)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK.mix(0.4))
        .draw()?;
    root.present()?;
    Ok(())
}
