//! Running one case: the base dataset with the case's change, the binary on it, and every
//! outcome the case states checked (exit code, messages, manifest, outputs, input untouched).

use super::*;
use std::collections::BTreeMap;
use std::ffi::OsString;
use std::process::Command;

const BIN: &str = env!("CARGO_BIN_EXE_panoconv");

struct Outcome {
    code: i32,
    stderr: String,
}

fn panoconv(args: &[OsString]) -> Outcome {
    let out = Command::new(BIN)
        .args(args)
        .output()
        .expect("cannot start panoconv");
    Outcome {
        // killed by a signal: reported as a mismatch of the exit code
        code: out.status.code().unwrap_or(-1),
        stderr: String::from_utf8_lossy(&out.stderr).into_owned(),
    }
}

/// Every entry under `root`: files by hash, symlinks by target, folders as `dir`. Missing root:
/// empty.
fn snapshot(root: &Path) -> BTreeMap<String, String> {
    fn walk(root: &Path, dir: &Path, out: &mut BTreeMap<String, String>) {
        let Ok(entries) = std::fs::read_dir(dir) else {
            return;
        };
        for e in entries.map(Result::unwrap) {
            let path = e.path();
            let rel = path
                .strip_prefix(root)
                .unwrap()
                .to_string_lossy()
                .into_owned();
            let kind = e.file_type().unwrap();
            if kind.is_symlink() {
                let target = std::fs::read_link(&path).unwrap();
                out.insert(rel, format!("-> {}", target.display()));
            } else if kind.is_dir() {
                out.insert(format!("{rel}/"), "dir".into());
                walk(root, &path, out);
            } else {
                let bytes = std::fs::read(&path).unwrap();
                out.insert(rel, blake3::hash(&bytes).to_hex().to_string());
            }
        }
    }
    let mut out = BTreeMap::new();
    if root.is_file() {
        out.insert(
            String::new(),
            blake3::hash(&std::fs::read(root).unwrap())
                .to_hex()
                .to_string(),
        );
    }
    walk(root, root, &mut out);
    out
}

fn outputs_of(split: &str, id: &str) -> Vec<String> {
    let mut v = vec![
        format!("{split}/image_2/{id}.png"),
        format!("{split}/calib/{id}.txt"),
    ];
    if split == "training" {
        v.push(format!("{split}/label_2/{id}.txt"));
    }
    v
}

