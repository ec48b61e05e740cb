//! `nextpose segment`: recorded TCP trajectories (CSV, see [`crate::import::trajectory`]) cut
//! into linear dynamical systems whose attractors are the waypoints (dissertation chapter 5),
//! locally and without a server: the same computation as `POST /v1/routines/{id}/trajectory` with
//! `"preview": true`.

use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use clap::builder::PossibleValue;
use clap::{Args, ValueEnum};
use serde::Serialize;

use super::write_json;
use crate::engine::lead_through::segment::{
    Criterion, SegmentSettings, Segmentation, TimedPose, segment,
};
use crate::import::trajectory::{TrajectorySample, parse_trajectory};

/// A segmentation criterion on the command line, spelled as on the wire ([`Criterion::name`]:
/// the dissertation's Eq. 5.7 is `seed`).
#[derive(Debug, Clone, Copy)]
pub struct CriterionArg(pub Criterion);

impl ValueEnum for CriterionArg {
    fn value_variants<'a>() -> &'a [CriterionArg] {
        const ALL: [CriterionArg; Criterion::ALL.len()] = [
            CriterionArg(Criterion::ALL[0]),
            CriterionArg(Criterion::ALL[1]),
        ];
        &ALL
    }

    fn to_possible_value(&self) -> Option<PossibleValue> {
        let help = match self.0 {
            Criterion::Direction => {
                "The predicted step's direction against the observed one (default)"
            }
            Criterion::ErrorOverStep => "Eq. 5.7 as written: prediction error over step length",
        };
        Some(PossibleValue::new(self.0.name()).help(help))
    }
}

#[derive(Debug, Args)]
pub struct SegmentArgs {
    /// Trajectory CSV files (header `t,x,y[,z][,qw,qx,qy,qz][,j1,…]`; mm, seconds).
    #[arg(required = true)]
    pub files: Vec<PathBuf>,
    /// Threshold of the normalised prediction error (ε_max).
    #[arg(long, default_value_t = SegmentSettings::default().epsilon_max)]
    pub epsilon_max: f64,
    #[arg(long, value_enum, default_value = "direction")]
    pub criterion: CriterionArg,
    /// Samples closer than this to the last kept one are dropped (mm; a few times the noise).
    #[arg(long, default_value_t = SegmentSettings::default().min_step_mm)]
    pub min_step_mm: f64,
    /// Weight of orientation in the state (mm per radian).
    #[arg(long, default_value_t = SegmentSettings::default().rotation_mm_per_rad)]
    pub rotation_mm_per_rad: f64,
    /// Reproduction moves to the next LDS within this distance of an attractor (mm).
    #[arg(long, default_value_t = SegmentSettings::default().zeta_mm)]
    pub zeta_mm: f64,
    /// Consecutive samples over ε_max that close a segment (1: the seed's rule).
    #[arg(long, default_value_t = SegmentSettings::default().persistence)]
    pub persistence: usize,
    /// Largest condition number of an LDS matrix kept (else a scaled identity).
    #[arg(long, default_value_t = SegmentSettings::default().fit.kappa_max)]
    pub kappa_max: f64,
    /// One line per file instead of the attractor table.
    #[arg(long)]
    pub summary: bool,
    /// Also write every segmentation (attractors, fits, reproduction) as JSON to this file.
    #[arg(long, value_name = "OUT.json")]
    pub json: Option<PathBuf>,
    /// Also draw each trajectory, its attractors and its reproduction (x–y view) as an SVG
    /// into this directory (cargo feature `plots`).
    #[cfg(feature = "plots")]
    #[arg(long, value_name = "DIR")]
    pub plot: Option<PathBuf>,
}

