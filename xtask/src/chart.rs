//! Charts as SVG and PNG (plotters). Text is drawn with the DejaVu Sans font bundled in
//! `xtask/assets/` (registered with plotters' `ab_glyph` backend), so the PNGs look the same on
//! a machine without system fonts.

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::colors::colormaps::ViridisRGB;
use std::path::{Path, PathBuf};
use std::sync::Once;

type Result<T> = std::result::Result<T, Box<dyn std::error::Error>>;

static FONT: &[u8] = include_bytes!("../assets/DejaVuSans.ttf");
static REGISTER: Once = Once::new();

const FONT_NAME: &str = "sans-serif";
const SIZE: (u32, u32) = (960, 640);

fn register_font() {
    REGISTER.call_once(|| {
        plotters::style::register_font(FONT_NAME, FontStyle::Normal, FONT)
            .unwrap_or_else(|_| panic!("the bundled DejaVuSans.ttf is a valid font"));
    });
}

/// One named series of `(x, y)` points; `labels` (optional, one per point) are drawn beside
/// the points of a scatter plot.
#[derive(Clone, Debug, Default)]
pub struct Series {
    pub name: String,
    pub points: Vec<(f64, f64)>,
    pub labels: Vec<String>,
}

/// A log–log chart of several series, joined by lines or drawn as markers only.
#[derive(Clone, Debug, Default)]
pub struct LogLogPlot {
    pub title: String,
    pub x_desc: String,
    pub y_desc: String,
    pub series: Vec<Series>,
    /// Join the points of each series (false: markers only).
    pub lines: bool,
    /// Vertical reference lines: `(x, label)`, drawn grey across the chart, the label at the
    /// top.
    pub vlines: Vec<(f64, String)>,
}

/// A grid of values (rows × columns), `None` where a value is missing (drawn grey and
/// labelled "pending").
#[derive(Clone, Debug, Default)]
pub struct HeatMap {
    pub title: String,
    pub x_desc: String,
    pub y_desc: String,
    pub cols: Vec<String>,
    pub rows: Vec<String>,
    pub values: Vec<Vec<Option<f64>>>,
    /// How to print a value inside its cell.
    pub unit: String,
    /// Values mapped to the ends of the (logarithmic) colour scale; `None`: the data's range.
    pub range: Option<(f64, f64)>,
}

fn palette(i: usize) -> RGBColor {
    const P: [RGBColor; 10] = [
        RGBColor(31, 119, 180),
        RGBColor(255, 127, 14),
        RGBColor(44, 160, 44),
        RGBColor(214, 39, 40),
        RGBColor(148, 103, 189),
        RGBColor(140, 86, 75),
        RGBColor(227, 119, 194),
        RGBColor(127, 127, 127),
        RGBColor(188, 189, 34),
        RGBColor(23, 190, 207),
    ];
    P[i % P.len()]
}

/// Writes `dir/stem.svg` and `dir/stem.png`; returns both paths.
pub fn write_loglog(dir: &Path, stem: &str, plot: &LogLogPlot) -> Result<Vec<PathBuf>> {
    register_font();
    std::fs::create_dir_all(dir)?;
    let svg = dir.join(format!("{stem}.svg"));
    let png = dir.join(format!("{stem}.png"));
    draw_loglog(SVGBackend::new(&svg, SIZE).into_drawing_area(), plot)?;
    draw_loglog(BitMapBackend::new(&png, SIZE).into_drawing_area(), plot)?;
    Ok(vec![svg, png])
}

/// Writes `dir/stem.svg` and `dir/stem.png`; returns both paths.
pub fn write_heat_map(dir: &Path, stem: &str, map: &HeatMap) -> Result<Vec<PathBuf>> {
    register_font();
    std::fs::create_dir_all(dir)?;
    let svg = dir.join(format!("{stem}.svg"));
    let png = dir.join(format!("{stem}.png"));
    draw_heat_map(SVGBackend::new(&svg, SIZE).into_drawing_area(), map)?;
    draw_heat_map(BitMapBackend::new(&png, SIZE).into_drawing_area(), map)?;
    Ok(vec![svg, png])
}

