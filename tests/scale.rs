//! Long runs with the real binary: one writer per output (a second process is refused naming
//! the holder, a dead holder's lock is taken over), the journal a killed run leaves (read by
//! `--resume`, refused by `merge`), and a clean folder after a complete run.

use crate::common;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

const BIN: &str = env!("CARGO_BIN_EXE_panoconv");

/// `n` frames: the shipped synthetic training frames hard-linked under new ids.
fn dataset(root: &Path, n: usize) -> PathBuf {
    let sample = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/synthetic_kitti/training");
    let d = root.join("in");
    for sub in ["image_2", "calib", "label_2"] {
        std::fs::create_dir_all(d.join("training").join(sub)).unwrap();
    }
    for i in 0..n {
        let src = format!("{:06}", i % 3);
        for (sub, ext) in [("image_2", "png"), ("calib", "txt"), ("label_2", "txt")] {
            std::fs::hard_link(
                sample.join(sub).join(format!("{src}.{ext}")),
                d.join("training").join(sub).join(format!("{i:06}.{ext}")),
            )
            .unwrap();
        }
    }
    d
}

fn kitti(input: &Path, output: &Path, extra: &[&str]) -> Command {
    let mut c = kitti_with_summary(input, output, extra);
    c.arg("--quiet");
    c
}

fn kitti_with_summary(input: &Path, output: &Path, extra: &[&str]) -> Command {
    let mut c = Command::new(BIN);
    c.args(["kitti", "--to", "equirect", "--input"])
        .arg(input)
        .arg("--output")
        .arg(output)
        .args(extra);
    c
}

fn run(mut c: Command) -> (Option<i32>, String) {
    let Output { status, stderr, .. } = c.output().unwrap();
    (status.code(), String::from_utf8_lossy(&stderr).into_owned())
}

/// Starts a conversion and waits until it holds `lock` and its journal has `lines` lines or
/// more (the header, then one per frame recorded).
fn start_and_wait(c: &mut Command, out: &Path, lock: &str, journal: &str, lines: usize) -> Child {
    let mut child = c.stderr(Stdio::piped()).spawn().unwrap();
    let t0 = Instant::now();
    while !(out.join(lock).exists() && journal_lines(&out.join(journal)) >= lines) {
        if t0.elapsed() > Duration::from_secs(120) || child.try_wait().unwrap().is_some() {
            let _ = child.kill();
            let o = child.wait_with_output().unwrap();
            panic!(
                "no {lines} journal lines: {}",
                String::from_utf8_lossy(&o.stderr)
            );
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    child
}

fn journal_lines(path: &Path) -> usize {
    std::fs::read(path).map_or(0, |j| j.iter().filter(|&&b| b == b'\n').count())
}

#[test]
fn a_second_writer_is_refused_naming_the_holder_and_a_dead_ones_lock_is_taken_over() {
    let tmp = tempfile::tempdir().unwrap();
    let input = dataset(tmp.path(), 150);
    let out = tmp.path().join("o");
    let mut first = start_and_wait(
        &mut kitti(&input, &out, &["--jobs", "1"]),
        &out,
        "panoconv.lock",
        "panoconv.journal",
        2,
    );
    let host = std::fs::read_to_string("/proc/sys/kernel/hostname")
        .unwrap()
        .trim()
        .to_owned();
    let holder = format!("pid {} on host {host}", first.id());
    for extra in [&["--resume"][..], &["--overwrite"], &[]] {
        let (code, err) = run(kitti(&input, &out, extra));
        assert_eq!(code, Some(2), "{extra:?}: {err}");
        assert!(
            err.contains(&holder) && err.contains("panoconv.lock"),
            "{extra:?}: {err}"
        );
    }
    // a shard of its own may share the folder meanwhile; the same shard twice may not
    let mut shard = start_and_wait(
        &mut kitti(&input, &out, &["--jobs", "1", "--shard", "1/2"]),
        &out,
        "panoconv.shard-1-of-2.lock",
        "panoconv.shard-1-of-2.journal",
        2,
    );
    let (code, err) = run(kitti(&input, &out, &["--shard", "1/2"]));
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains(&format!("pid {} on host {host}", shard.id())),
        "{err}"
    );
    let _ = shard.kill();
    let _ = shard.wait();

    // SIGKILL the holder: its lock file stays, naming a process that no longer runs
    first.kill().unwrap();
    first.wait().unwrap();
    assert!(out.join("panoconv.lock").exists());
    let (code, err) = run(kitti(&input, &out, &["--jobs", "2", "--resume"]));
    assert_eq!(code, Some(0), "{err}");
    assert!(
        err.contains(&format!(
            "taking over {}",
            out.join("panoconv.lock").display()
        )) && err.contains(&holder)
            && err.contains("no longer running"),
        "{err}"
    );
    assert!(!out.join("panoconv.lock").exists());
}

#[test]
fn a_complete_run_leaves_the_manifest_alone_and_verify_finds_no_extra_file() {
    let tmp = tempfile::tempdir().unwrap();
    let input = dataset(tmp.path(), 6);
    let out = tmp.path().join("o");
    let (code, err) = run(kitti(&input, &out, &["--jobs", "2"]));
    assert_eq!(code, Some(0), "{err}");
    let names: Vec<String> = common::tree_bytes(&out)
        .into_keys()
        .filter(|k| !k.contains('/'))
        .collect();
    assert_eq!(names, ["panoconv.json"]);
    let o = Command::new(BIN).arg("verify").arg(&out).output().unwrap();
    let said =
        String::from_utf8_lossy(&o.stdout).into_owned() + &String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success() && said.contains("0 extra"), "{said}");
}

