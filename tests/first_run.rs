//! A new user's first run: the README's Use block runs as written on what the repository
//! ships, the pictures in docs/ are what their script makes, and help, messages and docs agree
//! with the tool. Each through the real binary.

use crate::common::*;
use std::ffi::OsStr;
use std::path::Path;
use std::process::Command;

/// The indented block under the README's "## Use" heading, one command a line.
fn readme_use_block() -> Vec<String> {
    let readme = read_text(&repo().join("README.md"));
    let use_section = readme
        .split("\n## Use\n")
        .nth(1)
        .expect("a Use section")
        .split("\n## ")
        .next()
        .unwrap();
    let mut lines = Vec::new();
    for line in use_section.lines() {
        match line.strip_prefix("    ") {
            Some(l) => lines.push(l.to_owned()),
            None if !lines.is_empty() => break,
            None => {}
        }
    }
    lines
}

#[test]
fn the_readme_use_block_runs_top_to_bottom_on_the_shipped_files() {
    let block = readme_use_block();
    assert!(block.len() > 20, "{block:?}");
    // every file the block reads is shipped (or written by an earlier line of it)
    for line in &block {
        for word in line.split_whitespace() {
            if word.starts_with("fixtures/") || word.starts_with("scripts/") {
                assert!(repo().join(word).exists(), "{line}: {word} is not shipped");
            }
        }
    }
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("examples");
    let bin_dir = Path::new(BIN).parent().unwrap();
    let out = Command::new("bash")
        .arg(repo().join("scripts/readme_examples.sh"))
        .arg(BIN)
        .env("PANOCONV_EXAMPLES_DIR", &dir)
        .env(
            "PATH",
            format!("{}:{}", bin_dir.display(), std::env::var("PATH").unwrap()),
        )
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "a README line failed:\n{stdout}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(stdout.contains("# 0 failed"), "{stdout}");
    // the transcript ran every line, and verified what they wrote
    let (ran, verified) = stdout
        .split_once("# every dataset the block wrote, verified")
        .expect("the verify part");
    assert_eq!(
        ran.lines().filter(|l| l.starts_with("$ ")).count(),
        block.len(),
        "{stdout}"
    );
    assert!(
        verified.lines().filter(|l| l.starts_with("$ ")).count() >= 10,
        "{stdout}"
    );
    assert!(stdout.matches("verify: OK").count() >= 10, "{stdout}");
}

#[test]
fn the_pictures_in_docs_are_what_the_script_makes() {
    let tmp = tempfile::tempdir().unwrap();
    let out = Command::new("bash")
        .arg(repo().join("scripts/make_doc_images.sh"))
        .arg("--previews-only")
        .arg(BIN)
        .arg(tmp.path())
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let made = tree_bytes(tmp.path());
    assert_eq!(made.len(), 13, "{:?}", made.keys());
    for (name, bytes) in &made {
        let committed = std::fs::read(repo().join("docs/images").join(name))
            .unwrap_or_else(|e| panic!("docs/images/{name}: {e}"));
        assert!(
            committed == *bytes,
            "docs/images/{name} is not what scripts/make_doc_images.sh makes: run it"
        );
    }
    // every picture the docs show is made by the script (the occlusion figures by its
    // cargo example step), or from the real frames of ../shared: the PandaSet panorama by
    // scripts/make_pandaset_picture.sh (through the Python package), the stitch pictures by
    // scripts/make_real_images.sh
    for e in std::fs::read_dir(repo().join("docs/images")).unwrap() {
        let name = e.unwrap().file_name().to_string_lossy().into_owned();
        let real = name.starts_with("pandaset_")
            && std::fs::read_to_string(repo().join("scripts/make_real_images.sh"))
                .unwrap()
                .contains(
                    name.trim_end_matches(".png")
                        .trim_end_matches("_fixed")
                        .trim_end_matches("_depth"),
                );
        let elsewhere = name.starts_with("occlusion_") || name == "pandaset_equirect.png";
        assert!(
            made.contains_key(&name) || elsewhere || real,
            "docs/images/{name} is made by no script"
        );
    }
}

#[test]
fn folder_commands_list_only_the_targets_they_accept() {
    for command in ["pano", "fisheye"] {
        let run = panoconv([command, "--help"]);
        assert_eq!(run.code, 0);
        let to = run
            .stdout
            .split("\n      --to <TO>")
            .nth(1)
            .expect("--to in the help")
            .split("\n  -")
            .next()
            .unwrap()
            .to_owned();
        assert!(
            !to.contains("fisheye"),
            "{command} --help offers fisheye:{to}"
        );
        for p in ["equirect", "cylindrical", "perspective"] {
            assert!(to.contains(p), "{command}: {p} missing from{to}");
        }
        let run = panoconv([command, "--to", "fisheye", "--input", "x", "--output", "y"]);
        assert_eq!(run.code, 2, "{}", run.stderr);
    }
    let run = panoconv(["--help"]);
    let flat = run.stdout.split_whitespace().collect::<Vec<_>>().join(" ");
    assert!(
        flat.contains("KITTI-360, WoodScape or OpenCV calibration file"),
        "{}",
        run.stdout
    );
    let run = panoconv(["synth", "--help"]);
    assert!(
        run.stdout
            .split("\n      --overwrite")
            .nth(1)
            .is_some_and(|h| h.trim_start().starts_with("Write into")),
        "{}",
        run.stdout
    );
    let run = panoconv(["kitti-raw", "--help"]);
    assert!(
        run.stdout.contains("velodyne_points/data"),
        "{}",
        run.stdout
    );
}

