//! The building blocks of the figures: the context of a run, curves of R computed by the
//! sweep, and line figures drawn as PNG and SVG with their data as CSV.

use super::options::{FigureInfo, PaperOptions};
use crate::detector::{ModelParams, ModelSpec};
use crate::montecarlo::{sweep, Grid, SimConfig, SimRecord};
use crate::output::write_atomic;
use crate::plot::{LineChart, Series};
use crate::progress::Silent;
use crate::spot::{Sampling, Spot};
use crate::Result;
use std::fmt::Write as _;
use std::path::Path;

/// Signal levels of the paper's figures (photons per sub-aperture).
pub(super) const SIGNALS: [f64; 6] = [20.0, 50.0, 100.0, 200.0, 500.0, 1000.0];

/// A curve of R against x with standard errors, optionally with a fixed colour and style.
#[derive(Debug, Clone)]
pub(super) struct Curve {
    /// Legend label.
    pub name: String,
    /// (x, R, standard error of R).
    pub points: Vec<(f64, f64, f64)>,
    /// Colour index and style; `None`: the chart's defaults.
    pub look: Option<(usize, crate::plot::SeriesStyle)>,
}

/// A line figure ready to draw.
pub(super) struct LineFigure {
    pub number: u32,
    pub slug: &'static str,
    pub title: String,
    pub caption: String,
    pub x_label: String,
    pub y_label: String,
    /// CSV column names of x, y and y's standard error, with their units.
    pub columns: (&'static str, &'static str, &'static str),
    pub log_x: bool,
    pub log_y: bool,
    pub reference: Option<(f64, String)>,
    pub curves: Vec<Curve>,
}

/// Figure context: options, output directory, the paper's pdf and model parameters.
pub(super) struct Ctx<'a> {
    pub opts: &'a PaperOptions,
    pub dir: &'a Path,
    pub params: ModelParams,
}

impl Ctx<'_> {
    /// The configuration of one point: the paper's defaults with this run's sampling,
    /// iterations and seed.
    pub fn cfg(&self, subap_px: usize, spot: Spot, signal: f64) -> SimConfig {
        SimConfig {
            spot,
            sampling: self.opts.sampling,
            signal_photons: signal,
            iters: self.opts.iters,
            seed: self.opts.seed,
            ..SimConfig::paper(subap_px)
        }
    }

    /// The grid sub-apertures x spots x signals with this run's shared settings.
    pub fn grid(&self, subaps_px: &[usize], spots: &[Spot], signals: &[f64]) -> Grid {
        Grid {
            subaps_px: subaps_px.to_vec(),
            spots: spots.to_vec(),
            signals_photons: signals.to_vec(),
            shared: self.cfg(subaps_px[0], spots[0], signals[0]),
        }
    }

    /// One curve per model of `specs`, named by `labels`, over a grid whose configurations
    /// are the points `xs` in order (a one-dimensional grid).
    pub fn curves(
        &self,
        xs: &[f64],
        grid: &Grid,
        specs: &[ModelSpec],
        labels: &[String],
    ) -> Result<Vec<Curve>> {
        let records = sweep(&grid.configs()?, specs, &self.params, &Silent)?;
        Ok(curves(xs, &records, labels))
    }

    pub fn pick<T: Copy>(&self, full: &[T], quick: &[T]) -> Vec<T> {
        if self.opts.quick {
            quick.to_vec()
        } else {
            full.to_vec()
        }
    }

    pub fn signals(&self) -> Vec<f64> {
        self.pick(&SIGNALS, &[20.0, 200.0, 1000.0])
    }

    pub fn sampling_note(&self) -> String {
        format!(
            "{} sampling of the spot, {} iterations per point, seed {}; error bars are one standard error.",
            match self.opts.sampling {
                Sampling::Point => "Point (pixel-centre)",
                Sampling::Integrated => "Pixel-integrated",
            },
            self.opts.iters,
            self.opts.seed
        )
    }
}

/// One curve per label from sweep records in point order, then model order: the records of
/// point k are `records[k * labels.len()..][..labels.len()]`, at x = `xs[k]`.
pub(super) fn curves(xs: &[f64], records: &[SimRecord], labels: &[String]) -> Vec<Curve> {
    let mut curves: Vec<Curve> = labels
        .iter()
        .map(|n| Curve {
            name: n.clone(),
            points: Vec::new(),
            look: None,
        })
        .collect();
    for (&x, point) in xs.iter().zip(records.chunks(labels.len())) {
        for (curve, r) in curves.iter_mut().zip(point) {
            curve.points.push((x, r.result.r_px, r.result.r_se_px));
        }
    }
    curves
}

/// The models named (known names only).
pub(super) fn parse(names: &[&str]) -> Vec<ModelSpec> {
    names
        .iter()
        .map(|n| ModelSpec::parse(n).expect("known model"))
        .collect()
}

pub(super) fn strings(names: &[&str]) -> Vec<String> {
    names.iter().map(|s| s.to_string()).collect()
}

pub(super) fn airy(d: f64) -> Spot {
    Spot::Airy { diameter_px: d }
}