/// SIGINT (a manifest with `complete: false`), then a resume killed with SIGKILL (that
/// manifest and a journal), then a resume: the bytes of one uninterrupted run. A killed shard
/// leaves a journal, and `merge` refuses it by name until the shard is resumed.
#[test]
fn manifest_and_journal_together_resume_to_the_same_bytes_and_merge_waits_for_a_killed_shard() {
    let tmp = tempfile::tempdir().unwrap();
    let input = dataset(tmp.path(), 150);
    let reference = tmp.path().join("reference");
    assert_eq!(run(kitti(&input, &reference, &["--jobs", "2"])).0, Some(0));

    let out = tmp.path().join("o");
    let child = start_and_wait(
        &mut kitti(&input, &out, &["--jobs", "1"]),
        &out,
        "panoconv.lock",
        "panoconv.journal",
        2,
    );
    let pid = child.id().to_string();
    assert!(Command::new("kill")
        .args(["-INT", &pid])
        .status()
        .unwrap()
        .success());
    let o = child.wait_with_output().unwrap();
    assert_eq!(o.status.code(), Some(130));
    let manifest: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("panoconv.json")).unwrap()).unwrap();
    assert_eq!(manifest["complete"], false);
    let kept = manifest["frames"].as_array().unwrap().len();
    assert!((1..150).contains(&kept), "{kept} frames listed");
    assert!(!out.join("panoconv.journal").exists());

    // the resumed run records the kept frames first, then converts: wait for a new frame
    let mut resumed = start_and_wait(
        &mut kitti(&input, &out, &["--jobs", "1", "--resume"]),
        &out,
        "panoconv.lock",
        "panoconv.journal",
        kept + 2,
    );
    resumed.kill().unwrap();
    resumed.wait().unwrap();
    assert!(out.join("panoconv.json").exists() && out.join("panoconv.journal").exists());
    let (code, err) = run(kitti_with_summary(
        &input,
        &out,
        &["--jobs", "2", "--resume"],
    ));
    assert_eq!(code, Some(0), "{err}");
    let kept_again: usize = err
        .lines()
        .find(|l| l.contains("kept from the previous run"))
        .and_then(|l| l.split('(').nth(1))
        .and_then(|s| s.split_whitespace().next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no kept count in {err:?}"));
    assert!(
        kept_again > kept,
        "the killed resume's frames are kept too ({kept_again} kept, {kept} before it)"
    );
    let got = common::tree_bytes(&out);
    let expected = common::tree_bytes(&reference);
    assert_eq!(
        got.keys().collect::<Vec<_>>(),
        expected.keys().collect::<Vec<_>>()
    );
    assert!(got == expected, "resumed output differs from one run");

    // a killed shard
    let sharded = tmp.path().join("sharded");
    assert_eq!(
        run(kitti(&input, &sharded, &["--jobs", "2", "--shard", "0/2"])).0,
        Some(0)
    );
    let mut shard = start_and_wait(
        &mut kitti(&input, &sharded, &["--jobs", "1", "--shard", "1/2"]),
        &sharded,
        "panoconv.shard-1-of-2.lock",
        "panoconv.shard-1-of-2.journal",
        2,
    );
    shard.kill().unwrap();
    shard.wait().unwrap();
    let (code, err) = run({
        let mut c = Command::new(BIN);
        c.arg("merge").arg(&sharded);
        c
    });
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains("panoconv.shard-1-of-2.journal") && err.contains("resume it first"),
        "{err}"
    );
    let (code, err) = run(kitti(
        &input,
        &sharded,
        &["--jobs", "2", "--shard", "1/2", "--resume"],
    ));
    assert_eq!(code, Some(0), "{err}");
    let mut c = Command::new(BIN);
    c.arg("merge").arg(&sharded);
    assert_eq!(run(c).0, Some(0));
    assert!(
        common::tree_bytes(&sharded) == expected,
        "2 shards + merge differ from one run"
    );
}