/// The decades `(lo, hi)` (exponents of ten) covering `values` (positive ones) with a margin
/// of at least a third of a decade on each side.
fn log_range(values: impl Iterator<Item = f64>) -> (i32, i32) {
    let (mut lo, mut hi) = (f64::INFINITY, 0.0f64);
    for v in values.filter(|v| v.is_finite() && *v > 0.0) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if !lo.is_finite() {
        return (-1, 1);
    }
    (
        (lo.log10() - 0.3).floor() as i32,
        (hi.log10() + 0.3).ceil() as i32,
    )
}

fn err<E: std::fmt::Debug>(e: E) -> Box<dyn std::error::Error> {
    format!("chart: {e:?}").into()
}

/// Tick labels of a log axis drawn in exponent coordinates: `10^e` as `1e-3`-style text at
/// whole decades, nothing between them.
fn sci(e: &f64) -> String {
    if (e - e.round()).abs() < 1e-9 {
        let e = e.round() as i32;
        if (-2..=3).contains(&e) {
            format!("{}", 10f64.powi(e))
        } else {
            format!("1e{e}")
        }
    } else {
        String::new()
    }
}

/// A point in exponent coordinates.
fn log_point((x, y): (f64, f64)) -> (f64, f64) {
    (x.log10(), y.log10())
}

