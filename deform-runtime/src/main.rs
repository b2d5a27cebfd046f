//! `deform-runtime` CLI: deform a yarn pattern on an OBJ animation and write yarn polylines.
//!
//! ```text
//! deform-runtime run --pattern stockinette.pyp --database db/ --mesh 'anim/cloth_*.obj' --out out/
//! ```
//!
//! Writes one file per frame and format (`yarns_000001.obj` ...), with `--png` a rendered image
//! of the yarns as tubes of the pattern's yarn radius per frame (`frame_0001.png` ...,
//! [`yarn_output::render`], view fitted to each frame), and `manifest.json` with the
//! configuration, the precompute counters and per-frame statistics and timings.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::Context;
use clap::{Parser, Subcommand, ValueEnum};
use deform_runtime::backend::Backend;
use deform_runtime::obj::{expand_sequence, read_obj, read_obj_positions};
use deform_runtime::pipeline::{SetupOptions, build, load_pattern_and_database};
use deform_runtime::{DeformOptions, EmbedOptions};
use yarn_output::render::{Camera, RenderOptions, render_tubes};
use yarn_output::{Polylines, UpAxis, bcc, obj, ply, usda};

#[derive(Parser)]
#[command(
    name = "deform-runtime",
    version,
    about = "Mechanics-aware yarn deformation on animated meshes (paper 004 §4)"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum, serde::Serialize)]
enum Format {
    Obj,
    Ply,
    Bcc,
    Usda,
    /// One USD cache of every frame (`yarns.usda`, time-sampled points and extents).
    UsdCache,
}

#[derive(Subcommand)]
enum Command {
    /// Deform a pattern on every frame of a mesh animation.
    Run(RunArgs),
}

#[derive(clap::Args, serde::Serialize)]
struct RunArgs {
    /// Periodic yarn pattern (.pyp).
    #[arg(long)]
    pattern: PathBuf,
    /// Displacement database directory (axes.txt + data.npy).
    #[arg(long)]
    database: PathBuf,
    /// Mesh file or numbered sequence with `*` (e.g. 'anim_*.obj'); the first frame is the
    /// rest mesh whose UVs embed the pattern.
    #[arg(long)]
    mesh: String,
    /// Output directory.
    #[arg(long)]
    out: PathBuf,
    /// UV units to metres.
    #[arg(long, default_value_t = 1.0)]
    uv_scale: f64,
    /// Drop yarn fragments shorter than this material length (m).
    #[arg(long, default_value_t = 0.0)]
    min_fragment_length: f64,
    /// Lower bound on the eigenvalues of I (compression clamping).
    #[arg(long, default_value_t = 0.8)]
    lambda_min: f64,
    /// Output formats (repeatable): one file per frame, or `usd-cache` for one USD cache of
    /// the whole sequence (`yarns.usda`).
    #[arg(long = "format", value_enum, default_values_t = vec![Format::Obj])]
    formats: Vec<Format>,
    /// Frames per second of the mesh sequence (the USD cache's time codes per second).
    #[arg(long, default_value_t = 24.0)]
    fps: f64,
    /// Turn off compression clamping.
    #[arg(long)]
    no_clamping: bool,
    /// Turn off linearized bending.
    #[arg(long)]
    no_bending: bool,
    /// Turn off database displacements (naive embedding).
    #[arg(long)]
    no_displacement: bool,
    /// Turn off Phong deformation (piecewise affine embedding).
    #[arg(long)]
    no_phong: bool,
    /// Use per-face fundamental forms instead of interpolated vertex forms.
    #[arg(long)]
    no_form_interpolation: bool,
    /// Turn off skipping of identity faces and static frames.
    #[arg(long)]
    no_skip: bool,
    /// Back end of the per-vertex stage: `auto` uses the GPU when an adapter exists.
    #[arg(long, value_enum, default_value_t = BackendChoice::Auto)]
    backend: BackendChoice,
    /// Also render each frame as shaded tubes of the pattern's yarn radius into
    /// `frame_0001.png` ... (orthographic, fitted to the frame's yarns).
    #[arg(long)]
    png: bool,
    /// PNG size in pixels, `WIDTHxHEIGHT`.
    #[arg(long, default_value = "1024x768", value_parser = parse_size)]
    png_size: [u32; 2],
    /// PNG view direction `x,y,z` (from the eye into the scene; default: top view).
    #[arg(long, default_value = "0,0,-1", value_parser = parse_vec3)]
    png_view: [f64; 3],
    /// PNG up direction `x,y,z` (must not be parallel to the view direction).
    #[arg(long, default_value = "0,1,0", value_parser = parse_vec3)]
    png_up: [f64; 3],
}

