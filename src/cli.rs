//! The `laydown` command line: a thin layer over the pipeline runner and the archive.
//! Exit codes, the same for every command: 0 success, 1 runtime failure or damaged
//! archive, 2 bad input. A failing command prints nothing to stdout.
use crate::archive::data::Attr;
use crate::archive::{hdf, parse_stage_ref, Archive, Integrity};
use crate::runner::{self, RunError, RunOptions};
use crate::error::BadInput;
use crate::pipeline;
use anyhow::{Context, Result};
use clap::{Parser, Subcommand};
use std::path::PathBuf;

/// The text after `laydown --help`: every registered stage kind, and the exit codes.
fn after_help() -> String {
    format!(
        "Stage kinds: {}. `laydown stages KIND` prints a kind's parameters with units, defaults and allowed ranges.\n\
         Exit codes: 0 success, 1 runtime failure or damaged archive, 2 bad input.",
        crate::stages::kinds().join(", ")
    )
}

#[derive(Parser, Debug)]
#[command(name = "laydown", version, about = "Fibre laydown, curvature spectra, stochastic nonwoven webs and their uniformity, in one versioned HDF5 archive per study.", after_help = after_help())]
pub struct Cli {
    /// Say nothing but warnings and errors: no progress bars, per-stage lines or stage
    /// summaries (exit codes are unchanged).
    #[arg(short, long, global = true, conflicts_with = "verbose")]
    pub quiet: bool,
    /// Say more: per stage, why it was reused or rerun, its fingerprint and timings (on stderr).
    #[arg(short, long, global = true)]
    pub verbose: bool,
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Run a pipeline: every stage whose fingerprint (kind, code version, parameters,
    /// seed, inputs) has no complete version in the archive yet.
    Run {
        /// The pipeline YAML file.
        pipeline: PathBuf,
        /// Run only these stages, on the current versions of their other inputs (with a
        /// warning naming any that is out of date). Repeatable or comma-separated: the
        /// stages named run in pipeline order, one selected stage feeding the next.
        #[arg(long, value_name = "STAGE", conflicts_with = "from", value_delimiter = ',')]
        only: Vec<String>,
        /// Recompute this stage and run every stage downstream of it.
        #[arg(long, value_name = "STAGE")]
        from: Option<String>,
        /// Say for each stage what would run and why; compute and write nothing.
        #[arg(long)]
        dry_run: bool,
        /// Ignore the cache for this stage (repeatable).
        #[arg(long, value_name = "STAGE")]
        force: Vec<String>,
        /// Write to this archive instead of the pipeline's `archive:` (relative to the working directory).
        #[arg(long, value_name = "PATH")]
        archive: Option<PathBuf>,
        /// Where stages run: `local` (this process, all cores; the default) or `slurm`
        /// (one job array per stage; overrides the pipeline's `executor:`).
        #[arg(long, value_name = "EXECUTOR", value_parser = ["local", "slurm"])]
        executor: Option<String>,
        /// Slurm partition for the job arrays.
        #[arg(long, value_name = "PARTITION")]
        partition: Option<String>,
        /// Run at most this many Slurm array tasks at once.
        #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..))]
        max_parallel: Option<u32>,
        /// Units of work (replicates of a sweep point) per Slurm array task; default 1.
        #[arg(long, value_name = "K", value_parser = clap::value_parser!(u32).range(1..))]
        units_per_task: Option<u32>,
        /// Extra argument for sbatch, e.g. `--sbatch-arg=--time=01:00:00` (repeatable).
        #[arg(long, value_name = "ARG", allow_hyphen_values = true)]
        sbatch_arg: Vec<String>,
        /// Memory the stages may use, e.g. `2GiB`, `512MiB`, `4G`, `1.5GB` (default: the
        /// machine's available memory); a stage estimated above it is refused (exit 2).
        #[arg(long, value_name = "SIZE", value_parser = crate::memory::parse_size)]
        max_memory: Option<u64>,
        /// CPU time a stage may be estimated to take, e.g. `30min`, `2h` (default: no
        /// limit); a stage estimated above it is refused (exit 2) before anything runs.
        #[arg(long, value_name = "DURATION", value_parser = crate::run_time::parse_duration)]
        max_cpu_time: Option<f64>,
        /// Threads of this process (default: RAYON_NUM_THREADS, or one per core); the
        /// results are bit-identical with any number. Slurm array tasks use SLURM_CPUS_PER_TASK.
        #[arg(short = 'j', long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..))]
        threads: Option<u32>,
        /// Print a JSON summary of what ran on stdout (the per-stage lines go to stderr);
        /// see the README's CLI section.
        #[arg(long)]
        json: bool,
    },
    /// Print a shell completion script, e.g. `laydown completions bash > ~/.local/share/bash-completion/completions/laydown`.
    Completions {
        #[arg(value_enum)]
        shell: clap_complete::Shell,
    },
    /// Run one Slurm array task of a stage (used by `--executor slurm`).
    #[command(hide = true)]
    Worker {
        /// The stage's plan.json, written by the driver.
        #[arg(long)]
        plan: PathBuf,
        /// The array task (SLURM_ARRAY_TASK_ID).
        #[arg(long)]
        task: usize,
    },
    /// Parse and check a pipeline without computing anything.
    Validate {
        pipeline: PathBuf,
        /// Memory the stages may use, e.g. `2GiB` (default: the machine's available memory).
        #[arg(long, value_name = "SIZE", value_parser = crate::memory::parse_size)]
        max_memory: Option<u64>,
        /// CPU time a stage may be estimated to take, e.g. `30min`, `2h` (default: no limit).
        #[arg(long, value_name = "DURATION", value_parser = crate::run_time::parse_duration)]
        max_cpu_time: Option<f64>,
    },
    /// Print a pipeline's stage graph: one stage per line in the order they run, with
    /// kind, size and inputs; or Graphviz DOT (`laydown dag P --dot | dot -Tsvg > dag.svg`).
    Dag {
        pipeline: PathBuf,
        /// Graphviz DOT instead of text.
        #[arg(long)]
        dot: bool,
    },
    /// List stages and versions of an archive (status, params hash, wall time); `*`
    /// marks each stage's current version, the one the pipeline's last run matched or wrote.
    Ls {
        archive: PathBuf,
        /// Machine-readable output (see the README's CLI section).
        #[arg(long)]
        json: bool,
    },
    /// Remove stage versions that are not current (keeping, per stage, the current version,
    /// the N newest others and every version a kept one was computed from), in one atomic
    /// commit; prints what it removes. HDF5 does not shrink the file: add --repack for that.
    Prune {
        archive: PathBuf,
        /// Also keep the N newest non-current versions of each stage.
        #[arg(long, value_name = "N", default_value_t = 0)]
        keep: usize,
        /// Print what would be removed; change nothing.
        #[arg(long)]
        dry_run: bool,
        /// Then rewrite the archive into a new file without the removed versions' space,
        /// renamed over it atomically.
        #[arg(long)]
        repack: bool,
    },
    /// Check every version of an archive against the hashes stored when it was
    /// committed (reading every value); names each damaged group and dataset. Exit 1 on damage.
    Verify { archive: PathBuf },
    /// Show a stage version's provenance and datasets (`STAGE` is its current version).
    Show {
        archive: PathBuf,
        /// `STAGE` or `STAGE@vN`.
        stage: String,
        /// Machine-readable output.
        #[arg(long)]
        json: bool,
    },
    /// List stage kinds, or print one kind's parameter table (units, defaults, ranges).
    Stages {
        kind: Option<String>,
        /// Machine-readable output (see the README's CLI section).
        #[arg(long)]
        json: bool,
    },
    /// Print the JSON schema of pipeline files (schemas/pipeline.schema.json).
    Schema,
    /// Print a stage version's per-point results as a table (swept parameters as columns,
    /// means and standard deviations; per replicate with --all), at full precision.
    Table {
        archive: PathBuf,
        /// `STAGE` or `STAGE@vN`.
        stage: String,
        /// One row per replicate (laydown, grid), sample (image) or fibre (spectra).
        #[arg(long)]
        all: bool,
        #[arg(long, value_enum, default_value = "csv")]
        format: crate::table::Format,
    },
    /// Write a pipeline that computes a stage version again, with every version upstream
    /// of it, from their provenance (stdout, or --output FILE).
    Export {
        archive: PathBuf,
        /// `STAGE` or `STAGE@vN`.
        stage: String,
        #[arg(short, long)]
        output: Option<PathBuf>,
    },
    /// Draw a stage version's figures (PNG, SVG or PDF, at print size) and print their paths.
    Plot {
        archive: PathBuf,
        /// `STAGE` or `STAGE@vN`; several may be given. Default: every stage's current version.
        stages: Vec<String>,
        /// Directory for the figures (default: `<archive stem>_figures/<stage>/vN/` beside the archive).
        #[arg(long, value_name = "DIR")]
        out: Option<PathBuf>,
        /// One format or several, comma-separated (`png,pdf`).
        #[arg(long, value_enum, value_delimiter = ',', default_value = "png")]
        format: Vec<crate::plot::figure::Format>,
        /// Figure width on the page (mm), e.g. 180 for two columns, 85 for one. Default:
        /// 85 for a figure of one panel, 180 for more.
        #[arg(long, value_name = "MM", value_parser = positive)]
        width: Option<f64>,
        /// PNG resolution at that width.
        #[arg(long, default_value_t = 300.0, value_parser = positive)]
        dpi: f64,
        /// Label size (pt); tick labels are 0.9 of it.
        #[arg(long, value_name = "PT", default_value_t = 8.0, value_parser = positive)]
        font_size: f64,
        /// TrueType font for every label (default: LAYDOWN_FONT, else a system sans-serif).
        #[arg(long, value_name = "TTF")]
        font: Option<PathBuf>,
    },
}

/// Run the CLI; returns the process exit code.
pub fn main_with(cli: Cli) -> i32 {
    crate::verbosity::set(crate::verbosity::from_flags(cli.quiet, cli.verbose));
    match cli.command {
        Command::Completions { shell } => {
            use clap::CommandFactory;
            clap_complete::generate(shell, &mut Cli::command(), "laydown", &mut std::io::stdout());
            0
        }
        Command::Run { pipeline: path, only, from, dry_run, force, archive, executor, partition, max_parallel, units_per_task, sbatch_arg, max_memory, max_cpu_time, threads, json } => {
            crate::verbosity::set_json_stdout(json);
            // before the pipeline's memory estimates, which count the threads
            if let Some(n) = threads {
                if let Err(e) = crate::executor::local::set_threads(n as usize) {
                    eprintln!("error: --threads: {e:#}");
                    return 1;
                }
            }
            let mut p = match pipeline::load_with(&path, memory_limit(max_memory)) {
                Ok(p) => p,
                Err(d) => {
                    eprintln!("{d}");
                    return 2;
                }
            };
            print_warnings(&p);
            if over_cpu_limit(&p, &crate::run_time::estimates(&p), &path, max_cpu_time) {
                return 2;
            }
            if let Some(a) = archive {
                if a.is_dir() {
                    eprintln!("error: --archive: `{}` is a directory; give the path of an HDF5 file, e.g. {}", a.display(), a.join("study.h5").display());
                    return 2;
                }
                p.archive = crate::archive::absolute(&a);
            }
            if let Some(e) = executor {
                p.executor.kind = crate::executor::ExecutorKind::from_name(&e).expect("checked by clap");
            }
            if partition.is_some() {
                p.executor.partition = partition;
            }
            if let Some(m) = max_parallel {
                p.executor.max_parallel = Some(m as usize);
            }
            if let Some(k) = units_per_task {
                p.executor.units_per_task = Some(k as usize);
            }
            if !sbatch_arg.is_empty() {
                p.executor.sbatch_args = sbatch_arg;
            }
            let opts = RunOptions { only, from, force, progress: crate::verbosity::progress_bars(), executor: None, dry_run };
            match runner::run(&p, &opts) {
                Ok(reports) if json => {
                    println!("{}", serde_json::to_string_pretty(&crate::run_summary::json(&p, &reports, dry_run)).expect("JSON of plain values"));
                    0
                }
                Ok(reports) => {
                    // The results of every image stage that ran, on stdout (as `laydown table`).
                    // (Not under -q, which prints only warnings and errors.)
                    for r in reports.iter().filter(|r| r.outcome == runner::Outcome::Computed && !crate::verbosity::quiet()) {
                        if p.stage(&r.stage).is_some_and(|s| s.kind == "image") {
                            let stage_ref = format!("{}@v{}", r.stage, r.version);
                            match crate::table::read_table(&p.archive, &stage_ref, false) {
                                Ok(t) => print!("{stage_ref} (laydown table {} {stage_ref}):\n{}", p.archive.display(), t.render(crate::table::Format::Csv)),
                                Err(e) => {
                                    eprintln!("error: table of {stage_ref}: {e:#}");
                                    return 1;
                                }
                            }
                        }
                    }
                    0
                }
                Err(e) => {
                    eprintln!("error: {e}");
                    e.exit_code()
                }
            }
        }
        Command::Worker { plan, task } => match crate::executor::slurm::worker(&plan, task) {
            Ok(()) => 0,
            Err(e) => {
                eprintln!("error: {e:#}");
                1
            }
        },
        Command::Validate { pipeline: path, max_memory, max_cpu_time } => match pipeline::load_with(&path, memory_limit(max_memory)) {
            Ok(p) => {
                print_warnings(&p);
                let estimates = crate::run_time::estimates(&p);
                if over_cpu_limit(&p, &estimates, &path, max_cpu_time) {
                    return 2;
                }
                let n: usize = p.stages.iter().map(|s| s.points().0.len() * s.replicates).sum();
                println!("{}: ok ({} stages, {} units of work)", path.display(), p.stages.len(), n);
                for e in estimates {
                    let s = &p.stages[e.stage];
                    println!("  stage `{}` ({}): {} of CPU time, estimated from its parameters", s.name, s.kind, e.describe());
                }
                0
            }
            Err(d) => {
                eprintln!("{d}");
                2
            }
        },
        Command::Dag { pipeline: path, dot } => match pipeline::load(&path) {
            Ok(p) => {
                print!("{}", if dot { pipeline::dag::dot(&p) } else { pipeline::dag::text(&p) });
                0
            }
            Err(d) => {
                eprintln!("{d}");
                2
            }
        },
        Command::Ls { archive, json } => report(ls(&archive, json)),
        Command::Verify { archive } => report(verify(&archive)),
        Command::Prune { archive, keep, dry_run, repack } => report(prune(&archive, keep, dry_run, repack)),
        Command::Show { archive, stage, json } => report(show(&archive, &stage, json)),
        Command::Stages { kind, json } => report(describe_stages(kind.as_deref(), json)),
        Command::Plot { archive, stages, out, format, width, dpi, font_size, font } => {
            let opts = crate::plot::figure::RenderOptions { width_mm: width, dpi, font_pt: font_size, font };
            report(plot(&archive, &stages, out.as_deref(), &format, &opts))
        }
        Command::Table { archive, stage, all, format } => report(table(&archive, &stage, all, format)),
        Command::Export { archive, stage, output } => report(export(&archive, &stage, output.as_deref())),
        Command::Schema => {
            println!("{}", serde_json::to_string_pretty(&crate::schema::pipeline_schema()).unwrap());
            0
        }
    }
}

/// With `--max-cpu-time`, print the stages estimated above it; whether there are any.
fn over_cpu_limit(p: &pipeline::Pipeline, estimates: &[crate::run_time::CpuEstimate], path: &std::path::Path, limit: Option<f64>) -> bool {
    let over = limit.map(|limit| crate::run_time::over_limit(p, estimates, &path.display().to_string(), limit)).unwrap_or_default();
    if !over.is_empty() {
        eprintln!("{}", over.join("\n"));
    }
    !over.is_empty()
}

/// The pipeline's cautions ([`pipeline::Pipeline::warnings`]) on stderr, also under `-q`.
fn print_warnings(p: &pipeline::Pipeline) {
    for w in &p.warnings {
        eprintln!("warning: {w}");
    }
}

/// `--max-memory`, or the machine's available memory.
fn memory_limit(max_memory: Option<u64>) -> crate::memory::Limit {
    max_memory.map_or(crate::memory::Limit::Available, crate::memory::Limit::Bytes)
}

/// Print a command's error; exit 2 for bad input (a [`BadInput`] anywhere in the chain:
/// a missing archive, an unknown stage or version, a malformed argument), 1 for
/// everything else (a damaged archive, a failure while reading or drawing).
fn report(r: Result<()>) -> i32 {
    match r {
        Ok(()) => 0,
        Err(e) => {
            eprintln!("error: {e:#}");
            exit_code(&e)
        }
    }
}

/// 2 for bad input, 1 otherwise (see `report`).
pub fn exit_code(e: &anyhow::Error) -> i32 {
    if e.chain().any(|c| c.is::<BadInput>()) {
        return 2;
    }
    match e.downcast_ref::<RunError>() {
        Some(r) => r.exit_code(),
        None => 1,
    }
}

/// Lists everything before printing, so a failure prints nothing to stdout.
fn ls(path: &std::path::Path, json: bool) -> Result<()> {
    let listing = crate::listing::list(path)?;
    if json {
        println!("{}", serde_json::to_string_pretty(&listing.json())?);
    } else {
        print!("{}", listing.text());
    }
    Ok(())
}

/// Every version checked; the report goes to stdout (one line per version), then, if
/// anything is damaged, one error line (exit 1).
fn verify(path: &std::path::Path) -> Result<()> {
    let archive = Archive::open_read(path)?;
    let (mut lines, mut damaged, mut total) = (vec![], vec![], 0);
    for stage in archive.stages()? {
        let versions = match archive.versions(&stage) {
            Ok(v) => v,
            Err(e) => {
                lines.push(format!("DAMAGED    /{stage}: its versions cannot be listed ({})", e.to_string().lines().next().unwrap_or("")));
                damaged.push((format!("/{stage}"), stage.clone(), None));
                continue;
            }
        };
        for v in versions {
            total += 1;
            match v.verify() {
                Integrity::Ok => lines.push(format!("ok         {}", v.group_path())),
                Integrity::Unverifiable => lines.push(format!("unchecked  {} (written before laydown stored dataset hashes)", v.group_path())),
                Integrity::Damaged(problems) => {
                    lines.push(format!("DAMAGED    {}: {}", v.group_path(), problems.join("; ")));
                    damaged.push((v.group_path(), stage.clone(), v.attr_str("pipeline_file").map(str::to_string)));
                }
            }
        }
    }
    if !lines.is_empty() {
        println!("{}", lines.join("\n"));
    }
    if damaged.is_empty() {
        return Ok(());
    }
    let groups: Vec<&str> = damaged.iter().map(|(g, _, _)| g.as_str()).collect();
    let fixes: Vec<String> = damaged
        .iter()
        .map(|(_, stage, p)| format!("`laydown run {} --force {stage}`", p.as_deref().unwrap_or("PIPELINE")))
        .collect::<std::collections::BTreeSet<_>>()
        .into_iter()
        .collect();
    Err(anyhow::anyhow!(
        "archive {}: {} of {total} versions damaged ({}); do not use them: {} computes them again",
        path.display(),
        damaged.len(),
        groups.join(", "),
        fixes.join(", ")
    ))
}

/// `laydown prune`: the plan from [`crate::archive::prune`], printed; applied (and
/// repacked) unless a dry run.
fn prune(path: &std::path::Path, keep: usize, dry_run: bool, repack: bool) -> Result<()> {
    use crate::archive::prune as p;
    Archive::open_read(path)?;
    let archive = if dry_run { Archive::open_if_exists(path)? } else { Archive::open_write(path)? };
    let plan = p::plan(&archive, keep)?;
    if !dry_run {
        p::apply(&archive, &plan)?;
    }
    // Printed once everything is done: a failure prints nothing to stdout.
    let mut lines = p::describe(&plan, dry_run);
    let n = plan.removed.len();
    let s = if n == 1 { "" } else { "s" };
    if dry_run {
        lines.push(format!("dry run: {n} version{s} would be removed{}", if repack { ", then the archive repacked" } else { "" }));
    } else if repack {
        let (before, after) = p::repack(&archive).with_context(|| format!("{n} version{s} removed, but repacking failed (the archive is pruned, not repacked)"))?;
        lines.push(format!("removed {n} version{s}; repacked {}: {:.2} MB -> {:.2} MB", archive.path.display(), before as f64 / 1e6, after as f64 / 1e6));
    } else {
        lines.push(format!(
            "removed {n} version{s} from {}; HDF5 does not give their space back: the file keeps its size until `laydown prune {} --repack`",
            archive.path.display(),
            path.display()
        ));
    }
    println!("{}", lines.join("\n"));
    Ok(())
}

fn show(path: &std::path::Path, stage_ref: &str, json: bool) -> Result<()> {
    let archive = Archive::open_read(path)?;
    let (stage, number) = parse_stage_ref(stage_ref)?;
    let v = archive.version(&stage, number)?;
    // A damaged version is reported, not shown as if it were healthy.
    v.check()?;
    let current = archive.current(&stage)?;
    let file = v.open()?;
    let mut datasets = vec![];
    for name in file.member_names()? {
        if let Ok(ds) = file.dataset(&name) {
            let attrs = hdf::read_attrs(&ds)?;
            let s = |k: &str| match attrs.get(k) {
                Some(Attr::Str(s)) => s.clone(),
                _ => String::new(),
            };
            datasets.push((name, ds.shape(), s("units"), s("long_name")));
        }
    }
    if json {
        let prov: serde_json::Map<String, serde_json::Value> = v
            .attrs
            .iter()
            .map(|(k, a)| {
                let val = match a {
                    Attr::Str(s) => serde_json::Value::String(s.clone()),
                    Attr::F64(f) => serde_json::json!(f),
                    Attr::I64(i) => serde_json::json!(i),
                };
                (k.clone(), val)
            })
            .collect();
        let ds: Vec<serde_json::Value> = datasets
            .iter()
            .map(|(n, shape, u, l)| serde_json::json!({"name": n, "shape": shape, "units": u, "long_name": l}))
            .collect();
        let doc = serde_json::json!({"stage": stage, "version": v.number, "current": current == Some(v.number), "group": v.group_path(), "provenance": prov, "datasets": ds});
        println!("{}", serde_json::to_string_pretty(&doc)?);
        return Ok(());
    }
    let status = match current {
        Some(n) if n == v.number => "current".to_string(),
        Some(n) => format!("not current: the pipeline's last run used v{n}"),
        None => "no version is marked current (an archive of an older laydown)".to_string(),
    };
    println!("{} ({}; {status})", v.group_path(), v.file.display());
    println!("provenance:");
    for (k, a) in &v.attrs {
        let text = match a {
            Attr::Str(s) => s.trim_end().replace('\n', "\n      "),
            Attr::F64(f) => format!("{f}"),
            Attr::I64(i) => format!("{i}"),
        };
        println!("  {k}: {text}");
    }
    println!("datasets:");
    for (n, shape, u, l) in datasets {
        println!("  {n:<36} {:<20} [{u}] {l}", format!("{shape:?}"));
    }
    Ok(())
}

fn export(archive: &std::path::Path, stage_ref: &str, output: Option<&std::path::Path>) -> Result<()> {
    let (stage, number) = parse_stage_ref(stage_ref)?;
    let text = crate::archive::export::export_pipeline(&Archive::open_read(archive)?, &stage, number)?;
    match output {
        Some(path) => {
            std::fs::write(path, text).map_err(|e| anyhow::anyhow!("writing {}: {e}", path.display()))?;
            crate::info!("wrote {}", path.display());
        }
        None => print!("{text}"),
    }
    Ok(())
}

fn table(archive: &std::path::Path, stage_ref: &str, all: bool, format: crate::table::Format) -> Result<()> {
    let t = crate::table::read_table(archive, stage_ref, all)?;
    if let Some(note) = &t.note {
        crate::info!("{}: {note}", t.group);
    }
    print!("{}", t.render(format));
    Ok(())
}

fn plot(archive: &std::path::Path, stage_refs: &[String], out: Option<&std::path::Path>, formats: &[crate::plot::figure::Format], opts: &crate::plot::figure::RenderOptions) -> Result<()> {
    let refs = if stage_refs.is_empty() { Archive::open_read(archive)?.stages()? } else { stage_refs.to_vec() };
    // Paths are printed once every figure is drawn: a failure prints nothing to stdout.
    let mut written = vec![];
    for r in &refs {
        // Each stage in its own subdirectory when several go to one --out.
        let dir = out.map(|o| if refs.len() > 1 { o.join(r.replace('@', "_")) } else { o.to_path_buf() });
        written.extend(crate::plot::plot_stage(archive, r, dir.as_deref(), formats, opts).with_context(|| format!("plotting {r}"))?);
    }
    for path in written {
        println!("{}", path.display());
    }
    Ok(())
}

/// A finite number above zero (figure width, dpi, font size).
fn positive(s: &str) -> std::result::Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
        _ => Err(format!("`{s}` is not a number above 0")),
    }
}

fn describe_stages(kind: Option<&str>, json: bool) -> Result<()> {
    if json {
        println!("{}", serde_json::to_string_pretty(&crate::listing::stages_json(kind)?)?);
    } else {
        print!("{}", crate::listing::stages_text(kind)?);
    }
    Ok(())
}
