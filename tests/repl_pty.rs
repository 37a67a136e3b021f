//! The REPL users touch, driven through a pseudo-terminal: start the real binary, complete a
//! command and an operator with Tab, run, advise, undo, a definition over several lines under the
//! `...>` prompt, a misspelt command, quit.

#[cfg(unix)]
#[test]
fn the_repl_completes_runs_advises_and_undoes() -> Result<(), rexpect::error::Error> {
    let home = tempfile::tempdir().unwrap();
    let mut cmd = std::process::Command::new(env!("CARGO_BIN_EXE_advise"));
    cmd.env("ADVISE_HOME", home.path())
        .env("NO_COLOR", "1")
        .env("TERM", "xterm");
    let mut p = rexpect::session::spawn_command(cmd, Some(60_000))?;
    p.exp_string("type `help`")?;
    p.exp_string("advise> ")?;
    // Tab completes `ru` to `run`.
    p.send("ru\t")?;
    p.flush()?;
    p.send_line(" goal 2 -1 0.5")?;
    p.exp_string("execution 0: run goal 2 -1 0.5")?;
    p.send_line("select 20..40")?;
    p.exp_string("selected 20..40")?;
    // Tab completes an operator name after `advise`.
    p.send("advise slow_d\t")?;
    p.flush()?;
    p.send_line("")?;
    p.exp_string("advised 20..40 of execution 0 with slow_down")?;
    p.send_line("undo")?;
    p.exp_string("undid: #1 advise slow_down")?;
    // An unfinished definition continues under its own prompt.
    p.send_line("operator creep for positioning on action {")?;
    p.exp_string("...> ")?;
    p.send_line("  trans = 0.1")?;
    p.exp_string("...> ")?;
    p.send_line("}")?;
    p.exp_string("defined operator `creep`")?;
    // A misspelt command is named, with the one that was meant.
    p.send_line("selec 1..2")?;
    p.exp_string("did you mean `select`?")?;
    p.send_line("quit")?;
    p.exp_eof()?;
    Ok(())
}
