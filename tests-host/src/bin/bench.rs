//! `bench`: issue 14's benchmark. Runs every workload of `tests_host::bench` on every device
//! kind under callgrind, twice (0 and N operations), and prints the instructions per operation
//! as a markdown table (`docs/benchmarks.md`).
//!
//! ```sh
//! cargo run --release -p tests-host --bin bench [-- --quick] [-- --check]
//! ```

use std::path::Path;
use std::process::{Command, ExitCode};

use tests_host::bench::{callgrind_total, per_operation, Extra, Kind, Workload, KINDS, WEAR_PAGES};

const HELP: &str = "\
bench: instructions per operation of each workload under callgrind (issue 14)

usage: cargo run --release -p tests-host --bin bench -- [options]

  --quick         few operations per workload: shows that every workload runs, the figures
                  are not the ones to quote
  --check         exit 1 when a figure is above its goal (for CI once the goals are met)
  --device NAME   only this device kind (sgh10, sgh50, wv5800m, core)
  --only W        only this workload (W1 ... W6)
  --run KIND W N  (internal) run N operations of workload W on KIND, what valgrind measures

Exit status: 0 when every workload ran (above-goal figures too, unless --check), 1 when
--check finds a figure above its goal, 2 when a workload fails or valgrind is missing.
";

