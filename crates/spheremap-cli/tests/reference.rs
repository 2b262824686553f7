//! The CLI reference (`docs/cli.md`) and the man pages (`docs/man/`) are generated from
//! the command-line definition; this test fails when either is out of date.  To bring them up to
//! date: `SPHEREMAP_UPDATE_DOCS=1 cargo test -p spheremap-cli --test reference`.

use std::path::PathBuf;

fn docs() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../docs")
}

fn markdown() -> String {
    let opts = clap_markdown::MarkdownOptions::new()
        .title("The spheremap command line".to_string())
        .show_footer(false)
        .show_table_of_contents(true);
    let body = clap_markdown::help_markdown_command_custom(&spheremap_cli::command(), &opts);
    format!(
        "<!-- Generated from the CLI definition by crates/spheremap-cli/tests/reference.rs; \
         do not edit. -->\n\n{}",
        body.trim_end()
    ) + "\n"
}

/// The man pages, one per command (`spheremap.1`, `spheremap-convert.1`, ...), by name.
fn man_pages() -> Vec<(String, Vec<u8>)> {
    let tmp = std::env::temp_dir().join(format!("spheremap-man-{}", std::process::id()));
    std::fs::create_dir_all(&tmp).unwrap();
    clap_mangen::generate_to(spheremap_cli::command(), &tmp).unwrap();
    let mut pages: Vec<(String, Vec<u8>)> = std::fs::read_dir(&tmp)
        .unwrap()
        .map(|e| {
            let p = e.unwrap().path();
            let name = p.file_name().unwrap().to_string_lossy().into_owned();
            (name, std::fs::read(&p).unwrap())
        })
        .collect();
    std::fs::remove_dir_all(&tmp).unwrap();
    pages.sort();
    pages
}

fn check(name: &str, want: &[u8]) {
    let path = docs().join(name);
    if std::env::var_os("SPHEREMAP_UPDATE_DOCS").is_some() {
        std::fs::write(&path, want).unwrap();
        return;
    }
    let have = std::fs::read(&path).unwrap_or_default();
    assert!(
        have == want,
        "{} is out of date: run SPHEREMAP_UPDATE_DOCS=1 cargo test -p spheremap-cli --test reference",
        path.display()
    );
}

#[test]
fn the_cli_reference_is_current() {
    let md = markdown();
    for cmd in spheremap_cli::command().get_subcommands() {
        assert!(
            md.contains(&format!("## `spheremap {}`", cmd.get_name())),
            "{} missing",
            cmd.get_name()
        );
    }
    check("cli.md", md.as_bytes());
}

#[test]
fn the_man_pages_are_current() {
    let pages = man_pages();
    assert!(pages.iter().any(|(n, _)| n == "spheremap-convert.1"));
    let dir = docs().join("man");
    if std::env::var_os("SPHEREMAP_UPDATE_DOCS").is_some() {
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
    }
    let mut have: Vec<String> = std::fs::read_dir(&dir)
        .map(|d| {
            d.map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
                .collect()
        })
        .unwrap_or_default();
    have.sort();
    if std::env::var_os("SPHEREMAP_UPDATE_DOCS").is_none() {
        let want: Vec<&String> = pages.iter().map(|(n, _)| n).collect();
        assert_eq!(
            have.iter().collect::<Vec<_>>(),
            want,
            "docs/man holds other pages"
        );
    }
    for (name, text) in &pages {
        check(&format!("man/{name}"), text);
    }
}

#[test]
fn completion_scripts_name_every_subcommand() {
    for shell in ["bash", "zsh", "fish", "powershell"] {
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_spheremap"))
            .args(["completions", shell])
            .output()
            .unwrap();
        assert!(out.status.success(), "{shell}");
        let text = String::from_utf8(out.stdout).unwrap();
        for cmd in ["convert", "from-photo", "texgen", "completions"] {
            assert!(text.contains(cmd), "{shell}: {cmd}");
        }
    }
    let bad = std::process::Command::new(env!("CARGO_BIN_EXE_spheremap"))
        .args(["completions", "tcsh"])
        .output()
        .unwrap();
    assert_eq!(bad.status.code(), Some(2));
}