impl SegmentArgs {
    fn settings(&self) -> SegmentSettings {
        let d = SegmentSettings::default();
        SegmentSettings {
            epsilon_max: self.epsilon_max,
            criterion: self.criterion.0,
            min_step_mm: self.min_step_mm,
            rotation_mm_per_rad: self.rotation_mm_per_rad,
            zeta_mm: self.zeta_mm,
            persistence: self.persistence,
            fit: crate::engine::lead_through::lds::FitSettings {
                kappa_max: self.kappa_max,
                ..d.fit
            },
            ..d
        }
    }
}

/// One file's result, as written by `--json`.
#[derive(Serialize)]
struct FileReport {
    file: String,
    samples: usize,
    kept: usize,
    ldss: usize,
    parameters: usize,
    raw_parameters: usize,
    mean_error_mm: f64,
    max_error_mm: f64,
    converged: bool,
    attractors: Vec<AttractorReport>,
}

#[derive(Serialize)]
struct AttractorReport {
    sample: usize,
    t: f64,
    pose: crate::engine::PoseValues,
    joints: Option<Vec<f64>>,
    steps: usize,
    rank: usize,
    condition: f64,
    identity: bool,
    epsilon: Option<f64>,
}

fn report(file: &Path, samples: &[TrajectorySample], seg: &Segmentation) -> FileReport {
    FileReport {
        file: file.display().to_string(),
        samples: seg.samples,
        kept: seg.kept,
        ldss: seg.segments.len(),
        parameters: seg.parameters(),
        raw_parameters: seg.raw_parameters(),
        mean_error_mm: seg.mean_error_mm,
        max_error_mm: seg.max_error_mm,
        converged: seg.converged,
        attractors: seg
            .segments
            .iter()
            .map(|s| AttractorReport {
                sample: s.to,
                t: samples[s.to].sample.t,
                pose: samples[s.to].sample.pose.values(),
                joints: samples[s.to].joints.clone(),
                steps: s.steps,
                rank: s.fit.rank,
                condition: s.fit.condition,
                identity: s.fit.identity,
                epsilon: s.epsilon,
            })
            .collect(),
    }
}

pub(super) fn run_segment(args: &SegmentArgs) -> Result<()> {
    let settings = args.settings();
    settings.validate()?;
    let mut out = std::io::stdout().lock();
    let mut reports = Vec::new();
    if args.summary {
        writeln!(
            out,
            "{:<40} {:>7} {:>6} {:>5} {:>11} {:>9} {:>8}",
            "file", "samples", "kept", "LDSs", "M(d²+d)/Nd", "mean mm", "max mm"
        )?;
    }
    for file in &args.files {
        let text = std::fs::read_to_string(file)
            .with_context(|| format!("{}: cannot read", file.display()))?;
        let samples = parse_trajectory(&text)
            .with_context(|| format!("{}: not a trajectory", file.display()))?;
        let timed: Vec<TimedPose> = samples.iter().map(|s| s.sample).collect();
        let seg = segment(&timed, &settings).with_context(|| format!("{}", file.display()))?;
        let r = report(file, &samples, &seg);
        if args.summary {
            writeln!(
                out,
                "{:<40} {:>7} {:>6} {:>5} {:>10.1}% {:>9.3} {:>8.3}{}",
                r.file,
                r.samples,
                r.kept,
                r.ldss,
                100.0 * r.parameters as f64 / r.raw_parameters as f64,
                r.mean_error_mm,
                r.max_error_mm,
                if r.converged { "" } else { "  (not converged)" }
            )?;
        } else {
            write_table(&mut out, &r)?;
        }
        #[cfg(feature = "plots")]
        if let Some(dir) = &args.plot {
            let path = figure::write(dir, file, &samples, &seg)?;
            writeln!(out, "wrote {}", path.display())?;
        }
        reports.push(r);
    }
    if reports.len() > 1 {
        let n = reports.len() as f64;
        let mean = reports.iter().map(|r| r.mean_error_mm).sum::<f64>() / n;
        let ldss = reports.iter().map(|r| r.ldss).sum::<usize>() as f64 / n;
        let share = reports
            .iter()
            .map(|r| r.parameters as f64 / r.raw_parameters as f64)
            .sum::<f64>()
            / n;
        writeln!(
            out,
            "{} trajectories: {:.1} LDSs each, {:.1} % of the numbers, mean reproduction error {:.3} mm",
            reports.len(),
            ldss,
            100.0 * share,
            mean
        )?;
    }
    if let Some(path) = &args.json {
        write_json(path, &reports)?;
    }
    Ok(())
}