fn draw_loglog<DB: DrawingBackend>(root: DrawingArea<DB, Shift>, plot: &LogLogPlot) -> Result<()>
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE).map_err(err)?;
    let (x0, x1) = log_range(
        plot.series
            .iter()
            .flat_map(|s| s.points.iter().map(|p| p.0))
            .chain(plot.vlines.iter().map(|v| v.0)),
    );
    let (y0, y1) = log_range(
        plot.series
            .iter()
            .flat_map(|s| s.points.iter().map(|p| p.1)),
    );
    let mut chart = ChartBuilder::on(&root)
        .caption(&plot.title, (FONT_NAME, 22))
        .margin(20)
        .x_label_area_size(55)
        .y_label_area_size(85)
        // Exponent coordinates (log10 of the values), labelled at whole decades: plotters' own
        // log axes drop labels across many decades.
        .build_cartesian_2d(x0 as f64..x1 as f64, y0 as f64..y1 as f64)
        .map_err(err)?;
    chart
        .configure_mesh()
        .x_desc(&plot.x_desc)
        .y_desc(&plot.y_desc)
        .x_labels((x1 - x0) as usize + 1)
        .y_labels((y1 - y0) as usize + 1)
        .x_label_formatter(&sci)
        .y_label_formatter(&sci)
        .axis_desc_style((FONT_NAME, 17))
        .label_style((FONT_NAME, 14))
        .light_line_style(RGBColor(235, 235, 235))
        .draw()
        .map_err(err)?;
    // Their labels at the top, each below the last so that neighbours do not overlap.
    let mut vline_boxes = Vec::new();
    let vfont: TextStyle = (FONT_NAME, 14).into_font().into();
    for (k, (x, label)) in plot.vlines.iter().enumerate() {
        if !(x.is_finite() && *x > 0.0) {
            continue;
        }
        let grey = RGBColor(110, 110, 110);
        let lx = x.log10();
        chart
            .draw_series(LineSeries::new(
                vec![(lx, y0 as f64), (lx, y1 as f64)],
                grey.stroke_width(2),
            ))
            .map_err(err)?;
        let at = chart.backend_coord(&(lx, y1 as f64));
        let (w, h) = root.estimate_text_size(label, &vfont).map_err(err)?;
        let (px, py) = (at.0 + 5, at.1 + 4 + 20 * k as i32);
        root.draw_text(label, &vfont.color(&grey), (px, py))
            .map_err(err)?;
        vline_boxes.push(Rect {
            x0: px,
            y0: py,
            x1: px + w as i32,
            y1: py + h as i32,
        });
    }
    // Markers first (every point is an obstacle for the labels), then the labels.
    let mut occupied: Vec<Rect> = vline_boxes;
    // The legend in the corner with the fewest points, its box estimated from its entries.
    let legend_w = plot
        .series
        .iter()
        .map(|s| s.name.chars().count() as i32 * 8 + 40)
        .max()
        .unwrap_or(0);
    let legend_h = plot.series.len() as i32 * 21 + 20;
    let (tl, br) = (
        chart.backend_coord(&(x0 as f64, y1 as f64)),
        chart.backend_coord(&(x1 as f64, y0 as f64)),
    );
    let corners = [
        (SeriesLabelPosition::UpperLeft, (tl.0, tl.1)),
        (
            SeriesLabelPosition::UpperRight,
            (br.0 - legend_w - 20, tl.1),
        ),
        (SeriesLabelPosition::LowerLeft, (tl.0, br.1 - legend_h)),
        (
            SeriesLabelPosition::LowerRight,
            (br.0 - legend_w - 20, br.1 - legend_h),
        ),
    ];
    let pixels: Vec<(i32, i32)> = plot
        .series
        .iter()
        .flat_map(|s| s.points.iter())
        .filter(|(x, y)| x.is_finite() && y.is_finite() && *x > 0.0 && *y > 0.0)
        .map(|&p| chart.backend_coord(&log_point(p)))
        .collect();
    let (legend_at, legend_box) = corners
        .iter()
        .map(|(pos, (x, y))| {
            let r = Rect {
                x0: *x,
                y0: *y,
                x1: x + legend_w + 20,
                y1: y + legend_h,
            };
            let inside = pixels
                .iter()
                .filter(|p| r.overlap(&Rect::around(**p, 6)) > 0)
                .count();
            (inside, pos.clone(), r)
        })
        .min_by_key(|c| c.0)
        .map(|(_, pos, r)| (pos, r))
        .unwrap_or((SeriesLabelPosition::UpperLeft, Rect::around(tl, 0)));
    occupied.push(legend_box);
    let mut pending: Vec<((i32, i32), &str, RGBColor)> = Vec::new();
    for (i, s) in plot.series.iter().enumerate() {
        let color = palette(i);
        let pts: Vec<(f64, f64)> = s
            .points
            .iter()
            .copied()
            .filter(|(x, y)| x.is_finite() && y.is_finite() && *x > 0.0 && *y > 0.0)
            .map(log_point)
            .collect();
        if plot.lines {
            chart
                .draw_series(LineSeries::new(pts.clone(), color.stroke_width(2)))
                .map_err(err)?;
        }
        let anno = chart
            .draw_series(
                pts.iter()
                    .map(|&p| Circle::new(p, 5, color.filled()).into_dyn()),
            )
            .map_err(err)?;
        anno.label(&s.name).legend(move |(x, y)| {
            EmptyElement::at((x, y))
                + PathElement::new(vec![(-8, 0), (8, 0)], color.stroke_width(2))
                + Circle::new((0, 0), 4, color.filled())
        });
        for (k, &p) in s.points.iter().enumerate() {
            if !(p.0.is_finite() && p.1.is_finite() && p.0 > 0.0 && p.1 > 0.0) {
                continue;
            }
            let at = chart.backend_coord(&log_point(p));
            occupied.push(Rect::around(at, 6));
            // The line to the next point, sampled every few pixels.
            let next = s
                .points
                .get(k + 1)
                .filter(|q| q.0 > 0.0 && q.1 > 0.0 && plot.lines);
            if let Some(&q) = next {
                let b = chart.backend_coord(&log_point(q));
                let n = ((b.0 - at.0).abs().max((b.1 - at.1).abs()) / 6).max(1);
                for j in 1..n {
                    let f = j as f64 / n as f64;
                    let x = at.0 + ((b.0 - at.0) as f64 * f) as i32;
                    let y = at.1 + ((b.1 - at.1) as f64 * f) as i32;
                    occupied.push(Rect::around((x, y), 2));
                }
            }
            if let Some(l) = s.labels.get(k).filter(|l| !l.is_empty()) {
                pending.push((at, l.as_str(), color));
            }
        }
    }
    let area = {
        let (a, b) = (
            chart.backend_coord(&(x0 as f64, y0 as f64)),
            chart.backend_coord(&(x1 as f64, y1 as f64)),
        );
        Rect {
            x0: a.0,
            y0: b.1,
            x1: b.0,
            y1: a.1,
        }
    };
    let font: TextStyle = (FONT_NAME, 13).into_font().into();
    for (at, label, color) in pending {
        let (w, h) = root.estimate_text_size(label, &font).map_err(err)?;
        let r = place_label(at, (w as i32, h as i32), &occupied, &area);
        root.draw_text(label, &font.color(&color.mix(1.0)), (r.x0, r.y0))
            .map_err(err)?;
        occupied.push(r);
    }
    chart
        .configure_series_labels()
        .label_font((FONT_NAME, 15))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .position(legend_at)
        .draw()
        .map_err(err)?;
    root.present().map_err(err)?;
    Ok(())
}