/// Relative path → blake3 of every file under `root` (the trees are too big to hold).
fn tree_hashes(root: &Path) -> BTreeMap<String, String> {
    let mut out = BTreeMap::new();
    let mut stack = vec![root.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else {
                let rel = p.strip_prefix(root).unwrap().to_string_lossy().into_owned();
                let hash = blake3::hash(&std::fs::read(&p).unwrap())
                    .to_hex()
                    .to_string();
                out.insert(rel, hash);
            }
        }
    }
    out
}

/// kill -9 at several moments of a long run (each resume killed in turn), then `--resume`:
/// the bytes of one uninterrupted run. The real frames of ../shared/kitti/training hard-linked
/// under PANOCONV_SCALE_FRAMES ids (default 20 000), outputs at 414×125 to spare the disk.
/// Minutes long, so outside CI: `cargo test --release --test tests scale:: -- --ignored`.
#[test]
#[ignore = "minutes long: run by hand"]
fn kill_nine_at_scale_then_resume_gives_the_uninterrupted_bytes() {
    let n: usize = std::env::var("PANOCONV_SCALE_FRAMES").map_or(20_000, |v| v.parse().unwrap());
    let source = crate::common::real_kitti().join("training");
    let ids: Vec<String> = {
        let mut ids: Vec<String> = std::fs::read_dir(source.join("image_2"))
            .unwrap()
            .map(|e| {
                e.unwrap()
                    .path()
                    .file_stem()
                    .unwrap()
                    .to_string_lossy()
                    .into_owned()
            })
            .collect();
        ids.sort();
        ids
    };
    let tmp = tempfile::tempdir().unwrap();
    let input = tmp.path().join("in");
    for (sub, ext) in [("image_2", "png"), ("label_2", "txt"), ("calib", "txt")] {
        let dir = input.join("training").join(sub);
        std::fs::create_dir_all(&dir).unwrap();
        for i in 0..n {
            let src = source
                .join(sub)
                .join(format!("{}.{ext}", ids[i % ids.len()]));
            std::fs::hard_link(src, dir.join(format!("{i:06}.{ext}"))).unwrap();
        }
    }
    let options = ["--jobs", "2", "--resize", "414x125"];
    let reference = tmp.path().join("reference");
    let (code, err) = run(kitti(&input, &reference, &options));
    assert_eq!(code, Some(0), "{err}");
    let expected = tree_hashes(&reference);
    std::fs::remove_dir_all(&reference).unwrap();

    let out = tmp.path().join("o");
    // killed after about 5 %, then 30 % and 60 % more of the frames recorded by each run
    for (round, share) in [0.05, 0.3, 0.6].into_iter().enumerate() {
        let resume: &[&str] = if round == 0 { &[] } else { &["--resume"] };
        let before = journal_lines(&out.join("panoconv.journal"));
        let wanted = before.max(1) + (share * n as f64) as usize;
        let mut c = kitti(&input, &out, &options);
        c.args(resume);
        let mut child = start_and_wait(&mut c, &out, "panoconv.lock", "panoconv.journal", wanted);
        child.kill().unwrap();
        child.wait().unwrap();
        eprintln!(
            "round {round}: killed with {} journal lines",
            journal_lines(&out.join("panoconv.journal"))
        );
    }
    let mut c = kitti_with_summary(&input, &out, &options);
    c.arg("--resume");
    let (code, err) = run(c);
    assert_eq!(code, Some(0), "{err}");
    eprintln!("{err}");
    let got = tree_hashes(&out);
    assert_eq!(got.len(), expected.len());
    let differ: Vec<&String> = expected
        .iter()
        .filter(|(k, v)| got.get(*k) != Some(v))
        .map(|(k, _)| k)
        .collect();
    assert!(
        differ.is_empty(),
        "{} files differ: {:?}",
        differ.len(),
        &differ[..differ.len().min(5)]
    );
}