/// A figure of R (px, log scale) against `x_label`.
pub(super) fn r_figure(
    number: u32,
    slug: &'static str,
    title: impl Into<String>,
    caption: impl Into<String>,
    (x_label, x_col): (&str, &'static str),
    log_x: bool,
    curves: Vec<Curve>,
) -> LineFigure {
    LineFigure {
        number,
        slug,
        title: title.into(),
        caption: caption.into(),
        x_label: x_label.into(),
        y_label: "R, mean radial error (px)".into(),
        columns: (x_col, "r_px", "r_se_px"),
        log_x,
        log_y: true,
        reference: None,
        curves,
    }
}

/// Draw a line figure (PNG, SVG) and write its CSV.
pub(super) fn save_line(ctx: &Ctx, fig: LineFigure) -> Result<FigureInfo> {
    let stem = format!("fig{:02}-{}", fig.number, fig.slug);
    let mut chart = LineChart::new(fig.title.clone(), fig.x_label.clone(), fig.y_label.clone());
    chart.log_x = fig.log_x;
    chart.log_y = fig.log_y;
    chart.series = fig
        .curves
        .iter()
        .map(|c| {
            let s = Series::with_errors(c.name.clone(), c.points.iter().copied());
            match c.look {
                Some((colour, style)) => s.coloured(colour).styled(style),
                None => s,
            }
        })
        .collect();
    if let Some((y, label)) = &fig.reference {
        chart.reference.push(crate::plot::RefLine {
            y: *y,
            label: label.clone(),
        });
    }
    let (x_col, y_col, se_col) = fig.columns;
    let mut csv = format!("series,{x_col},{y_col},{se_col}\n");
    for c in &fig.curves {
        for (x, y, se) in &c.points {
            let _ = writeln!(csv, "\"{}\",{x},{y},{se}", c.name);
        }
    }
    write_atomic(&ctx.dir.join(format!("{stem}.csv")), csv.as_bytes())?;
    chart.save(ctx.dir.join(format!("{stem}.png")))?;
    chart.save(ctx.dir.join(format!("{stem}.svg")))?;
    Ok(FigureInfo {
        number: fig.number,
        title: fig.title,
        caption: format!("{} {}", fig.caption, ctx.sampling_note()),
        files: ["png", "svg", "csv"]
            .iter()
            .map(|e| format!("{stem}.{e}"))
            .collect(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::montecarlo::{LevelStats, SimResult};

    #[test]
    fn curves_take_one_record_per_model_from_each_point() {
        // Records of 3 points x 2 models, R = 10 x point + model: each curve collects its
        // model's record from every point, at that point's x.
        let record = |point: usize, model: usize| {
            let result = SimResult {
                model: format!("m{model}"),
                centroider: "cog".into(),
                param_name: None,
                param_opt: None,
                best: 0,
                r_px: (10 * point + model) as f64,
                r_se_px: 0.5,
                b_opt_e: 0.0,
                b_at_grid_edge: false,
                no_eligible_level: false,
                r0_px: 0.0,
                r0_se_px: 0.0,
                zero_frames: 0,
                parts: Default::default(),
                levels: Vec::<LevelStats>::new(),
            };
            SimRecord::new(&SimConfig::paper(4), Some(500.0), result)
        };
        let records: Vec<SimRecord> = (0..3)
            .flat_map(|p| (0..2).map(move |m| record(p, m)))
            .collect();
        let c = curves(&[20.0, 50.0, 100.0], &records, &strings(&["a", "b"]));
        assert_eq!(c.len(), 2);
        assert_eq!(c[0].name, "a");
        assert_eq!(
            c[0].points,
            [(20.0, 0.0, 0.5), (50.0, 10.0, 0.5), (100.0, 20.0, 0.5)]
        );
        assert_eq!(
            c[1].points,
            [(20.0, 1.0, 0.5), (50.0, 11.0, 0.5), (100.0, 21.0, 0.5)]
        );
    }

    #[test]
    fn a_grid_keeps_the_run_settings_and_varies_its_axes() {
        let opts = PaperOptions {
            iters: 300,
            seed: 7,
            sampling: Sampling::Point,
            quick: true,
        };
        let ctx = Ctx {
            opts: &opts,
            dir: Path::new("."),
            params: ModelParams::default(),
        };
        let configs = ctx
            .grid(&[4, 16], &[airy(2.0)], &[20.0, 1000.0])
            .configs()
            .unwrap();
        let axes: Vec<(usize, f64)> = configs
            .iter()
            .map(|c| (c.subap_px, c.signal_photons))
            .collect();
        assert_eq!(axes, [(4, 20.0), (4, 1000.0), (16, 20.0), (16, 1000.0)]);
        for c in &configs {
            assert_eq!((c.iters, c.seed, c.sampling), (300, 7, Sampling::Point));
            assert_eq!(c.spot, airy(2.0));
            assert_eq!((c.qe, c.max_empty_frac), (1.0, 0.01));
        }
        assert_eq!(ctx.signals(), [20.0, 200.0, 1000.0]);
    }
}