/// A box in backend pixels (x right, y down).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Rect {
    x0: i32,
    y0: i32,
    x1: i32,
    y1: i32,
}

impl Rect {
    fn around((x, y): (i32, i32), r: i32) -> Rect {
        Rect {
            x0: x - r,
            y0: y - r,
            x1: x + r,
            y1: y + r,
        }
    }

    fn overlap(&self, o: &Rect) -> i64 {
        let w = (self.x1.min(o.x1) - self.x0.max(o.x0)).max(0) as i64;
        let h = (self.y1.min(o.y1) - self.y0.max(o.y0)).max(0) as i64;
        w * h
    }

    fn inside(&self, o: &Rect) -> bool {
        self.x0 >= o.x0 && self.x1 <= o.x1 && self.y0 >= o.y0 && self.y1 <= o.y1
    }
}

/// Where a label of `size` (w, h) beside the point `at` overlaps nothing in `occupied` and
/// stays in `area`: the first free place of eight around the point (right, left, above,
/// below, then the diagonals), at one, two and three times the marker's distance; else the
/// place of least overlap.
fn place_label(at: (i32, i32), (w, h): (i32, i32), occupied: &[Rect], area: &Rect) -> Rect {
    let mut best: Option<(i64, Rect)> = None;
    for reach in [1, 2, 3] {
        let d = 7 * reach;
        let spots = [
            (d, -h / 2),
            (-w - d, -h / 2),
            (-w / 2, -h - d),
            (-w / 2, d),
            (d - 2, -h - d + 2),
            (d - 2, d - 2),
            (-w - d + 2, -h - d + 2),
            (-w - d + 2, d - 2),
        ];
        for (dx, dy) in spots {
            let r = Rect {
                x0: at.0 + dx,
                y0: at.1 + dy,
                x1: at.0 + dx + w,
                y1: at.1 + dy + h,
            };
            let cost = occupied.iter().map(|o| o.overlap(&r)).sum::<i64>()
                + if r.inside(area) { 0 } else { 1_000_000 };
            if cost == 0 {
                return r;
            }
            if best.is_none_or(|(c, _)| cost < c) {
                best = Some((cost, r));
            }
        }
    }
    best.map_or(Rect::around(at, 0), |(_, r)| r)
}

