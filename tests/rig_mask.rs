//! `--mask` of the rig commands through the binary, on the synthetic nuScenes scene (the rig
//! with nuScenes' camera offsets, whose depth-guided stitch has fallback pixels): `mask_2/`
//! is white exactly where `source_2` is below 64 (a camera passed the occlusion test; in a
//! fixed stitch, some camera covers the pixel), it adds files without changing any other,
//! the manifest records it, and `verify`, `inspect`, `--shard` + `merge` and `--resume` keep
//! it.

use crate::common::{self, assert_success, panoconv, read_manifest, read_png, tree_bytes};
use crate::nuscenes_command::scene;
use panoconv::warp::{FALLBACK_SOURCE, FAR_SOURCE, NO_SOURCE};
use std::path::Path;

/// `panoconv nuscenes` of the offset scene into `output`, 720 px wide, with `extra`.
fn convert(output: &Path, extra: &[&str]) -> common::Run {
    let mut args = vec![
        "nuscenes",
        "--input",
        scene(false).to_str().unwrap(),
        "--version",
        "v1.0-mini",
        "--to",
        "equirect",
        "--pano-width",
        "720",
        "-q",
        "--output",
        output.to_str().unwrap(),
    ];
    args.extend(extra);
    panoconv(&args)
}

/// A 1-bit grey PNG (the format of `kitti --mask`) as one bool per pixel, white = true.
fn read_mask_bits(path: &Path) -> (u32, u32, Vec<bool>) {
    let p = read_png(path);
    assert_eq!(
        (p.color, p.depth),
        (png::ColorType::Grayscale, png::BitDepth::One),
        "{}: not a 1-bit grey PNG",
        path.display()
    );
    let (w, h) = (p.width as usize, p.height as usize);
    let stride = w.div_ceil(8);
    assert_eq!(p.data.len(), stride * h);
    let bits = (0..w * h)
        .map(|i| p.data[i / w * stride + i % w / 8] >> (7 - i % w % 8) & 1 == 1)
        .collect();
    (p.width, p.height, bits)
}

/// Checks every frame's mask against the rule on its `source_2`, pixel for pixel; returns the
/// frames' (fallback, uncovered, trusted) pixel counts.
fn check_masks(out: &Path) -> (usize, usize, usize) {
    let training = out.join("training");
    let manifest = read_manifest(out);
    let frames = manifest["frames"].as_array().unwrap();
    assert_eq!(frames.len(), 2);
    let (mut fallback, mut uncovered, mut trusted) = (0, 0, 0);
    for f in frames {
        let id = f["id"].as_str().unwrap();
        let source = read_png(&training.join(format!("source_2/{id}.png")));
        let (w, h, mask) = read_mask_bits(&training.join(format!("mask_2/{id}.png")));
        assert_eq!((w, h), (source.width, source.height), "{id}");
        for (i, (&s, &m)) in source.data.iter().zip(&mask).enumerate() {
            let rule = s != NO_SOURCE && s & (FALLBACK_SOURCE | FAR_SOURCE) == 0;
            assert_eq!(m, rule, "{id}: pixel {i}: source_2 {s}, mask {m}");
        }
        fallback += (source.data.iter())
            .filter(|&&s| s != NO_SOURCE && s & (FALLBACK_SOURCE | FAR_SOURCE) != 0)
            .count();
        uncovered += source.data.iter().filter(|&&s| s == NO_SOURCE).count();
        trusted += mask.iter().filter(|&&m| m).count();
        // the manifest lists the mask among the frame's outputs
        let outputs: Vec<&str> = (f["outputs"].as_array().unwrap().iter())
            .map(|o| o[0].as_str().unwrap())
            .collect();
        let listed = format!("training/mask_2/{id}.png");
        assert!(outputs.contains(&listed.as_str()), "{id}: {outputs:?}");
    }
    (fallback, uncovered, trusted)
}

/// `verify` passes and `inspect` finds no problem.
fn check_tools(out: &Path) {
    assert_success(&panoconv(["verify", out.to_str().unwrap()]));
    let inspect = panoconv(["inspect", out.to_str().unwrap()]);
    assert_success(&inspect);
    assert!(
        inspect.stdout.contains("problems: none"),
        "{}",
        inspect.stdout
    );
}

#[test]
fn the_rig_mask_is_source_2_below_64_in_both_stitch_modes_and_adds_only_itself() {
    let tmp = tempfile::tempdir().unwrap();
    for (mode, fallbacks) in [("depth", true), ("fixed", false)] {
        let with = tmp.path().join(format!("{mode}_mask"));
        assert_success(&convert(&with, &["--stitch-mode", mode, "--mask"]));
        let (fallback, uncovered, trusted) = check_masks(&with);
        // the rule is not vacuous: trusted, fallback (depth-guided only) and uncovered pixels
        // all occur, and the mask tells the first from the other two
        assert!(trusted > 50_000, "{mode}: {trusted} trusted pixels");
        assert!(uncovered > 1_000, "{mode}: {uncovered} uncovered pixels");
        match fallbacks {
            true => assert!(fallback > 100, "{mode}: {fallback} fallback pixels"),
            false => assert_eq!(fallback, 0, "{mode}: a fixed stitch has no fallback"),
        }
        assert_eq!(
            read_manifest(&with)["parameters"]["mask"],
            true,
            "{mode}: the manifest records --mask"
        );
        check_tools(&with);

        // without --mask: no mask_2, no `mask` parameter, every other file the same bytes
        let without = tmp.path().join(mode);
        assert_success(&convert(&without, &["--stitch-mode", mode]));
        assert!(!without.join("training/mask_2").exists(), "{mode}");
        let parameters = read_manifest(&without)["parameters"].clone();
        assert!(parameters.get("mask").is_none(), "{mode}: {parameters}");
        let (a, b) = (tree_bytes(&with), tree_bytes(&without));
        for (name, bytes) in &b {
            if name != "panoconv.json" {
                assert!(a.get(name) == Some(bytes), "{mode}: {name} differs");
            }
        }
        let added: Vec<&String> = a.keys().filter(|k| !b.contains_key(*k)).collect();
        assert_eq!(
            added,
            ["training/mask_2/000000.png", "training/mask_2/000001.png"],
            "{mode}"
        );
    }
}

#[test]
fn shards_merge_and_resume_keep_the_rig_mask() {
    let tmp = tempfile::tempdir().unwrap();
    let single = tmp.path().join("single");
    assert_success(&convert(&single, &["--mask"]));
    let sharded = tmp.path().join("sharded");
    for k in 0..2 {
        let shard = format!("{k}/2");
        assert_success(&convert(&sharded, &["--mask", "--shard", &shard]));
    }
    assert_success(&panoconv(["merge", sharded.to_str().unwrap()]));
    assert!(
        tree_bytes(&sharded) == tree_bytes(&single),
        "2 shards + merge differ from one run"
    );
    check_tools(&sharded);

    // a frame whose mask is gone is converted again by --resume, to the same bytes
    let before = tree_bytes(&single);
    std::fs::remove_file(single.join("training/mask_2/000001.png")).unwrap();
    let run = convert(&single, &["--mask", "--resume"]);
    assert_success(&run);
    assert!(tree_bytes(&single) == before, "resume changed the output");
    // a resume without --mask is another run's parameters
    let run = convert(&single, &["--resume"]);
    assert_eq!(run.code, 2, "{}", run.stderr);
    assert!(
        run.stderr.contains("cannot resume")
            && run.stderr.contains("written with other parameters (mask)"),
        "{}",
        run.stderr
    );
}