fn parse_size(s: &str) -> Result<[u32; 2], String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("expected WIDTHxHEIGHT, found {s:?}"))?;
    let parse = |t: &str| {
        t.trim()
            .parse::<u32>()
            .map_err(|e| format!("{t:?} in {s:?}: {e}"))
    };
    Ok([parse(w)?, parse(h)?])
}

fn parse_vec3(s: &str) -> Result<[f64; 3], String> {
    let v: Vec<f64> = s
        .split(',')
        .map(|t| {
            t.trim()
                .parse::<f64>()
                .map_err(|e| format!("{t:?} in {s:?}: {e}"))
        })
        .collect::<Result<_, _>>()?;
    v.try_into()
        .map_err(|v: Vec<f64>| format!("expected three comma-separated numbers, found {}", v.len()))
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum, serde::Serialize)]
enum BackendChoice {
    Auto,
    Cpu,
    Gpu,
}

/// What the deformer writes into its files' comments and headers.
const COMMENT: &str = "deform-runtime yarn polylines (m)";

/// Writes one frame's yarns in `format` (the yarn-output writers; z up, as the meshes).
fn write_yarns(
    file: &std::path::Path,
    format: Format,
    lines: &Polylines<'_, f32>,
    radius: f64,
) -> anyhow::Result<()> {
    let bcc_header = bcc::BccHeader {
        curve: bcc::CurveType::Polyline,
        up: UpAxis::Z,
        info: COMMENT,
    };
    let usd = usda::UsdOptions {
        radius,
        up: UpAxis::Z,
        comment: COMMENT,
        meshes: &[],
    };
    match format {
        Format::Obj => yarn_output::write_with(file, |w| obj::write(w, lines, COMMENT))?,
        Format::Ply => yarn_output::write_with(file, |w| ply::write(w, lines, COMMENT))?,
        Format::Bcc => yarn_output::write_file(file, &bcc::to_bytes(lines, &bcc_header)?)?,
        Format::Usda => yarn_output::write_file(file, usda::to_string(lines, &usd)?.as_bytes())?,
        Format::UsdCache => {
            anyhow::bail!("the USD cache is written by usda::Sequence, not per frame")
        }
    }
    Ok(())
}

fn main() -> anyhow::Result<()> {
    match Cli::parse().command {
        Command::Run(args) => run(args),
    }
}