/// One measured figure.
struct Figure {
    kind: &'static str,
    workload: Workload,
    per_op: u64,
    extra: Extra,
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.first().map(String::as_str) == Some("--run") {
        return run_one(&args[1..]);
    }
    let (mut quick, mut check, mut device, mut only) = (false, false, None, None);
    let mut it = args.iter();
    while let Some(a) = it.next() {
        match a.as_str() {
            "--quick" => quick = true,
            "--check" => check = true,
            "--device" => device = it.next().cloned(),
            "--only" => match it.next().and_then(|w| Workload::parse(w)) {
                Some(w) => only = Some(w),
                None => return usage("--only takes W1 ... W6"),
            },
            "-h" | "--help" => {
                print!("{HELP}");
                return ExitCode::SUCCESS;
            }
            other => return usage(&format!("unknown argument {other}")),
        }
    }
    let kinds: Vec<&Kind> = KINDS.iter().filter(|k| device.as_deref().is_none_or(|d| d == k.name)).collect();
    if kinds.is_empty() {
        return usage("--device: no such kind (sgh10, sgh50, wv5800m, core)");
    }
    let valgrind = match Command::new("valgrind").arg("--version").output() {
        Ok(o) if o.status.success() => String::from_utf8_lossy(&o.stdout).trim().to_string(),
        _ => {
            eprintln!("bench: valgrind not found (apt-get install valgrind)");
            return ExitCode::from(2);
        }
    };
    let exe = match std::env::current_exe() {
        Ok(e) => e,
        Err(e) => {
            eprintln!("bench: {e}");
            return ExitCode::from(2);
        }
    };
    let dir = std::env::temp_dir().join(format!("bench-{}", std::process::id()));
    if let Err(e) = std::fs::create_dir_all(&dir) {
        eprintln!("bench: {}: {e}", dir.display());
        return ExitCode::from(2);
    }
    let mut figures = Vec::new();
    let mut failed = false;
    for kind in &kinds {
        for &w in kind.workloads.iter().filter(|w| only.is_none_or(|o| o == **w)) {
            let n = w.iterations(quick);
            match measure(&exe, &dir, kind.name, w, n) {
                Ok((per_op, extra)) => {
                    eprintln!("bench: {} {}: {per_op} instructions per operation (N = {n})", kind.name, w.name());
                    figures.push(Figure { kind: kind.name, workload: w, per_op, extra });
                }
                Err(e) => {
                    eprintln!("bench: {} {}: {e}", kind.name, w.name());
                    failed = true;
                }
            }
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
    print_table(&kinds, &figures, only, quick, &valgrind);
    if failed {
        return ExitCode::from(2);
    }
    let over: Vec<String> = figures
        .iter()
        .filter(|f| over_goal(f))
        .map(|f| format!("{} {} {}", f.kind, f.workload.name(), f.per_op))
        .collect();
    if check && !over.is_empty() {
        eprintln!("bench: above the goal: {}", over.join(", "));
        return ExitCode::from(1);
    }
    ExitCode::SUCCESS
}

fn usage(msg: &str) -> ExitCode {
    eprintln!("bench: {msg}\n\n{HELP}");
    ExitCode::from(2)
}

/// Is this figure above its goal (for W6 also: more than one erase per page written)?
fn over_goal(f: &Figure) -> bool {
    f.per_op > f.workload.goal() || (f.workload == Workload::W6 && f.extra.erases_per_page_written_percent() > 100)
}

/// `--run KIND W N`: what runs under valgrind. Prints W6's wear figure for the driver.
fn run_one(args: &[String]) -> ExitCode {
    let [kind, w, n] = args else { return usage("--run takes KIND W N") };
    let (Some(kind), Some(w), Ok(n)) = (KINDS.iter().find(|k| k.name == kind), Workload::parse(w), n.parse::<u64>())
    else {
        return usage("--run takes KIND W N");
    };
    match (kind.run)(w, n) {
        Ok(extra) => {
            println!("erases {} bytes-written {}", extra.erases, extra.bytes_written);
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("{e}");
            ExitCode::FAILURE
        }
    }
}

/// Runs the workload under callgrind at 0 and at `n` operations.
fn measure(exe: &Path, dir: &Path, kind: &str, w: Workload, n: u64) -> Result<(u64, Extra), String> {
    let mut totals = [0; 2];
    let mut extra = Extra::default();
    for (i, count) in [0, n].into_iter().enumerate() {
        let out_file = dir.join(format!("{kind}-{}-{count}.out", w.name()));
        let out = Command::new("valgrind")
            .args(["--tool=callgrind", "-q"])
            .arg(format!("--callgrind-out-file={}", out_file.display()))
            .arg(exe)
            .args(["--run", kind, w.name(), &count.to_string()])
            .output()
            .map_err(|e| format!("valgrind: {e}"))?;
        if !out.status.success() {
            return Err(format!("failed at N = {count}: {}", String::from_utf8_lossy(&out.stderr).trim()));
        }
        let text = std::fs::read_to_string(&out_file).map_err(|e| format!("{}: {e}", out_file.display()))?;
        totals[i] = callgrind_total(&text).ok_or_else(|| format!("{}: no totals line", out_file.display()))?;
        let stdout = String::from_utf8_lossy(&out.stdout);
        let words: Vec<&str> = stdout.split_whitespace().collect();
        if let ["erases", e, "bytes-written", b] = words[..] {
            extra = Extra { erases: e.parse().unwrap_or(0), bytes_written: b.parse().unwrap_or(0) };
        }
    }
    Ok((per_operation(totals[0], totals[1], n), extra))
}

fn print_table(kinds: &[&Kind], figures: &[Figure], only: Option<Workload>, quick: bool, valgrind: &str) {
    let stamp = |cmd: &str, args: &[&str]| {
        Command::new(cmd)
            .args(args)
            .output()
            .ok()
            .filter(|o| o.status.success())
            .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
            .unwrap_or_else(|| "?".into())
    };
    println!(
        "Instructions per operation (x86-64, release, callgrind: (N minus 0) / N{}), {}, {}, commit {}, {}:",
        if quick { ", --quick: small N, not for quoting" } else { "" },
        stamp("date", &["-u", "+%Y-%m-%d"]),
        stamp("rustc", &["-V"]),
        stamp("git", &["rev-parse", "--short", "HEAD"]),
        valgrind
    );
    println!();
    let names: Vec<&str> = kinds.iter().map(|k| k.name).collect();
    println!("| workload | {} | goal |", names.join(" | "));
    println!("|---|{}---:|", "---:|".repeat(names.len()));
    for w in Workload::ALL.into_iter().filter(|w| only.is_none_or(|o| o == *w)) {
        let cells: Vec<String> = kinds
            .iter()
            .map(|k| match figures.iter().find(|f| f.kind == k.name && f.workload == w) {
                Some(f) if over_goal(f) => format!("{} (over)", thousands(f.per_op)),
                Some(f) => thousands(f.per_op),
                None => "-".into(),
            })
            .collect();
        println!("| {} {} | {} | ≤ {} |", w.name(), w.what(), cells.join(" | "), thousands(w.goal()));
    }
    if let Some(f) = figures.iter().find(|f| f.workload == Workload::W6) {
        println!();
        let pct = f.extra.erases_per_page_written_percent();
        println!(
            "W6 wear ({}, steady state, {WEAR_PAGES} pages filled): {} page erases, {} bytes programmed ({} pages of {} bytes): \
             {}.{:02} erases per page written (goal: at most 1, a page erased once it is full){}.",
            f.kind,
            f.extra.erases,
            thousands(f.extra.bytes_written),
            f.extra.bytes_written.div_ceil(tests_host::flash::PAGE as u64),
            tests_host::flash::PAGE,
            pct / 100,
            pct % 100,
            if pct > 100 { " (over)" } else { "" }
        );
    }
}

/// 10927 as `10,927`, as the issue writes it.
fn thousands(v: u64) -> String {
    let s = v.to_string();
    let mut out = String::new();
    for (i, c) in s.chars().enumerate() {
        if i > 0 && (s.len() - i).is_multiple_of(3) {
            out.push(',');
        }
        out.push(c);
    }
    out
}
