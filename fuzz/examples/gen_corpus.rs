//! Writes the seed corpus of every fuzz target (`fuzz/corpus/<target>/seed-NN`) from
//! the harnesses' seed functions, and checks that every seed gets past the integrity
//! checks of its decoder (its harness counts a message).
//!
//! - `cargo run --example gen_corpus`: (re)write the seeds (after a format change).
//! - `cargo run --example gen_corpus -- --check`: fail when the committed seeds differ
//!   from what the encoders write now, or one does not reach past the checks.
//! - `cargo run --example gen_corpus -- --count TARGET DIR...`: run TARGET's harness on
//!   every file of the directories (a corpus a fuzz run grew) and count the inputs
//!   that got past the integrity checks.

use kerf_fuzz::{Target, TARGETS};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

fn corpus_dir(target: &Target) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("corpus")
        .join(target.name)
}

fn seed_files(dir: &Path) -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .map(|d| d.filter_map(|e| e.ok().map(|e| e.path())).collect())
        .unwrap_or_default();
    files.retain(|p| {
        p.file_name()
            .is_some_and(|n| n.to_string_lossy().starts_with("seed-"))
    });
    files.sort();
    files
}

fn count(name: &str, dirs: &[String]) -> Result<(), String> {
    let target = TARGETS
        .iter()
        .find(|t| t.name == name)
        .ok_or(format!("no target {name}"))?;
    let (mut inputs, mut past, mut messages) = (0, 0, 0);
    for dir in dirs {
        let entries = std::fs::read_dir(dir).map_err(|e| format!("{dir}: {e}"))?;
        for entry in entries.flatten() {
            let data = std::fs::read(entry.path()).map_err(|e| e.to_string())?;
            let n = (target.run)(&data);
            inputs += 1;
            past += usize::from(n > 0);
            messages += n;
        }
    }
    println!("{name}: {inputs} inputs, {past} past the integrity checks ({messages} messages)");
    Ok(())
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.first().map(String::as_str) == Some("--count") {
        return match args.get(1).map(|name| count(name, &args[2..])) {
            Some(Ok(())) => ExitCode::SUCCESS,
            Some(Err(e)) => {
                eprintln!("gen_corpus: {e}");
                ExitCode::FAILURE
            }
            None => {
                eprintln!("usage: gen_corpus --count TARGET DIR...");
                ExitCode::FAILURE
            }
        };
    }
    let check = args.first().map(String::as_str) == Some("--check");
    let mut failed = false;
    for target in &TARGETS {
        let seeds = (target.seeds)();
        let dir = corpus_dir(target);
        for (k, seed) in seeds.iter().enumerate() {
            let n = (target.run)(seed);
            if n == 0 {
                eprintln!(
                    "gen_corpus: {} seed {k} does not get past the checks",
                    target.name
                );
                failed = true;
            }
        }
        if check {
            let committed: Vec<Vec<u8>> = seed_files(&dir)
                .iter()
                .filter_map(|p| std::fs::read(p).ok())
                .collect();
            if committed != seeds {
                eprintln!(
                    "gen_corpus: {} is stale: run `cargo run --example gen_corpus` in fuzz/",
                    dir.display()
                );
                failed = true;
            }
        } else {
            std::fs::create_dir_all(&dir).expect("the corpus directory");
            for old in seed_files(&dir) {
                std::fs::remove_file(old).expect("an old seed removed");
            }
            for (k, seed) in seeds.iter().enumerate() {
                std::fs::write(dir.join(format!("seed-{k:02}")), seed).expect("a seed written");
            }
        }
        let bytes: usize = seeds.iter().map(Vec::len).sum();
        println!("{}: {} seeds, {bytes} bytes", target.name, seeds.len());
    }
    if failed {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    }
}
