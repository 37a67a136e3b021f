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

/// `teleop` in the real REPL on the simulator: keys typed at the terminal drive the base in real
/// time and the drive is kept as a demonstration.
#[cfg(unix)]
#[test]
fn teleop_drives_the_simulator_from_the_keys_and_keeps_a_demonstration()
-> Result<(), rexpect::error::Error> {
    let home = tempfile::tempdir().unwrap();
    let mut cmd = std::process::Command::new(env!("CARGO_BIN_EXE_advise"));
    cmd.args(["repl", "--demos", "0"])
        .env("ADVISE_HOME", home.path())
        .env("NO_COLOR", "1")
        .env("TERM", "xterm");
    let mut p = rexpect::session::spawn_command(cmd, Some(60_000))?;
    p.exp_string("advise> ")?;
    p.send_line("teleop for 20")?;
    p.exp_string("Enter or q ends")?;
    // Three steps of speed, held, then a turn, then stop and end.
    p.send("www")?;
    p.flush()?;
    p.exp_string("speed +0.30 m/s, turn +0.00 rad/s")?;
    std::thread::sleep(std::time::Duration::from_millis(1500));
    p.send("a")?;
    p.flush()?;
    p.exp_string("turn +0.10 rad/s")?;
    std::thread::sleep(std::time::Duration::from_millis(500));
    p.send(" ")?;
    p.flush()?;
    p.exp_string("speed +0.00 m/s, turn +0.00 rad/s")?;
    p.send("q")?;
    p.flush()?;
    let (_, shown) =
        p.exp_regex(r"recorded demonstration `teleop 0` driven from the terminal: (\d+) points")?;
    let points: usize = shown
        .rsplit(": ")
        .next()
        .and_then(|s| s.split(' ').next())
        .and_then(|n| n.parse().ok())
        .unwrap_or(0);
    // About two seconds at 30 Hz between the first key and the end.
    assert!((40..=200).contains(&points), "{shown}");
    p.exp_string("advise> ")?;
    p.send_line("quit")?;
    p.exp_eof()?;
    Ok(())
}
