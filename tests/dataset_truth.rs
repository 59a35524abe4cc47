//! No quiet way to a wrong dataset: `--overwrite` leaves exactly what a run into an empty
//! folder leaves, `verify` fails an unfinished run, augmented views of one frame stay on one
//! side of a train/val split, files that are not frames are named, derived files survive a
//! resume, sharded augmented runs list their views, and set-up mistakes (a huge scale, a
//! converted or split folder as input) are one set-up error. Each test drives the real binary
//! on copies of the synthetic sample.

use crate::common::*;
use std::collections::{BTreeMap, BTreeSet};
use std::ffi::OsStr;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

fn verify(output: &Path) -> Run {
    panoconv([OsStr::new("verify"), output.as_os_str()])
}

#[track_caller]
fn assert_verifies(output: &Path) {
    let run = verify(output);
    assert_eq!(run.code, 0, "{}{}", run.stdout, run.stderr);
    assert!(run.stdout.contains("verify: OK"), "{}", run.stdout);
}

#[test]
fn overwrite_leaves_exactly_what_a_run_into_an_empty_folder_leaves() {
    let s = Scratch::synth();
    // a cylindrical run with depth-less extras: a preview recorded under `derived`
    assert_success(&kitti("cylindrical", &s.input, &s.output, &["--mask"]));
    let preview = s.output_file("preview.png");
    assert_success(&panoconv([
        OsStr::new("preview"),
        s.output.as_os_str(),
        OsStr::new("--frame"),
        OsStr::new("1"),
        OsStr::new("--output"),
        preview.as_os_str(),
    ]));
    assert!(preview.is_file() && s.output_file("training/mask_2/000001.png").is_file());

    let fresh = s.path("fresh");
    assert_success(&kitti("equirect", &s.input, &fresh, &[]));
    let run = kitti("equirect", &s.input, &s.output, &["--overwrite"]);
    assert_success(&run);
    assert_eq!(
        tree_hashes(&s.output),
        tree_hashes(&fresh),
        "--overwrite must leave what a run into an empty folder leaves (files and folders)"
    );
    assert_verifies(&s.output);
}

#[test]
fn overwrite_refuses_files_no_run_wrote_naming_them_and_removes_nothing() {
    let s = Scratch::synth();
    assert_success(&kitti("cylindrical", &s.input, &s.output, &[]));
    write_text(&s.output_file("notes.txt"), "mine\n");
    write_text(&s.output_file("training/image_2/999999.png"), "not ours");
    let before = tree_hashes(&s.output);
    let run = kitti("equirect", &s.input, &s.output, &["--overwrite"]);
    assert_eq!(run.code, 2, "{}", run.stderr);
    assert_eq!(run.stderr.lines().count(), 1, "{}", run.stderr);
    for w in ["notes.txt", "training/image_2/999999.png", "2 files"] {
        assert!(
            run.stderr.contains(w),
            "{w:?} not named in:\n{}",
            run.stderr
        );
    }
    assert_eq!(
        tree_hashes(&s.output),
        before,
        "a refused --overwrite changed the folder"
    );
}

#[test]
fn overwrite_of_a_folder_conversion_removes_the_previous_images() {
    let tmp = tempfile::tempdir().unwrap();
    let panos = tmp.path().join("panos");
    std::fs::create_dir_all(&panos).unwrap();
    let pano = real_panos();
    let first = std::fs::read_dir(&pano)
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|e| e == "png" || e == "jpg"))
        .min()
        .expect("a panorama in ../shared/pano");
    std::fs::copy(&first, panos.join(first.file_name().unwrap())).unwrap();
    let out = tmp.path().join("views");
    let pano_run = |yaw: &str, extra: &[&str]| {
        let mut args: Vec<&OsStr> = ["pano", "--to", "perspective", "--fov", "60", "--yaw", yaw]
            .into_iter()
            .map(OsStr::new)
            .collect();
        args.extend([
            OsStr::new("--input"),
            panos.as_os_str(),
            OsStr::new("--output"),
            out.as_os_str(),
        ]);
        args.extend(extra.iter().map(OsStr::new));
        panoconv(args)
    };
    assert_success(&pano_run("0,90,180", &[]));
    let three = tree_files(&out);
    assert_success(&pano_run("0", &["--overwrite"]));
    let one = tree_files(&out);
    assert!(
        one.len() < three.len(),
        "the views of yaw 90 and 180 stayed: {one:?}"
    );
    assert_verifies(&out);
}