fn run(args: RunArgs) -> anyhow::Result<()> {
    let started = Instant::now();
    let (tile, db) = load_pattern_and_database(&args.pattern, &args.database)?;
    let frames = expand_sequence(&args.mesh)?;
    let rest = read_obj(&frames[0])?;
    let skip = !args.no_skip;
    let options = SetupOptions {
        uv_scale: args.uv_scale,
        embed: EmbedOptions {
            min_fragment_length: args.min_fragment_length,
            ..EmbedOptions::default()
        },
        deform: DeformOptions {
            displacement: !args.no_displacement,
            linearized_bending: !args.no_bending,
            clamp_compression: !args.no_clamping,
            lambda_min: args.lambda_min,
            interpolate_forms: !args.no_form_interpolation,
            phong: !args.no_phong,
            skip_identity: skip,
            skip_static: skip,
            ..DeformOptions::default()
        },
    };
    let render = args.png.then(|| RenderOptions {
        camera: Camera {
            direction: args.png_view,
            up: args.png_up,
        },
        supersample: 2,
        ..RenderOptions::new(args.png_size[0], args.png_size[1], tile.radius)
    });
    if let Some(render) = &render {
        render.validate().context("PNG options")?;
    }
    let t_setup = Instant::now();
    let mut deformer = build::<f32>(&tile, &db, &rest, &options)?;
    let setup_seconds = t_setup.elapsed().as_secs_f64();
    let embed = deformer.embedding().stats;
    let (mut backend, backend_message) = match args.backend {
        BackendChoice::Cpu => (Backend::Cpu, "CPU back end (requested)".to_string()),
        BackendChoice::Auto => Backend::auto(&deformer),
        BackendChoice::Gpu => Backend::gpu(&deformer)?,
    };
    eprintln!(
        "deform-runtime: {} yarn vertices in {} curves on {} triangles; {} frame(s); {backend_message}",
        embed.vertices,
        embed.curves,
        deformer.mesh().n_faces(),
        frames.len(),
    );
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    let bar = indicatif::ProgressBar::new(frames.len() as u64).with_style(
        indicatif::ProgressStyle::with_template(
            "{msg:10} [{bar:40}] {pos}/{len} {elapsed} ETA {eta}",
        )
        .expect("valid template")
        .progress_chars("=> "),
    );
    bar.set_message("frames");
    let mut cache = if args.formats.contains(&Format::UsdCache) {
        let options = usda::SequenceOptions {
            radius: tile.radius,
            up: UpAxis::Z,
            comment: COMMENT.to_string(),
            frames_per_second: args.fps,
        };
        Some(usda::Sequence::create(
            &args.out.join("yarns.usda"),
            options,
        )?)
    } else {
        None
    };
    let mut positions = Vec::new();
    let mut per_frame = Vec::new();
    for (k, path) in frames.iter().enumerate() {
        read_obj_positions(path, deformer.mesh().n_positions, &mut positions)?;
        let stats = backend.frame(&mut deformer, &positions)?;
        let t_write = Instant::now();
        let e = deformer.embedding();
        let o = backend.output(&deformer);
        let lines = e.polylines(o);
        let mut written = Vec::new();
        if let Some(cache) = &mut cache {
            cache.push(&lines, &[])?;
        }
        for format in &args.formats {
            let ext = match format {
                Format::Obj => "obj",
                Format::Ply => "ply",
                Format::Bcc => "bcc",
                Format::Usda => "usda",
                Format::UsdCache => continue,
            };
            let file = args.out.join(format!("yarns_{:06}.{ext}", k + 1));
            write_yarns(&file, *format, &lines, tile.radius)?;
            written.push(file);
        }
        let mut rendered = serde_json::Value::Null;
        if let Some(render) = &render {
            let file = args.out.join(format!("frame_{:04}.png", k + 1));
            let r = render_tubes(&lines, render)?;
            r.image.write_png(&file)?;
            rendered = serde_json::json!({
                "segments": r.segments, "skipped_vertices": r.skipped_vertices, "framing": r.framing,
            });
            written.push(file);
        }
        per_frame.push(serde_json::json!({
            "input": path, "outputs": written, "stats": stats, "render": rendered,
            "write_seconds": t_write.elapsed().as_secs_f64(),
        }));
        bar.inc(1);
    }
    bar.finish_and_clear();
    let cache = cache.map(usda::Sequence::finish).transpose()?;
    let manifest = serde_json::json!({
        "usd_cache": cache,
        "tool": "deform-runtime run",
        "version": env!("CARGO_PKG_VERSION"),
        "config": args,
        "options": options,
        "render": render,
        "backend": backend_message,
        "threads": rayon::current_num_threads(),
        "pattern": { "vertices": tile.positions.len(), "period_m": tile.period, "radius_m": tile.radius },
        "database": { "shape": deformer.database().shape(), "bytes_f32": deformer.database().memory_bytes() },
        "mesh": { "positions": deformer.mesh().n_positions, "triangles": deformer.mesh().n_faces(),
                  "dropped_degenerate_uv": deformer.mesh().dropped_degenerate_uv },
        "embedding": embed,
        "setup_seconds": setup_seconds,
        "total_seconds": started.elapsed().as_secs_f64(),
        "frames": per_frame,
    });
    let path = args.out.join("manifest.json");
    std::fs::write(&path, serde_json::to_string_pretty(&manifest)?)
        .with_context(|| format!("writing {}", path.display()))?;
    eprintln!(
        "deform-runtime: wrote {} frame(s) to {} in {:.2} s",
        frames.len(),
        args.out.display(),
        started.elapsed().as_secs_f64()
    );
    Ok(())
}
