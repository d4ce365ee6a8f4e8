//! A PNG of force magnitude against time, the contact tissue marked as a coloured band under the
//! curve (tissue colours from the table). Drawn with `plotters`' bitmap backend and no text, so it
//! needs no system fonts; the CSV beside it carries the numbers and names.
use std::path::Path;

use plotters::prelude::*;

use crate::error::{Error, Result};
use crate::session::replay::ForceSample;

/// Writes `path` (PNG, `width`×`height`). `colours[i]` is tissue i's RGB in 0..1.
pub fn plot_forces(path: &Path, forces: &[ForceSample], colours: &[[f32; 3]], width: u32, height: u32) -> Result<()> {
    let err = |m: String| Error::File { path: path.to_owned(), message: m };
    let t_end = forces.last().map_or(1.0, |s| s.t_s).max(1e-3);
    let f_max = forces.iter().map(|s| s.force.length()).fold(0.0, f64::max).max(0.1) * 1.1;
    dentsim_atomic::write_via(path, |tmp| -> Result<()> {
        let root = BitMapBackend::new(tmp, (width.max(64), height.max(64))).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(e.to_string()))?;
        let (w, h) = (width.max(64) as i32, height.max(64) as i32);
        let margin = 20;
        let band = 14;
        let plot = root.margin(margin, margin + band + 4, margin, margin);
        let mut chart = ChartBuilder::on(&plot)
            .build_cartesian_2d(0.0..t_end, 0.0..f_max)
            .map_err(|e| err(e.to_string()))?;
        // Axes and grid without labels (no fonts).
        chart
            .draw_series((0..=10).map(|i| {
                let y = f_max * f64::from(i) / 10.0;
                PathElement::new(vec![(0.0, y), (t_end, y)], RGBColor(225, 225, 225))
            }))
            .map_err(|e| err(e.to_string()))?;
        chart
            .draw_series(std::iter::once(PathElement::new(
                vec![(0.0, f_max), (0.0, 0.0), (t_end, 0.0)],
                BLACK.stroke_width(2),
            )))
            .map_err(|e| err(e.to_string()))?;
        chart
            .draw_series(LineSeries::new(forces.iter().map(|s| (s.t_s, s.force.length())), BLUE.stroke_width(2)))
            .map_err(|e| err(e.to_string()))?;
        // The contact tissue as a band along the bottom edge.
        let x_of = |t: f64| margin + ((t / t_end) * f64::from(w - 2 * margin)) as i32;
        for pair in forces.windows(2) {
            let Some(c) = usize::try_from(pair[0].tissue).ok().and_then(|i| colours.get(i)) else { continue };
            let colour = RGBColor((c[0] * 255.0) as u8, (c[1] * 255.0) as u8, (c[2] * 255.0) as u8);
            let (x0, x1) = (x_of(pair[0].t_s), x_of(pair[1].t_s).max(x_of(pair[0].t_s) + 1));
            root.draw(&Rectangle::new([(x0, h - margin - band), (x1, h - margin)], colour.filled()))
                .map_err(|e| err(e.to_string()))?;
        }
        root.present().map_err(|e| err(e.to_string()))
    })
}
