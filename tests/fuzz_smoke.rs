//! The fuzz smoke run on stable Rust: the checks of the cargo-fuzz targets
//! (fuzz/src/lib.rs) on the seed corpus and on seeded random mutations of it,
//! so `cargo test` exercises every fuzz target without nightly or cargo-fuzz.
//! The long run is `make fuzz` (scripts/fuzz.sh).
//!
//! Corpus: reference_models/, tests/data/, fuzz/seeds/ and gymnasium's MJCF
//! assets; the mesh readers' is fuzz/seeds/mesh/. A mutation applies 1-8 edits (flip a byte, insert a token of the
//! target's libFuzzer dictionary, delete or duplicate a span); the generator
//! is seeded, so every run checks the same inputs.

mod common;

#[path = "../fuzz/src/lib.rs"]
mod checks;

use std::path::{Path, PathBuf};

use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};

/// Mutations per loader, and random inputs of the step check.
const MUTATIONS: usize = 2000;
const STEP_INPUTS: usize = 4000;

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// The files of `dirs` whose name ends with `ext`, sorted.
fn files(dirs: &[PathBuf], ext: &str) -> Vec<PathBuf> {
    let mut found: Vec<PathBuf> = dirs
        .iter()
        .flat_map(|d| std::fs::read_dir(d).unwrap_or_else(|e| panic!("{}: {e}", d.display())))
        .map(|e| e.unwrap().path())
        .filter(|p| p.to_string_lossy().ends_with(ext))
        .collect();
    found.sort();
    found
}

fn mjcf_corpus() -> Vec<PathBuf> {
    let dirs = [
        root().join("reference_models"),
        root().join("tests/data"),
        root().join("fuzz/seeds/mjcf"),
        common::gym_assets(),
    ];
    files(&dirs, ".xml")
}

fn urdf_corpus() -> Vec<PathBuf> {
    let dirs = [
        root().join("reference_models"),
        root().join("fuzz/seeds/urdf"),
    ];
    files(&dirs, ".urdf")
}

/// The tokens of a libFuzzer dictionary: each line's quoted text, with `\"`
/// and `\\` unescaped.
fn dictionary(name: &str) -> Vec<Vec<u8>> {
    let text = std::fs::read_to_string(root().join("fuzz").join(name)).unwrap();
    text.lines()
        .filter(|l| l.starts_with('"'))
        .map(|l| {
            let inner = &l[1..l.rfind('"').unwrap()];
            inner
                .replace("\\\"", "\"")
                .replace("\\\\", "\\")
                .into_bytes()
        })
        .collect()
}

/// `data` after 1-8 random edits.
fn mutate(data: &[u8], tokens: &[Vec<u8>], r: &mut StdRng) -> Vec<u8> {
    let mut out = data.to_vec();
    for _ in 0..r.random_range(1..=8) {
        let at = r.random_range(0..=out.len());
        match r.random_range(0..4) {
            0 if at < out.len() => out[at] ^= 1 << r.random_range(0..8),
            1 => {
                let token = &tokens[r.random_range(0..tokens.len())];
                out.splice(at..at, token.iter().copied());
            }
            2 => {
                let end = (at + r.random_range(0..64)).min(out.len());
                out.drain(at..end);
            }
            _ => {
                let end = (at + r.random_range(0..64)).min(out.len());
                let span = out[at..end].to_vec();
                out.splice(at..at, span);
            }
        }
    }
    out
}

fn replay_and_mutate(corpus: &[PathBuf], dict: &str, seed: u64, check: fn(&[u8])) {
    let seeds: Vec<Vec<u8>> = corpus.iter().map(|p| std::fs::read(p).unwrap()).collect();
    for (path, data) in corpus.iter().zip(&seeds) {
        eprintln!("replaying {}", path.display());
        check(data);
    }
    let tokens = dictionary(dict);
    let mut r = StdRng::seed_from_u64(seed);
    for k in 0..MUTATIONS {
        let mutated = mutate(&seeds[k % seeds.len()], &tokens, &mut r);
        let shown = String::from_utf8_lossy(&mutated).into_owned();
        let caught = std::panic::catch_unwind(|| check(&mutated));
        assert!(caught.is_ok(), "mutation {k} failed; its input:\n{shown}");
    }
}

#[test]
fn mjcf_loader_survives_its_corpus_and_mutations() {
    let corpus = mjcf_corpus();
    assert!(corpus.len() >= 20, "{corpus:?}");
    replay_and_mutate(&corpus, "mjcf.dict", 1, checks::check_mjcf);
}

#[test]
fn urdf_loader_survives_its_corpus_and_mutations() {
    let corpus = urdf_corpus();
    assert!(corpus.len() >= 6, "{corpus:?}");
    replay_and_mutate(&corpus, "urdf.dict", 2, checks::check_urdf);
}

#[test]
fn mesh_readers_survive_their_corpus_and_mutations() {
    let dirs = [root().join("fuzz/seeds/mesh")];
    let corpus: Vec<PathBuf> = [".stl", ".obj", ".msh", ".dae"]
        .iter()
        .flat_map(|ext| files(&dirs, ext))
        .collect();
    assert!(corpus.len() >= 4, "{corpus:?}");
    replay_and_mutate(&corpus, "mesh.dict", 4, checks::check_mesh);
}

#[test]
fn step_and_jacobians_survive_random_inputs() {
    let mut r = StdRng::seed_from_u64(3);
    for k in 0..STEP_INPUTS {
        let len = r.random_range(0..160);
        let data: Vec<u8> = (0..len).map(|_| r.random()).collect();
        let caught = std::panic::catch_unwind(|| checks::check_step(&data));
        assert!(caught.is_ok(), "input {k} failed: {data:?}");
    }
}