fn draw_heat_map<DB: DrawingBackend>(root: DrawingArea<DB, Shift>, map: &HeatMap) -> Result<()>
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE).map_err(err)?;
    let (nc, nr) = (map.cols.len() as i32, map.rows.len() as i32);
    let present: Vec<f64> = map
        .values
        .iter()
        .flatten()
        .flatten()
        .copied()
        .filter(|v| *v > 0.0)
        .collect();
    let (lo, hi) = (
        present.iter().copied().fold(f64::INFINITY, f64::min),
        present.iter().copied().fold(0.0, f64::max),
    );
    let (llo, lhi) = if let Some((a, b)) = map.range {
        (a.log10(), b.log10())
    } else if present.is_empty() {
        (0.0, 1.0)
    } else if hi > lo {
        (lo.log10(), hi.log10())
    } else {
        (lo.log10() - 1.0, lo.log10() + 1.0)
    };
    let mut chart = ChartBuilder::on(&root)
        .caption(&map.title, (FONT_NAME, 22))
        .margin(20)
        .x_label_area_size(55)
        .y_label_area_size(140)
        // A segmented range a..b has the segments a, a+1, …, b.
        .build_cartesian_2d((0..nc - 1).into_segmented(), (0..nr - 1).into_segmented())
        .map_err(err)?;
    let cols = map.cols.clone();
    let rows = map.rows.clone();
    let col_fmt = move |v: &SegmentValue<i32>| match v {
        SegmentValue::CenterOf(i) if (*i as usize) < cols.len() => cols[*i as usize].clone(),
        _ => String::new(),
    };
    let row_fmt = move |v: &SegmentValue<i32>| match v {
        SegmentValue::CenterOf(i) if (*i as usize) < rows.len() => rows[*i as usize].clone(),
        _ => String::new(),
    };
    chart
        .configure_mesh()
        .disable_mesh()
        .x_desc(&map.x_desc)
        .y_desc(&map.y_desc)
        .x_labels(nc as usize + 1)
        .y_labels(nr as usize + 1)
        .x_label_formatter(&col_fmt)
        .y_label_formatter(&row_fmt)
        .axis_desc_style((FONT_NAME, 17))
        .label_style((FONT_NAME, 14))
        .draw()
        .map_err(err)?;
    for (r, row) in map.values.iter().enumerate() {
        for (c, v) in row.iter().enumerate() {
            let (c, r) = (c as i32, r as i32);
            let (fill, text, text_color) = match v {
                Some(v) => {
                    let t = if lhi > llo {
                        ((v.log10() - llo) / (lhi - llo)).clamp(0.0, 1.0)
                    } else {
                        0.5
                    };
                    let color = ViridisRGB::get_color_normalized(t, 0.0, 1.0);
                    let tc = if t > 0.6 { BLACK } else { WHITE };
                    (color, format!("{v:.3} {}", map.unit), tc)
                }
                None => (RGBColor(215, 215, 215), "pending".to_string(), BLACK),
            };
            chart
                .draw_series(std::iter::once(Rectangle::new(
                    [
                        (SegmentValue::Exact(c), SegmentValue::Exact(r)),
                        (SegmentValue::Exact(c + 1), SegmentValue::Exact(r + 1)),
                    ],
                    fill.filled(),
                )))
                .map_err(err)?;
            chart
                .draw_series(std::iter::once(Text::new(
                    text,
                    (SegmentValue::CenterOf(c), SegmentValue::CenterOf(r)),
                    (FONT_NAME, 13).into_font().color(&text_color).pos(
                        plotters::style::text_anchor::Pos::new(
                            plotters::style::text_anchor::HPos::Center,
                            plotters::style::text_anchor::VPos::Center,
                        ),
                    ),
                )))
                .map_err(err)?;
        }
    }
    root.present().map_err(err)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tmp(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("xtask-chart-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        d
    }

    #[test]
    fn loglog_writes_svg_and_png() {
        let dir = tmp("loglog");
        let plot = LogLogPlot {
            title: "t".into(),
            x_desc: "links".into(),
            y_desc: "time per step (µs)".into(),
            series: vec![
                Series {
                    name: "a".into(),
                    points: vec![(10.0, 1.0), (100.0, 10.0), (1000.0, 100.0)],
                    labels: vec![],
                },
                Series {
                    name: "b".into(),
                    points: vec![(10.0, 3e-15), (100.0, 0.0)],
                    labels: vec!["p".into(), "q".into()],
                },
            ],
            lines: true,
            vlines: vec![],
        };
        let files = write_loglog(&dir, "x", &plot).unwrap();
        if let Some(keep) = std::env::var_os("XTASK_KEEP_CHARTS") {
            for f in &files {
                std::fs::copy(f, std::path::Path::new(&keep).join(f.file_name().unwrap())).unwrap();
            }
        }
        assert_eq!(files.len(), 2);
        let svg = std::fs::read_to_string(&files[0]).unwrap();
        assert!(svg.starts_with("<svg") && svg.contains("time per step"));
        let png = std::fs::read(&files[1]).unwrap();
        assert_eq!(&png[1..4], b"PNG");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn heat_map_marks_missing_cells_pending() {
        let dir = tmp("heat");
        let map = HeatMap {
            title: "t".into(),
            x_desc: "forces".into(),
            y_desc: "budget".into(),
            cols: vec!["1".into(), "5".into()],
            rows: vec!["1".into(), "300".into()],
            values: vec![vec![None, None], vec![Some(0.4), Some(0.5)]],
            unit: "ms".into(),
            range: None,
        };
        let files = write_heat_map(&dir, "h", &map).unwrap();
        let svg = std::fs::read_to_string(&files[0]).unwrap();
        assert_eq!(svg.matches("pending").count(), 2);
        assert!(svg.contains("0.500 ms"));
        assert!(std::fs::metadata(&files[1]).unwrap().len() > 1000);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn log_range_spans_whole_decades() {
        assert_eq!(log_range([3.0, 250.0].into_iter()), (0, 3));
        assert_eq!(log_range([1.2e-19, 8.8e-8].into_iter()), (-20, -6));
        assert_eq!(log_range([0.0, -1.0].into_iter()), (-1, 1));
    }
}
