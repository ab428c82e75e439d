//! Report curves: one line per scene, drawn with plotters to SVG and PNG.
//! Text uses the bundled DejaVu Sans Mono (`clients/assets`), so no system
//! font library is needed.

use std::path::Path;
use std::sync::Once;

use anyhow::{anyhow, Context};
use plotters::coord::Shift;
use plotters::prelude::*;

const FONT: &[u8] = include_bytes!("../../assets/DejaVuSansMono.ttf");
const SIZE: (u32, u32) = (800, 520);
/// One colour per series, up to twelve (a chart with more repeats them).
const COLOURS: [RGBColor; 12] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
    RGBColor(255, 127, 14),
    RGBColor(23, 190, 207),
    RGBColor(120, 80, 40),
    RGBColor(60, 60, 60),
    RGBColor(227, 119, 194),
    RGBColor(188, 189, 34),
    RGBColor(0, 0, 128),
    RGBColor(140, 200, 140),
];

/// At most this many tick labels per axis, so that log axes' labels do
/// not overlap.
const TICKS: usize = 8;

/// A tick label: whole numbers without a decimal point (the bundled font's
/// point renders a pixel high at these sizes), others with the fewest
/// decimals that tell them apart.
fn tick(v: &f64) -> String {
    let v = *v;
    if (v - v.round()).abs() <= 1e-9 * v.abs().max(1.0) {
        // `+ 0.0` turns a negative zero into zero: no "-0" tick.
        return format!("{:.0}", v.round() + 0.0);
    }
    for decimals in 1..=4 {
        let s = format!("{v:.decimals$}");
        if (s.parse::<f64>().unwrap_or(f64::NAN) - v).abs() <= 1e-9 * v.abs().max(1e-12) {
            return s;
        }
    }
    format!("{v:.3e}")
}

/// Markers per series at most: a longer series is marked at every n-th point.
const MARKED: usize = 30;

/// Width of the legend column right of the plot, pixels.
const LEGEND_WIDTH: u32 = 190;

/// Characters of a legend line (the column's width in the bundled font).
const LEGEND_CHARS: usize = 19;

/// `name` in lines of at most `width` characters, broken at spaces (a word
/// longer than a line is cut).
fn wrap(name: &str, width: usize) -> Vec<String> {
    let mut lines: Vec<String> = Vec::new();
    for word in name.split_whitespace() {
        let word: String = word.chars().take(width).collect();
        match lines.last_mut() {
            Some(l) if l.chars().count() + 1 + word.chars().count() <= width => {
                l.push(' ');
                l.push_str(&word);
            }
            _ => lines.push(word),
        }
    }
    if lines.is_empty() {
        lines.push(String::new());
    }
    lines
}

/// Series `k`'s line: solid, dashed or dotted in turn, so that curves that
/// coincide still show both (with the colour and the marker, no two of the
/// first twelve series look alike).
fn dash(k: usize) -> Option<(u32, u32)> {
    match k % 3 {
        0 => None,
        1 => Some((10, 6)),
        _ => Some((3, 4)),
    }
}

/// Draws series `k`'s marker at `p`: circle, triangle, cross or square.
fn marker<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    k: usize,
    (x, y): (i32, i32),
    colour: RGBColor,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    let style = colour.filled();
    match k % 4 {
        0 => area.draw(&Circle::new((x, y), 4, style)),
        1 => area.draw(&Polygon::new(vec![(x, y - 5), (x - 5, y + 4), (x + 5, y + 4)], style)),
        2 => {
            area.draw(&PathElement::new(
                vec![(x - 4, y - 4), (x + 4, y + 4)],
                colour.stroke_width(2),
            ))?;
            area.draw(&PathElement::new(
                vec![(x - 4, y + 4), (x + 4, y - 4)],
                colour.stroke_width(2),
            ))
        }
        _ => area.draw(&Rectangle::new([(x - 4, y - 4), (x + 4, y + 4)], style)),
    }
}