fn write_table(out: &mut impl Write, r: &FileReport) -> Result<()> {
    writeln!(
        out,
        "{}: {} samples ({} kept), {} LDSs: {} numbers against {} ({:.1} %); reproduction error mean {:.3} mm, max {:.3} mm{}",
        r.file,
        r.samples,
        r.kept,
        r.ldss,
        r.parameters,
        r.raw_parameters,
        100.0 * r.parameters as f64 / r.raw_parameters as f64,
        r.mean_error_mm,
        r.max_error_mm,
        if r.converged { "" } else { " (not converged)" }
    )?;
    writeln!(
        out,
        "{:>6} {:>9} {:>9} {:>9} {:>9}  {:>7} {:>7} {:>7} {:>7}  {:>5} {:>4} {:>6}",
        "sample", "t s", "x", "y", "z", "qw", "qx", "qy", "qz", "steps", "rank", "ε"
    )?;
    for a in &r.attractors {
        let p = a.pose;
        writeln!(
            out,
            "{:>6} {:>9.3} {:>9.2} {:>9.2} {:>9.2}  {:>7.4} {:>7.4} {:>7.4} {:>7.4}  {:>5} {:>4} {:>6}",
            a.sample,
            a.t,
            p.x,
            p.y,
            p.z,
            p.qw,
            p.qx,
            p.qy,
            p.qz,
            a.steps,
            if a.identity {
                "I".to_string()
            } else {
                a.rank.to_string()
            },
            a.epsilon.map_or("end".to_string(), |e| format!("{e:.2}"))
        )?;
    }
    Ok(())
}

#[cfg(feature = "plots")]
mod figure {
    use std::path::{Path, PathBuf};

    use anyhow::{Context, Result, anyhow};
    use plotters::coord::Shift;
    use plotters::prelude::*;

    use crate::engine::lead_through::segment::Segmentation;
    use crate::import::trajectory::TrajectorySample;
    use crate::replay::plots::fonts::{FONT, register_font};

    const SIZE: (u32, u32) = (720, 560);

    struct Figure {
        title: String,
        recorded: Vec<(f64, f64)>,
        reproduced: Vec<(f64, f64)>,
        attractors: Vec<(f64, f64)>,
        x: std::ops::Range<f64>,
        y: std::ops::Range<f64>,
    }