/// Starts a conversion of `input` into `out` and waits until its journal holds at least
/// `lines` frame lines (or the run ends).
fn start_and_wait_for_frames(input: &Path, out: &Path, lines: usize) -> std::process::Child {
    let mut child = Command::new(BIN)
        .args([
            "kitti", "--to", "equirect", "--quiet", "--jobs", "1", "--input",
        ])
        .arg(input)
        .arg("--output")
        .arg(out)
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let journal = out.join("panoconv.journal");
    let deadline = Instant::now() + Duration::from_secs(120);
    while Instant::now() < deadline {
        let n = std::fs::read(&journal)
            .map(|b| b.iter().filter(|&&c| c == b'\n').count())
            .unwrap_or(0);
        if n > lines || child.try_wait().unwrap().is_some() {
            break;
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    child
}

/// 60 frames: the synthetic training frames under new ids.
fn many_frames(root: &Path) -> PathBuf {
    let sample = synth_source().join("training");
    let d = root.join("in");
    for sub in ["image_2", "calib", "label_2"] {
        std::fs::create_dir_all(d.join("training").join(sub)).unwrap();
    }
    for i in 0..60 {
        for (sub, ext) in [("image_2", "png"), ("calib", "txt"), ("label_2", "txt")] {
            std::fs::copy(
                sample.join(sub).join(format!("{:06}.{ext}", i % 3)),
                d.join("training").join(sub).join(format!("{i:06}.{ext}")),
            )
            .unwrap();
        }
    }
    d
}

#[test]
fn verify_fails_an_interrupted_or_killed_run_saying_how_far_it_got() {
    let tmp = tempfile::tempdir().unwrap();
    let input = many_frames(tmp.path());

    // Ctrl-C: the manifest says "complete": false
    let out = tmp.path().join("interrupted");
    let child = start_and_wait_for_frames(&input, &out, 2);
    assert!(Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap()
        .success());
    let status = child.wait_with_output().unwrap().status;
    if status.code() == Some(130) {
        let m = read_manifest(&out);
        assert_eq!(m["complete"], false);
        let done = m["summary"]["frames"].as_u64().unwrap();
        let run = verify(&out);
        assert_eq!(run.code, 1, "{}", run.stdout);
        let want = format!("after {done} of 60 frames");
        assert!(
            run.stdout.contains("incomplete") && run.stdout.contains(&want),
            "{want:?} not in:\n{}",
            run.stdout
        );
        assert!(run.stdout.contains("--resume"), "{}", run.stdout);
        assert!(!run.stdout.contains("verify: OK"), "{}", run.stdout);
    } else {
        eprintln!("the run ended before SIGINT ({status}); the interrupted case is not checked");
    }

    // kill -9: a journal and no manifest
    let out = tmp.path().join("killed");
    let mut child = start_and_wait_for_frames(&input, &out, 2);
    let _ = child.kill();
    let _ = child.wait();
    if out.join("panoconv.json").exists() {
        eprintln!("the run ended before the kill; the killed case is not checked");
        return;
    }
    let run = verify(&out);
    assert_eq!(run.code, 1, "{}{}", run.stdout, run.stderr);
    assert!(
        run.stdout.contains("incomplete")
            && run.stdout.contains("killed")
            && run.stdout.contains("of 60 frames")
            && run.stdout.contains("--resume"),
        "{}{}",
        run.stdout,
        run.stderr
    );
    assert!(!run.stderr.contains("No such file"), "{}", run.stderr);
}

/// The export split (`train`/`val`) of each image of a COCO export, by file name.
fn coco_sides(dir: &Path) -> BTreeMap<String, String> {
    let mut sides = BTreeMap::new();
    for side in ["train", "val"] {
        let path = dir.join(format!("instances_{side}.json"));
        if !path.exists() {
            continue;
        }
        let doc: serde_json::Value = serde_json::from_str(&read_text(&path)).unwrap();
        for image in doc["images"].as_array().unwrap() {
            let name = image["file_name"].as_str().unwrap();
            let id = name.rsplit('/').next().unwrap().trim_end_matches(".png");
            sides.insert(id.to_owned(), side.to_owned());
        }
    }
    sides
}

#[test]
fn val_fraction_keeps_every_view_of_a_frame_on_one_side() {
    let tmp = tempfile::tempdir().unwrap();
    let input = many_frames(tmp.path());
    // 12 source frames, 4 views each
    let ids: Vec<String> = (0..12).map(|i| format!("{i:06}")).collect();
    let frames = ids.join(",");
    let out = tmp.path().join("aug");
    let args = [
        "--augment",
        "4",
        "--seed",
        "3",
        "--scale-range",
        "0.8,1.2",
        "--crop-size",
        "160x64",
        "--frames",
        &frames,
    ];
    assert_success(&kitti("equirect", &input, &out, &args));
    let m = read_manifest(&out);
    let mut source_of = BTreeMap::new();
    for f in m["frames"].as_array().unwrap() {
        for v in f["views"].as_array().unwrap() {
            source_of.insert(
                v["id"].as_str().unwrap().to_owned(),
                f["id"].as_str().unwrap().to_owned(),
            );
        }
    }
    assert_eq!(source_of.len(), 48);
    for seed in ["1", "2", "3", "4"] {
        let ann = tmp.path().join(format!("ann{seed}"));
        let run = panoconv([
            OsStr::new("export"),
            out.as_os_str(),
            OsStr::new("--format"),
            OsStr::new("coco"),
            OsStr::new("--output"),
            ann.as_os_str(),
            OsStr::new("--val-fraction"),
            OsStr::new("0.25"),
            OsStr::new("--seed"),
            OsStr::new(seed),
        ]);
        assert_success(&run);
        let sides = coco_sides(&ann);
        assert_eq!(sides.len(), 48, "every view exported");
        let mut side_of_source: BTreeMap<&str, BTreeSet<&str>> = BTreeMap::new();
        for (view, side) in &sides {
            side_of_source
                .entry(source_of[view].as_str())
                .or_default()
                .insert(side.as_str());
        }
        for (source, in_sides) in &side_of_source {
            assert_eq!(
                in_sides.len(),
                1,
                "seed {seed}: views of frame {source} are in both train and val"
            );
        }
        let val = side_of_source
            .values()
            .filter(|s| s.contains("val"))
            .count();
        assert_eq!(
            val, 3,
            "seed {seed}: a quarter of the 12 source frames in val"
        );
    }
}

#[test]
fn files_that_are_not_frames_are_named_in_the_summary() {
    let s = Scratch::synth();
    std::fs::copy(
        s.input_file("training/image_2/000001.png"),
        s.input_file("training/image_2/000007.jpg"),
    )
    .unwrap();
    std::fs::copy(
        s.input_file("training/calib/000001.txt"),
        s.input_file("training/calib/000009.txt"),
    )
    .unwrap();
    std::fs::copy(
        s.input_file("training/label_2/000001.txt"),
        s.input_file("training/label_2/000009.txt"),
    )
    .unwrap();
    let run = kitti("equirect", &s.input, &s.output, &[]);
    assert_success(&run);
    assert!(run.stderr.contains("4 frames converted"), "{}", run.stderr);
    assert!(
        run.stderr.contains("3 files of the input not converted"),
        "{}",
        run.stderr
    );
    for w in [
        "training/image_2/000007.jpg: the file is a JPEG",
        "training/calib/000009.txt: no image_2/000009.png",
        "training/label_2/000009.txt: no image_2/000009.png",
    ] {
        assert!(run.stderr.contains(w), "{w:?} not in:\n{}", run.stderr);
    }
    // a clean dataset has no such line
    let run = kitti("equirect", synth_source(), &s.path("clean"), &[]);
    assert_success(&run);
    assert!(!run.stderr.contains("not converted"), "{}", run.stderr);
}

#[test]
fn a_resumed_run_keeps_the_derived_files_of_the_dataset() {
    let s = Scratch::synth();
    assert_success(&kitti("equirect", &s.input, &s.output, &[]));
    let pixels = s.output_file("training/pixels");
    assert_success(&panoconv([
        OsStr::new("labels-to-pixels"),
        OsStr::new("--input"),
        s.output.as_os_str(),
        OsStr::new("--output"),
        pixels.as_os_str(),
    ]));
    assert_verifies(&s.output);
    let derived = read_manifest(&s.output)["derived"].clone();
    assert!(derived.as_array().is_some_and(|d| !d.is_empty()));
    assert_success(&kitti("equirect", &s.input, &s.output, &["--resume"]));
    assert_eq!(read_manifest(&s.output)["derived"], derived);
    assert_verifies(&s.output);
}

#[test]
fn sharded_augmented_runs_and_merge_list_the_views_as_one_run_does() {
    let s = Scratch::synth();
    let args = [
        "--augment",
        "3",
        "--seed",
        "1",
        "--crop-size",
        "128x64",
        "--quiet",
    ];
    let single = s.path("single");
    assert_success(&kitti("equirect", &s.input, &single, &args));
    let sharded = s.path("sharded");
    for k in 0..2 {
        let shard = format!("{k}/2");
        let mut a = args.to_vec();
        a.extend(["--shard", &shard]);
        assert_success(&kitti("equirect", &s.input, &sharded, &a));
    }
    assert_success(&panoconv([OsStr::new("merge"), sharded.as_os_str()]));
    assert!(sharded.join("ImageSets/training.txt").is_file());
    assert_eq!(tree_bytes(&sharded), tree_bytes(&single));
    assert_verifies(&sharded);
}

#[track_caller]
fn assert_setup_error_writes_nothing(run: &Run, output: &Path, wanted: &[&str]) {
    assert_eq!(run.code, 2, "{}", run.stderr);
    assert_eq!(run.stderr.lines().count(), 1, "{}", run.stderr);
    for w in wanted {
        assert!(run.stderr.contains(w), "{w:?} not in:\n{}", run.stderr);
    }
    assert!(!output.exists(), "{} was created", output.display());
}

#[test]
fn a_scale_too_large_is_one_setup_error_naming_the_option_and_the_limit() {
    let s = Scratch::synth();
    for (option, value) in [("--pano-width", "1000000"), ("--px-per-deg", "1e9")] {
        let run = kitti("equirect", &s.input, &s.output, &[option, value]);
        assert_setup_error_writes_nothing(&run, &s.output, &[option, "65535"]);
        assert!(run.frame_failures().is_empty(), "{}", run.stderr);
    }
}

#[test]
fn a_converted_dataset_or_a_split_folder_as_input_is_a_setup_error() {
    let s = Scratch::synth();
    assert_success(&kitti("equirect", &s.input, &s.output, &[]));
    let again = s.path("again");
    let run = kitti("cylindrical", &s.output, &again, &[]);
    assert_setup_error_writes_nothing(&run, &again, &["converted dataset", "panoconv.json"]);

    let run = kitti("cylindrical", &s.input.join("training"), &again, &[]);
    let want = format!("use --input {}", s.input.display());
    assert_setup_error_writes_nothing(&run, &again, &[&want, "--split training"]);
}

#[test]
fn frames_takes_short_ids_and_trims_spaces() {
    let s = Scratch::synth();
    let run = kitti("equirect", &s.input, &s.output, &["--frames", "1, 2 ,3"]);
    assert_success(&run);
    assert_eq!(
        tree_files(&s.output),
        expected_files(&[
            ("training", "000001"),
            ("training", "000002"),
            ("testing", "000003")
        ])
    );
    // an id that is not there is still named
    let run = kitti("equirect", &s.input, &s.path("o2"), &["--frames", "1,42"]);
    assert_eq!(run.code, 2, "{}", run.stderr);
    assert!(run.stderr.contains("42"), "{}", run.stderr);
}
