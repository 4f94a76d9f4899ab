//! Every reader on hostile bytes, inside the normal test command: the fuzz
//! corpus (`fuzz/corpus/<format>/`), deterministic mutations of it
//! (truncations, byte flips, spliced bytes), and random bytes. Each input must
//! give `Ok` or an error message, never a panic. `cargo fuzz` runs the same
//! entry points without bounds (see `fuzz/Cargo.toml`).

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::{Path, PathBuf};

use drape::untrusted::{Format, read};
use proptest::prelude::*;

fn corpus(name: &str) -> Vec<(PathBuf, Vec<u8>)> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz/corpus").join(name);
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|entry| entry.unwrap().path())
        .collect();
    files.sort();
    files.into_iter().map(|path| (path.clone(), std::fs::read(&path).unwrap())).collect()
}

/// Reads `bytes`, failing the test with `what` if the reader panics; an
/// error must say something.
fn survives(format: Format, bytes: &[u8], what: &dyn Fn() -> String) -> bool {
    match catch_unwind(AssertUnwindSafe(|| read(format, bytes))) {
        Ok(Ok(())) => true,
        Ok(Err(message)) => {
            assert!(!message.trim().is_empty(), "{}: an empty error message", what());
            false
        }
        Err(_) => panic!("{:?} reader panicked on {}", format, what()),
    }
}

/// A small deterministic generator (xorshift64*), so mutations are the same on every run.
struct Bits(u64);

impl Bits {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }

    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

/// Truncations, byte flips and splices of `seed`.
fn mutations(seed: &[u8], bits: &mut Bits) -> Vec<(String, Vec<u8>)> {
    let mut out = Vec::new();
    for k in 0..24 {
        let length = seed.len() * k / 24;
        out.push((format!("truncated to {length} bytes"), seed[..length].to_vec()));
    }
    for _ in 0..48 {
        let mut bytes = seed.to_vec();
        for _ in 0..1 + bits.below(4) {
            let at = bits.below(bytes.len());
            if let Some(b) = bytes.get_mut(at) {
                *b ^= 1 << bits.below(8);
            }
        }
        out.push(("with flipped bits".to_owned(), bytes));
    }
    for _ in 0..16 {
        let mut bytes = seed.to_vec();
        let (from, to) = (bits.below(bytes.len()), bits.below(bytes.len()));
        let chunk: Vec<u8> = bytes[from.min(to)..from.max(to)].to_vec();
        let at = bits.below(bytes.len());
        bytes.splice(at..at, chunk);
        out.push(("with a repeated span".to_owned(), bytes));
    }
    out
}

#[test]
fn every_corpus_file_reads_and_at_least_one_per_format_is_valid() {
    for (format, name) in Format::ALL {
        let files = corpus(name);
        assert!(!files.is_empty(), "fuzz/corpus/{name} is empty");
        let valid =
            files.iter().filter(|(path, bytes)| survives(format, bytes, &|| path.display().to_string())).count();
        assert!(valid > 0, "no file of fuzz/corpus/{name} reads: the corpus would not reach the deep code");
    }
}

#[test]
fn mutated_corpus_files_give_ok_or_an_error_never_a_panic() {
    let mut bits = Bits(0x9e37_79b9_7f4a_7c15);
    let (mut read_ok, mut refused) = (0, 0);
    for (format, name) in Format::ALL {
        for (path, seed) in corpus(name) {
            for (how, bytes) in mutations(&seed, &mut bits) {
                match survives(format, &bytes, &|| format!("{} {how}", path.display())) {
                    true => read_ok += 1,
                    false => refused += 1,
                }
            }
        }
    }
    eprintln!("{read_ok} mutated inputs read, {refused} refused with an error");
    assert!(read_ok > 50 && refused > 500, "the mutations reach both outcomes: {read_ok} read, {refused} refused");
}

fn format() -> impl Strategy<Value = Format> {
    proptest::sample::select(Format::ALL.map(|(format, _)| format).to_vec())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    /// Random bytes, and random bytes behind each format's magic.
    #[test]
    fn random_bytes_give_ok_or_an_error(format in format(), bytes in proptest::collection::vec(any::<u8>(), 0..1024)) {
        let magic: &[u8] = match format {
            Format::Fbx => b"Kaydara FBX Binary  \x00\x1a\x00",
            Format::MotionCache => b"DRAPEMOT",
            Format::Pc2 => b"POINTCACHE2\x00",
            _ => b"",
        };
        survives(format, &bytes, &|| format!("{} random bytes", bytes.len()));
        let behind: Vec<u8> = magic.iter().chain(&bytes).copied().collect();
        survives(format, &behind, &|| format!("{} random bytes after the magic", bytes.len()));
    }
}