    /// Writes the x–y view as `<stem>.svg` and `<stem>.png` into `dir`: samples (grey),
    /// reproduction (blue), attractors (red), start (black). Returns the SVG's path.
    pub(super) fn write(
        dir: &Path,
        file: &Path,
        samples: &[TrajectorySample],
        seg: &Segmentation,
    ) -> Result<PathBuf> {
        register_font().map_err(|e| anyhow!("{e}"))?;
        std::fs::create_dir_all(dir).with_context(|| format!("{}", dir.display()))?;
        let stem = file
            .file_stem()
            .map_or("trajectory".into(), |s| s.to_string_lossy().into_owned());
        let recorded: Vec<(f64, f64)> = samples
            .iter()
            .map(|s| {
                let p = s.sample.pose.position();
                (p.x, p.y)
            })
            .collect();
        let reproduced: Vec<(f64, f64)> = seg.reproduction.iter().map(|x| (x[0], x[1])).collect();
        let attractors: Vec<(f64, f64)> = seg.attractors().map(|i| recorded[i]).collect();
        let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
        for (x, y) in recorded.iter().chain(&reproduced) {
            x0 = x0.min(*x);
            x1 = x1.max(*x);
            y0 = y0.min(*y);
            y1 = y1.max(*y);
        }
        let pad = 0.05 * (x1 - x0).max(y1 - y0).max(1.0);
        let figure = Figure {
            title: format!(
                "{stem}: {} samples, {} attractors, mean error {:.2} mm",
                seg.samples,
                seg.segments.len(),
                seg.mean_error_mm
            ),
            recorded,
            reproduced,
            attractors,
            x: (x0 - pad)..(x1 + pad),
            y: (y0 - pad)..(y1 + pad),
        };

        let mut svg = String::new();
        {
            let root = SVGBackend::with_string(&mut svg, SIZE).into_drawing_area();
            draw(&figure, &root)?;
            root.present().map_err(|e| anyhow!("{e}"))?;
        }
        let svg_path = dir.join(format!("{stem}.svg"));
        std::fs::write(&svg_path, svg).with_context(|| format!("{}", svg_path.display()))?;

        let mut rgb = vec![0u8; SIZE.0 as usize * SIZE.1 as usize * 3];
        {
            let root = BitMapBackend::with_buffer(&mut rgb, SIZE).into_drawing_area();
            draw(&figure, &root)?;
            root.present().map_err(|e| anyhow!("{e}"))?;
        }
        let png_path = dir.join(format!("{stem}.png"));
        let mut bytes = Vec::new();
        let mut encoder = png::Encoder::new(&mut bytes, SIZE.0, SIZE.1);
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        encoder.set_compression(png::Compression::Best);
        let mut writer = encoder.write_header()?;
        writer.write_image_data(&rgb)?;
        writer.finish()?;
        std::fs::write(&png_path, bytes).with_context(|| format!("{}", png_path.display()))?;
        Ok(svg_path)
    }

    fn draw<DB: DrawingBackend>(f: &Figure, root: &DrawingArea<DB, Shift>) -> Result<()>
    where
        DB::ErrorType: 'static,
    {
        let e = |e: DrawingAreaErrorKind<DB::ErrorType>| anyhow!("drawing the figure: {e}");
        root.fill(&WHITE).map_err(e)?;
        let mut chart = ChartBuilder::on(root)
            .caption(&f.title, (FONT, 18))
            .margin(12)
            .x_label_area_size(36)
            .y_label_area_size(52)
            .build_cartesian_2d(f.x.clone(), f.y.clone())
            .map_err(e)?;
        chart
            .configure_mesh()
            .x_desc("x (mm)")
            .y_desc("y (mm)")
            .label_style((FONT, 13))
            .draw()
            .map_err(e)?;
        let grey = RGBColor(160, 160, 160);
        // Every fourth sample keeps the figure light; the path stays visible.
        chart
            .draw_series(
                f.recorded
                    .iter()
                    .step_by(4)
                    .map(|p| Circle::new(*p, 2, grey.filled())),
            )
            .map_err(e)?
            .label("recorded samples (every 4th)")
            .legend(move |(x, y)| Circle::new((x + 8, y), 3, grey.filled()));
        chart
            .draw_series(LineSeries::new(f.reproduced.clone(), BLUE.stroke_width(2)))
            .map_err(e)?
            .label("reproduction (Eq. 5.4, LDS after LDS)")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], BLUE.stroke_width(2)));
        chart
            .draw_series(
                f.attractors
                    .iter()
                    .map(|p| Circle::new(*p, 6, RED.stroke_width(2))),
            )
            .map_err(e)?
            .label("attractors = waypoints")
            .legend(|(x, y)| Circle::new((x + 8, y), 5, RED.stroke_width(2)));
        if let Some(start) = f.recorded.first() {
            chart
                .draw_series(std::iter::once(Circle::new(*start, 5, BLACK.filled())))
                .map_err(e)?
                .label("start")
                .legend(|(x, y)| Circle::new((x + 8, y), 4, BLACK.filled()));
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::LowerLeft)
            .label_font((FONT, 13))
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .draw()
            .map_err(e)?;
        Ok(())
    }
}
