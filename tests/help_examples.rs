//! Every example of every command's `--help` runs, on the fixtures: the examples are read from
//! the binary's own `--help` output (wrapped lines joined), their placeholders (`/data/kitti`,
//! `K`, `R`, `O`, frame ids, model and camera files) stood in for by copies of the fixtures in
//! a scratch folder, and each is run with `sh` in a fresh copy of that folder: it must exit 0.

use crate::common::*;
use std::path::Path;
use std::process::Command;

/// The subcommands `panoconv CMD --help` lists under "Commands:" (help aside).
fn commands(prefix: &[&str]) -> Vec<Vec<String>> {
    let mut args: Vec<&str> = prefix.to_vec();
    args.push("--help");
    let help = panoconv(&args).stdout;
    let mut out = Vec::new();
    let mut inside = false;
    for line in help.lines() {
        if line == "Commands:" {
            inside = true;
        } else if inside && line.starts_with("  ") && !line.starts_with("   ") {
            let name = line.split_whitespace().next().unwrap();
            if name != "help" {
                let mut cmd: Vec<String> = prefix.iter().map(|s| s.to_string()).collect();
                cmd.push(name.to_owned());
                out.push(cmd);
            }
        } else if inside && line.is_empty() {
            inside = false;
        }
    }
    out
}

/// The examples of `panoconv CMD --help`: the lines under "Examples:" that start a command,
/// with the lines that continue them joined, and `#` comments cut.
fn examples(cmd: &[String]) -> Vec<String> {
    let mut args = cmd.to_vec();
    args.push("--help".into());
    let help = panoconv(&args).stdout;
    let mut out: Vec<String> = Vec::new();
    let mut inside = false;
    for line in help.lines() {
        if line == "Examples:" {
            inside = true;
            continue;
        }
        if !inside || line.is_empty() {
            inside &= !line.is_empty();
            continue;
        }
        let text = line.trim();
        let starts = text.starts_with("panoconv ") || text.starts_with("mkdir ");
        match out.last_mut() {
            Some(last) if !starts => {
                last.push(' ');
                last.push_str(text);
            }
            _ => out.push(text.to_owned()),
        }
    }
    out.into_iter()
        .map(|e| e.split(" #").next().unwrap().trim().to_owned())
        .collect()
}

/// The example with its placeholders replaced by the scratch folder's stand-ins.
fn stand_in(cmd: &str, example: &str) -> String {
    let r = if cmd == "nuscenes" {
        "fixtures/nuscenes"
    } else {
        "fixtures/kitti360"
    };
    let mut tokens: Vec<String> = Vec::new();
    for t in example.split_whitespace() {
        let t = match t {
            "K" => "data/kitti".to_owned(),
            "R" => r.to_owned(),
            "P" => "preds/depth".to_owned(),
            "G" => "data/kitti_cyl/training/depth_2".to_owned(),
            "F" => "frames".to_owned(),
            "$PROFILE" => "profile.ps1".to_owned(),
            "./panoconv.1" if example.contains("&& man") => "./panoconv.1".to_owned(),
            _ => t.replace("/data/", "data/").replace("/tmp/", "tmp/"),
        };
        tokens.push(t);
    }
    let mut line = tokens.join(" ");
    for (from, to) in [
        ("&& man ./panoconv.1", "&& test -s ./panoconv.1"),
        ("/usr/local/share/man/man1", "man1"),
        (
            "2013_05_28_drive_0000_sync,2013_05_28_drive_0003_sync",
            "2013_05_28_drive_0000_sync",
        ),
        ("scene-0061,scene-0103", "scene-0001"),
        (
            "kitti360/calibration/image_02.yaml",
            "fixtures/kitti360/calibration/image_02.yaml",
        ),
        ("000123", "000001"),
        ("000042", "000002"),
        ("000007", "000003"),
    ] {
        line = line.replace(from, to);
    }
    line
}

/// Runs `line` with `sh` in `dir`, the binary first on PATH and HOME inside `dir`.
fn sh(dir: &Path, line: &str) -> (bool, String) {
    let bin = Path::new(BIN).parent().unwrap();
    let path = format!(
        "{}:{}",
        bin.display(),
        std::env::var("PATH").unwrap_or_default()
    );
    let out = Command::new("sh")
        .args(["-c", line])
        .current_dir(dir)
        .env("PATH", path)
        .env("HOME", dir.join("home"))
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stderr).into_owned();
    (out.status.success(), text)
}

#[track_caller]
fn run_ok(dir: &Path, line: &str) {
    let (ok, stderr) = sh(dir, line);
    assert!(ok, "`{line}` failed in {}:\n{stderr}", dir.display());
}

