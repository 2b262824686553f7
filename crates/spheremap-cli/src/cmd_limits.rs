//! `spheremap limits`: the core's table of limits, as text or JSON.

use spheremap::base::limits::table;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// Print the table as JSON (a list of {name, value, min, unit, what, env}).
    #[arg(long)]
    json: bool,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let rows = table();
    if a.json {
        crate::out(&(serde_json::to_string_pretty(&rows)? + "\n"));
        return Ok(());
    }
    let mut o = String::new();
    for l in &rows {
        let env = l
            .env
            .map(|e| format!(" (${e} replaces it)"))
            .unwrap_or_default();
        let range = format!("{}..={}", l.min, l.value);
        o += &format!("{:<17} {range:<16} {:<8} {}{env}\n", l.name, l.unit, l.what);
    }
    crate::out(&o);
    Ok(())
}