#[test]
fn preview_refuses_a_name_that_is_not_png() {
    let tmp = tempfile::tempdir().unwrap();
    let p = tmp.path().join("p.jpg");
    let run = panoconv([
        OsStr::new("preview"),
        synth_source().as_os_str(),
        OsStr::new("--frame"),
        OsStr::new("1"),
        OsStr::new("--output"),
        p.as_os_str(),
    ]);
    assert_eq!(run.code, 2, "{}", run.stderr);
    assert!(run.stderr.contains("PNG"), "{}", run.stderr);
    assert!(!p.exists());
}

#[test]
fn summaries_count_with_the_right_nouns() {
    let s = Scratch::synth();
    // one frame: "1 frame", not "1 frames"
    let run = kitti("equirect", &s.input, &s.output, &["--frames", "000001"]);
    assert_success(&run);
    assert!(run.stderr.contains("1 frame converted"), "{}", run.stderr);
    // YOLO says it drops the DontCare regions
    let yolo = s.path("yolo");
    let run = panoconv([
        OsStr::new("export"),
        s.output.as_os_str(),
        OsStr::new("--format"),
        OsStr::new("yolo"),
        OsStr::new("--output"),
        yolo.as_os_str(),
    ]);
    assert_success(&run);
    assert!(
        run.stderr
            .contains("1 ignore region dropped (YOLO has none)"),
        "{}",
        run.stderr
    );
    // a folder conversion's failed item is an image, not a frame
    let panos = s.path("panos");
    std::fs::create_dir_all(&panos).unwrap();
    write_text(&panos.join("f0.png"), "not a png");
    std::fs::copy(
        s.input_file("training/image_2/000001.png"),
        panos.join("f1.png"),
    )
    .unwrap();
    let run = panoconv([
        OsStr::new("pano"),
        OsStr::new("--to"),
        OsStr::new("perspective"),
        OsStr::new("--input"),
        panos.as_os_str(),
        OsStr::new("--output"),
        s.path("views").as_os_str(),
    ]);
    assert_eq!(run.code, 1, "{}", run.stderr);
    assert!(
        run.stderr.contains("panoconv: image f0.png failed"),
        "{}",
        run.stderr
    );
}

#[test]
fn a_missing_style_model_is_named_before_a_missing_runtime() {
    let s = Scratch::synth();
    let model = s.path("no_such_model.onnx");
    let run = kitti(
        "equirect",
        &s.input,
        &s.output,
        &[
            "--style",
            model.to_str().unwrap(),
            "--ort-lib",
            "/nonexistent/libonnxruntime.so",
        ],
    );
    assert_eq!(run.code, 2, "{}", run.stderr);
    assert!(
        run.stderr.contains("no_such_model.onnx") && !run.stderr.contains("libonnxruntime"),
        "{}",
        run.stderr
    );
    assert!(!s.output.exists());
}

#[test]
fn inspect_says_a_png_that_is_a_jpeg_is_a_jpeg_as_kitti_does() {
    let s = Scratch::synth();
    let jpeg = [0xFF, 0xD8, 0xFF, 0xE0, 0, 16, b'J', b'F', b'I', b'F', 0];
    std::fs::write(s.input_file("training/image_2/000001.png"), jpeg).unwrap();
    let run = panoconv([OsStr::new("inspect"), s.input.as_os_str()]);
    assert_eq!(run.code, 1, "{}{}", run.stdout, run.stderr);
    let all = format!("{}{}", run.stdout, run.stderr);
    assert!(all.contains("the file is a JPEG"), "{all}");
    let run = kitti("equirect", &s.input, &s.output, &[]);
    assert_eq!(run.code, 1);
    assert!(run.stderr.contains("the file is a JPEG"), "{}", run.stderr);
}

#[test]
fn the_style_docs_give_a_generator_export_recipe_in_panoconvs_convention() {
    let doc = read_text(&repo().join("docs/style.md"));
    let recipe = doc
        .split("## Exporting a trained CycleGAN generator")
        .nth(1)
        .expect("a recipe section")
        .split("\n## ")
        .next()
        .unwrap();
    for needed in [
        "torch.onnx.export",
        "resnet_9blocks",
        "norm=\"instance\"",
        "dynamic_axes",
        "x / 127.5 − 1",
        "tanh",
        "--style",
    ] {
        assert!(recipe.contains(needed), "{needed:?} not in the recipe");
    }
    // the command it gives is one the tool takes: the model is checked before any frame
    let s = Scratch::synth();
    let run = kitti(
        "equirect",
        &s.input,
        &s.output,
        &["--style", "fixtures/style/bad_one_channel.onnx"],
    );
    assert_eq!(run.code, 2, "{}", run.stderr);
}