/// The inputs: the fixtures, a KITTI root with image sets, a raw date folder, nuScenes with a
/// v1.0-trainval version, camera and model files, fisheye frames and 2:1 panoramas.
fn inputs(w: &Path) {
    copy_tree(&repo().join("fixtures"), &w.join("fixtures"));
    copy_tree(&w.join("fixtures/synthetic_kitti"), &w.join("data/kitti"));
    let sets = w.join("data/kitti/ImageSets");
    std::fs::create_dir_all(&sets).unwrap();
    write_text(&sets.join("train.txt"), "000000\n000002\n");
    write_text(&sets.join("val.txt"), "000001\n");
    std::fs::create_dir_all(w.join("data/raw")).unwrap();
    crate::raw::raw_date_folder(&w.join("data/raw"));
    copy_tree(&w.join("fixtures/kitti360"), &w.join("data/KITTI-360"));
    let nus = w.join("data/nuscenes");
    copy_tree(&w.join("fixtures/nuscenes"), &nus);
    std::fs::rename(nus.join("v1.0-mini"), nus.join("v1.0-trainval")).unwrap();
    for name in ["front.json", "rear.json"] {
        std::fs::copy(w.join("fixtures/cameras/front.json"), w.join(name)).unwrap();
    }
    let yaml = w.join("fixtures/kitti360/calibration/image_02.yaml");
    std::fs::copy(yaml, w.join("kitti360_image_02.yaml")).unwrap();
    std::fs::copy(
        w.join("fixtures/style/generator.onnx"),
        w.join("miami_BtoA.onnx"),
    )
    .unwrap();
    for d in [
        "tmp",
        "home/.local/share/bash-completion/completions",
        "home/.zfunc",
        "home/.config/fish/completions",
    ] {
        std::fs::create_dir_all(w.join(d)).unwrap();
    }
    run_ok(w, "panoconv kitti --to fisheye --camera front.json --input data/kitti --output fish -q && mkdir frames && cp fish/training/image_2/*.png frames/");
    run_ok(w, "panoconv kitti --to equirect --full-360 --pano-width 512 --input data/kitti --output full -q && mkdir panos && cp full/training/image_2/*.png panos/");
}

/// What the commands that read a converted dataset read: data/kitti_equi, data/kitti_cyl (with
/// depth), O, pixel-object predictions and depth predictions.
fn converted(w: &Path) {
    run_ok(
        w,
        "panoconv kitti --to equirect --input data/kitti --output data/kitti_equi -q",
    );
    run_ok(
        w,
        "panoconv kitti --to cylindrical --depth --input data/kitti --output data/kitti_cyl -q",
    );
    run_ok(
        w,
        "panoconv kitti --to equirect --input data/kitti --output O -q",
    );
    run_ok(w, "panoconv labels-to-pixels --input O --output preds && mkdir -p preds/depth && cp data/kitti_cyl/training/depth_2/*.png preds/depth/");
}

/// The commands that read a converted dataset rather than convert one.
const READERS: [&str; 7] = [
    "preview",
    "labels-to-pixels",
    "unproject",
    "eval-depth",
    "verify",
    "inspect",
    "export",
];

#[test]
fn every_help_example_runs_on_the_fixtures() {
    let tmp = tempfile::tempdir().unwrap();
    let (plain, read) = (tmp.path().join("plain"), tmp.path().join("read"));
    inputs(&plain);
    copy_tree(&plain, &read);
    converted(&read);
    let style = std::env::var_os("ORT_DYLIB_PATH").is_some() || repo().join(".ort").is_dir();
    let mut cmds = commands(&[]);
    cmds.extend(commands(&["camera"]));
    let (mut ran, mut failed) = (0, Vec::new());
    for cmd in cmds {
        let name = cmd.join(" ");
        if name == "rig-stream" {
            // its frames come from a peer program on stdin (a Python RigSource): its examples
            // run in python/tests/test_rig_source.py (the docs' adapter, `python -m panoconv
            // pandaset`), and the command with a Rust peer in tests/rig_stream.rs
            continue;
        }
        let lines: Vec<String> = examples(&cmd).iter().map(|e| stand_in(&name, e)).collect();
        let world = tmp.path().join(format!("run-{ran}"));
        // merge's examples are one sequence: every shard, then the merge
        let sequences: Vec<Vec<String>> = if name == "merge" {
            let shards = (0..4).map(|k| lines[0].replace("--shard 0/4", &format!("--shard {k}/4")));
            vec![shards.chain(lines[1..].iter().cloned()).collect()]
        } else {
            lines.iter().map(|l| vec![l.clone()]).collect()
        };
        for (k, sequence) in sequences.iter().enumerate() {
            if !style && sequence.iter().any(|l| l.contains("--style")) {
                eprintln!("help_examples: no ONNX Runtime here, not run: {sequence:?}");
                continue;
            }
            // an example that converts (`export`'s `kitti --export`) starts without outputs
            let first = sequence[0].split_whitespace().nth(1).unwrap_or_default();
            let base = if READERS.contains(&first) {
                &read
            } else {
                &plain
            };
            let dir = world.with_extension(k.to_string());
            copy_tree(base, &dir);
            for line in sequence {
                let (ok, stderr) = sh(&dir, line);
                ran += 1;
                if !ok {
                    failed.push(format!("{name}: `{line}`: {}", stderr.trim()));
                }
            }
            std::fs::remove_dir_all(&dir).unwrap();
        }
    }
    assert!(ran > 50, "{ran} examples found");
    assert!(
        failed.is_empty(),
        "{} of {ran} examples failed:\n{}",
        failed.len(),
        failed.join("\n")
    );
}
