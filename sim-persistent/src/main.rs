//! `sim-persistent`: run a TOML scene (see the library's `scene` module for the schema) and
//! write the yarn rendering curves in the formats of its `[output]` section (OBJ, PLY, `.bcc`,
//! PNG; see the `output` module), one file per format and output frame:
//! `DIR/frame_NNNNN.<ext>`, frame 0 being the initial state.
//!
//! ```text
//! sim-persistent run scene.toml              # frames in scene-out/ beside the scene file
//! sim-persistent run scene.toml --out frames # frames in frames/
//! sim-persistent run scene.toml --resume     # go on from scene-out/checkpoint.bin
//! ```
//!
//! A run checkpoints into `DIR/checkpoint.bin` every `--checkpoint-frames` frames (default
//! 10; 0: never). After a kill, the same command with `--resume` goes on from the last
//! checkpoint and ends with the frames of an uninterrupted run, bit for bit
//! ([`sim_persistent::scene::checkpoint`]); a damaged checkpoint, or one of another scene or
//! interval, is refused. A run writing a USD cache cannot be resumed.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, Result};
use clap::{Parser, Subcommand};

use sim_persistent::output::FrameWriter;
use sim_persistent::scene::Scene;

#[derive(Parser)]
#[command(
    name = "sim-persistent",
    version,
    about = "Persistent-contact yarn-level cloth (Cirio et al. 2017)"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Simulate a scene and write its output frames.
    Run {
        /// The scene file (TOML).
        scene: PathBuf,
        /// Output folder (default: `<scene stem>-out` beside the scene file).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Write a checkpoint every this many frames (0: never).
        #[arg(long, default_value_t = 10)]
        checkpoint_frames: usize,
        /// Go on from the output folder's checkpoint (from the start when there is none).
        #[arg(long)]
        resume: bool,
    },
}

fn main() -> Result<()> {
    match Cli::parse().command {
        Command::Run {
            scene,
            out,
            checkpoint_frames,
            resume,
        } => run(scene, out, checkpoint_frames, resume),
    }
}

/// Runs a scene's `[uniaxial]` test and writes `uniaxial.csv` into `out`.
fn uniaxial(test: &sim_persistent::experiment::UniaxialTest, out: &std::path::Path) -> Result<()> {
    let run = test.run()?;
    let mut table = yarn_output::table::Table::new(&[
        "stretch",
        "force_n",
        "stress_n_per_m",
        "compression",
        "newton_iterations",
    ]);
    for p in &run.samples {
        table.push_row([
            p.stretch,
            p.force,
            p.stress,
            p.compression,
            p.newton_iterations as f64,
        ]);
    }
    let path = out.join("uniaxial.csv");
    table.write_csv(&path)?;
    let last = run.samples.last().expect("the first sample always exists");
    println!(
        "{} stretch of a {:.1} mm long, {:.1} mm wide swatch ({} DoFs) in {:.1} s: σ = {:.3} N/m, c = {:.3} at s = {:.3} -> {}",
        run.pull.name(),
        run.length * 1e3,
        run.width * 1e3,
        run.dofs,
        run.seconds,
        last.stress,
        last.compression,
        last.stretch,
        path.display()
    );
    Ok(())
}

fn run(path: PathBuf, out: Option<PathBuf>, checkpoint_frames: usize, resume: bool) -> Result<()> {
    use sim_persistent::scene::checkpoint;
    let text =
        std::fs::read_to_string(&path).with_context(|| format!("reading {}", path.display()))?;
    let fingerprint = checkpoint::fingerprint(&text, checkpoint_frames);
    let scene = Scene::read(&path)?;
    let out = out.unwrap_or_else(|| {
        let stem = path
            .file_stem()
            .map_or("scene".into(), |s| s.to_string_lossy());
        path.with_file_name(format!("{stem}-out"))
    });
    std::fs::create_dir_all(&out).with_context(|| format!("creating {}", out.display()))?;
    if let Some(test) = scene.uniaxial_test()? {
        return uniaxial(&test, &out);
    }
    let mut run = scene.build()?;
    let (params, ..) = scene.yarn()?;
    let every = scene.frame_every();
    let frame_interval = every as f64 * run.sim.settings().dt;
    let mut writer = FrameWriter::new(&out, &scene.output, params.radius, frame_interval)?;
    let start = Instant::now();
    let resumed = if resume {
        checkpoint::read(&out, fingerprint)?
    } else {
        None
    };
    let (done, mut written) = match &resumed {
        Some(c) => {
            run.resume(c)?;
            writer.resume_at(c.frames, c.framing)?;
            eprintln!(
                "resuming after step {} of {} ({} frames written) from {}",
                c.steps,
                scene.steps,
                c.frames,
                checkpoint::path(&out).display()
            );
            (c.steps, vec![])
        }
        None => {
            if resume {
                eprintln!(
                    "no checkpoint in {}: starting from the beginning",
                    out.display()
                );
            }
            (0, writer.write(&run.sim)?)
        }
    };
    let first = written.clone();
    for k in done + 1..=scene.steps {
        run.step().with_context(|| format!("step {k}"))?;
        if k % every == 0 {
            written = writer.write(&run.sim)?;
            let frames = writer.frames_written();
            if checkpoint_frames > 0 && (frames - 1) % checkpoint_frames == 0 && k < scene.steps {
                let c = run.checkpoint(k, frames, writer.framing());
                checkpoint::write(&out, &c, fingerprint)?;
            }
            eprintln!(
                "step {k}/{}: t = {:.4} s, kinetic {:.3e} J, potential {:.3e} J, {:.1} s",
                scene.steps,
                run.sim.time(),
                run.sim.kinetic_energy(),
                run.sim.potential_energy(),
                start.elapsed().as_secs_f64()
            );
        }
    }
    let frames = writer.frames_written();
    let cache = writer.finish()?;
    println!(
        "{frames} frames ({:?}, every {every} steps) in {}",
        scene.output.formats,
        out.display()
    );
    if let Some(cache) = cache {
        println!("  {} (USD cache of every frame)", cache.display());
    }
    for p in first.iter().chain(if written == first {
        &[][..]
    } else {
        &written[..]
    }) {
        println!("  {}", p.display());
    }
    Ok(())
}
