//! `mpm render` and `mpm plot`: pictures of a run.

use std::path::PathBuf;

use clap::Args;

#[derive(Args, Debug)]
pub(crate) struct RenderArgs {
    /// The run's output folder (it holds particles.pvd).
    run_dir: PathBuf,
    /// The colouring field: an array of the snapshots (velocity, displacement, pressure, J,
    /// mass, volume, body, …; a vector by its length), or a component: velocity:x, stress:xy,
    /// strain:yy, deformation_gradient:yx.
    #[arg(long, default_value = "velocity")]
    field: String,
    /// Output folder [default: RUN_DIR].
    #[arg(long, short = 'o', value_name = "DIR")]
    out: Option<PathBuf>,
    /// Image width in pixels (the height follows the domain).
    #[arg(long, default_value_t = 640)]
    width: u32,
    /// Draw the background grid's cell lines.
    #[arg(long)]
    grid: bool,
    /// Fixed colour scale: --range MIN MAX [default: the field's range over all frames].
    #[arg(long, num_args = 2, value_names = ["MIN", "MAX"], allow_negative_numbers = true)]
    range: Option<Vec<f64>>,
    /// Draw every K-th snapshot (the last one always).
    #[arg(long, default_value_t = 1, value_name = "K")]
    every: usize,
    /// Frames per second of the GIF.
    #[arg(long, default_value_t = 10.0)]
    fps: f64,
    /// Write the PNG frames only, no GIF.
    #[arg(long)]
    no_gif: bool,
}

#[derive(Args, Debug)]
pub(crate) struct PlotArgs {
    /// The run's output folder (it holds report.csv).
    run_dir: PathBuf,
    /// The PNG to write [default: RUN_DIR/report.png].
    #[arg(long, short = 'o', value_name = "FILE")]
    out: Option<PathBuf>,
}

pub(crate) fn render(args: &RenderArgs) -> Result<(), String> {
    let options = sparse_mpm_cli::render::RenderOptions {
        field: args.field.clone(),
        width: args.width,
        grid_lines: args.grid,
        range: args.range.as_ref().map(|r| [r[0], r[1]]),
        every: args.every,
        fps: args.fps,
        gif: !args.no_gif,
        out: args.out.clone(),
    };
    let rendered = sparse_mpm_cli::render::render_run(&args.run_dir, &options).map_err(|e| e.to_string())?;
    let [lo, hi] = rendered.range;
    println!(
        "{} frame(s) of {} × {} pixels, `{}` from {lo:.6e} to {hi:.6e}, in {}",
        rendered.frames.len(),
        rendered.size[0],
        rendered.size[1],
        args.field,
        rendered.frames[0]
            .parent()
            .map_or(String::new(), |p| p.display().to_string())
    );
    if let Some(gif) = &rendered.gif {
        println!("animation: {}", gif.display());
    }
    Ok(())
}

pub(crate) fn plot(args: &PlotArgs) -> Result<(), String> {
    let png = sparse_mpm_cli::render::plot_report(&args.run_dir, args.out.as_deref()).map_err(|e| e.to_string())?;
    println!("{}", png.display());
    Ok(())
}