/// A chart: labelled series of `(x, y)` points, x on a log axis unless
/// `linear_x`, y on a log axis when `log_y`.
pub struct Chart<'a> {
    /// Title.
    pub title: &'a str,
    /// X axis label.
    pub x_label: &'a str,
    /// Y axis label.
    pub y_label: &'a str,
    /// `(name, points)`; points with a non-finite x or y (or, on a log axis,
    /// a non-positive x) are left out.
    pub series: Vec<(String, Vec<(f64, f64)>)>,
    /// A linear x axis.
    pub linear_x: bool,
    /// A log y axis (non-positive y left out).
    pub log_y: bool,
    /// Unused: the legend is drawn in a column of its own, right of the
    /// plot, where it covers no data (kept so callers need not change).
    pub legend: SeriesLabelPosition,
}

fn register_font() -> anyhow::Result<()> {
    static ONCE: Once = Once::new();
    let mut result = Ok(());
    ONCE.call_once(|| {
        result = plotters::style::register_font("sans-serif", FontStyle::Normal, FONT)
            .map_err(|_| anyhow!("the bundled font does not parse"));
    });
    result
}

impl Chart<'_> {
    fn points(&self) -> Vec<(&str, Vec<(f64, f64)>)> {
        self.series
            .iter()
            .map(|(name, pts)| {
                let kept = pts
                    .iter()
                    .copied()
                    .filter(|(x, y)| {
                        x.is_finite() && (self.linear_x || *x > 0.0) && y.is_finite() && (!self.log_y || *y > 0.0)
                    })
                    .collect();
                (name.as_str(), kept)
            })
            .collect()
    }

    fn draw<DB: DrawingBackend>(&self, root: DrawingArea<DB, Shift>) -> anyhow::Result<()>
    where
        DB::ErrorType: 'static,
    {
        let series = self.points();
        let all: Vec<(f64, f64)> = series.iter().flat_map(|(_, p)| p.iter().copied()).collect();
        anyhow::ensure!(!all.is_empty(), "chart {:?} has no point to draw", self.title);
        let (x0, x1) = all
            .iter()
            .fold((f64::INFINITY, 0f64), |(a, b), p| (a.min(p.0), b.max(p.0)));
        let (y0, y1) = all
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| (a.min(p.1), b.max(p.1)));
        // A margin of 8 % of the span (half a unit when every value is one).
        let pad = if y1 > y0 { (y1 - y0) * 0.08 } else { 0.5 };
        let e = |err| anyhow!("drawing {:?}: {err:?}", self.title);
        root.fill(&WHITE).map_err(e)?;
        // The title over the whole width, the legend in a column of its own.
        let root = root.titled(self.title, ("sans-serif", 20)).map_err(e)?;
        let (w, _) = root.dim_in_pixel();
        let (plot, legend) = root.split_horizontally(w.saturating_sub(LEGEND_WIDTH));
        let mut builder = ChartBuilder::on(&plot);
        builder.margin(12).x_label_area_size(44).y_label_area_size(56);
        let (lin_x, log_x) = (x0..x1.max(x0 + 1.0), (x0 / 1.3..x1 * 1.3).log_scale());
        // Values that are never negative get no negative half-axis.
        let floor = if y0 >= 0.0 { (y0 - pad).max(0.0) } else { y0 - pad };
        let (lin_y, log_y) = (floor..(y1 + pad), (y0 / 1.5..y1 * 1.5).log_scale());
        match (self.linear_x, self.log_y) {
            (true, false) => self.series_on(builder.build_cartesian_2d(lin_x, lin_y).map_err(e)?, &series),
            (true, true) => self.series_on(builder.build_cartesian_2d(lin_x, log_y).map_err(e)?, &series),
            (false, false) => self.series_on(builder.build_cartesian_2d(log_x, lin_y).map_err(e)?, &series),
            (false, true) => self.series_on(builder.build_cartesian_2d(log_x, log_y).map_err(e)?, &series),
        }
        .map_err(e)?;
        self.legend_on(&legend, &series).map_err(e)?;
        root.present().map_err(e)?;
        Ok(())
    }

    /// The legend in its own column: each series' line style, marker and name.
    fn legend_on<DB: DrawingBackend>(
        &self,
        area: &DrawingArea<DB, Shift>,
        series: &[(&str, Vec<(f64, f64)>)],
    ) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
        let font = ("sans-serif", 13).into_font();
        let mut y = 20;
        for (k, (name, _)) in series.iter().enumerate() {
            let colour = COLOURS[k % COLOURS.len()];
            let line: Vec<(i32, i32)> = match dash(k) {
                None => vec![(4, y), (34, y)],
                Some((on, off)) => {
                    // Dashes drawn as short segments.
                    let mut x = 4;
                    while x < 34 {
                        area.draw(&PathElement::new(
                            vec![(x, y), ((x + on as i32).min(34), y)],
                            colour.stroke_width(2),
                        ))?;
                        x += (on + off) as i32;
                    }
                    vec![]
                }
            };
            if !line.is_empty() {
                area.draw(&PathElement::new(line, colour.stroke_width(2)))?;
            }
            marker(area, k, (19, y), colour)?;
            // A long name wraps at spaces onto the lines below.
            for text in wrap(name, LEGEND_CHARS) {
                area.draw(&Text::new(text, (40, y - 7), font.clone()))?;
                y += 15;
            }
            y += 7;
        }
        Ok(())
    }

    fn series_on<'b, DB: DrawingBackend + 'b, X, Y>(
        &self,
        mut chart: ChartContext<'b, DB, Cartesian2d<X, Y>>,
        series: &[(&str, Vec<(f64, f64)>)],
    ) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>>
    where
        X: Ranged<ValueType = f64> + plotters::coord::ranged1d::ValueFormatter<f64>,
        Y: Ranged<ValueType = f64> + plotters::coord::ranged1d::ValueFormatter<f64>,
    {
        chart
            .configure_mesh()
            .x_desc(self.x_label)
            .y_desc(self.y_label)
            .x_labels(TICKS)
            .y_labels(TICKS)
            .x_label_formatter(&tick)
            .y_label_formatter(&tick)
            .label_style(("sans-serif", 13))
            .draw()?;
        for (k, (_, pts)) in series.iter().enumerate() {
            let colour = COLOURS[k % COLOURS.len()];
            let style = colour.stroke_width(2);
            match dash(k) {
                None => {
                    chart.draw_series(LineSeries::new(pts.iter().copied(), style))?;
                }
                Some((on, off)) => {
                    chart.draw_series(DashedLineSeries::new(pts.iter().copied(), on, off, style))?;
                }
            }
            // Markers at the samples; a long series at every n-th one.
            let every = pts.len().div_ceil(MARKED).max(1);
            let area = chart.plotting_area();
            for &p in pts.iter().step_by(every) {
                let at = area.map_coordinate(&p);
                let (dx, dy) = area.get_base_pixel();
                marker(&area.strip_coord_spec(), k, (at.0 - dx, at.1 - dy), colour)?;
            }
        }
        Ok(())
    }

    /// Writes `base.svg` and `base.png`.
    pub fn write(&self, base: &Path) -> anyhow::Result<()> {
        register_font()?;
        let svg = base.with_extension("svg");
        self.draw(SVGBackend::new(&svg, SIZE).into_drawing_area())?;
        let mut rgb = vec![0u8; (SIZE.0 * SIZE.1 * 3) as usize];
        self.draw(BitMapBackend::with_buffer(&mut rgb, SIZE).into_drawing_area())?;
        let png = base.with_extension("png");
        image::RgbImage::from_raw(SIZE.0, SIZE.1, rgb)
            .ok_or_else(|| anyhow!("chart buffer size"))?
            .save(&png)
            .with_context(|| format!("cannot write {}", png.display()))?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::tick;

    #[test]
    fn tick_labels_drop_needless_decimals() {
        assert_eq!(tick(&38.0), "38");
        assert_eq!(tick(&-2.0), "-2");
        assert_eq!(tick(&-0.0), "0");
        assert_eq!(
            super::wrap("JPEG depth maps, meshed losslessly", 19),
            ["JPEG depth maps,", "meshed losslessly"]
        );
        assert_eq!(super::wrap("rqt", 19), ["rqt"]);
        assert_eq!(tick(&-1e-12), "0");
        assert_eq!(tick(&0.5), "0.5");
        assert_eq!(tick(&0.25), "0.25");
        assert_eq!(tick(&1000.0), "1000");
        assert_eq!(tick(&0.00001), "1.000e-5");
    }
}
