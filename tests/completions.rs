//! Shell completions, the man page, and the examples in every subcommand's --help.
//!
//! Completion scripts are checked by the real shell where it is installed (`bash -n`, `zsh -n`,
//! `fish --no-execute`); elsewhere only their content is checked. The test prints which shells
//! really ran (visible with --nocapture).

use crate::common::*;
use std::process::Command;

/// The subcommands `panoconv --help` lists (all but `help`): every one must have its
/// completions, its man page and its examples.
fn subcommands() -> Vec<String> {
    let run = panoconv(["--help"]);
    assert_success(&run);
    let mut in_commands = false;
    let mut subs = Vec::new();
    for line in run.stdout.lines() {
        if line.starts_with("Commands:") {
            in_commands = true;
            continue;
        }
        if in_commands {
            if line.trim().is_empty() || !line.starts_with("  ") {
                break;
            }
            // a subcommand line starts with two spaces and its name; continuation lines are indented more
            if let Some(name) = line.strip_prefix("  ").filter(|l| !l.starts_with(' ')) {
                let name = name.split_whitespace().next().unwrap_or("").to_owned();
                if name != "help" {
                    subs.push(name);
                }
            }
        }
    }
    assert!(
        subs.len() >= 6,
        "too few subcommands parsed from --help: {subs:?}"
    );
    subs
}

fn completion(shell: &str) -> String {
    let run = panoconv(["completions", shell]);
    assert_success(&run);
    assert!(!run.stdout.is_empty(), "{shell}: empty script");
    run.stdout
}

fn have(shell: &str) -> bool {
    Command::new(shell)
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success())
}

/// Runs `shell args... script` on the script written to a file; None when the shell is absent.
fn syntax_check(shell: &str, args: &[&str], script: &str) -> Option<()> {
    if !have(shell) {
        eprintln!("{shell}: not installed, content checked only");
        return None;
    }
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("panoconv.completion");
    std::fs::write(&file, script).unwrap();
    let out = Command::new(shell).args(args).arg(&file).output().unwrap();
    assert!(
        out.status.success(),
        "{shell} {args:?} rejects the script: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    eprintln!("{shell}: syntax checked by the real shell");
    Some(())
}

#[test]
fn completion_scripts_for_every_shell() {
    for shell in ["bash", "zsh", "fish", "elvish", "powershell"] {
        let s = completion(shell);
        assert!(s.contains("panoconv"), "{shell}");
        for sub in subcommands() {
            assert!(s.contains(sub.as_str()), "{shell}: no {sub}");
        }
        for opt in ["to", "pano-width", "grid", "json"] {
            // fish spells long options `-l NAME`
            let spelled = if shell == "fish" {
                format!("-l {opt}")
            } else {
                format!("--{opt}")
            };
            assert!(s.contains(&spelled), "{shell}: no {spelled}");
        }
    }
    let bash = completion("bash");
    assert!(bash.contains("complete -F _panoconv"), "{bash}");
    // the value lists of --to are offered
    assert!(bash.contains("equirect cylindrical perspective"), "{bash}");
    let zsh = completion("zsh");
    assert!(zsh.starts_with("#compdef panoconv"), "{zsh}");
    let fish = completion("fish");
    assert!(fish.contains("complete -c panoconv"), "{fish}");

    syntax_check("bash", &["-n"], &bash);
    syntax_check("zsh", &["-n"], &zsh);
    syntax_check("fish", &["--no-execute"], &fish);

    // the bash script really completes: source it and ask for `panoconv ki<TAB>`
    if have("bash") {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("panoconv.bash");
        std::fs::write(&file, &bash).unwrap();
        let probe = format!(
            "source '{}'; COMP_WORDS=(panoconv ki); COMP_CWORD=1; COMP_LINE='panoconv ki'; \
             COMP_POINT=11; _panoconv panoconv ki panoconv; echo \"${{COMPREPLY[@]}}\"",
            file.display()
        );
        let out = Command::new("bash").arg("-c").arg(&probe).output().unwrap();
        let reply = String::from_utf8_lossy(&out.stdout);
        assert_eq!(
            reply.trim(),
            "kitti kitti-raw kitti360",
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
    }

    // and so does the fish one (fish sorts the candidates)
    if have("fish") {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("panoconv.fish");
        std::fs::write(&file, &fish).unwrap();
        let probe = format!(
            "source '{}'; complete -C 'panoconv ki'; complete -C 'panoconv kitti --to '",
            file.display()
        );
        let out = Command::new("fish").arg("-c").arg(&probe).output().unwrap();
        let reply = String::from_utf8_lossy(&out.stdout);
        let words: Vec<&str> = reply
            .lines()
            .map(|l| l.split('\t').next().unwrap())
            .collect();
        assert_eq!(
            words,
            [
                "kitti",
                "kitti-raw",
                "cylindrical",
                "equirect",
                "perspective"
            ],
            "{reply}{}",
            String::from_utf8_lossy(&out.stderr)
        );
    }

    let run = panoconv(["completions", "tcsh"]);
    assert_eq!(run.code, 2);
}

#[test]
fn man_page_to_stdout_and_one_per_subcommand() {
    let run = panoconv(["man"]);
    assert_success(&run);
    let page = &run.stdout;
    assert!(page.contains(".TH panoconv 1"), "{page}");
    for sub in subcommands() {
        assert!(
            page.contains(&format!("panoconv\\-{}", sub.replace('-', "\\-"))),
            "no {sub} in\n{page}"
        );
    }

    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("man1");
    let run = panoconv(["man".as_ref(), "--output".as_ref(), out.as_os_str()]);
    assert_success(&run);
    let mut names: Vec<String> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    let mut want: Vec<String> = subcommands()
        .iter()
        .map(|s| format!("panoconv-{s}.1"))
        .chain(["panoconv.1".to_owned()])
        // Nested subcommands get a page of their own.
        .chain(["panoconv-camera-convert.1".to_owned()])
        .collect();
    want.sort();
    assert_eq!(names, want);
    let kitti = read_text(&out.join("panoconv-kitti.1"));
    assert!(kitti.contains("\\-\\-pano\\-width"), "{kitti}");
    assert!(kitti.contains("Examples:"), "{kitti}");
}

#[test]
fn every_subcommand_help_has_examples() {
    for sub in subcommands() {
        let run = panoconv([sub.as_str(), "--help"]);
        assert_success(&run);
        let examples = run
            .stdout
            .split_once("Examples:")
            .unwrap_or_else(|| panic!("{sub} --help has no examples:\n{}", run.stdout))
            .1;
        assert!(
            examples.contains(&format!("panoconv {sub} ")),
            "{sub}: {examples}"
        );
    }
}