/// Runs one case; `Err` describes the first mismatch.
pub(super) fn run_case(case: &Case) -> Result<(), String> {
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path().canonicalize().unwrap();
    let input = root.join("in");
    for (split, id) in BASE_FRAMES {
        write_frame(&input, split, id);
    }
    let mut env = Env {
        output: root.join("out"),
        input,
        root: root.clone(),
        args: Vec::new(),
        frames: BASE_FRAMES
            .iter()
            .map(|(s, i)| (s.to_string(), i.to_string()))
            .collect(),
    };
    (case.setup)(&mut env);
    let fill = |m: &str| {
        m.replace("{IN}", &env.input.display().to_string())
            .replace("{OUT}", &env.output.display().to_string())
            .replace("{ROOT}", &root.display().to_string())
    };
    let input_before = snapshot(&root.join("in"));
    let output_before = snapshot(&env.output);

    let mut args: Vec<OsString> = ["kitti", "--to", "equirect", "--quiet", "--input"]
        .iter()
        .map(OsString::from)
        .collect();
    args.push(env.input.clone().into());
    args.push("--output".into());
    args.push(env.output.clone().into());
    args.extend(env.args.iter().map(OsString::from));
    let run = panoconv(&args);

    // the input is never touched
    let input_after = snapshot(&root.join("in"));
    if input_after != input_before {
        return Err(format!(
            "the input was modified:\nbefore {input_before:#?}\nafter {input_after:#?}"
        ));
    }
    let err = |what: String| {
        let code = match run.code {
            -1 => "killed by a signal".to_owned(),
            c => format!("exit {c}"),
        };
        Err(format!("{what}\n{code}; stderr:\n{}", run.stderr))
    };

    let failed: Vec<(String, String, String)> = match &case.expect {
        Expect::Setup(message) => {
            if run.code != 2 {
                return err("expected exit 2".into());
            }
            let line = run.stderr.trim_end();
            let want = format!("panoconv: error: {}", fill(message));
            let ok = match want.strip_suffix('…') {
                Some(prefix) => line.starts_with(prefix) && !line.contains('\n'),
                None => line == want,
            };
            if !ok {
                return err(format!("expected stderr {want:?}"));
            }
            let output_after = snapshot(&env.output);
            if output_after != output_before {
                return err(format!(
                    "a set-up error wrote into the output: {output_after:#?}"
                ));
            }
            return Ok(());
        }
        Expect::Ok(_) => Vec::new(),
        Expect::Fails(frames, message) => frames
            .iter()
            .map(|(s, i)| {
                (
                    s.to_string(),
                    i.to_string(),
                    fill(&message.replace("{ID}", i)),
                )
            })
            .collect(),
    };
    let want_code = if failed.is_empty() { 0 } else { 1 };
    if run.code != want_code {
        return err(format!("expected exit {want_code}"));
    }

    // stderr: exactly one line per failed frame, with the message
    let reported: Vec<&str> = run.stderr.lines().collect();
    if reported.len() != failed.len() {
        return err(format!("expected {} failure lines", failed.len()));
    }
    let matches = |got: &str, want: &str| match want.strip_suffix('…') {
        Some(prefix) => got.starts_with(prefix) && got.len() > prefix.len(),
        None => got == want,
    };
    for (split, id, message) in &failed {
        let who = if split.is_empty() {
            format!("frame {id}")
        } else {
            format!("frame {split}/{id}")
        };
        let prefix = format!("panoconv: {who} failed: ");
        let Some(line) = reported.iter().find(|l| l.starts_with(&prefix)) else {
            return err(format!("no failure reported for {who}"));
        };
        if !matches(&line[prefix.len()..], message) {
            return err(format!("{who}: expected {message:?}"));
        }
    }

    // the manifest: one record per frame, failed ones with the message and no outputs
    let manifest: serde_json::Value = match std::fs::read(env.output.join("panoconv.json")) {
        Ok(b) => serde_json::from_slice(&b).map_err(|e| e.to_string())?,
        Err(e) => return err(format!("no manifest: {e}")),
    };
    let records = manifest["frames"].as_array().cloned().unwrap_or_default();
    let mut expected_files: Vec<String> = vec!["panoconv.json".into()];
    let mut all: Vec<(String, String)> = env.frames.clone();
    all.extend(
        failed
            .iter()
            .filter(|(s, i, _)| !env.frames.contains(&(s.clone(), i.clone())))
            .map(|(s, i, _)| (s.clone(), i.clone())),
    );
    if let Some(pos) = env.args.iter().position(|a| a == "--frames") {
        let ids: Vec<&str> = env.args[pos + 1].split(',').collect();
        all.retain(|(s, i)| ids.contains(&i.as_str()) || s.is_empty());
    }
    if records.len() != all.len() {
        return err(format!(
            "manifest has {} frames, expected {:?}",
            records.len(),
            all
        ));
    }
    for (split, id) in &all {
        let rec = records
            .iter()
            .find(|r| r["split"] == split.as_str() && r["id"] == id.as_str())
            .ok_or(format!("no manifest record for {split}/{id}"))?;
        match failed.iter().find(|(s, i, _)| s == split && i == id) {
            Some((_, _, message)) => {
                let got = rec["error"].as_str().unwrap_or("");
                if rec["status"] != "failed" || !matches(got, message) {
                    return err(format!("manifest record of {split}/{id}: {rec}"));
                }
                if rec["outputs"].as_array().is_none_or(|o| !o.is_empty()) {
                    return err(format!("failed frame {split}/{id} lists outputs: {rec}"));
                }
            }
            None => {
                if rec["status"] != "ok" {
                    return err(format!("manifest record of {split}/{id}: {rec}"));
                }
                expected_files.extend(outputs_of(split, id));
            }
        }
    }
    // exactly the converted frames' outputs exist (a failed frame leaves nothing behind)
    let mut files: Vec<String> = snapshot(&env.output)
        .into_iter()
        .filter(|(_, v)| v != "dir")
        .map(|(k, _)| k)
        .collect();
    files.sort();
    expected_files.sort();
    if files != expected_files {
        return err(format!(
            "output files {files:?}, expected {expected_files:?}"
        ));
    }
    // every label written is well formed: 15/16 fields, finite numbers
    for f in files.iter().filter(|f| f.contains("/label_2/")) {
        let text = std::fs::read_to_string(env.output.join(f)).unwrap();
        for line in text.lines() {
            let t: Vec<&str> = line.split_whitespace().collect();
            let finite = t[1..]
                .iter()
                .all(|v| v.parse::<f64>().is_ok_and(f64::is_finite));
            if !(t.len() == 15 || t.len() == 16) || !finite {
                return err(format!("{f}: malformed output label {line:?}"));
            }
        }
    }
    // and the folder verifies against its manifest (failed frames, which `verify` reports,
    // are the case's point here)
    let verify = panoconv(&[
        "verify".into(),
        "--allow-failed".into(),
        env.output.clone().into(),
    ]);
    if verify.code != 0 {
        return err(format!("verify failed: {}", verify.stderr));
    }
    if let Expect::Ok(check) = &case.expect {
        check(&env);
    }
    Ok(())
}
