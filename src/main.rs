//! `linkgi` command-line tool (the whole of it lives in the library's
//! `cli` module, behind the `cli` feature).

fn main() -> anyhow::Result<()> {
    linkgi::run_cli()
}
